//! FmuClient on the mixed system (the FMI 3.0 plant and the FMI 2.0 controller in one actor
//! model, bit for bit with `inchworm run dist/fmi3/InchwormSystemMixed.ssp`), and on bad
//! FMUs: each gives a clear error from the model's run or from loading, never a panic or
//! a hang.

#[path = "../examples/mirror_fmu.rs"]
#[allow(dead_code)]
mod mirror_fmu;

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

use gmt_dos_actors::prelude::*;
use inchworm_cosim::ssp::{first_bindings, Archive};
use inchworm_dos_actors::uid::{DacEarth, EncoderCounts, RunnerPosition};
use inchworm_dos_actors::{ssp_value, FmuClient, Logger};
use inchworm_fmu_models::PlantFmu;
use mirror_fmu::{fmu_chain, STEP};

use inchworm_dist::dir as dist;

/// One actuator of FMU clients and a logger, `steps` steps, within 60 s.
async fn run(
    controller: FmuClient,
    plant: FmuClient,
    reference: &[(String, f64)],
    steps: u64,
) -> Result<Logger, String> {
    let logger = Logger::default().into_arcx();
    let mut sink = Actor::<_, 2, 0>::new(logger.clone());
    let model = async {
        let mut tasks = fmu_chain::<0>(controller, plant, reference, steps, None, &mut sink)?;
        tasks.push(Box::new(sink));
        Model::new(tasks).name("chain").quiet().check()?.run().await?;
        Ok::<(), mirror_fmu::BoxError>(())
    };
    match tokio::time::timeout(Duration::from_secs(60), model).await {
        Err(_) => Err("the model's run did not end within 60 s".into()),
        Ok(Err(e)) => Err(chain_text(&*e)),
        Ok(Ok(())) => Ok(std::mem::take(&mut *logger.lock().await)),
    }
}

/// An error and its sources, as one line.
fn chain_text(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        text.push_str(&format!(": {s}"));
        source = s.source();
    }
    text
}

fn controller() -> FmuClient {
    FmuClient::load(dist().join("InchwormController.fmu"), "controller", STEP).unwrap()
}

fn plant() -> FmuClient {
    FmuClient::load(dist().join("InchwormPlant.fmu"), "plant", STEP).unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fmi3_plant_and_fmi2_controller_are_the_mixed_ssp_bit_for_bit() {
    const STEPS: u64 = 500;
    let ssp = dist().join("fmi3/InchwormSystemMixed.ssp");
    let bindings = first_bindings(Some(&Archive::open(&ssp).unwrap())).unwrap();
    let of = |component: &str| -> Vec<(String, String)> {
        let prefix = format!("{component}.");
        let named =
            |(n, v): &(String, String)| Some((n.strip_prefix(&prefix)?.to_string(), v.clone()));
        bindings.iter().filter_map(named).collect()
    };
    // The SSP's components: the reference FMU (its bindings to the native source), the
    // FMI 2.0 controller and the FMI 3.0 plant (its own FMU, from the SSP's folder).
    let reference: Vec<(String, f64)> =
        of("reference").into_iter().map(|(n, v)| (n, ssp_value(&v).unwrap())).collect();
    let mut controller =
        FmuClient::load(dist().join("InchwormController.fmu"), "controller", STEP).unwrap();
    for (n, v) in of("controller") {
        controller = controller.parameter_text(&n, &v).unwrap();
    }
    let mut plant = FmuClient::load(dist().join("fmi3/InchwormPlant.fmu"), "plant", STEP).unwrap();
    for (n, v) in of("plant") {
        plant = plant.parameter_text(&n, &v).unwrap();
    }
    let logger = run(controller, plant, &reference, STEPS).await.unwrap();

    let (counts, runner) = (PlantFmu::ENCODER_COUNTS.name(), PlantFmu::RUNNER_POSITION.name());
    let (counts, runner) = (format!("plant.{counts}"), format!("plant.{runner}"));
    let opts = inchworm_cosim::Options {
        stop_time: Some(STEPS as f64 * STEP),
        step_size: None,
        coupling: inchworm_cosim::Coupling::Jacobi,
        params: Vec::new(),
        parameter_set: None,
        input: None,
        outputs: vec![counts.clone(), runner.clone()],
    };
    let trace = inchworm_cosim::master::run(&ssp, &opts, |_| {}).unwrap();
    for (column, name) in [
        (logger.column::<EncoderCounts<0>>().unwrap(), counts),
        (logger.column::<RunnerPosition<0>>().unwrap(), runner),
    ] {
        let master = trace.column(&name).unwrap();
        assert!(
            column.len() >= master.len(),
            "{name}: {} rows, the master's {}",
            column.len(),
            master.len()
        );
        for (k, (a, m)) in column.iter().zip(&master).enumerate() {
            assert_eq!(a.to_bits(), m.to_bits(), "{name}, row {k}: {a} against {m}");
        }
    }
    // The runner has moved most of the 100 µm step in 1 s.
    let end = logger.column::<RunnerPosition<0>>().unwrap()[STEPS as usize];
    assert!(end > 90e-6, "runner at 1 s: {end}");
}

#[test]
fn a_missing_fmu_is_an_error_naming_the_file() {
    let e = FmuClient::load(dist().join("NoSuch.fmu"), "plant", STEP).unwrap_err();
    assert!(e.to_string().contains("NoSuch.fmu: no such FMU file"), "{e}");
}

/// A copy of the mount FMU whose description declares Model Exchange only.
fn model_exchange_only(dir: &Path) -> PathBuf {
    let mut source =
        zip::ZipArchive::new(std::fs::File::open(dist().join("InchwormMount.fmu")).unwrap())
            .unwrap();
    let path = dir.join("MountME.fmu");
    let mut out = zip::ZipWriter::new(std::fs::File::create(&path).unwrap());
    for i in 0..source.len() {
        let mut entry = source.by_index(i).unwrap();
        let mut bytes = Vec::new();
        entry.read_to_end(&mut bytes).unwrap();
        let name = entry.name().to_string();
        if name == "modelDescription.xml" {
            let xml = String::from_utf8(bytes).unwrap();
            let start = xml.find("<CoSimulation").unwrap();
            let end = start + xml[start..].find("/>").unwrap() + 2;
            bytes = format!("{}{}", &xml[..start], &xml[end..]).into_bytes();
        }
        if entry.is_dir() {
            out.add_directory(name, zip::write::SimpleFileOptions::default()).unwrap();
        } else {
            out.start_file(name, zip::write::SimpleFileOptions::default()).unwrap();
            out.write_all(&bytes).unwrap();
        }
    }
    out.finish().unwrap();
    path
}

#[test]
fn an_fmu_without_co_simulation_is_an_error() {
    let dir = std::env::temp_dir().join(format!("inchworm-dos-actors-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let e = FmuClient::load(model_exchange_only(&dir), "mount", STEP).unwrap_err();
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(e.to_string().contains("no Co-Simulation interface"), "{e}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_unknown_variable_ends_the_run_with_its_name() {
    let plant = plant().rename::<DacEarth<0>>("dac_earht");
    let e = run(controller(), plant, &[], 50).await.unwrap_err();
    assert!(e.contains("(plant): InchwormPlant: no variable named `dac_earht`"), "{e}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_step_the_fmu_refuses_ends_the_run() {
    // The plant is told to stop at 40 ms; the model steps on.
    let plant = plant().stop_time(0.04).unwrap();
    let e = run(controller(), plant, &[], 50).await.unwrap_err();
    assert!(e.contains("(plant): InchwormPlant") && e.contains("DoStep"), "{e}");
}
