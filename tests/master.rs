//! `inchworm run`'s master on the project's SSP and FMUs: the same trace as the direct
//! coupling, parameter sets, Gauss–Seidel, and a clear error for every bad file or name.

use std::io::Write;
use std::path::Path;

use inchworm_controller::Params;
use inchworm_cosim::master::{run, Coupling, InputTable, Options};
use inchworm_cosim::trace::Trace;
use inchworm_fmu_models::{ControllerFmu, PlantFmu};
use inchworm_plant::PlantParams;
use inchworm_scenarios::closed_loop::run as direct;

use inchworm_dist::path as dist;

/// The plant's variable `name` as the systems record it.
fn plant(name: &str) -> String {
    format!("plant.{name}")
}

/// The plant's encoder counts as the systems record them.
fn encoder_counts() -> String {
    plant(PlantFmu::ENCODER_COUNTS.name())
}

/// The open system's output connector of the plant's encoder position.
fn encoder_position() -> &'static str {
    PlantFmu::ENCODER_POSITION.name()
}

fn options(parameter_set: Option<&str>, coupling: Coupling) -> Options {
    Options {
        stop_time: Some(10.0),
        step_size: Some(0.002),
        coupling,
        params: vec![],
        parameter_set: parameter_set.map(str::to_string),
        input: Some(InputTable::parse("time,reference\n0,1e-4\n").unwrap()),
        outputs: vec![encoder_counts(), encoder_position().into()],
    }
}

fn counts(r: &Trace) -> Vec<i64> {
    r.column(&encoder_counts()).unwrap().iter().map(|&c| c as i64).collect()
}

#[test]
fn ssp_through_the_master_equals_the_direct_coupling() {
    let ssp = dist("InchwormSystemOpen.ssp");
    let full = run(&ssp, &options(None, Coupling::Jacobi), |_| {}).unwrap();
    let d = direct(PlantParams::fia20(), Params::default(), |_| 100e-6, 10.0).unwrap();
    assert_eq!(counts(&full), counts(&d), "full control");
    let fb = run(&ssp, &options(Some("feedback-only"), Coupling::Jacobi), |_| {}).unwrap();
    let d = direct(
        PlantParams::fia20(),
        Params {
            feedforward: false,
            use_scale_factor_estimate: false,
            use_disturbance_estimate: false,
            ..Params::default()
        },
        |_| 100e-6,
        10.0,
    )
    .unwrap();
    assert_eq!(counts(&fb), counts(&d), "feedback only");
    // The system output connector carries the plant's encoder position.
    let pos = full.column(encoder_position()).unwrap();
    assert!((pos.last().unwrap() - 100e-6).abs() < 1e-6);
}

#[test]
fn parameter_sets_and_params_reach_the_fmus() {
    let ssp = dist("InchwormSystemOpen.ssp");
    let mut o = options(Some("fia6"), Coupling::Jacobi);
    o.stop_time = Some(1.0);
    let fia6 = run(&ssp, &o, |_| {}).unwrap();
    let mut o = options(None, Coupling::Jacobi);
    o.stop_time = Some(1.0);
    let fia20 = run(&ssp, &o, |_| {}).unwrap();
    // fia6's weaker transducer moves less per step: after the first step (0.2 s) the
    // runner is nearer the start.
    let at = |r: &Trace| r.column(&encoder_counts()).unwrap()[100];
    assert!(at(&fia6) < 0.8 * at(&fia20), "fia6 {} vs fia20 {} counts", at(&fia6), at(&fia20));
    o.params = vec![
        (plant(PlantParams::T_EM.name()), "2.5".into()),
        (plant(PlantParams::F_D0.name()), "105".into()),
    ];
    let by_param = run(&ssp, &o, |_| {}).unwrap();
    assert_eq!(counts(&by_param), counts(&fia6));
}

#[test]
fn gauss_seidel_closes_the_loop_too() {
    let r = run(&dist("InchwormSystemOpen.ssp"), &options(None, Coupling::GaussSeidel), |_| {})
        .unwrap();
    let pos = r.column(encoder_position()).unwrap();
    assert!((pos.last().unwrap() - 100e-6).abs() < 1e-6, "final position {}", pos.last().unwrap());
    assert_ne!(
        counts(&r),
        counts(
            &run(&dist("InchwormSystemOpen.ssp"), &options(None, Coupling::Jacobi), |_| {})
                .unwrap()
        )
    );
}

fn error_of(path: &Path, o: &Options) -> String {
    match run(path, o, |_| {}) {
        Ok(_) => panic!("{} ran although it should not", path.display()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_files_names_and_values_are_refused_clearly() {
    let ssp = dist("InchwormSystemOpen.ssp");
    let mut o = options(None, Coupling::Jacobi);
    o.outputs = vec!["plant.no_such_thing".into()];
    let e = error_of(&ssp, &o);
    assert!(e.contains("no_such_thing") && e.contains("no variable"), "{e}");
    let mut o = options(None, Coupling::Jacobi);
    o.params = vec![(plant(PlantParams::T_EM.name()), "lots".into())];
    assert!(error_of(&ssp, &o).contains("not a number"));
    let mut o = options(None, Coupling::Jacobi);
    o.parameter_set = Some("nonexistent".into());
    assert!(error_of(&ssp, &o).contains("parameter set nonexistent"));
    let mut o = options(None, Coupling::Jacobi);
    o.input = Some(InputTable::parse("time,refrence\n0,1\n").unwrap());
    assert!(error_of(&ssp, &o).contains("refrence"));
    assert!(InputTable::parse("t,x\n0,1\n").unwrap_err().to_string().contains("time"));
    assert!(InputTable::parse("time,x\n1,1\n0,2\n").unwrap_err().to_string().contains("backwards"));

    let dir = std::env::temp_dir().join(format!("inchworm-master-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // Not a zip at all.
    let corrupt = dir.join("corrupt.fmu");
    std::fs::write(&corrupt, b"this is not an FMU").unwrap();
    let e = error_of(&corrupt, &options(None, Coupling::Jacobi));
    assert!(e.contains("corrupt.fmu"), "{e}");
    // A real model description but no binary for this platform.
    let nobin = dir.join("nobinary.fmu");
    let md = {
        let mut z =
            zip::ZipArchive::new(std::fs::File::open(dist("InchwormPlant.fmu")).unwrap()).unwrap();
        let mut s = String::new();
        std::io::Read::read_to_string(&mut z.by_name("modelDescription.xml").unwrap(), &mut s)
            .unwrap();
        s
    };
    let mut w = zip::ZipWriter::new(std::fs::File::create(&nobin).unwrap());
    w.start_file("modelDescription.xml", zip::write::SimpleFileOptions::default()).unwrap();
    w.write_all(md.as_bytes()).unwrap();
    w.finish().unwrap();
    let mut o = options(None, Coupling::Jacobi);
    o.input = None;
    o.outputs = vec![];
    let e = error_of(&nobin, &o);
    assert!(e.contains("nobinary.fmu"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn streamed_rows_are_the_collected_trace() {
    let ssp = dist("InchwormSystemOpen.ssp");
    let mut o = options(None, Coupling::Jacobi);
    o.stop_time = Some(1.0);
    let collected = run(&ssp, &o, |_| {}).unwrap();
    let sim = inchworm_cosim::master::System::load(&ssp).unwrap().initialise(&o).unwrap();
    assert_eq!(sim.n_steps(), 500);
    let mut streamed = Trace::new(sim.record_names().to_vec());
    sim.run_into(
        |t, row| {
            streamed.push(t, row.to_vec());
            Ok::<(), inchworm_cosim::Error>(())
        },
        |_| {},
    )
    .unwrap();
    assert_eq!(streamed, collected);
    assert_eq!(streamed.rows.len(), 501);
    assert_eq!(streamed.rows.last().unwrap().0, 1.0);
}

#[test]
fn a_stop_time_off_the_grid_is_refused_before_any_step() {
    let ssp = dist("InchwormSystemOpen.ssp");
    let mut o = options(None, Coupling::Jacobi);
    o.stop_time = Some(0.011);
    assert_eq!(
        error_of(&ssp, &o),
        "stop time 0.011 is not a whole number of steps of 0.002 (0.011 / 0.002 = 5.5): choose a stop time that is"
    );
    o.stop_time = Some(0.001);
    assert!(error_of(&ssp, &o).starts_with("stop time 0.001 is not a whole number of steps"));
    o.stop_time = Some(1e300);
    assert!(error_of(&ssp, &o).ends_with("more than the 2^53 this master can count exactly"));
    // 10 s in 2 ms steps is 5000.000000000001 in floating point: on the grid.
    o.stop_time = Some(10.0);
    let sim = inchworm_cosim::master::System::load(&ssp).unwrap().initialise(&o).unwrap();
    assert_eq!(sim.n_steps(), 5000);
}

#[test]
fn input_tables_skip_a_bom_and_cut_what_they_echo() {
    let t = InputTable::parse("\u{feff}time,reference\n0,1\n").unwrap();
    assert_eq!(t.names, vec!["reference".to_string()]);
    let long = format!("time,x\n0,{}y\n", "1".repeat(10_000));
    let e = InputTable::parse(&long).unwrap_err().to_string();
    assert_eq!(e, format!("input CSV line 2: not all numbers: `0,{}…`", "1".repeat(198)));
    let mut o = options(None, Coupling::Jacobi);
    o.input = Some(InputTable::parse("time,reference\n0.5,1e-4\n").unwrap());
    assert_eq!(
        error_of(&dist("InchwormSystemOpen.ssp"), &o),
        "input CSV starts at t = 0.5, after the start time 0: its first row must be at t = 0 or earlier"
    );
}

#[test]
fn a_stop_flag_ends_the_run_between_two_steps() {
    let ssp = dist("InchwormSystemOpen.ssp");
    let o = options(None, Coupling::Jacobi);
    let stop = inchworm_cosim::StopFlag::new();
    let sim = inchworm_cosim::System::load(&ssp).unwrap().initialise(&o).unwrap();
    let sim = sim.stop_when(stop.clone());
    let mut rows = 0;
    let e = sim
        .run_into(
            |_, _| {
                rows += 1;
                if rows == 10 {
                    stop.set();
                }
                Ok::<(), inchworm_cosim::Error>(())
            },
            |_| {},
        )
        .unwrap_err();
    assert!(e.is_stopped(), "{e}");
    assert_eq!(rows, 10, "no step after the flag is set");
}

#[test]
fn a_component_that_cannot_load_keeps_the_import_error_as_source() {
    let dir = std::env::temp_dir().join(format!("inchworm-missing-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let ssp = dir.join("Missing.ssp");
    let mut w = zip::ZipWriter::new(std::fs::File::create(&ssp).unwrap());
    w.start_file("SystemStructure.ssd", zip::write::SimpleFileOptions::default()).unwrap();
    std::io::Write::write_all(
        &mut w,
        br#"<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" version="1.0" name="S"><ssd:System name="S"><ssd:Elements><ssd:Component name="a" source="resources/A.fmu"/></ssd:Elements></ssd:System></ssd:SystemStructureDescription>"#,
    )
    .unwrap();
    w.finish().unwrap();
    let Err(e) = inchworm_cosim::System::load(&ssp) else { panic!("loaded without its FMU") };
    match &e {
        inchworm_cosim::Error::Component { component, source } => {
            assert_eq!(component, "a");
            assert!(matches!(source, inchworm_cosim::fmu::FmuError::Missing(_)), "{source:?}");
        }
        other => panic!("{other:?}"),
    }
    assert!(e.to_string().starts_with("component a: "), "{e}");
    std::fs::remove_dir_all(dir).unwrap();
}

/// Steps `n` times, sampling after each step.
fn steps(sim: &mut inchworm_cosim::Simulation, n: usize) -> Vec<Vec<f64>> {
    (0..n)
        .map(|_| {
            sim.step().unwrap();
            sim.sample().unwrap()
        })
        .collect()
}

/// The master sets an input group only when its values change, so after a restore it
/// must set them all again: the restored FMUs hold the checkpoint's inputs, not the last
/// ones set. Here the reference jumps at the checkpoint itself, to the value the master
/// set last before the restore.
#[test]
fn after_a_restore_every_input_is_set_again() {
    use inchworm_cosim::System;
    for coupling in [Coupling::Jacobi, Coupling::GaussSeidel] {
        let opts = Options {
            stop_time: Some(2.0),
            step_size: Some(0.002),
            coupling,
            params: vec![],
            parameter_set: None,
            input: Some(
                InputTable::steps(ControllerFmu::REFERENCE.name(), &[(0.0, 0.0), (0.3, 1e-4)])
                    .unwrap(),
            ),
            outputs: vec![encoder_counts(), plant(PlantFmu::RUNNER_POSITION.name())],
        };
        let mut sim =
            System::load(&dist("InchwormSystemOpen.ssp")).unwrap().initialise(&opts).unwrap();
        steps(&mut sim, 150);
        let cp = sim.checkpoint().unwrap();
        let first = steps(&mut sim, 200);
        sim.restore(&cp).unwrap();
        let again = steps(&mut sim, 200);
        let bits = |rows: &[Vec<f64>]| -> Vec<u64> {
            rows.iter().flatten().map(|v| v.to_bits()).collect()
        };
        assert_ne!(first[0], first[199], "{coupling:?}: the runner moved after the jump");
        assert_eq!(bits(&first), bits(&again), "{coupling:?}: the run after the checkpoint");
        sim.release(cp).unwrap();
    }
}

/// A step reads the recorded outputs with the sources and the row after it calls no FMU;
/// a row taken right after a restore reads the restored FMUs, not the last step's values.
/// `plant.runner_position` is recorded and feeds no input.
#[test]
fn a_row_after_a_restore_reads_the_restored_fmus() {
    use inchworm_cosim::System;
    let opts = Options {
        stop_time: Some(2.0),
        step_size: Some(0.002),
        coupling: Coupling::Jacobi,
        params: vec![],
        parameter_set: None,
        input: Some(InputTable::steps(ControllerFmu::REFERENCE.name(), &[(0.0, 1e-4)]).unwrap()),
        outputs: vec![plant(PlantFmu::RUNNER_POSITION.name()), encoder_counts()],
    };
    let mut sim = System::load(&dist("InchwormSystemOpen.ssp")).unwrap().initialise(&opts).unwrap();
    steps(&mut sim, 150);
    let cp = sim.checkpoint().unwrap();
    let at_checkpoint = sim.sample().unwrap();
    let later = steps(&mut sim, 200);
    assert_ne!(later[199][0], at_checkpoint[0], "the runner moved after the checkpoint");
    sim.restore(&cp).unwrap();
    let restored = sim.sample().unwrap();
    let bits = |row: &[f64]| -> Vec<u64> { row.iter().map(|v| v.to_bits()).collect() };
    assert_eq!(bits(&restored), bits(&at_checkpoint), "the row right after the restore");
    sim.release(cp).unwrap();
}

#[test]
fn a_checkpoint_of_fmi3_and_fmi2_components_repeats_the_run_bit_for_bit() {
    use inchworm_cosim::System;
    // The FMI 3.0 plant with the FMI 2.0 controller and reference, and both FMUs FMI 3.0.
    for (ssp, input) in
        [("fmi3/InchwormSystemMixed.ssp", None), ("fmi3/InchwormSystemOpen.ssp", Some(1e-4))]
    {
        let opts = Options {
            stop_time: Some(2.0),
            step_size: Some(0.002),
            coupling: Coupling::Jacobi,
            params: vec![],
            parameter_set: None,
            input: input
                .map(|r| InputTable::steps(ControllerFmu::REFERENCE.name(), &[(0.0, r)]).unwrap()),
            outputs: vec![encoder_counts(), plant(PlantFmu::RUNNER_POSITION.name())],
        };
        let mut sim = System::load(&dist(ssp)).unwrap().initialise(&opts).unwrap();
        // Into the move of Fig. 5, where the gait and the estimator are busy.
        steps(&mut sim, 150);
        let cp = sim.checkpoint().unwrap();
        assert_eq!(cp.step(), 150);
        let first = steps(&mut sim, 200);
        sim.restore(&cp).unwrap();
        assert_eq!(sim.time(), 150.0 * 0.002, "{ssp}: time after restore");
        let again = steps(&mut sim, 200);
        let bits = |rows: &[Vec<f64>]| -> Vec<u64> {
            rows.iter().flatten().map(|v| v.to_bits()).collect()
        };
        assert_eq!(bits(&first), bits(&again), "{ssp}: the run after the checkpoint");
        assert_ne!(first[0], first[199], "{ssp}: the runner moved over the 0.4 s compared");

        // A checkpoint of another simulation names the call that refused it.
        let mut other = System::load(&dist(ssp)).unwrap().initialise(&opts).unwrap();
        let e = other.restore(&cp).unwrap_err().to_string();
        let call = if input.is_some() { "fmi3SetFMUState" } else { "fmi2SetFMUstate" };
        assert!(e.contains(call), "{ssp}: {e}");
        sim.release(cp).unwrap();
    }
}
