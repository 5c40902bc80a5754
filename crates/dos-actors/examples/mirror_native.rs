//! The three-actuator mirror mount as a dos-actors model, native clients only: the
//! references sampled at the 1 kHz base rate, each actuator (controller and plant) an
//! actor at 500 Hz (rate 2), the mount kinematics at 500 Hz, and a logger. Two ways:
//! [`network`], an actor per actuator and one for the mount, and [`one_client`], the whole
//! mount one [`MirrorMount`] client. Both give the traces of
//! `inchworm run dist/MirrorMount.ssp` bit for bit (tests/mirror.rs).
//!
//! `cargo run --release -p inchworm-dos-actors --example mirror_native`

use std::sync::Arc;

use gmt_dos_actors::framework::model::Task;
use gmt_dos_actors::prelude::*;
use inchworm_dos_actors::interface::{TryRead, TryWrite};
use inchworm_dos_actors::uid::{EncoderCounts, Piston, Reference, RunnerPosition, Tilt, Tip};
use inchworm_dos_actors::{Inchworm, Logger, MirrorMount, Mount, ReferenceSource, Sampler};
use inchworm_fmu_models::mount::{actuator_positions, ANGLE_A_DEG, RADIUS};
use inchworm_fmu_models::ReferenceFmu;
use tokio::sync::Mutex;

pub type BoxError = Box<dyn std::error::Error + Send + Sync>;

/// The base sample period: 1 kHz.
pub const BASE: f64 = 1e-3;
/// The actuators' rate: every second base sample, 500 Hz (their 2 ms controller sample).
pub const R: usize = 2;

/// A chain's reference: `command`, parameters of the reference table by name, sampled at
/// 1 kHz, and the sampler that hands each second sample on: `steps + 1` of them, so the
/// actuators step once past `t_steps`. Each actor ends when an input closes, so one that
/// ends first can cut a neighbour's last send; the extra step keeps every output up to
/// `t_steps` whole, and [`Logger`] keeps the rows all its inputs have.
pub fn reference<const ID: u8>(
    command: &[(String, f64)],
    steps: u64,
) -> Result<(Actor<ReferenceSource<ID>, 0, 1>, Actor<Sampler<Reference<ID>>, 1, R>), BoxError> {
    // The actuators' step k takes the sample at k R base samples: R steps + 1 of them.
    let samples = R as u64 * steps + 1;
    let mut source = ReferenceSource::<ID>::new(&format!("reference_{ID}"), BASE, samples)?;
    for (name, value) in command {
        source = source.parameter(name, *value)?;
    }
    let mut source: Actor<_, 0, 1> = source.into();
    let mut sampler: Actor<_, 1, R> = Sampler::<Reference<ID>>::default().into();
    source.add_output().build::<Reference<ID>>().into_input(&mut sampler)?;
    Ok((source, sampler))
}

/// One actuator of the network: its reference and its actor, the runner position to the
/// mount and the logger, the encoder to the logger. Every output the actuator steps is
/// bootstrapped: its value at t = 0 goes first, so the mount's step k takes the positions
/// at `t_k` (the master's Jacobi step) and the logger's row k is `t_k`.
fn chain<const ID: u8>(
    command: &[(String, f64)],
    steps: u64,
    mount: &mut Actor<Mount, R, R>,
    sink: &mut Actor<Logger, R, 0>,
) -> Result<Vec<Box<dyn Task>>, BoxError>
where
    Mount: TryRead<RunnerPosition<ID>>,
{
    let (source, mut sampler) = reference::<ID>(command, steps)?;
    let mut actuator: Actor<_, R, R> = Inchworm::<ID>::new(&format!("inchworm_{ID}"))?.into();
    sampler.add_output().build::<Reference<ID>>().into_input(&mut actuator)?;
    // The logger first, on unbounded channels: when the model ends and the mount has
    // dropped its inputs, the send to the mount fails, and the logger has its row already.
    actuator
        .add_output()
        .unbounded()
        .bootstrap()
        .multiplex(2)
        .build::<RunnerPosition<ID>>()
        .into_input(sink)
        .into_input(mount)?;
    actuator.add_output().bootstrap().build::<EncoderCounts<ID>>().into_input(sink)?;
    Ok(vec![Box::new(source), Box::new(sampler), Box::new(actuator)])
}

/// The actor network: three actuators and the mount, `steps` steps of 2 ms.
pub async fn network(
    commands: &[Vec<(String, f64)>; 3],
    steps: u64,
) -> Result<Arc<Mutex<Logger>>, BoxError> {
    let logger = Logger::default().into_arcx();
    let mut sink = Actor::<_, R, 0>::new(logger.clone());
    let mut mount: Actor<_, R, R> = Mount::new("mount")?.into();
    let mut tasks = chain::<0>(&commands[0], steps, &mut mount, &mut sink)?;
    tasks.extend(chain::<1>(&commands[1], steps, &mut mount, &mut sink)?);
    tasks.extend(chain::<2>(&commands[2], steps, &mut mount, &mut sink)?);
    run_with_mount(tasks, mount, sink, "mirror-network").await?;
    Ok(logger)
}

/// Runs the actors of `tasks` with the mount (its pose to the logger) and the logger.
pub async fn run_with_mount<C>(
    mut tasks: Vec<Box<dyn Task>>,
    mut mount: Actor<C, R, R>,
    mut sink: Actor<Logger, R, 0>,
    name: &str,
) -> Result<(), BoxError>
where
    C: TryWrite<Piston> + TryWrite<Tip> + TryWrite<Tilt> + 'static,
{
    mount.add_output().bootstrap().build::<Piston>().into_input(&mut sink)?;
    mount.add_output().bootstrap().build::<Tip>().into_input(&mut sink)?;
    mount.add_output().bootstrap().build::<Tilt>().into_input(&mut sink)?;
    tasks.push(Box::new(mount));
    tasks.push(Box::new(sink));
    Model::new(tasks).name(name).quiet().check()?.run().await?;
    Ok(())
}

/// The same mount as one client ([`MirrorMount`]) fed by the three references.
pub async fn one_client(
    commands: &[Vec<(String, f64)>; 3],
    steps: u64,
) -> Result<Arc<Mutex<Logger>>, BoxError> {
    let logger = Logger::default().into_arcx();
    let mut sink = Actor::<_, R, 0>::new(logger.clone());
    let mut mirror: Actor<_, R, R> = MirrorMount::new("mirror")?.into();
    let (source_a, mut sampler_a) = reference::<0>(&commands[0], steps)?;
    let (source_b, mut sampler_b) = reference::<1>(&commands[1], steps)?;
    let (source_c, mut sampler_c) = reference::<2>(&commands[2], steps)?;
    sampler_a.add_output().build::<Reference<0>>().into_input(&mut mirror)?;
    sampler_b.add_output().build::<Reference<1>>().into_input(&mut mirror)?;
    sampler_c.add_output().build::<Reference<2>>().into_input(&mut mirror)?;
    mirror.add_output().bootstrap().build::<EncoderCounts<0>>().into_input(&mut sink)?;
    mirror.add_output().bootstrap().build::<EncoderCounts<1>>().into_input(&mut sink)?;
    mirror.add_output().bootstrap().build::<EncoderCounts<2>>().into_input(&mut sink)?;
    mirror.add_output().bootstrap().build::<Piston>().into_input(&mut sink)?;
    mirror.add_output().bootstrap().build::<Tip>().into_input(&mut sink)?;
    mirror.add_output().bootstrap().build::<Tilt>().into_input(&mut sink)?;
    let tasks: Vec<Box<dyn Task>> = vec![
        Box::new(source_a),
        Box::new(sampler_a),
        Box::new(source_b),
        Box::new(sampler_b),
        Box::new(source_c),
        Box::new(sampler_c),
        Box::new(mirror),
        Box::new(sink),
    ];
    Model::new(tasks).name("mirror-one-client").quiet().check()?.run().await?;
    Ok(logger)
}

/// Each actuator's reference table: 30 µm of piston from t = 0, and 4 µrad of tip from
/// t = 4 s (the actuator positions of that pose, by the mount's inverse kinematics).
pub fn commands() -> [Vec<(String, f64)>; 3] {
    let z = actuator_positions(30e-6, 4e-6, 0.0, RADIUS, ANGLE_A_DEG);
    std::array::from_fn(|i| {
        [
            (ReferenceFmu::N_POINTS, 2.0),
            (ReferenceFmu::TIMES_1, 0.0),
            (ReferenceFmu::POSITIONS_1, 30e-6),
            (ReferenceFmu::TIMES_2, 4.0),
            (ReferenceFmu::POSITIONS_2, z[i]),
        ]
        .into_iter()
        .map(|(v, x)| (v.name().to_string(), x))
        .collect()
    })
}

#[tokio::main]
async fn main() -> Result<(), BoxError> {
    let steps = 5000; // 10 s
    let logger = network(&commands(), steps).await?;
    let logger = logger.lock().await;
    for (name, column) in [
        ("piston (m)", logger.column::<Piston>()),
        ("tip (rad)", logger.column::<Tip>()),
        ("tilt (rad)", logger.column::<Tilt>()),
        ("encoder a (counts)", logger.column::<EncoderCounts<0>>()),
    ] {
        println!("{name} at 10 s: {:?}", column.and_then(|c| c.last()));
    }
    let one = one_client(&commands(), steps).await?;
    let one = one.lock().await;
    let same = one.column::<Piston>() == logger.column::<Piston>()
        && one.column::<Tip>() == logger.column::<Tip>()
        && one.column::<Tilt>() == logger.column::<Tilt>();
    println!("one MirrorMount client, the same piston, tip and tilt: {same}");
    Ok(())
}
