//! The plant's Model Exchange interfaces through the FMI entry points of both standards, for
//! both formulations (`InchwormPlant`'s reduced one of 11 states, `InchwormPlantFull`'s 17):
//! the exact directional derivatives against central differences of
//! `GetDerivatives`/`GetContinuousStateDerivatives`, for every state and DAC input; a brake
//! switch as a state event; the event budget; and, for the reduced formulation, the time
//! the master sets moving the fast part, and a serialized state continuing bit for bit.

use inchworm_fmi_export::api::Fmi2;
use inchworm_fmi_export::entry::Array;
use inchworm_fmi_export::fmi3::api::Fmi3;
use inchworm_fmi_export::testing::{Harness, Master};
use inchworm_fmi_export::Model;
use inchworm_fmu_models::{PlantFmu, PlantFullFmu};

const DAC: [u32; 3] = [3, 1, 2]; // extension, earth, non-earth
const MODE: u32 = 17;
const EXTENSION: u32 = 13;
const RUNNER_POSITION: u32 = 12;
const VOLTAGE_EARTH: u32 = 14;
const VOLTAGE_NONEARTH: u32 = 15;

/// The value references of the continuous states and of their derivatives, as declared.
fn states<M: Model>() -> (Vec<u32>, Vec<u32>) {
    let me = M::model_exchange().expect("the plant has Model Exchange");
    (me.states.iter().map(|s| s.value).collect(), me.states.iter().map(|s| s.derivative).collect())
}

/// The index of the state held in `vr`.
fn index<M: Model>(vr: u32) -> usize {
    states::<M>().0.iter().position(|&s| s == vr).expect("a continuous state")
}

/// A state in HOLD with every mode of the stack and all three channels moving (the stack's
/// nodes only where the formulation has them), and each state's scale.
fn moving<M: Model>() -> (Vec<f64>, Vec<f64>) {
    let of = |vr: u32| match vr {
        200 => (1e-7, 1e-5),
        201 => (0.02, 1e-2),
        202 => (3e-7, 1e-5),
        203 => (-0.01, 1e-2),
        EXTENSION => (6e-6, 1e-5),
        204 => (0.05, 1e-2),
        RUNNER_POSITION | 212 => (0.0, 1e-5),
        205 | 213 => (0.0, 1e-2),
        206 => (4.0, 1.0),
        207 => (900.0, 1e3),
        16 => (35.0, 1.0),
        208 => (2.0, 1.0),
        209 => (300.0, 1e3),
        VOLTAGE_EARTH => (25.0, 1.0),
        210 => (1.0, 1.0),
        211 => (-50.0, 1e3),
        VOLTAGE_NONEARTH => (12.0, 1.0),
        _ => panic!("no test value for state {vr}"),
    };
    states::<M>().0.into_iter().map(of).unzip()
}

fn fd_check<M: Model, S: Master>() {
    let h = Harness::<M, S>::init_me("jacobian");
    assert_eq!(h.set_reals(&DAC, &[6.0, 3.0, 2.0]), 0);
    assert_eq!(h.update().0, 0);
    assert_eq!(h.enter_continuous_time_mode(), 0);
    let ((x0, kind), (vrs, der)) = (moving::<M>(), states::<M>());
    let n = x0.len();
    assert_eq!(h.set_states(&x0), 0, "{:?}", h.logged());
    let f = |x: &[f64]| {
        assert_eq!(h.set_states(x), 0);
        let (s, d) = h.array(Array::Derivatives, n);
        assert_eq!(s, 0);
        d
    };
    let mut worst: f64 = 0.0;
    let mut compare = |column: &[f64], fd: &[f64]| {
        let amax = column.iter().chain(fd).fold(0.0f64, |m, v| m.max(v.abs()));
        for (j, d) in column.iter().zip(fd) {
            worst = worst.max((j - d).abs() / j.abs().max(1e-6 * amax).max(f64::MIN_POSITIVE));
        }
    };
    for (c, &vr) in vrs.iter().enumerate() {
        let mut seed = vec![0.0; n];
        seed[c] = 1.0;
        assert_eq!(h.set_states(&x0), 0);
        let (s, column) = h.directional(&der, &vrs, &seed);
        assert_eq!(s, 0, "{:?}", h.logged());
        let eps = 1e-6 * (x0[c].abs() + kind[c]);
        let (mut hi, mut lo) = (x0.clone(), x0.clone());
        hi[c] += eps;
        lo[c] -= eps;
        let (fh, fl) = (f(&hi), f(&lo));
        let fd: Vec<f64> = fh.iter().zip(&fl).map(|(a, b)| (a - b) / (2.0 * eps)).collect();
        compare(&column, &fd);
        // The states' own sensitivities are the identity.
        let (_, own) = h.directional(&[vr], &vrs, &seed);
        assert_eq!(own, [1.0]);
    }
    assert_eq!(h.set_states(&x0), 0);
    for vr in DAC {
        let (s, column) = h.directional(&der, &[vr], &[1.0]);
        assert_eq!(s, 0);
        let base = h.real(vr).1;
        let at = |v: f64| {
            assert_eq!(h.set_real(vr, v), 0, "a continuous input between events");
            h.array(Array::Derivatives, n).1
        };
        let (fh, fl) = (at(base + 1e-3), at(base - 1e-3));
        assert_eq!(h.set_real(vr, base), 0);
        let fd: Vec<f64> = fh.iter().zip(&fl).map(|(a, b)| (a - b) / 2e-3).collect();
        compare(&column, &fd);
    }
    eprintln!(
        "{} {}: directional derivatives against central differences, worst relative error {worst:.2e}",
        M::info().model_identifier,
        S::VERSION
    );
    assert!(worst < 1e-6, "{worst}");
    assert_eq!(
        h.directional(&[der[0]], &[100], &[1.0]).0,
        3,
        "no derivative with respect to a parameter"
    );
}

#[test]
fn directional_derivatives_match_finite_differences_fmi2() {
    fd_check::<PlantFmu, Fmi2>();
    fd_check::<PlantFullFmu, Fmi2>();
}

#[test]
fn directional_derivatives_match_finite_differences_fmi3() {
    fd_check::<PlantFmu, Fmi3>();
    fd_check::<PlantFullFmu, Fmi3>();
}

/// The earth amplifier set above V_th in HOLD: its indicator is positive, and the event
/// update opens the earth brake (FREE with the non-earth brake open) and says so.
fn brake_switch<M: Model, S: Master>() {
    let h = Harness::<M, S>::init_me("switch");
    assert_eq!(h.update().0, 0);
    assert_eq!(h.enter_continuous_time_mode(), 0);
    let (x, _) = states::<M>();
    let mut x = vec![0.0; x.len()];
    x[index::<M>(VOLTAGE_EARTH)] = 55.0;
    assert_eq!(h.set_states(&x), 0);
    let (s, z) = h.array(Array::EventIndicators, 5);
    assert_eq!((s, z[0]), (0, 5.0), "earth volts − V_th");
    assert_eq!(h.enter_event_mode(), 0);
    let (s, u, term) = h.update();
    assert_eq!(
        (s, u.states_changed, term),
        (1, false, false),
        "FREE is a warning: {:?}",
        h.logged()
    );
    assert_eq!(h.integer(MODE), (0, 4));
}

#[test]
fn a_brake_switch_is_a_state_event() {
    brake_switch::<PlantFmu, Fmi2>();
    brake_switch::<PlantFmu, Fmi3>();
    brake_switch::<PlantFullFmu, Fmi2>();
    brake_switch::<PlantFullFmu, Fmi3>();
}

/// A master chattering at the non-earth threshold: the non-earth volts set alternately just
/// above and below V_th, each followed by an event update (LOCKED and HOLD in turn). The
/// 20 000 updates of a 2 ms window succeed (the first window's include the one at exit
/// from initialization), the next window starts afresh, and one update too many fails with
/// the reason, asks the master to terminate and leaves the instance in the Error state.
fn chattering<M: Model, S: Master>() {
    let h = Harness::<M, S>::init_me("chatter");
    assert_eq!(h.update().0, 0);
    let (x, _) = states::<M>();
    let mut x = vec![0.0; x.len()];
    let nonearth = index::<M>(VOLTAGE_NONEARTH);
    let mut k = 0u32;
    let mut chatter = |t: f64| {
        assert_eq!(h.enter_continuous_time_mode(), 0);
        assert_eq!(h.set_time(t), 0);
        k += 1;
        x[nonearth] = if k % 2 == 1 { 50.0 + 1e-6 } else { 50.0 - 1e-6 };
        assert_eq!(h.set_states(&x), 0);
        assert_eq!(h.enter_event_mode(), 0);
        let (s, _, term) = h.update();
        (s, term, h.integer(MODE).1, k % 2 == 1)
    };
    for i in 0..19_999 {
        let (s, term, mode, above) = chatter(1e-3 + f64::from(i) * 1e-8);
        assert_eq!(
            (s, term, mode),
            (0, false, if above { 2 } else { 1 }),
            "first window, update {i}"
        );
    }
    for i in 0..20_000 {
        let (s, term, _, _) = chatter(2.5e-3 + f64::from(i) * 1e-8);
        assert_eq!((s, term), (0, false), "second window, update {i}");
    }
    let t = 2.5e-3 + 20_000.0 * 1e-8;
    let (s, term, _, _) = chatter(t);
    assert_eq!((s, term), (3, true), "one update too many");
    let logged = h.take_logged();
    let last = logged.last().expect("the refusal is logged");
    let why = format!("more than 20000 event updates in the 2 ms from t = 0.002 s (at t = {t} s)");
    assert!(last.contains("logStatusError") && last.contains(&why), "{last}");
    // The Error state takes no further event mode.
    assert_eq!(h.enter_event_mode(), 3);
}

#[test]
fn chattering_beyond_the_event_budget_is_an_error_that_terminates() {
    chattering::<PlantFmu, Fmi2>();
    chattering::<PlantFmu, Fmi3>();
    chattering::<PlantFullFmu, Fmi2>();
    chattering::<PlantFullFmu, Fmi3>();
}

/// The reduced formulation at rest with the extension DAC stepped to 6 V: the update splits
/// anew (the held volts are part of the slow state), so the stack is off its new slow
/// manifold and rings in the fast part. With the states held, the time the master sets
/// moves the physical extension (the surge modes' ring, tens of kHz, damped in a few ms),
/// and the same time gives the same bits again; the full formulation's extension is a
/// state and does not move with time alone.
fn set_time_moves_the_fast_part<S: Master>() {
    let h = Harness::<PlantFmu, S>::init_me("set time");
    assert_eq!(h.set_real(DAC[0], 6.0), 0);
    assert_eq!(h.update().0, 0);
    assert_eq!(h.enter_continuous_time_mode(), 0);
    let (s, x) = h.array(Array::States, 11);
    assert_eq!(s, 0);
    let at = |t: f64| {
        assert_eq!(h.set_time(t), 0);
        assert_eq!(h.set_states(&x), 0);
        h.real(EXTENSION).1
    };
    let (e0, e1, e2) = (at(0.0), at(10e-6), at(0.0));
    assert_eq!(e0.to_bits(), e2.to_bits());
    assert!((e1 - e0).abs() > 1e-12, "extension {e0} at 0, {e1} at 10 µs");
    let late = at(0.05);
    assert!(
        (late - e0).abs() > 1e-12 && (at(0.06) - late).abs() < 1e-6 * (late - e0).abs(),
        "the ring dies out"
    );

    let full = Harness::<PlantFullFmu, S>::init_me("set time, full");
    assert_eq!(full.set_real(DAC[0], 6.0), 0);
    assert_eq!(full.update().0, 0);
    assert_eq!(full.enter_continuous_time_mode(), 0);
    let before = full.real(EXTENSION).1;
    assert_eq!(full.set_time(10e-6), 0);
    assert_eq!(full.real(EXTENSION).1.to_bits(), before.to_bits());
}

#[test]
fn the_time_a_master_sets_moves_the_reduced_formulations_fast_part() {
    set_time_moves_the_fast_part::<Fmi2>();
    set_time_moves_the_fast_part::<Fmi3>();
}

/// Integrates the reduced formulation with explicit Euler steps of 1 µs from `t` for `n`
/// steps (the runner and channels are slow: 475 Hz at most), with an event update at the
/// end; returns the states, the derivatives and the runner position.
fn euler<S: Master>(h: &Harness<PlantFmu, S>, t: f64, n: u32) -> (Vec<f64>, Vec<f64>, f64) {
    let dt = 1e-6;
    assert_eq!(h.enter_continuous_time_mode(), 0);
    let mut x = h.array(Array::States, 11).1;
    for k in 0..n {
        assert_eq!(h.set_time(t + f64::from(k) * dt), 0);
        assert_eq!(h.set_states(&x), 0);
        let d = h.array(Array::Derivatives, 11).1;
        x.iter_mut().zip(&d).for_each(|(x, d)| *x += dt * d);
    }
    assert_eq!(h.set_time(t + f64::from(n) * dt), 0);
    assert_eq!(h.set_states(&x), 0);
    assert_eq!(h.enter_event_mode(), 0);
    assert!(h.update().0 <= 1);
    (h.array(Array::States, 11).1, h.array(Array::Derivatives, 11).1, h.real(RUNNER_POSITION).1)
}

/// A Model Exchange state serialized in DRIVE, while the fast part rings, and restored into
/// a fresh instance continues bit for bit: the slow state, the fast part and the time of its
/// split are in it.
fn serialized_state_continues<S: Master>() {
    let h = Harness::<PlantFmu, S>::init_me("serialize");
    // Earth brake open, non-earth closed (DRIVE), the extension stepped: the stack rings.
    assert_eq!(h.set_reals(&DAC, &[5.0, 10.0, 10.0]), 0);
    assert_eq!(h.update().0, 0);
    euler(&h, 0.0, 1500);
    assert_eq!(h.integer(MODE), (0, 3), "DRIVE: {:?}", h.logged());
    assert_eq!(h.set_real(DAC[0], 8.0), 0);
    assert_eq!(h.update().0, 0);
    let blob = h.serialize();
    let ahead = euler(&h, 1.5e-3, 300);

    let g = Harness::<PlantFmu, S>::init_me("restored");
    assert_eq!(g.update().0, 0);
    assert_eq!(g.deserialize(&blob), 0, "{:?}", g.logged());
    let again = euler(&g, 1.5e-3, 300);
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!((bits(&again.0), bits(&again.1)), (bits(&ahead.0), bits(&ahead.1)));
    assert_eq!(again.2.to_bits(), ahead.2.to_bits());
    assert!(ahead.2 > 1e-7, "the runner moved: {}", ahead.2);
}

#[test]
fn a_serialized_model_exchange_state_continues_bit_for_bit() {
    serialized_state_continues::<Fmi2>();
    serialized_state_continues::<Fmi3>();
}
