//! The engine from outside: `dist/InchwormSystem.ssp` (the FMI 2.0 closed loop, built by
//! `cargo run --release -p fmu-build`) run through `inchworm-cosim`'s public API, phase by
//! phase, with a stop flag that is never set.

use std::path::Path;

use inchworm_cosim::{Coupling, Error, Options, StopFlag, System, Trace};
use inchworm_fmu_models::{PlantFmu, ReferenceFmu};

// The recorded names, `component.variable`, the variables' names from the FMUs' tables.
fn encoder_counts() -> String {
    format!("plant.{}", PlantFmu::ENCODER_COUNTS.name())
}
fn encoder_position() -> String {
    format!("plant.{}", PlantFmu::ENCODER_POSITION.name())
}
fn reference() -> String {
    format!("reference.{}", ReferenceFmu::REFERENCE.name())
}

#[test]
fn fig5_closed_loop_for_two_seconds() {
    let ssp = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../dist/InchwormSystem.ssp");
    assert!(ssp.is_file(), "build the FMUs first: cargo run --release -p fmu-build");
    let opts = Options {
        stop_time: Some(2.0),
        step_size: Some(0.002),
        coupling: Coupling::Jacobi,
        params: vec![],
        parameter_set: None,
        input: None,
        outputs: vec![reference(), encoder_counts(), encoder_position()],
    };
    let sim = System::load(&ssp).unwrap().initialise(&opts).unwrap();
    assert_eq!(sim.n_steps(), 1000);
    let sim = sim.stop_when(StopFlag::new());
    let mut trace = Trace::new(sim.record_names().to_vec());
    sim.run_into(
        |t, row| {
            trace.push(t, row.to_vec());
            Ok::<(), Error>(())
        },
        |_| {},
    )
    .unwrap();

    assert_eq!(trace.rows.len(), 1001);
    assert_eq!(trace.rows.last().unwrap().0, 2.0);
    let reference = trace.column(&reference()).unwrap();
    assert!(reference.iter().all(|&r| r == 100e-6), "Fig. 5: a 100 µm step from t = 0");
    let counts = trace.column(&encoder_counts()).unwrap();
    let position = trace.column(&encoder_position()).unwrap();
    assert_eq!(counts[0], 0.0, "the runner starts at rest at 0");
    // Full control settles within 1 µm at 0.788 s (tests/sweep.rs); at 2 s the encoder
    // reads 83340 counts of 1.2 nm: 100.008 µm.
    assert_eq!(*counts.last().unwrap(), 83340.0);
    let end = *position.last().unwrap();
    assert!((end - 100e-6).abs() < 1e-6, "encoder at {end} m");
    assert!((end - 83340.0 * 1.2e-9).abs() < 1e-15, "position is counts × q_enc");
    // It moved toward the reference from the start and overshot it by less than 10 µm.
    let at = |t: f64| position[(t / 0.002).round() as usize];
    assert!(at(0.2) > 0.0 && at(0.4) > at(0.2), "moving forward: {} {}", at(0.2), at(0.4));
    assert!(position.iter().all(|&x| (0.0..110e-6).contains(&x)));
}

#[test]
fn a_name_the_system_lacks_is_a_typed_error() {
    let ssp = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../dist/InchwormSystem.ssp");
    let opts = Options {
        stop_time: Some(0.01),
        step_size: Some(0.002),
        coupling: Coupling::Jacobi,
        params: vec![],
        parameter_set: None,
        input: None,
        outputs: vec!["plant.no_such_variable".into()],
    };
    let e = System::load(&ssp).unwrap().initialise(&opts).err().expect("refused");
    let Error::Context { source, .. } = &e else { panic!("{e:?}") };
    assert!(matches!(**source, Error::Fmu(_)), "the import layer's error, kept: {source:?}");
    assert!(e.to_string().starts_with("output `plant.no_such_variable`: "), "{e}");
}
