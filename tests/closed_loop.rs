//! The paper's results (docs/model.md §4.1) with plant and controller coupled directly in Rust:
//! Fig. 5 (full control vs feedback only), Figs. 6–7 (a staircase in regulation), the
//! estimator's convergence from the nominal start, and what each flag does.
//!
//! "Settled" is judged on the parked samples (all three DACs zero for the previous 8
//! samples), as docs/model.md §4.1 defines it.

use inchworm_controller::basis::Basis;
use inchworm_controller::gait::{Direction, Timing};
use inchworm_controller::measurements::raw;
use inchworm_controller::{Params, CALIBRATED_DISTURBANCE, CALIBRATED_WEIGHTS, NOMINAL_WEIGHTS};
use inchworm_plant::PlantParams;
use inchworm_scenarios::closed_loop::{self, LoopView};

const UM: f64 = 1e-6;

fn run(plant: PlantParams, p: Params, reference: impl Fn(f64) -> f64, duration: f64) -> LoopView {
    LoopView::new(&closed_loop::run(plant, p, reference, duration).unwrap()).unwrap()
}

fn fig5(p: Params) -> LoopView {
    run(PlantParams::fia20(), p, |_| 100.0 * UM, 20.0)
}

fn feedback_only() -> Params {
    Params {
        feedforward: false,
        use_scale_factor_estimate: false,
        use_disturbance_estimate: false,
        ..Params::default()
    }
}

/// The Figs. 6–7 staircase: seven levels of 100 s, large and small changes.
const LEVELS_UM: [f64; 7] = [100.0, 60.0, 250.0, 245.0, 130.0, 131.5, 20.0];
fn staircase(t: f64) -> f64 {
    LEVELS_UM[((t / 100.0) as usize).min(LEVELS_UM.len() - 1)] * UM
}

/// Peak position beyond the reference among the parked samples (m).
fn overshoot(tr: &LoopView) -> f64 {
    tr.parked().iter().map(|&i| -tr.error(i)).fold(f64::NEG_INFINITY, f64::max)
}

#[test]
fn fig5_full_control_settles_within_3_s_and_feedback_only_over_twice_later() {
    let full = fig5(Params::default());
    let fb = fig5(feedback_only());
    let t_full = full.settle_time(1.0 * UM).expect("full control settles within 1 µm");
    let t_fb = fb.settle_time(1.0 * UM).expect("feedback only settles within 1 µm");
    eprintln!(
        "Fig. 5: full control settles in {t_full:.3} s, feedback only in {t_fb:.3} s (ratio {:.2})",
        t_fb / t_full
    );
    assert!(t_full < 3.0, "full control settle time {t_full} s, expected < 3 s");
    assert!(
        t_fb >= 2.0 * t_full,
        "feedback only settles at {t_fb} s, not 2x later than full control at {t_full} s"
    );
}

/// Raw measurements of every step of a trace: steps are back to back from t = 0.
fn steps(tr: &LoopView) -> Vec<(f64, f64, f64)> {
    let timing = Timing::new(100);
    let mut out = Vec::new();
    for s in 0..tr.time.len() / 100 {
        let rows = s * 100..(s + 1) * 100;
        let dac = &tr.dac[rows.clone()];
        let direction = if dac[50][2] > 0.0 && dac[20][2] == 0.0 {
            Direction::Forward
        } else if dac[20][2] > 0.0 || dac[50][0] > 0.0 {
            Direction::Backward
        } else if dac[35][0] > 0.0 {
            Direction::Forward
        } else {
            continue; // idle
        };
        let enc = &tr.encoder_position[rows.clone()];
        let ext: Vec<f64> = dac.iter().map(|d| d[2] / 10.0).collect();
        let r = raw(&timing, direction, enc, &ext);
        out.push((r.ext_cmd, r.ext_moved, r.bd));
    }
    out
}

#[test]
fn figs6_7_staircase_regulates_to_a_nanometre_and_learns_the_scale_factor() {
    let p = Params { prefilter: true, ..Params::default() };
    let tr = run(PlantParams::fia20(), p, staircase, 700.0);
    for (k, level) in LEVELS_UM.iter().enumerate() {
        let (from, to) = (k as f64 * 100.0 + 20.0, (k + 1) as f64 * 100.0);
        let rms = tr.parked_rms(from, to);
        eprintln!("level {level} µm: parked RMS {:.3} nm over [{from}, {to}) s", rms * 1e9);
        assert!(
            rms <= 1e-9,
            "RMS error {:.3} nm at level {level} µm over [{from}, {to}) s, expected <= 1 nm",
            rms * 1e9
        );
        let bd = tr.disturbance_estimate[((to - 0.1) / 0.002) as usize];
        assert!(
            (4.0 * UM..=5.5 * UM).contains(&bd),
            "disturbance estimate {:.3} µm at t = {to} s, expected 4..5.5 µm",
            bd / UM
        );
    }
    // Multi-step moves only right after large reference changes.
    for (i, &n) in tr.n_steps.iter().enumerate() {
        let t = tr.time[i];
        if tr.iterated[i] && n > 0 {
            let since_change = t % 100.0;
            let k = (t / 100.0) as usize;
            let jump = if k == 0 { LEVELS_UM[0] } else { (LEVELS_UM[k] - LEVELS_UM[k - 1]).abs() };
            assert!(
                since_change < 15.0 && jump > 15.0,
                "{n} full steps at t = {t} s, {since_change:.1} s after a {jump} µm change"
            );
        }
    }
    // The final inverse scale factor reproduces the measured (EXT_moved, EXT_cmd) pairs.
    let basis = Basis::new(inchworm_controller::basis::FIA20_PEAKS).unwrap();
    let pairs = steps(&tr);
    let resid: Vec<f64> =
        pairs.iter().map(|(cmd, moved, _)| basis.eval(*moved, &tr.scale_weights) - cmd).collect();
    let rms = (resid.iter().map(|r| r * r).sum::<f64>() / resid.len() as f64).sqrt();
    eprintln!("inverse scale factor: RMS residual {rms:.4} over {} steps", pairs.len());
    assert!(pairs.len() > 3000);
    assert!(rms <= 0.01, "inverse scale factor RMS residual {rms}, expected <= 0.01");
}

#[test]
fn estimator_converges_from_the_nominal_start() {
    // Nominal linear inverse scale factor (20 µm per full step) and zero disturbance.
    let p = Params {
        scale_weights_start: NOMINAL_WEIGHTS,
        disturbance_start: 0.0,
        ..Params::default()
    };
    let tr = run(PlantParams::fia20(), p, |_| 100.0 * UM, 80.0);
    // 60 s of regulation after the ~4 s approach.
    let bd = *tr.disturbance_estimate.last().unwrap();
    eprintln!(
        "from nominal: disturbance estimate {:.3} µm after 80 s (calibrated {:.3} µm)",
        bd / UM,
        CALIBRATED_DISTURBANCE / UM
    );
    assert!(
        (bd - CALIBRATED_DISTURBANCE).abs() <= 0.3 * UM,
        "disturbance estimate {:.3} µm, calibrated {:.3} µm",
        bd / UM,
        CALIBRATED_DISTURBANCE / UM
    );
    assert!(tr.settle_time(1.0 * UM).is_some());
}

#[test]
fn calibrated_defaults_are_what_the_calibration_run_converges_to() {
    // docs/controller-design.md: the defaults are the estimates at the end of the
    // staircase run from the nominal start.
    let p = Params {
        prefilter: true,
        scale_weights_start: NOMINAL_WEIGHTS,
        disturbance_start: 0.0,
        ..Params::default()
    };
    let tr = run(PlantParams::fia20(), p, staircase, 700.0);
    for (i, (got, want)) in tr.scale_weights.iter().zip(CALIBRATED_WEIGHTS).enumerate() {
        assert!(
            (got - want).abs() < 1e-5,
            "weight {}: calibration gives {got}, constant is {want}",
            i + 1
        );
    }
    let bd = *tr.disturbance_estimate.last().unwrap();
    assert!(
        (bd - CALIBRATED_DISTURBANCE).abs() < 1e-10,
        "disturbance: calibration gives {bd}, constant is {CALIBRATED_DISTURBANCE}"
    );
}

/// Mean |error| left by the first move after each of a series of small reference changes
/// (+7 µm / −4 µm every 10 s after 60 s of learning), judged at the next iteration.
fn small_moves(p: Params) -> f64 {
    let reference = |t: f64| {
        let k = ((t - 60.0) / 10.0).floor().max(-1.0) as i64 + 1;
        (100.0 + 3.0 * (k / 2) as f64 + 7.0 * (k % 2) as f64) * UM
    };
    let tr = run(PlantParams::fia20(), p, reference, 200.0);
    let iterations: Vec<usize> = (0..tr.time.len()).filter(|&i| tr.iterated[i]).collect();
    let mut errors = Vec::new();
    for c in 0..14 {
        let change = 60.0 + 10.0 * c as f64;
        // The first iteration after the change plans the move; the next one sees its result.
        if let Some(j) = iterations.iter().position(|&i| tr.time[i] > change + 0.002) {
            if let Some(&next) = iterations.get(j + 1) {
                errors.push(tr.error(next - 1).abs());
            }
        }
    }
    errors.iter().sum::<f64>() / errors.len() as f64
}

#[test]
fn each_flag_changes_behaviour_as_the_paper_says() {
    let full = fig5(Params::default());
    let t_full = full.settle_time(UM).unwrap();
    // Feedforward: without it the loop must integrate its way to the reference.
    let no_ff = fig5(Params { feedforward: false, ..Params::default() });
    assert!(
        no_ff.settle_time(UM).unwrap() > 2.0 * t_full,
        "feedforward off should settle much later"
    );
    // Disturbance estimate: without it every full step of the feedforward move carries an
    // uncompensated ~4.7 µm, so the runner overshoots by several steps' worth.
    let no_bd = fig5(Params { use_disturbance_estimate: false, ..Params::default() });
    assert!(
        overshoot(&no_bd) > overshoot(&full) + 10.0 * UM,
        "overshoot without BD estimate {:.2} µm vs {:.2} µm",
        overshoot(&no_bd) / UM,
        overshoot(&full) / UM
    );
    // Prefilter: the reference is smoothed, the first move is a fraction of the step.
    let pf = fig5(Params { prefilter: true, ..Params::default() });
    assert_eq!(
        full.n_steps[0], 3,
        "without prefilter the first move takes the whole 100 µm: 3 full steps of ~26 µm (extension and disturbance) and a fraction"
    );
    assert!(
        pf.n_steps[0] <= 1,
        "prefiltered, the first move is 20 % of the step: {} full steps",
        pf.n_steps[0]
    );
    assert!(overshoot(&pf) <= overshoot(&full) + 0.1 * UM);
    // Scale-factor estimate: from a wrong start (the nominal linear map), fractional moves
    // land where the learned map says, not where the line says: after each small reference
    // change, the error left by the first move is smaller with the estimate in use.
    let nominal = Params { scale_weights_start: NOMINAL_WEIGHTS, ..Params::default() };
    let with_sf = small_moves(nominal.clone());
    let without_sf = small_moves(Params { use_scale_factor_estimate: false, ..nominal });
    eprintln!("first-move error after small changes: {:.1} nm with the scale-factor estimate, {:.1} nm with the nominal map", with_sf * 1e9, without_sf * 1e9);
    assert!(
        with_sf < 0.5 * without_sf,
        "scale-factor estimate: {:.1} nm vs {:.1} nm",
        with_sf * 1e9,
        without_sf * 1e9
    );
    // Deadband: once inside it, the actuator parks and stops stepping.
    let db = fig5(Params { deadband: 5e-9, ..Params::default() });
    let parked_late = db.parked().into_iter().filter(|&i| db.time[i] > 15.0).count();
    assert!(parked_late > 2000, "with a 5 nm deadband the actuator should stay parked, {parked_late} parked samples after 15 s");
    assert!(db
        .parked()
        .into_iter()
        .filter(|&i| db.time[i] > 15.0)
        .all(|i| db.error(i).abs() < 5e-9 + PlantParams::default().q_enc));
}

#[test]
fn fia6_device_settles_from_its_nominal_map() {
    let s = inchworm_scenarios::scenario::by_name("fia6").unwrap();
    let tr = run(
        PlantParams::fia6(),
        inchworm_scenarios::controller::fia6(),
        |t| s.reference.value(0, t),
        s.duration,
    );
    let t = tr.settle_time(UM).expect("fia6 settles within 1 µm");
    let bd = *tr.disturbance_estimate.last().unwrap();
    eprintln!("fia6: settles in {t:.2} s, disturbance estimate {:.3} µm", bd / UM);
    assert!(t < 10.0, "fia6 settle time {t} s");
    // F_d0 = 105 N against 175 N: the disturbance per step is about 0.6 of fia20's.
    assert!((2.0 * UM..3.5 * UM).contains(&bd), "fia6 disturbance estimate {:.3} µm", bd / UM);
}
