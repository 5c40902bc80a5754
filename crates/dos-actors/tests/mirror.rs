//! The dos-actors models of the mirror mount against the co-simulation master: the native
//! network, the native one-client model and the FMU-client network give the encoder,
//! piston, tip and tilt traces of `inchworm run dist/MirrorMount.ssp` bit for bit, each
//! actuator's reference table read from the SSP's parameter bindings.

// mirror_fmu.rs holds mirror_native.rs as its module.
#[path = "../examples/mirror_fmu.rs"]
#[allow(dead_code)]
mod mirror_fmu;

use mirror_fmu::mirror_native;

use std::path::Path;

use inchworm_cosim::ssp::{first_bindings, Archive};
use inchworm_cosim::Options;
use inchworm_dos_actors::uid::{EncoderCounts, Piston, Tilt, Tip};
use inchworm_dos_actors::{ssp_value, Logger};
use inchworm_fmi_export::{Model, Var};
use inchworm_fmu_models::{MountFmu, PlantFmu};

/// 5 s: the piston move, its settling and the tip commanded at 4 s.
const STEPS: u64 = 2500;

pub use inchworm_dist::dir as dist;

/// Each chain's reference bindings in `MirrorMount.ssp`, by parameter name.
fn commands() -> [Vec<(String, f64)>; 3] {
    let ssp = Archive::open(&dist().join("MirrorMount.ssp")).expect("dist/MirrorMount.ssp");
    let bindings = first_bindings(Some(&ssp)).unwrap();
    ["a", "b", "c"].map(|x| {
        let prefix = format!("reference_{x}.");
        bindings
            .iter()
            .filter_map(|(n, v)| Some((n.strip_prefix(&prefix)?.to_string(), ssp_value(v)?)))
            .collect()
    })
}

/// The master's name of `var` of the SSP's `component`.
fn path<M: Model>(component: &str, var: Var<M>) -> String {
    format!("{component}.{}", var.name())
}

/// The master's trace of the mount and the encoders.
fn master() -> inchworm_cosim::Trace {
    let pose = [MountFmu::PISTON, MountFmu::TIP, MountFmu::TILT];
    let mut outputs: Vec<String> = pose.map(|v| path("mount", v)).into();
    outputs.extend(["a", "b", "c"].map(|x| path(&format!("plant_{x}"), PlantFmu::ENCODER_COUNTS)));
    master_run(&dist().join("MirrorMount.ssp"), outputs)
}

/// `inchworm run` of `ssp` for `STEPS` steps, recording `outputs`.
pub fn master_run(ssp: &Path, outputs: Vec<String>) -> inchworm_cosim::Trace {
    let opts = Options {
        stop_time: Some(STEPS as f64 * 0.002),
        step_size: None,
        coupling: inchworm_cosim::Coupling::Jacobi,
        params: Vec::new(),
        parameter_set: None,
        input: None,
        outputs,
    };
    inchworm_cosim::master::run(ssp, &opts, |_| {}).unwrap()
}

fn same_bits(what: &str, actors: Option<&[f64]>, master: &[f64]) {
    let actors = actors.unwrap_or_else(|| panic!("{what}: not logged"));
    // The model steps once past the master's last row (mirror_native::reference).
    assert!(
        actors.len() >= master.len(),
        "{what}: {} rows, the master's {}",
        actors.len(),
        master.len()
    );
    for (k, (a, m)) in actors.iter().zip(master).enumerate() {
        assert_eq!(a.to_bits(), m.to_bits(), "{what}, row {k}: {a} against the master's {m}");
    }
}

fn check(logger: &Logger, trace: &inchworm_cosim::Trace) {
    let col = |n: String| trace.column(&n).unwrap();
    let pose = |v: Var<MountFmu>| col(path("mount", v));
    let encoder = |x: &str| col(path(&format!("plant_{x}"), PlantFmu::ENCODER_COUNTS));
    let (piston, tip, tilt) = (MountFmu::PISTON, MountFmu::TIP, MountFmu::TILT);
    same_bits(piston.name(), logger.column::<Piston>(), &pose(piston));
    same_bits(tip.name(), logger.column::<Tip>(), &pose(tip));
    same_bits(tilt.name(), logger.column::<Tilt>(), &pose(tilt));
    same_bits("encoder a", logger.column::<EncoderCounts<0>>(), &encoder("a"));
    same_bits("encoder b", logger.column::<EncoderCounts<1>>(), &encoder("b"));
    same_bits("encoder c", logger.column::<EncoderCounts<2>>(), &encoder("c"));
    // Not a trivial agreement: the mount has moved by the end.
    let piston = logger.column::<Piston>().unwrap();
    assert!(piston.last().unwrap() > &25e-6, "piston at the end: {:?}", piston.last());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn native_network_is_the_master_bit_for_bit() {
    let logger = mirror_native::network(&commands(), STEPS).await.unwrap();
    check(&*logger.lock().await, &master());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn native_one_client_is_the_master_bit_for_bit() {
    let logger = mirror_native::one_client(&commands(), STEPS).await.unwrap();
    check(&*logger.lock().await, &master());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fmu_network_is_the_master_bit_for_bit() {
    let logger = mirror_fmu::network(&dist(), &commands(), STEPS).await.unwrap();
    check(&*logger.lock().await, &master());
}
