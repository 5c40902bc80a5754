//! The delay line closed around its fringe tracker: the loop types' steady states, the
//! regimes' figures against what the parts say, and bad input refused or reported.

use inchworm_controller::Params;
use inchworm_delay_line::fine_stage::FineStageParams;
use inchworm_delay_line::geometry::GeometryError;
use inchworm_delay_line::system::{run, DelayLineParams, Error};
use inchworm_delay_line::tracker::TrackerParams;
use inchworm_plant::PlantParams;

const T: f64 = 2e-3;

/// Space, no disturbance but a drift of `rate` the model does not know, an ideal tracker,
/// the inchworm parked by a 50 nm deadband and no offload: the fine stage alone takes the
/// ramp.
fn fine_stage_alone(loop_type: u32, rate: f64) -> (f64, DelayLineParams) {
    let d = DelayLineParams::default();
    let p = DelayLineParams {
        space: true,
        disturbances: false,
        offload_time: 1e4,
        tracker: TrackerParams { noise: false, ..d.tracker },
        fine: FineStageParams { loop_type, ..d.fine },
        ..d
    };
    let path = |t: f64| rate * t;
    let parked = Params { deadband: 50e-9, ..Params::default() };
    // The drift is the disturbance: the run's drift_rate.
    let p = DelayLineParams { drift_rate: rate, ..p };
    let r = run(&p, PlantParams::fia20(), parked, 8.0).unwrap();
    let last = r.residual.len() - 1;
    assert!((r.path[last] - path(r.time[last])).abs() < 1e-15);
    assert!(r.runner.iter().all(|x| x.abs() < 1e-8), "the inchworm stays parked");
    (r.residual[last], p)
}

#[test]
fn with_an_ideal_tracker_a_constant_rate_leaves_the_loop_types_error() {
    let rate = 1e-6;
    let (e1, p) = fine_stage_alone(1, rate);
    let kv = p.fine.gain / T;
    assert!((e1 - rate / kv).abs() / (rate / kv) < 0.02, "type 1: {e1:e} vs {:e}", rate / kv);
    let (e2, _) = fine_stage_alone(2, rate);
    assert!(e2.abs() < 0.02 * rate / kv, "type 2: {e2:e}");
}

/// With the offload on, the inchworm takes the ramp: the residual goes to zero and the
/// fine stage holds the offload loop's lag, rate × τ (a type-1 loop, K_v = 1/τ), here with
/// analog mode, which follows a slow ramp without steps.
#[test]
fn the_offload_hands_a_ramp_to_the_inchworm() {
    let d = DelayLineParams::default();
    let rate = 20e-9;
    let p = DelayLineParams {
        space: true,
        disturbances: false,
        drift_rate: rate,
        tracker: TrackerParams { noise: false, ..d.tracker },
        ..d
    };
    let analog = Params { analog: true, ..Params::default() };
    let r = run(&p, PlantParams::fia20(), analog, 30.0).unwrap();
    let last = r.residual.len() - 1;
    assert!(r.residual[last].abs() < 2e-9, "residual {:e}", r.residual[last]);
    let lag = rate * p.offload_time;
    let fine = r.fine[last];
    assert!((fine - lag).abs() < 0.2 * lag + 2e-9, "fine stage {fine:e} vs {lag:e}");
    assert!((2.0 * r.runner[last] - (rate * r.time[last] - fine)).abs() < 5e-9);
    assert_eq!(r.figures().lost, 0);
}

#[test]
fn bad_geometry_is_refused_and_a_rate_beyond_the_gait_is_reported_as_lost_lock() {
    let d = DelayLineParams::default();
    let go = |p: &DelayLineParams| run(p, PlantParams::fia20(), Params::default(), 1.0);
    for bad in [0.0, f64::NAN, -5.0] {
        let e = go(&DelayLineParams { baseline_length: bad, ..d.clone() }).unwrap_err();
        assert!(matches!(&e, Error::Range { name: "baseline_length", .. }), "{bad}: {e}");
    }
    // Latitude +40°, a star at −60°: never above the horizon.
    let e = go(&DelayLineParams { latitude: 40.0, declination: -60.0, ..d.clone() }).unwrap_err();
    assert!(matches!(e, Error::Geometry(GeometryError::BelowHorizon { .. })), "{e}");
    assert!(e.to_string().contains("below the horizon"), "{e}");
    assert!(matches!(
        run(&d, PlantParams::fia20(), Params::default(), f64::INFINITY),
        Err(Error::Duration(_))
    ));
    // 10 mm/s of path with no cart: far beyond what 0.2 s steps can take. The run
    // completes and says so: lost samples, finite residuals.
    let p = DelayLineParams {
        cart: false,
        disturbances: false,
        baseline_length: 10e-3 / inchworm_delay_line::geometry::EARTH_ROTATION_RATE,
        latitude: 0.0,
        declination: 0.0,
        hour_angle: 0.0,
        ..d
    };
    let r = run(&p, PlantParams::fia20(), Params::default(), 4.0).unwrap();
    let f = r.figures();
    assert!(f.lost > 0 && f.first_lost.is_some(), "{f:?}");
    assert!(r.residual.iter().all(|x| x.is_finite()));
}

/// The same seeds give the same run to the bit; another seed another run.
#[test]
fn runs_replay_from_their_seeds() {
    let d = DelayLineParams::default();
    let a = run(&d, PlantParams::fia20(), Params::default(), 1.0).unwrap();
    let b = run(&d, PlantParams::fia20(), Params::default(), 1.0).unwrap();
    assert_eq!(a, b);
    let c = run(&DelayLineParams { seed: 12, ..d }, PlantParams::fia20(), Params::default(), 1.0)
        .unwrap();
    assert_ne!(a.residual, c.residual);
}
