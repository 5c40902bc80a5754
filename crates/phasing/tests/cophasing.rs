//! The 37-segment mirror co-phased on its 111 inchworms, noise and disturbances off: the
//! global loop through the edge sensors and the reconstructor parks the mirror where the
//! perfect-knowledge run parks it (docs/phasing.md).

use inchworm_controller::Params;
use inchworm_phasing::cophasing::{self, GlobalLoop, Knowledge, Setup};
use inchworm_phasing::disturbances::Disturbances;
use inchworm_phasing::{EdgeSensors, Mirror, Reconstructor, DEFAULT_THRESHOLD};
use inchworm_plant::PlantParams;

/// Seeded errors as the segmented mirrors draw them: piston within ±10 µm, tip and tilt
/// within ±5 µrad.
fn errors(n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut state = seed;
    let mut uniform =
        |half: f64| half * (2.0 * (inchworm_plant::noise::gaussian(&mut state).tanh()));
    (0..n).map(|_| [uniform(10e-6), uniform(5e-6), uniform(5e-6)]).collect()
}

/// The 37-segment mirror of 0.15 m segments, 3 mm gaps, 5 mm dihedral gain, every
/// actuator fia20, from the errors of seed 42.
fn setup(controller: Params, disturbances: Disturbances) -> Setup {
    let mirror = Mirror::new(3, true, 0.15, 0.003).unwrap();
    let sensors = EdgeSensors::new(&mirror, 0.005).unwrap();
    let errors = errors(mirror.segments(), 42);
    let plants = vec![PlantParams::fia20(); 3 * mirror.segments()];
    Setup { mirror, sensors, errors, plants, controller, disturbances }
}

fn reconstructor(setup: &Setup) -> Knowledge {
    let a = setup.sensors.interaction(setup.mirror.centres());
    Knowledge::EdgeSensors(Reconstructor::new(&setup.mirror, &a, DEFAULT_THRESHOLD).unwrap())
}

#[test]
fn the_edge_sensor_loop_parks_the_37_segment_mirror_where_perfect_knowledge_does() {
    let setup = setup(Params { analog: true, ..Params::default() }, Disturbances::OFF);
    let duration = 6.0;
    let global = GlobalLoop::DEFAULT;
    let perfect = cophasing::run(&setup, &Knowledge::Perfect, global, duration).unwrap();
    let sensed = cophasing::run(&setup, &reconstructor(&setup), global, duration).unwrap();
    let start = perfect.cophasing_rms[0];
    let (p_end, s_end) =
        (*perfect.cophasing_rms.last().unwrap(), *sensed.cophasing_rms.last().unwrap());
    let diff: Vec<[f64; 3]> = perfect
        .parked
        .iter()
        .zip(&sensed.parked)
        .map(|(a, b)| std::array::from_fn(|j| a[j] - b[j]))
        .collect();
    let apart = cophasing::cophasing_rms(&setup.mirror, &diff);
    println!(
        "37 segments from {:.3} µm: parked at {:.3} nm (perfect knowledge), {:.3} nm (edge sensors, {} updates), {:.3} nm apart",
        start * 1e6,
        p_end * 1e9,
        s_end * 1e9,
        sensed.updates,
        apart * 1e9
    );
    for t in [0.5, 1.0, 2.0, 4.0, 5.99] {
        let k = (t / cophasing::SAMPLE_PERIOD) as usize;
        println!(
            "t = {t} s: {:.3} nm perfect, {:.3} nm sensed",
            perfect.cophasing_rms[k] * 1e9,
            sensed.cophasing_rms[k] * 1e9
        );
    }
    assert!(start > 1e-6, "the mirror starts out of phase");
    assert!(
        apart <= 1e-9,
        "the edge-sensor loop parks {apart:e} m RMS from the perfect-knowledge run"
    );
}

#[test]
fn a_global_loop_that_cannot_run_is_refused() {
    let setup = setup(Params::default(), Disturbances::OFF);
    for (global, why) in [
        (GlobalLoop { period: 0, ..GlobalLoop::DEFAULT }, "period 0"),
        (GlobalLoop { average: 0, ..GlobalLoop::DEFAULT }, "averaging 0"),
        (GlobalLoop { average: 501, ..GlobalLoop::DEFAULT }, "averaging 501"),
        (GlobalLoop { gain: f64::NAN, ..GlobalLoop::DEFAULT }, "gain NaN"),
        (GlobalLoop { gain: 2.5, ..GlobalLoop::DEFAULT }, "gain 2.5"),
    ] {
        let err = cophasing::run(&setup, &Knowledge::Perfect, global, 0.01).unwrap_err();
        assert!(err.to_string().contains(why), "{why}: {err}");
    }
    let mut short = setup.clone();
    short.errors.pop();
    let err = cophasing::run(&short, &Knowledge::Perfect, GlobalLoop::DEFAULT, 0.01).unwrap_err();
    assert!(err.to_string().contains("need 37 errors"), "{err}");
    for bad in [f64::NAN, 0.0, -1.0] {
        let err =
            cophasing::run(&setup, &Knowledge::Perfect, GlobalLoop::DEFAULT, bad).unwrap_err();
        assert!(err.to_string().starts_with("duration = "), "{err}");
    }
}
