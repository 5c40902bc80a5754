//! The mirror mount of `mirror_native.rs` with the FMUs in place of the native clients:
//! each actuator is two [`FmuClient`] actors, `dist/InchwormController.fmu` and
//! `dist/InchwormPlant.fmu`, coupled through the loop's UIDs (DAC volts one way, encoder
//! the other), and the mount is an [`FmuClient`] on `dist/InchwormMount.fmu`. The
//! references are the native sources at 1 kHz; the FMUs step 2 ms at each of their actors'
//! iterations (rate 2). The traces are those of `inchworm run dist/MirrorMount.ssp` bit
//! for bit (tests/mirror.rs).
//!
//! `cargo run --release -p inchworm-dos-actors --example mirror_fmu` (after
//! `cargo run --release -p fmu-build`, which builds `dist/`)

#[path = "mirror_native.rs"]
#[allow(dead_code)]
pub mod mirror_native;

use std::path::Path;
use std::sync::Arc;

use gmt_dos_actors::framework::model::Task;
use gmt_dos_actors::prelude::*;
use inchworm_dos_actors::interface::TryRead;
use inchworm_dos_actors::uid::*;
use inchworm_dos_actors::{FmuClient, Logger};
pub use mirror_native::{reference, BoxError, R};
use tokio::sync::Mutex;

/// The FMUs' communication step: the actuators' 2 ms sample, R base samples.
pub const STEP: f64 = R as f64 * mirror_native::BASE;

/// One actuator as two FMU actors: its reference into the controller, the DAC volts to the
/// plant, the encoder back to the controller. Every FMU output is bootstrapped (its value
/// at t = 0 first), which makes each actor's step k take the others' outputs at `t_k`: the
/// master's Jacobi step. The runner position goes to `mount` if given, the encoder and the
/// runner position to the logger.
pub fn fmu_chain<const ID: u8>(
    controller: FmuClient,
    plant: FmuClient,
    command: &[(String, f64)],
    steps: u64,
    mount: Option<&mut Actor<FmuClient, R, R>>,
    sink: &mut Actor<Logger, R, 0>,
) -> Result<Vec<Box<dyn Task>>, BoxError>
where
    FmuClient: TryRead<RunnerPosition<ID>>,
{
    let (source, mut sampler) = reference::<ID>(command, steps)?;
    let mut controller: Actor<_, R, R> = controller.into();
    let mut plant: Actor<_, R, R> = plant.into();
    sampler.add_output().build::<Reference<ID>>().into_input(&mut controller)?;
    controller.add_output().bootstrap().build::<DacEarth<ID>>().into_input(&mut plant)?;
    controller.add_output().bootstrap().build::<DacNonearth<ID>>().into_input(&mut plant)?;
    controller.add_output().bootstrap().build::<DacExtension<ID>>().into_input(&mut plant)?;
    // A multiplexed output sends to its inputs in order and stops at the first that has
    // gone: the logger first, on unbounded channels, so that when the model ends (the
    // controller and the mount drop their inputs) the logger has the last row.
    plant
        .add_output()
        .unbounded()
        .bootstrap()
        .multiplex(2)
        .build::<EncoderCounts<ID>>()
        .into_input(sink)
        .into_input(&mut controller)?;
    match mount {
        Some(mount) => plant
            .add_output()
            .unbounded()
            .bootstrap()
            .multiplex(2)
            .build::<RunnerPosition<ID>>()
            .into_input(sink)
            .into_input(mount)?,
        None => plant.add_output().bootstrap().build::<RunnerPosition<ID>>().into_input(sink)?,
    }
    Ok(vec![Box::new(source), Box::new(sampler), Box::new(controller), Box::new(plant)])
}

/// Controller and plant FMU clients for chain `ID` from `dist`.
fn actuator<const ID: u8>(dist: &Path) -> Result<(FmuClient, FmuClient), BoxError> {
    let controller =
        FmuClient::load(dist.join("InchwormController.fmu"), &format!("controller_{ID}"), STEP)?;
    let plant = FmuClient::load(dist.join("InchwormPlant.fmu"), &format!("plant_{ID}"), STEP)?;
    Ok((controller, plant))
}

/// The FMU-client network: three actuators and the mount, `steps` steps of 2 ms.
pub async fn network(
    dist: &Path,
    commands: &[Vec<(String, f64)>; 3],
    steps: u64,
) -> Result<Arc<Mutex<Logger>>, BoxError> {
    let logger = Logger::default().into_arcx();
    let mut sink = Actor::<_, R, 0>::new(logger.clone());
    // The mount FMU's inputs take the runner positions under their own names.
    let mount = FmuClient::load(dist.join("InchwormMount.fmu"), "mount", STEP)?
        .rename::<RunnerPosition<0>>(MOUNT_INPUTS[0])
        .rename::<RunnerPosition<1>>(MOUNT_INPUTS[1])
        .rename::<RunnerPosition<2>>(MOUNT_INPUTS[2]);
    let mut mount: Actor<_, R, R> = mount.into();
    let (c, p) = actuator::<0>(dist)?;
    let mut tasks = fmu_chain::<0>(c, p, &commands[0], steps, Some(&mut mount), &mut sink)?;
    let (c, p) = actuator::<1>(dist)?;
    tasks.extend(fmu_chain::<1>(c, p, &commands[1], steps, Some(&mut mount), &mut sink)?);
    let (c, p) = actuator::<2>(dist)?;
    tasks.extend(fmu_chain::<2>(c, p, &commands[2], steps, Some(&mut mount), &mut sink)?);
    mirror_native::run_with_mount(tasks, mount, sink, "mirror-fmu").await?;
    Ok(logger)
}

#[tokio::main]
async fn main() -> Result<(), BoxError> {
    let dist = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../dist");
    let logger = network(&dist, &mirror_native::commands(), 5000).await?;
    let logger = logger.lock().await;
    for (name, column) in [
        ("piston (m)", logger.column::<Piston>()),
        ("tip (rad)", logger.column::<Tip>()),
        ("tilt (rad)", logger.column::<Tilt>()),
    ] {
        println!("{name} at 10 s: {:?}", column.and_then(|c| c.last()));
    }
    Ok(())
}
