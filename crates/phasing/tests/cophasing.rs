//! The 37-segment mirror co-phased on its 111 inchworms, noise and disturbances off: the
//! global loop through the edge sensors and the reconstructor parks the mirror where the
//! perfect-knowledge run parks it (docs/phasing.md).

use inchworm_controller::Params;
use inchworm_phasing::cophasing::{self, Knowledge};
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

#[test]
fn the_edge_sensor_loop_parks_the_37_segment_mirror_where_perfect_knowledge_does() {
    let mirror = Mirror::new(3, true, 0.15, 0.003).unwrap();
    let sensors = EdgeSensors::new(&mirror, 0.005).unwrap();
    let reconstructor =
        Reconstructor::new(&mirror, &sensors.interaction(mirror.centres()), DEFAULT_THRESHOLD)
            .unwrap();
    let errors = errors(mirror.segments(), 42);
    let plants = vec![PlantParams::fia20(); 3 * mirror.segments()];
    let controller = Params { analog: true, ..Params::default() };
    let duration = 6.0;
    let perfect = cophasing::run(
        &mirror,
        &sensors,
        &errors,
        &plants,
        &controller,
        &Knowledge::Perfect,
        duration,
    )
    .unwrap();
    let global = Knowledge::EdgeSensors { reconstructor, period: 500, gain: 1.0 };
    let sensed =
        cophasing::run(&mirror, &sensors, &errors, &plants, &controller, &global, duration)
            .unwrap();
    let start = perfect.cophasing_rms[0];
    let (p_end, s_end) =
        (*perfect.cophasing_rms.last().unwrap(), *sensed.cophasing_rms.last().unwrap());
    let diff: Vec<[f64; 3]> = perfect
        .parked
        .iter()
        .zip(&sensed.parked)
        .map(|(a, b)| std::array::from_fn(|j| a[j] - b[j]))
        .collect();
    let apart = cophasing::cophasing_rms(&mirror, &sensors, &diff);
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
