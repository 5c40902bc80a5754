//! The timing contract of `Controller::tick` (crate docs, "Timing"), sample by sample on
//! a hand-made encoder trace, with every number worked out by hand.

use inchworm_controller::gait::{Direction, Timing};
use inchworm_controller::{Controller, Params, DAC_FULL_SCALE, DAC_MAX_CODE, NOMINAL_WEIGHTS};

const Q: f64 = 1.2e-9;

fn code(v: f64) -> u16 {
    (v / DAC_FULL_SCALE * f64::from(DAC_MAX_CODE)).round() as u16
}

/// Feedback only and the nominal linear map (20 µm per full step), so a move of `d` is
/// the fraction `d / 20 µm` and every number below is K, a and a division.
fn feedback_only() -> Params {
    Params {
        feedforward: false,
        use_scale_factor_estimate: false,
        use_disturbance_estimate: true,
        scale_weights_start: NOMINAL_WEIGHTS,
        disturbance_start: 0.0,
        ..Params::default()
    }
}

#[test]
fn one_step_moves_sample_by_sample() {
    let p = feedback_only();
    let (k, a) = (p.gains.k, p.gains.a);
    let timing = Timing::new(100);
    let mut c = Controller::new(p).unwrap();
    let r = 10e-6;

    // Tick 0 (t = 0): iterates from the encoder at t = 0. e0 = 10 µm, D0 = K e0 = 3.6 µm,
    // fraction 0.18, and returns sample 2 of that step (parked, segment 1).
    let s = c.tick(0, r);
    assert!(s.iterated && s.n_steps == 0 && s.moving);
    let d0 = k * r;
    assert!(
        (s.fraction - d0 / 20e-6).abs() < 1e-12,
        "first fraction {} vs {}",
        s.fraction,
        d0 / 20e-6
    );
    assert_eq!(s.codes, [0, 0, 0]);

    // Ticks 1..=98 receive w_enc(1..=98) and return samples 3..=100 of the forward gait at
    // amplitude 0.18; tick 99 receives w_enc(99) and returns sample 1 of the next step.
    // The encoder: 1000 counts during the s7 window (samples 95–99), 0 elsewhere, and
    // 5000 counts at w_enc(100), which only the servo error may see.
    let w_enc = |kk: usize| {
        if (95..=99).contains(&kk) {
            1000
        } else if kk == 100 {
            5000
        } else {
            0
        }
    };
    for j in 1..=99 {
        let s = c.tick(w_enc(j), r);
        assert!(!s.iterated, "tick {j}: no iteration inside a step");
        let sample = if j == 99 { 1 } else { j + 2 };
        let expect = if sample == 1 {
            [0.0; 3]
        } else {
            timing.volts(Direction::Forward, d0 / 20e-6, sample)
        };
        assert_eq!(s.codes, expect.map(code), "tick {j}: sample {sample} of the step");
        assert_eq!(s.disturbance_estimate, 0.0, "tick {j}: the estimator waits for the step's end");
    }

    // Tick 100 receives w_enc(100). First the estimator update: BD = (s7 − s1) − (s4 − s3)
    // = 1.2 µm, gain P/(P + R) with P = (5 µm)² + (0.1 µm)²·0.2 s, R = (0.05 µm)².
    // Then the iteration with y1 = s7 = 1.2 µm, not w_enc(100) = 6 µm:
    // D1 = D0 + K (e1 − a e0), and the fraction from the just-updated disturbance.
    let s = c.tick(w_enc(100), r);
    assert!(s.iterated, "tick 100 iterates");
    let p_bd = 25e-12 + 1e-14 * 0.2;
    let bd = p_bd / (p_bd + 2.5e-15) * 1000.0 * Q;
    assert!(
        (s.disturbance_estimate - bd).abs() < 1e-15,
        "disturbance estimate {} vs {bd}",
        s.disturbance_estimate
    );
    let y1 = 1000.0 * Q;
    let d1 = d0 + k * ((r - y1) - a * r);
    let expect = (d1 - bd) / 20e-6;
    assert!((s.fraction - expect).abs() < 1e-9, "second fraction {} vs {expect}", s.fraction);
    assert!(
        (s.servo_error - (r - 5000.0 * Q)).abs() < 1e-18,
        "servo error uses the encoder of this tick"
    );
    assert_eq!(s.codes, [0, 0, 0], "sample 2 of the new step");
}

#[test]
fn a_multi_step_move_iterates_only_when_done() {
    // Feedforward of a 45 µm reference from 0: two full steps of 20 µm, then 0.25.
    let p = Params { feedforward: true, use_disturbance_estimate: false, ..feedback_only() };
    let timing = Timing::new(100);
    let mut c = Controller::new(p).unwrap();
    let mut iterated = Vec::new();
    for j in 0..400 {
        // A still encoder: the estimator sees steps that did not move; the plan holds.
        let s = c.tick(0, 45e-6);
        if s.iterated {
            iterated.push(j);
        }
        if j == 0 {
            // Bisection leaves SD within 1e-13 m of 20 µm.
            assert!(
                s.n_steps == 2 && (s.fraction - 0.25).abs() < 1e-7,
                "45 µm = 2 × 20 µm + 0.25 × 20 µm, got {} and {}",
                s.n_steps,
                s.fraction
            );
        }
        // Sample 47 of each step (segment 4 of the forward gait) shows its amplitude.
        if j % 100 == 45 && j < 300 {
            let amplitude = [1.0, 1.0, 0.25][j / 100];
            let expect = timing.volts(Direction::Forward, amplitude, 47).map(code);
            assert_eq!(s.codes, expect, "tick {j}: sample 47 of step {}", j / 100 + 1);
        }
        if (j + 1) % 100 == 0 {
            assert_eq!(s.codes, [0, 0, 0], "tick {j}: sample 1 of every step is parked");
        }
    }
    assert_eq!(
        iterated,
        vec![0, 300],
        "one iteration per move: at t = 0 and after the three steps"
    );
}
