//! Any accepted parameter set gives finite outputs in bounded time, and values just outside
//! the ranges of `inchworm_plant::params::range` are refused with the parameter's name.

use std::sync::mpsc;
use std::time::{Duration, Instant};

mod common;
use common::{splitmix, uniform};

use inchworm_controller::gait::{Direction, Timing};
use inchworm_plant::params::range;
use inchworm_plant::{Dac, Plant, PlantParams, StepError, MAX_STEP};

/// A value in `[lo, hi]`: log-uniform where the range is positive, with its ends drawn
/// one time in eight each, so the corners are exercised.
fn draw(state: &mut u64, (lo, hi): (f64, f64)) -> f64 {
    match splitmix(state) % 8 {
        0 => lo,
        1 => hi,
        _ if lo > 0.0 => (lo.ln() + uniform(state) * (hi.ln() - lo.ln())).exp(),
        _ => lo + uniform(state) * (hi - lo),
    }
}

fn random_params(state: &mut u64) -> PlantParams {
    let r = |name: &str| {
        let (lo, hi, _) = range(name).unwrap();
        (lo, hi)
    };
    let mut p = PlantParams::fia20();
    for (field, id) in [
        (&mut p.m_p, PlantParams::M_P),
        (&mut p.k_p, PlantParams::K_P),
        (&mut p.c_p, PlantParams::C_P),
        (&mut p.m_b, PlantParams::M_B),
        (&mut p.k_f, PlantParams::K_F),
        (&mut p.c_f, PlantParams::C_F),
        (&mut p.m_r, PlantParams::M_R),
        (&mut p.k_e, PlantParams::K_E),
        (&mut p.c_e, PlantParams::C_E),
        (&mut p.l_p, PlantParams::L_P),
        (&mut p.l_r, PlantParams::L_R),
        (&mut p.t_em, PlantParams::T_EM),
        (&mut p.c, PlantParams::C),
        (&mut p.f_d0, PlantParams::F_D0),
        (&mut p.gamma, PlantParams::GAMMA),
        (&mut p.v_th, PlantParams::V_TH),
        (&mut p.f_bessel, PlantParams::F_BESSEL),
        (&mut p.amp_gain, PlantParams::AMP_GAIN),
        (&mut p.f_amp, PlantParams::F_AMP),
        (&mut p.q_enc, PlantParams::Q_ENC),
        (&mut p.encoder_noise, PlantParams::ENCODER_NOISE),
        (&mut p.rel_tol, PlantParams::REL_TOL),
    ] {
        *field = draw(state, r(id.name()));
    }
    let (lo, hi) = r(PlantParams::PLAY_RADIUS.name());
    let mut radii: Vec<f64> = (0..5).map(|_| draw(state, (lo, hi))).collect();
    radii.sort_by(f64::total_cmp);
    radii.dedup();
    while radii.len() < 5 {
        radii.push(radii.last().unwrap() * 1.5 + 0.1);
    }
    if radii[4] > hi {
        radii = vec![10.0, 20.0, 30.0, 40.0, 50.0];
    }
    p.play_radius.copy_from_slice(&radii);
    for w in p.play_weight.iter_mut() {
        *w = draw(state, r(PlantParams::PLAY_WEIGHT.name()));
    }
    p
}

/// One forward and one backward gait and a long quiet step: every output finite, or the
/// step refused with `NonFinite` and the plant left as it was.
fn exercise(p: PlantParams) -> Result<(), String> {
    p.validate().map_err(|e| format!("drawn inside the ranges, refused: {e}"))?;
    let mut plant = Plant::new(p.clone()).map_err(|e| e.to_string())?;
    let timing = Timing::new(100);
    let mut steps: Vec<(Dac, f64)> = Vec::new();
    for dir in [Direction::Forward, Direction::Backward] {
        for k in 1..=100 {
            let [earth, nonearth, extension] = timing.volts(dir, 0.7, k);
            steps.push((Dac { earth, nonearth, extension }, 0.002));
        }
    }
    steps.push((Dac::default(), 0.1));
    for (k, (d, h)) in steps.into_iter().enumerate() {
        let before = plant.outputs();
        match plant.step(d, h) {
            Ok(_) => {
                let o = plant.outputs();
                let values = [
                    o.encoder_position,
                    o.runner_position,
                    o.extension,
                    o.voltage_earth,
                    o.voltage_nonearth,
                    o.voltage_extension,
                ];
                if !values.iter().all(|v| v.is_finite()) {
                    return Err(format!("step {k}: non-finite output {o:?} with {p:?}"));
                }
            }
            Err(StepError::NonFinite { .. }) => {
                if plant.outputs() != before {
                    return Err(format!("step {k}: a refused step changed the outputs"));
                }
                return Ok(());
            }
            Err(e) => return Err(format!("step {k}: {e}")),
        }
    }
    Ok(())
}

#[test]
fn random_parameters_inside_the_ranges_run_finite_and_bounded() {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut state = 0x1A5E_2026_u64;
        let mut slowest = (Duration::ZERO, 0);
        for case in 0..120 {
            let p = random_params(&mut state);
            let t = Instant::now();
            if std::env::var_os("ROBUSTNESS_TRACE").is_some() {
                eprintln!("case {case}: {p:?}");
            }
            let r = exercise(p.clone()).map_err(|e| format!("case {case}: {e}"));
            slowest = slowest.max((t.elapsed(), case));
            if r.is_err() {
                tx.send(r).unwrap();
                return;
            }
        }
        eprintln!("slowest case {} took {:?}", slowest.1, slowest.0);
        tx.send(Ok(())).unwrap();
    });
    // A hang is a failure, not a stuck test run.
    match rx.recv_timeout(Duration::from_secs(300)) {
        Ok(r) => r.unwrap(),
        Err(_) => panic!("a case did not finish within 300 s"),
    }
}

#[test]
fn values_just_outside_the_ranges_are_refused_by_name() {
    type Set = fn(&mut PlantParams, f64);
    let cases: [(&str, Set); 8] = [
        (PlantParams::K_P.name(), |p, v| p.k_p = v),
        (PlantParams::M_P.name(), |p, v| p.m_p = v),
        (PlantParams::C.name(), |p, v| p.c = v),
        (PlantParams::T_EM.name(), |p, v| p.t_em = v),
        (PlantParams::K_E.name(), |p, v| p.k_e = v),
        (PlantParams::GAMMA.name(), |p, v| p.gamma = v),
        (PlantParams::F_D0.name(), |p, v| p.f_d0 = v),
        (PlantParams::REL_TOL.name(), |p, v| p.rel_tol = v),
    ];
    for (name, set) in cases {
        let (lo, hi, _) = range(name).unwrap();
        let below = if lo > 0.0 { lo * 0.999 } else { lo - 1e-9 * (1.0 + hi.abs()) };
        for v in [below, hi * 1.001 + 1e-300, f64::NAN, f64::INFINITY, 5e-324, 1e308] {
            if (lo..=hi).contains(&v) {
                continue;
            }
            let mut p = PlantParams::fia20();
            set(&mut p, v);
            let e = p.validate().expect_err(&format!("{name} = {v:e} accepted"));
            assert_eq!(e.field, name);
            assert!(e.reason.contains("must be within"), "{e}");
            assert!(Plant::new(p).is_err());
        }
    }
    let mut p = PlantParams::fia20();
    p.play_weight[0] = 1e308;
    assert_eq!(p.validate().unwrap_err().field, PlantParams::PLAY_WEIGHT.name());
}

#[test]
fn steps_outside_the_accepted_sizes_are_refused_and_change_nothing() {
    let mut plant = Plant::new(PlantParams::fia20()).unwrap();
    let d = Dac { earth: 0.0, nonearth: 10.0, extension: 5.0 };
    for h in [0.0, -0.002, f64::NAN, f64::INFINITY, 1e300, MAX_STEP * 1.0001] {
        let e = plant.step(d, h).unwrap_err();
        assert!(matches!(e, StepError::StepSize { h: got } if got.to_bits() == h.to_bits()), "{e}");
        assert_eq!(plant.time(), 0.0);
    }
    // The largest step is bounded work: 1000 s in well under a second of CPU.
    let t = Instant::now();
    plant.step(d, MAX_STEP).unwrap();
    assert_eq!(plant.time(), MAX_STEP);
    eprintln!("a {MAX_STEP} s step took {:?}", t.elapsed());
}

#[test]
fn a_step_that_would_overflow_is_undone() {
    let mut plant = Plant::new(PlantParams::fia20()).unwrap();
    plant.step(Dac::default(), 0.002).unwrap();
    plant.set_mechanics([0.0; 4], [1e308, 1e308, 1e308, 0.0]);
    let (before, v) = (plant.positions(), plant.velocities());
    let e = plant.step(Dac::default(), 0.002).unwrap_err();
    assert_eq!(e, StepError::NonFinite { time: 0.002 });
    assert!(e.to_string().contains("non-finite"), "{e}");
    assert_eq!((plant.positions(), plant.velocities(), plant.time()), (before, v, 0.002));
}
