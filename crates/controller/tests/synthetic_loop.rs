//! The controller against the synthetic step plant of `common` (brake logic without the
//! analog chain, 18 µm full step with a slightly nonlinear scale factor, 4.5 µm brake
//! disturbance): convergence of the servo and of the estimator, the scaled gait, and
//! what each flag changes. The plant is exact, so the numbers are reproducible by hand
//! and any change in them is a change in the controller.

mod common;

use common::{parked, run, settle_time, true_inverse, true_weights, Record, StepPlant};
use inchworm_controller::basis::{Basis, FIA20_PEAKS};
use inchworm_controller::{Params, NOMINAL_WEIGHTS};

const BD: f64 = 4.5e-6;
const REF: f64 = 100e-6;

/// Started from the plant's true inverse scale factor and disturbance.
fn calibrated() -> Params {
    let basis = Basis::new(FIA20_PEAKS).unwrap();
    Params { scale_weights_start: true_weights(&basis), disturbance_start: BD, ..Params::default() }
}

/// Started from the nominal linear map (20 µm per full step) and zero disturbance.
fn nominal() -> Params {
    Params { scale_weights_start: NOMINAL_WEIGHTS, disturbance_start: 0.0, ..Params::default() }
}

fn to_100um(p: Params, seconds: f64) -> Vec<Record> {
    run(p, &mut StepPlant::new(BD), |_| REF, seconds)
}

fn parked_rms(tr: &[Record], n: usize, from: f64) -> f64 {
    let e: Vec<f64> =
        parked(tr, n).filter(|r| r.time >= from).map(|r| r.reference - r.position).collect();
    (e.iter().map(|e| e * e).sum::<f64>() / e.len() as f64).sqrt()
}

/// Parked position after the move planned at the first iteration.
fn after_first_move(tr: &[Record]) -> f64 {
    tr.iter().filter(|r| r.out.iterated).nth(1).expect("a second iteration").position
}

#[test]
fn from_the_nominal_start_the_servo_settles_and_the_estimator_learns_the_plant() {
    let tr = to_100um(nominal(), 60.0);
    let settle = settle_time(&tr, 100, 1e-6).expect("settles");
    assert!(settle <= 5.0, "settle time within 1 µm: {settle} s, expected ≤ 5 s (measured 3.8 s)");
    // Parked RMS in regulation: the floor is set by 100 µm = 83 333.3 counts of 1.2 nm.
    let rms = parked_rms(&tr, 100, 50.0);
    assert!(rms <= 1e-9, "parked RMS over 50–60 s: {:.3} nm, expected ≤ 1 nm", rms * 1e9);
    let last = tr.last().unwrap().out;
    assert!(
        (last.disturbance_estimate - BD).abs() < 0.01e-6,
        "disturbance estimate at 60 s: {:.4} µm, expected 4.5 ± 0.01 µm",
        last.disturbance_estimate * 1e6
    );
    // Full forward steps of the first move teach the map at +18 µm: SD_f = 18 + 4.5 µm.
    assert!(
        (last.step_forward - 22.5e-6).abs() < 0.05e-6,
        "forward full step {:.4} µm, expected 22.5 ± 0.05 µm",
        last.step_forward * 1e6
    );
    // Regulation takes backward fractional steps of ≈ −4.5 µm: the map is learned there.
    let basis = Basis::new(FIA20_PEAKS).unwrap();
    let (learned, truth) = (basis.eval(-4.5e-6, &last.scale_weights), true_inverse(-4.5e-6));
    assert!(
        (learned - truth).abs() < 0.005,
        "inverse scale factor at −4.5 µm: {learned:.4}, true {truth:.4}"
    );
}

#[test]
fn from_the_true_map_the_first_move_lands_and_the_loop_settles_in_a_second() {
    let tr = to_100um(calibrated(), 10.0);
    // Four full steps of 22.5 µm and a fraction for the last 10 µm; the 0.42 µm miss is
    // the piecewise-linear map between the 3 and 8 µm peaks on the curved truth.
    let y1 = after_first_move(&tr);
    assert!(
        (y1 - REF).abs() < 0.5e-6,
        "position after the first move: {:.3} µm, expected 100 ± 0.5 µm",
        y1 * 1e6
    );
    let settle = settle_time(&tr, 100, 1e-6).expect("settles");
    assert!(
        settle <= 1.2,
        "settle time within 1 µm: {settle} s, expected ≤ 1.2 s (measured 1.0 s)"
    );
}

#[test]
fn ten_samples_per_step_runs_the_same_loop_ten_times_faster() {
    let slow = to_100um(calibrated(), 8.0);
    let fast = to_100um(Params { samples_per_step: 10, ..calibrated() }, 0.8);
    // The plant has no dynamics, so step by step the two gaits move alike; only the
    // estimator's process noise, integrated over a 10× shorter step, weighs the prior more
    // (P ← P + Q T_sp): a count apart after 20 steps.
    for (i, (a, b)) in parked(&slow, 100).zip(parked(&fast, 10)).enumerate() {
        let tol = if i < 20 { 1e-12 } else { 1.3e-9 };
        assert!(
            (a.position - b.position).abs() < tol,
            "step {i}: {} m at 100 samples vs {} m at 10",
            a.position,
            b.position
        );
    }
    let settle = settle_time(&fast, 10, 1e-6).expect("settles");
    assert!(settle <= 0.12, "settle time at 10 samples per step: {settle} s, expected ≤ 0.12 s");
}

#[test]
fn feedforward_flag_settles_more_than_twice_as_fast() {
    let full = settle_time(&to_100um(calibrated(), 20.0), 100, 1e-6).unwrap();
    let no_ff =
        settle_time(&to_100um(Params { feedforward: false, ..calibrated() }, 20.0), 100, 1e-6)
            .unwrap();
    let feedback_only = Params {
        feedforward: false,
        use_scale_factor_estimate: false,
        use_disturbance_estimate: false,
        ..calibrated()
    };
    let fb = settle_time(&to_100um(feedback_only, 20.0), 100, 1e-6).unwrap();
    assert!(
        no_ff >= 2.0 * full,
        "settle {no_ff} s without feedforward vs {full} s with: expected ≥ 2×"
    );
    assert!(
        fb >= 2.0 * full,
        "settle {fb} s with feedback only vs {full} s full control: expected ≥ 2×"
    );
}

#[test]
fn prefilter_flag_spreads_the_change_over_moves_without_overshoot() {
    let p = calibrated();
    let pole = p.gains.prefilter_pole;
    let filtered = to_100um(Params { prefilter: true, ..p.clone() }, 20.0);
    let raw = to_100um(p, 20.0);
    // First move: (1 − p) of the change, instead of all of it.
    let y1 = after_first_move(&filtered);
    assert!(
        (y1 - (1.0 - pole) * REF).abs() < 0.5e-6,
        "first move with the prefilter reaches {:.3} µm, expected {:.1} ± 0.5 µm",
        y1 * 1e6,
        (1.0 - pole) * REF * 1e6
    );
    assert!((after_first_move(&raw) - REF).abs() < 0.5e-6);
    let peak = parked(&filtered, 100).map(|r| r.position).fold(f64::MIN, f64::max);
    assert!(
        peak <= REF + 2.4e-9,
        "prefiltered approach peaks at {:.4} µm, expected no overshoot",
        peak * 1e6
    );
    assert!(settle_time(&filtered, 100, 1e-6).unwrap() > settle_time(&raw, 100, 1e-6).unwrap());
}

#[test]
fn disturbance_flag_off_overshoots_by_the_disturbance_of_every_step() {
    let with = to_100um(calibrated(), 20.0);
    let without = to_100um(Params { use_disturbance_estimate: false, ..calibrated() }, 20.0);
    let overshoot =
        |tr: &[Record]| parked(tr, 100).map(|r| r.position - REF).fold(f64::MIN, f64::max);
    // Planned with 18 µm steps, five steps move 5 × 22.5 µm plus a fraction.
    assert!(
        overshoot(&without) > 10e-6,
        "overshoot without the disturbance estimate: {:.3} µm, expected > 10 µm",
        overshoot(&without) * 1e6
    );
    assert!(
        overshoot(&with) < 0.5e-6,
        "overshoot with it: {:.3} µm, expected < 0.5 µm",
        overshoot(&with) * 1e6
    );
    // The flag selects what the waveform uses; the estimator still tracks the truth.
    let bd = without.last().unwrap().out.disturbance_estimate;
    assert!(
        (bd - BD).abs() < 0.01e-6,
        "disturbance estimate with the flag off: {:.4} µm",
        bd * 1e6
    );
    let sd = without.last().unwrap().out.step_forward;
    assert!(
        (sd - 18e-6).abs() < 0.01e-6,
        "flag off: full step {:.4} µm, expected 18 µm from the map alone",
        sd * 1e6
    );
}

#[test]
fn scale_factor_flag_off_keeps_the_nominal_map_and_misses_small_moves() {
    // Reference changes of 3 and 7 µm every 2 s: after learning, the first move after a
    // change lands within nanometres; with the nominal linear map it misses by ~0.1 µm.
    let stair = |t: f64| {
        REF + if (t / 2.0) as i64 % 2 == 1 { 3e-6 } else { 0.0 }
            - if (t / 6.0) as i64 % 2 == 1 { 7e-6 } else { 0.0 }
    };
    let first_move_error = |p: Params| {
        let tr = run(p, &mut StepPlant::new(BD), stair, 120.0);
        let (mut errors, mut last_ref, mut since_change) = (Vec::new(), f64::NAN, 0);
        for r in &tr {
            if r.reference != last_ref {
                (last_ref, since_change) = (r.reference, 0);
            }
            if r.out.iterated {
                since_change += 1;
                if since_change == 2 && r.time > 60.0 {
                    errors.push((r.reference - r.position).abs());
                }
            }
        }
        (errors.iter().sum::<f64>() / errors.len() as f64, tr.last().unwrap().out.scale_weights)
    };
    let (on, learned) = first_move_error(nominal());
    let (off, kept) = first_move_error(Params { use_scale_factor_estimate: false, ..nominal() });
    assert!(on < 20e-9, "mean first-move error with the scale-factor estimate: {:.1} nm, expected < 20 nm (measured 8.8)", on * 1e9);
    assert!(
        off > 5.0 * on,
        "without it: {:.1} nm, expected > 5 × {:.1} nm (measured 135)",
        off * 1e9,
        on * 1e9
    );
    assert_ne!(learned, NOMINAL_WEIGHTS);
    // The output still shows the estimator's weights; only the waveform ignores them.
    assert_ne!(kept, NOMINAL_WEIGHTS);
}

#[test]
fn deadband_parks_the_actuator_once_inside() {
    let band = 0.5e-6;
    let tr = to_100um(Params { deadband: band, ..calibrated() }, 30.0);
    let tail: Vec<&Record> = tr.iter().filter(|r| r.time >= 20.0).collect();
    assert!(
        tail.iter().all(|r| r.out.codes == [0, 0, 0] && !r.out.moving),
        "deadband {band} m: the actuator must be parked after 20 s"
    );
    assert!(tail.iter().all(|r| (r.reference - r.position).abs() < band), "parked inside the band");
    // Iterations go on once per (idle) step, ready to move when the error leaves the band.
    assert_eq!(tail.iter().filter(|r| r.out.iterated).count(), 50);
    let stepping = to_100um(calibrated(), 30.0);
    assert!(
        stepping.iter().filter(|r| r.time >= 20.0).all(|r| r.out.moving),
        "deadband 0 steps forever"
    );
}

#[test]
fn a_non_monotone_map_reports_no_root_and_moves_by_fractions() {
    let mut p =
        Params { use_scale_factor_estimate: false, disturbance_start: BD, ..Params::default() };
    // Forward half of the map saturates at 0.3: φ(u − BD)ᵀθ never reaches +1.
    p.scale_weights_start = NOMINAL_WEIGHTS;
    for w in p.scale_weights_start.iter_mut().skip(5) {
        *w = w.min(0.3);
    }
    let tr = run(p, &mut StepPlant::new(BD), |_| REF, 4.0);
    let iterations: Vec<&Record> = tr.iter().filter(|r| r.out.iterated).collect();
    assert_eq!(iterations.len(), 20, "one single-step move per step");
    // Forward moves until the first fraction-only step passes 100 µm.
    assert!(
        iterations[..9]
            .iter()
            .all(|r| r.out.no_root && r.out.n_steps == 0 && r.out.step_forward == 0.0),
        "every forward move: no root, no full steps"
    );
    // Fractions clamp at 0.3: each step moves extension(3 V) + BD = 5.82 + 4.5 µm.
    let y = parked(&tr, 100).nth(5).unwrap().position;
    assert!((y - 5.0 * 10.32e-6).abs() < 2e-9, "after five steps: {} µm", y * 1e6);
}
