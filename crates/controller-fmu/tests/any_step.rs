//! The controller at any communication step (docs/model.md §5, "Any communication
//! step"), for both standards through the layer's entry points: the latch at every 2 ms
//! instant in `[t, t + h)`, the DAC write at every instant in `(t, t + h]`, outputs held
//! in between. Against a synthetic encoder (exact, fast) and in the closed loop with the
//! plant and reference FMUs (Fig. 5).

use inchworm_fmi_export::api::Fmi2;
use inchworm_fmi_export::fmi3::api::Fmi3;
use inchworm_fmi_export::instance::Status;
use inchworm_fmi_export::testing::{Harness, Master};
use inchworm_fmi_export::Var;
use inchworm_fmu_models::{ControllerFmu, PlantFmu, ReferenceFmu};

const T: f64 = 0.002;
const Q_ENC: f64 = 1.2e-9;

/// The sample index of `p` if it is a 2 ms instant up to the layer's 1e-9 rounding.
fn instant(p: f64) -> Option<u64> {
    let n = (p / T).round();
    ((n * T - p).abs() <= 1e-9 * p.abs().max(T)).then_some(n as u64)
}

/// Every output of the controller, as bits.
fn outputs<S: Master>(c: &Harness<ControllerFmu, S>) -> Vec<u64> {
    let reals = [
        ControllerFmu::DAC_EARTH,
        ControllerFmu::DAC_NONEARTH,
        ControllerFmu::DAC_EXTENSION,
        ControllerFmu::SERVO_ERROR,
        ControllerFmu::DISTURBANCE_ESTIMATE,
        ControllerFmu::STEP_FORWARD,
        ControllerFmu::STEP_BACKWARD,
        ControllerFmu::FRACTION,
    ];
    let mut v: Vec<u64> = reals.iter().map(|r| ok(c.real(r.vr())).to_bits()).collect();
    // The estimator's ten weights: scalars in FMI 2.0, one array in FMI 3.0.
    v.extend(ok(c.reals(ControllerFmu::SCALE_WEIGHTS_1.vr(), 10)).iter().map(|w| w.to_bits()));
    let integers = [
        ControllerFmu::DAC_EARTH_CODE,
        ControllerFmu::DAC_NONEARTH_CODE,
        ControllerFmu::DAC_EXTENSION_CODE,
        ControllerFmu::N_STEPS,
    ];
    v.extend(integers.map(|i| ok(c.integer(i.vr())) as u64));
    v.push(ok(c.boolean(ControllerFmu::MOVING.vr())) as u64);
    v
}

/// The value of a getter that must return OK (0 in both standards).
fn ok<X>((status, x): (Status, X)) -> X {
    assert_eq!(status, 0);
    x
}

fn controller<S: Master>(name: &str, reference: f64) -> Harness<ControllerFmu, S> {
    let c = Harness::<ControllerFmu, S>::init(name);
    assert_eq!(c.set_real(ControllerFmu::REFERENCE.vr(), reference), 0);
    c
}

/// The controller stepped through `points` (from 0) against a synthetic plant whose
/// encoder moves 2 counts at each 2 ms instant the controller's `dac_nonearth` is above
/// 5 V there; `encoder(p, counts)` is what the master passes at point `p`. The outputs
/// after each step, with the step's end.
fn synthetic<S: Master>(
    points: &[f64],
    reference: f64,
    encoder: impl Fn(f64, i32) -> i32,
) -> Vec<(f64, Vec<u64>)> {
    let c = controller::<S>("synthetic", reference);
    let mut counts = 0;
    let mut out = Vec::new();
    for w in points.windows(2) {
        assert_eq!(c.set_integer(ControllerFmu::ENCODER_COUNTS.vr(), encoder(w[0], counts)), 0);
        assert_eq!(c.step(w[0], w[1] - w[0]), 0, "step {w:?}: {:?}", c.logged());
        if instant(w[1]).is_some() {
            counts += (ok(c.real(ControllerFmu::DAC_NONEARTH.vr())) > 5.0) as i32 * 2;
        }
        out.push((w[1], outputs(&c)));
    }
    out
}

/// Points `k · h` (counted, as `k · h` masters do) from 0 to `end`.
fn counted(h: f64, end: f64) -> Vec<f64> {
    (0..=(end / h).round() as usize).map(|k| k as f64 * h).collect()
}

/// Points `t += h` over the repeated pattern (accumulated, as `t += h` masters do).
fn accumulated(pattern: &[f64], end: f64) -> Vec<f64> {
    let mut t = 0.0;
    let mut points = vec![t];
    for h in pattern.iter().cycle() {
        t += h;
        points.push(t);
        if t >= end - 1e-12 {
            return points;
        }
    }
    unreachable!()
}

/// Sub-sample steps (1, 0.5, 0.1 ms and a variable sequence that meets every instant):
/// at each instant the outputs equal the 2 ms run's bit for bit, between instants they
/// hold, and an encoder value passed between instants is never read.
fn sub_sample_steps_reproduce_the_2_ms_run<S: Master>() {
    let end = 1.2;
    let two = synthetic::<S>(&counted(T, end), 60e-6, |_, n| n);
    assert!(two.iter().any(|(_, o)| o[1] != 0), "the synthetic loop moved");
    let variable = [0.3e-3, 0.7e-3, 1.0e-3, 0.5e-3, 1.5e-3, 0.25e-3, 1.75e-3, 2e-3];
    for (what, points) in [
        ("1 ms", counted(1e-3, end)),
        ("0.5 ms", counted(0.5e-3, end)),
        ("0.1 ms", counted(0.1e-3, end)),
        ("variable", accumulated(&variable, end)),
    ] {
        // Garbage between instants: the latch reads the encoder at the instant only.
        let run = synthetic::<S>(&points, 60e-6, |p, n| match instant(p) {
            Some(_) => n,
            None => n + 1000,
        });
        let mut previous = &two[0].1; // placeholder until the first row
        let mut at_instants = 0;
        for (i, (p, o)) in run.iter().enumerate() {
            match instant(*p) {
                Some(n) => {
                    assert_eq!(o, &two[n as usize - 1].1, "{what}: outputs at instant {n}");
                    at_instants += 1;
                }
                None if i > 0 => assert_eq!(o, previous, "{what}: outputs held at {p}"),
                None => {}
            }
            previous = o;
        }
        assert_eq!(at_instants, two.len(), "{what}: every instant met");
    }
}

#[test]
fn sub_sample_steps_reproduce_the_2_ms_run_fmi2() {
    sub_sample_steps_reproduce_the_2_ms_run::<Fmi2>();
}

#[test]
fn sub_sample_steps_reproduce_the_2_ms_run_fmi3() {
    sub_sample_steps_reproduce_the_2_ms_run::<Fmi3>();
}

/// Which encoder value each write uses, measured: the encoder is a clock (counts = time
/// in 0.1 ms at each point), the reference 0, so `servo_error = -q_enc · counts` of the
/// write's latch tells the point whose value it latched. Returns per write reaching a
/// point: (age of the encoder value at the write instant, lateness of the write at the
/// first point at or after it), in seconds.
fn latencies<S: Master>(points: &[f64]) -> Vec<(f64, f64)> {
    let c = controller::<S>("clock", 0.0);
    let mut out = Vec::new();
    let mut seen = 0;
    for w in points.windows(2) {
        let counts = (w[0] / 1e-4).round() as i32;
        assert_eq!(c.set_integer(ControllerFmu::ENCODER_COUNTS.vr(), counts), 0);
        let status = c.step(w[0], w[1] - w[0]);
        assert!(status == 0 || status == 1, "step {w:?}: {:?}", c.logged());
        // The last write instant reached: floor(end / T) up to rounding.
        let last = (w[1] / T + 1e-9).floor() as u64;
        if last > seen && last >= 1 {
            seen = last;
            let latched = -ok(c.real(ControllerFmu::SERVO_ERROR.vr())) / Q_ENC * 1e-4;
            let write = last as f64 * T;
            // The latch of write n is at instant n - 1: the last point at or before it.
            let expected = points.iter().copied().rfind(|&p| p <= write - T + 1e-12);
            assert!(
                (latched - expected.unwrap()).abs() < 1e-9,
                "write at {write}: latched the value of {latched}, expected {expected:?}"
            );
            out.push((write - latched, w[1] - write));
        }
    }
    out
}

fn max(v: &[(f64, f64)], f: impl Fn(&(f64, f64)) -> f64) -> f64 {
    v.iter().map(f).fold(f64::MIN, f64::max)
}

fn min(v: &[(f64, f64)], f: impl Fn(&(f64, f64)) -> f64) -> f64 {
    v.iter().map(f).fold(f64::MAX, f64::min)
}

/// The latency table of docs/model.md §5: at 2 ms and every step that meets every
/// instant the encoder value is exactly 2 ms old at the write and the write is on time;
/// a straddling 3 ms step adds < h on each side; 4 ms (k = 2) latches one sample early.
fn latency_table<S: Master>() {
    let end = 0.06;
    for h in [2e-3, 1e-3, 0.5e-3, 0.1e-3] {
        let l = latencies::<S>(&counted(h, end));
        assert_eq!(l.len(), 30, "h = {h}: a write reached at every instant");
        for (age, late) in &l {
            assert!((age - T).abs() < 1e-9 && late.abs() < 1e-9, "h = {h}: {age} {late}");
        }
    }
    // 3 ms: the instants fall 0, 1 or 2 ms after a point.
    let l = latencies::<S>(&counted(3e-3, end));
    assert_eq!(l.len(), 20, "3 ms: one write per step reaches the plant");
    let (age, late) = ((min(&l, |x| x.0), max(&l, |x| x.0)), (min(&l, |x| x.1), max(&l, |x| x.1)));
    // Points 0, 3, 6, ... ms: the plant sees the write at 2 (latched at 0, from 0) at 3, at
    // 6 (latched at 4, from 3) at 6, at 8 (from 6) at 9, ...: 2 or 3 ms old, 1 or 0 late.
    assert!((age.0 - 2e-3).abs() < 1e-9 && (age.1 - 3e-3).abs() < 1e-9, "3 ms ages {age:?}");
    assert!(late.0.abs() < 1e-9 && (late.1 - 1e-3).abs() < 1e-9, "3 ms lateness {late:?}");
    assert!(l.iter().all(|(a, d)| a - T < 3e-3 && *d < 3e-3), "each side adds < h");
    // 4 ms = 2 samples: the write the plant sees latched at t, one sample before its
    // instant t + 2 ms: 4 ms old at the write, on time.
    let l = latencies::<S>(&counted(4e-3, end));
    assert!(l.iter().all(|(a, d)| (a - 4e-3).abs() < 1e-9 && d.abs() < 1e-9), "{l:?}");
}

#[test]
fn latency_table_fmi2() {
    latency_table::<Fmi2>();
}

#[test]
fn latency_table_fmi3() {
    latency_table::<Fmi3>();
}

/// A 3 ms step is the 1 ms run of a master that only passes new values every 3 ms: the
/// outputs at the 3 ms points equal bit for bit (the rule does not depend on how the
/// master splits its time, only on which value holds at each instant).
#[test]
fn straddling_steps_follow_the_latch_and_write_rule() {
    let end = 1.2;
    let three = synthetic::<Fmi2>(&counted(3e-3, end), 60e-6, |_, n| n);
    // The 1 ms master sees the synthetic plant's counts as a 3 ms master would: updated at
    // the points that are both 2 ms instants and 3 ms points, held from 3 ms points.
    let c = controller::<Fmi2>("one", 60e-6);
    let (mut counts, mut held, mut rows) = (0, 0, Vec::new());
    for k in 0..(end / 1e-3).round() as usize {
        let (p, q) = (k as f64 * 1e-3, (k + 1) as f64 * 1e-3);
        if k % 3 == 0 {
            held = counts;
        }
        assert_eq!(c.set_integer(ControllerFmu::ENCODER_COUNTS.vr(), held), 0);
        assert_eq!(c.step(p, 1e-3), 0);
        if (k + 1) % 3 == 0 {
            if instant(q).is_some() {
                counts += (ok(c.real(ControllerFmu::DAC_NONEARTH.vr())) > 5.0) as i32 * 2;
            }
            rows.push(outputs(&c));
        }
    }
    assert_eq!(rows.len(), three.len());
    for (i, (row, (p, o))) in rows.iter().zip(&three).enumerate() {
        assert_eq!(row, o, "row {i} at {p}");
    }
    assert!(three.iter().any(|(_, o)| o[1] != 0), "the loop moved");
    // The brake sample first powered at instant 14 (28 ms) reaches a 3 ms master at 30 ms.
    let first = three.iter().find(|(_, o)| f64::from_bits(o[1]) > 5.0).unwrap().0;
    assert!((first - 0.030).abs() < 1e-12, "{first}");
    let one = synthetic::<Fmi2>(&counted(1e-3, 0.06), 100e-6, |_, n| n);
    let first = one.iter().find(|(_, o)| f64::from_bits(o[1]) > 5.0).unwrap().0;
    assert!((first - 0.028).abs() < 1e-12, "{first}");
}

// ---- The closed loop: Fig. 5 at other master steps --------------------------------

const PROFILE_FIG5: i32 = 1;
/// The controller's DAC outputs and the plant's inputs they drive.
const DAC: [Var<ControllerFmu>; 3] = ControllerFmu::DAC_OUTPUTS;
const PLANT_DAC: [Var<PlantFmu>; 3] = PlantFmu::DAC_INPUTS;

/// Per 2 ms instant: reference, encoder position, the DAC sample the plant receives.
type Row = (f64, f64, [f64; 3]);

/// The reference FMU with the Fig. 5 profile, initialized.
fn fig5_reference<S: Master>() -> Harness<ReferenceFmu, S> {
    let refr = Harness::<ReferenceFmu, S>::new("reference");
    assert_eq!((refr.setup(), refr.enter()), (0, 0));
    assert_eq!(refr.set_integer(ReferenceFmu::PROFILE.vr(), PROFILE_FIG5), 0);
    assert_eq!(refr.exit(), 0);
    refr
}

/// Plant + controller + reference FMUs on a Jacobi grid of step `h` (counted points),
/// recorded at the 2 ms instants.
fn fig5<S: Master>(h: f64, end: f64) -> Vec<Row> {
    let plant = Harness::<PlantFmu, S>::init("plant");
    let ctrl = Harness::<ControllerFmu, S>::init("controller");
    let refr = fig5_reference::<S>();
    let mut rows = Vec::new();
    let n = (end / h).round() as usize;
    for k in 0..=n {
        let t = k as f64 * h;
        // Jacobi: every output at t, then every input, then every FMU steps.
        let r = ok(refr.real(ReferenceFmu::REFERENCE.vr()));
        let counts = ok(plant.integer(PlantFmu::ENCODER_COUNTS.vr()));
        let dac = DAC.map(|var| ok(ctrl.real(var.vr())));
        if instant(t).is_some() {
            rows.push((r, ok(plant.real(PlantFmu::ENCODER_POSITION.vr())), dac));
        }
        if k == n {
            break;
        }
        assert_eq!(ctrl.set_integer(ControllerFmu::ENCODER_COUNTS.vr(), counts), 0);
        assert_eq!(ctrl.set_real(ControllerFmu::REFERENCE.vr(), r), 0);
        assert_eq!(plant.set_reals(&PLANT_DAC.map(Var::vr), &dac), 0);
        for (what, status) in [
            ("plant", plant.step(t, h)),
            ("controller", ctrl.step(t, h)),
            ("reference", refr.step(t, h)),
        ] {
            assert!(status == 0 || status == 1, "{what} at {t}: status {status}");
        }
    }
    rows
}

/// docs/model.md §4.1 as the project's loop analysis reads a trace: sample j is the
/// plant at instant j + 1 with the DAC sample it held up to there (written at instant j);
/// the settle time is the first instant after which every parked sample (all DAC outputs
/// zero over the last 8 samples) is within `tol` of the reference.
fn settle_time(rows: &[Row], tol: f64) -> Option<f64> {
    let held = |j: usize| rows[j].2;
    let error = |j: usize| rows[j + 1].0 - rows[j + 1].1;
    let parked: Vec<usize> = (8..rows.len() - 1)
        .filter(|&j| (j - 7..=j).all(|i| held(i).iter().all(|v| *v == 0.0)))
        .collect();
    let j = match parked.iter().rposition(|&j| error(j).abs() > tol) {
        None => *parked.first()?,
        Some(b) => *parked.get(b + 1)?,
    };
    Some((j + 1) as f64 * T)
}

#[test]
fn fig5_closed_loop_settles_within_one_sample_of_the_2_ms_run_at_1_05_and_01_ms() {
    let end: f64 = std::env::var("FIG5_END").map(|v| v.parse().unwrap()).unwrap_or(1.2);
    let two = fig5::<Fmi2>(T, end);
    let reference = settle_time(&two, 1e-6).expect("the 2 ms run settles");
    assert!((reference - 0.788).abs() < 1e-9, "Fig. 5 full control at 2 ms: {reference} s");
    for h in [1e-3, 0.5e-3, 0.1e-3] {
        let rows = fig5::<Fmi2>(h, end);
        let settle = settle_time(&rows, 1e-6).unwrap_or(f64::NAN);
        let final_error = rows.last().map(|r| r.0 - r.1).unwrap();
        let same = rows.iter().zip(&two).filter(|(a, b)| a.1 == b.1).count();
        eprintln!(
            "h = {h}: settles within 1 um at {settle} s (2 ms: {reference} s), final error {:.3} nm, encoder equal to the 2 ms run's at {same} of {} instants",
            final_error * 1e9,
            rows.len()
        );
        assert!((settle - reference).abs() <= T + 1e-9, "h = {h}: {settle} s vs {reference} s");
        assert!(final_error.abs() < 1e-6, "h = {h}: final error {final_error}");
    }
}

/// The closed loop at 1 ms through FMI 3.0 equals FMI 2.0 bit for bit.
#[test]
fn fig5_at_1_ms_is_the_same_in_both_standards() {
    let (two, three) = (fig5::<Fmi2>(1e-3, 0.3), fig5::<Fmi3>(1e-3, 0.3));
    assert_eq!(two.len(), three.len());
    for (i, (a, b)) in two.iter().zip(&three).enumerate() {
        assert_eq!(format!("{a:?}"), format!("{b:?}"), "instant {i}");
    }
    assert!(two.iter().any(|r| r.2[1] != 0.0), "the loop moved");
}

/// A state saved between two instants (inputs latched, the write still ahead) replays bit
/// for bit after fmi2SetFMUstate and after a round trip through the serialized form.
#[test]
fn a_state_saved_between_instants_replays_bit_for_bit() {
    let a = controller::<Fmi2>("a", 60e-6);
    let drive = |c: &Harness<ControllerFmu, Fmi2>, from: usize, n: usize| {
        let mut counts = 0;
        (from..from + n)
            .map(|k| {
                let t = k as f64 * 1e-3;
                assert_eq!(c.set_integer(ControllerFmu::ENCODER_COUNTS.vr(), counts), 0);
                assert_eq!(c.step(t, 1e-3), 0);
                counts += (ok(c.real(ControllerFmu::DAC_NONEARTH.vr())) > 5.0) as i32 * 2;
                outputs(c)
            })
            .collect::<Vec<_>>()
    };
    drive(&a, 0, 301);
    // At 0.301 s the latch of 0.300 s is pending.
    let s = a.get_state();
    let bytes = a.serialize();
    let first = drive(&a, 301, 400);
    assert_eq!(a.set_state(s), 0);
    assert_eq!(drive(&a, 301, 400), first);
    let b = Harness::<ControllerFmu, Fmi2>::new("b");
    assert_eq!(b.deserialize(&bytes), 0, "{:?}", b.logged());
    assert_eq!(drive(&b, 301, 400), first);
    assert_eq!(a.free_state(s), 0);
}

// ---- Model Exchange: the same instants as time events ------------------------------

/// Fig. 5 with the controller as Model Exchange: each event is the time event it asked
/// for, where the master hands it the plant's encoder and the reference, runs the event
/// update and steps the plant and reference FMUs (Co-Simulation, 2 ms) to the next one
/// with the DAC sample just written. Returns the rows of [`fig5`] and the event times.
fn fig5_me<S: Master>(end: f64) -> (Vec<Row>, Vec<f64>) {
    let plant = Harness::<PlantFmu, S>::init("plant");
    let ctrl = Harness::<ControllerFmu, S>::init_me("controller");
    let refr = fig5_reference::<S>();
    let (mut rows, mut events) = (Vec::new(), vec![0.0]);
    let n = (end / T).round() as usize;
    for k in 0..=n {
        let t = k as f64 * T;
        let r = ok(refr.real(ReferenceFmu::REFERENCE.vr()));
        assert_eq!(
            ctrl.set_integer(
                ControllerFmu::ENCODER_COUNTS.vr(),
                ok(plant.integer(PlantFmu::ENCODER_COUNTS.vr()))
            ),
            0
        );
        assert_eq!(ctrl.set_real(ControllerFmu::REFERENCE.vr(), r), 0);
        let (status, update, terminate) = ctrl.update();
        assert_eq!((status, update.states_changed, terminate), (0, false, false), "{t}");
        let next = update.next_event_time.expect("a time event at every instant");
        let dac = DAC.map(|var| ok(ctrl.real(var.vr())));
        rows.push((r, ok(plant.real(PlantFmu::ENCODER_POSITION.vr())), dac));
        if k == n {
            break;
        }
        assert_eq!(ctrl.enter_continuous_time_mode(), 0);
        // Between events the outputs hold, whatever the continuous input does.
        let held = outputs(&ctrl);
        assert_eq!(
            (ctrl.set_time(0.5 * (t + next)), ctrl.set_real(ControllerFmu::REFERENCE.vr(), -r)),
            (0, 0)
        );
        assert_eq!(outputs(&ctrl), held);
        assert_eq!(plant.set_reals(&PLANT_DAC.map(Var::vr), &dac), 0);
        for (what, status) in [("plant", plant.step(t, T)), ("reference", refr.step(t, T))] {
            assert!(status == 0 || status == 1, "{what} at {t}: status {status}");
        }
        assert_eq!((ctrl.set_time(next), ctrl.enter_event_mode()), (0, 0));
        events.push(next);
    }
    (rows, events)
}

/// The closed loop through the ME controller is the 2 ms Jacobi loop bit for bit: the
/// event at s_n writes the sample latched at s_(n-1) and latches the encoder at s_n, as a
/// 2 ms step does. Its time events are the counted instants n × 2 ms, exactly.
#[test]
fn the_model_exchange_controller_closes_the_2_ms_loop_bit_for_bit() {
    let end = 0.9;
    let two = fig5::<Fmi2>(T, end);
    assert!((settle_time(&two, 1e-6).unwrap() - 0.788).abs() < 1e-9);
    for (standard, (rows, events)) in
        [("FMI 2.0", fig5_me::<Fmi2>(end)), ("FMI 3.0", fig5_me::<Fmi3>(end))]
    {
        assert_eq!(rows.len(), two.len(), "{standard}");
        for (i, (a, b)) in rows.iter().zip(&two).enumerate() {
            assert_eq!(format!("{a:?}"), format!("{b:?}"), "{standard}: instant {i}");
        }
        for (k, e) in events.iter().enumerate() {
            assert_eq!(e.to_bits(), (k as f64 * T).to_bits(), "{standard}: event {k}");
        }
        eprintln!(
            "{standard}: {} time events, settles within 1 um at {:?} s",
            events.len(),
            settle_time(&rows, 1e-6)
        );
    }
}

/// An event between instants (another FMU's, say) writes nothing and latches nothing; a
/// late event catches up every instant it passed, as a long step does; the instance has
/// no continuous states or indicators.
#[test]
fn events_off_the_grid_follow_the_step_rule() {
    use inchworm_fmi_export::entry::Array;
    let me = Harness::<ControllerFmu, Fmi2>::init_me("me");
    let cs = controller::<Fmi2>("cs", 60e-6);
    assert_eq!(me.set_real(ControllerFmu::REFERENCE.vr(), 60e-6), 0);
    assert_eq!((me.array(Array::States, 0).0, me.array(Array::EventIndicators, 0).0), (0, 0));
    assert_eq!(me.array(Array::Derivatives, 1).0, 3, "no continuous states");
    assert_eq!(me.update().1.next_event_time, Some(T), "after the latch at 0: the write at s_1");
    let at = |t: f64| {
        assert_eq!(
            (me.enter_continuous_time_mode(), me.set_time(t), me.enter_event_mode()),
            (0, 0, 0)
        );
        let (s, u, _) = me.update();
        assert_eq!(s, 0);
        u.next_event_time.unwrap()
    };
    assert_eq!(at(0.0013), T, "between instants: nothing due");
    assert_eq!(outputs(&me), {
        assert_eq!(cs.step(0.0, 0.0013), 0);
        outputs(&cs)
    });
    // Late by 3.5 samples: every write up to 0.0083 s is made, and the latch at 0.008 s.
    assert_eq!(at(0.0083), 5.0 * T);
    assert_eq!(cs.step(0.0013, 0.007), 0);
    assert_eq!(outputs(&me), outputs(&cs));
}
