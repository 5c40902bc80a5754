//! The 37-segment mirror co-phased on its 111 inchworms (docs/phasing.md): noise and
//! disturbances off, the global loop through the edge sensors and the reconstructor parks
//! the mirror where the perfect-knowledge run parks it; with the sensors' bias it parks
//! off it by the reconstructed bias; the loop holds the mirror against the cell's
//! deformation and the wind.

use inchworm_controller::Params;
use inchworm_phasing::cophasing::{self, GlobalLoop, Knowledge, Setup};
use inchworm_phasing::disturbances::{
    CellDeformation, Disturbances, SensorErrors, SensorNoise, Wind,
};
use inchworm_phasing::{EdgeSensors, Mirror, Reconstructor, DEFAULT_THRESHOLD};
use inchworm_scenarios::segmented;

/// `fmu-build segmented`'s default seed: its errors and its actuators' draws.
const SEED: u64 = 1;

/// The 37-segment mirror of 0.15 m segments, 3 mm gaps, 5 mm dihedral gain, every
/// actuator its own plant, the errors and the plants `fmu-build segmented` draws by
/// default.
fn setup(controller: Params, disturbances: Disturbances) -> Setup {
    let mirror = Mirror::new(3, true, 0.15, 0.003).unwrap();
    let sensors = EdgeSensors::new(&mirror, 0.005).unwrap();
    let errors = segmented::errors(SEED, mirror.segments());
    let plants = segmented::draws(SEED, 3 * mirror.segments()).iter().map(|d| d.plant()).collect();
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
    let apart = cophasing::apart(&setup.mirror, &perfect.parked, &sensed.parked);
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

/// The global loop at 10 Hz, averaging its last 20 ms.
const TEN_HZ: GlobalLoop = GlobalLoop { period: 50, gain: 1.0, average: 10 };

#[test]
fn the_edge_sensor_loop_parks_off_perfect_knowledge_by_the_reconstructed_sensor_bias() {
    // The integrator drives the readings to zero: A u + b = 0 for the sensors' bias b, so
    // the segments park R b off the perfect-knowledge run (the white noise averages down,
    // the drift is 0.1 nm in 6 s).
    let noise = SensorNoise::published();
    let disturbances = Disturbances { sensors: Some(noise), ..Disturbances::OFF };
    let setup = setup(Params { analog: true, ..Params::default() }, disturbances);
    let Knowledge::EdgeSensors(r) = reconstructor(&setup) else { unreachable!() };
    let mut bias = vec![0.0; setup.sensors.len()];
    SensorErrors::new(SensorNoise { white: 0.0, drift: 0.0, ..noise }, bias.len())
        .corrupt(&mut bias);
    let predicted =
        cophasing::cophasing_rms(&setup.mirror, &setup.sensors.poses(&r.reconstruct(&bias)));
    let perfect = cophasing::run(&setup, &Knowledge::Perfect, TEN_HZ, 6.0).unwrap();
    let sensed = cophasing::run(&setup, &Knowledge::EdgeSensors(r), TEN_HZ, 6.0).unwrap();
    let apart = cophasing::apart(&setup.mirror, &perfect.parked, &sensed.parked);
    println!(
        "sensor bias 2 nm RMS: parked {:.3} nm off perfect knowledge, R b predicts {:.3} nm",
        apart * 1e9,
        predicted * 1e9
    );
    assert!(predicted > 1e-9, "the bias reconstructs to a visible offset");
    assert!((apart / predicted - 1.0).abs() < 0.1, "{apart:e} against {predicted:e}");
}

#[test]
fn the_global_loop_holds_the_mirror_against_the_cells_deformation() {
    // 1 µm of co-phasing error from the cell over 6 s, wind on: perfect knowledge at 10 Hz
    // on analog actuators holds the mirror to nanometres once co-phased.
    let cell = CellDeformation::new(1e-6, 6.0, 3).unwrap();
    let disturbances =
        Disturbances { cell: Some(cell), wind: Some(Wind::published()), ..Disturbances::OFF };
    let setup = setup(Params { analog: true, ..Params::default() }, disturbances);
    let run = cophasing::run(&setup, &Knowledge::Perfect, TEN_HZ, 6.0).unwrap();
    let from = (1.5 / cophasing::SAMPLE_PERIOD) as usize;
    let tail = &run.cophasing_rms[from..];
    let every = (tail.iter().map(|r| r * r).sum::<f64>() / tail.len() as f64).sqrt();
    let worst = tail.iter().copied().fold(0.0, f64::max);
    println!(
        "cell to 1 µm over 6 s and wind: {:.3} nm RMS every sample from 1.5 s, {:.3} nm at worst",
        every * 1e9,
        worst * 1e9
    );
    assert!(every < 20e-9 && worst < 60e-9, "{every:e} RMS, {worst:e} at worst");
}
