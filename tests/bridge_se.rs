//! The HIL bridge driving the FMI 3.0 controller through Scheduled Execution: in lock-step,
//! against the virtual board with the FMI 3.0 plant, the encoder trace is the one the same
//! bridge gives through Co-Simulation and the one the master gives for the same system
//! (`dist/fmi3/InchwormSystemOpen.ssp`, Jacobi, 2 ms), with the controller in plain
//! Co-Simulation and in Scheduled Execution, bit for bit; the output clock
//! `gait_step` lands in the run log. An FMU without Scheduled Execution is refused for it,
//! with the reason.

use std::path::PathBuf;
use std::process::Command;

use inchworm::bridge::{FmuController, Interface};
use inchworm::closed_loop::{recorded, LoopView, REFERENCE};
use inchworm::master::{self, Coupling, InputTable, Options};
use inchworm_bridge::controller::ControllerReport;
use inchworm_bridge::runlog::{read_log, Record};

use inchworm_dist::path as dist;

#[path = "support/lockstep.rs"]
mod lockstep;

#[path = "support/real_time.rs"]
mod real_time;
use real_time::{turn, RealTime};

const BIN: &str = env!("CARGO_BIN_EXE_inchworm");
const SECONDS: f64 = 4.0;

fn reference(t: f64) -> f64 {
    if t < 2.0 {
        100e-6
    } else {
        40e-6
    }
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("iw-bridge-se-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The bridge in lock-step: the FMI 3.0 plant in a virtual board on loopback, the FMI 3.0
/// controller through `interface` here, its run log at `log`.
fn lockstep(interface: Interface, log: &std::path::Path) -> (ControllerReport, &'static str) {
    let mut comp =
        FmuController::load(&dist("fmi3/InchwormController.fmu"), &[], interface).unwrap();
    let ticks = (SECONDS / 0.002) as u64;
    let (report, _) =
        lockstep::lockstep(&dist("fmi3/InchwormPlant.fmu"), &mut comp, &reference, ticks, log);
    (report, comp.interface())
}

#[test]
fn scheduled_execution_gives_the_co_simulation_trace_and_the_masters() {
    let _rt = RealTime::enter();
    let opts = Options {
        stop_time: Some(SECONDS),
        step_size: Some(0.002),
        coupling: Coupling::Jacobi,
        params: vec![],
        parameter_set: None,
        input: Some(InputTable::steps(REFERENCE, &[(0.0, 100e-6), (2.0, 40e-6)]).unwrap()),
        outputs: recorded(),
    };
    let cosim =
        LoopView::new(&master::run(&dist("fmi3/InchwormSystemOpen.ssp"), &opts, |_| {}).unwrap())
            .unwrap();
    assert!(cosim.settle_time(1e-6).is_some(), "the scenario moves and settles");

    let dir = scratch("lockstep");
    let (cs, cs_name) = lockstep(Interface::CoSimulation, &dir.join("cs.log"));
    let (se, se_name) = lockstep(Interface::ScheduledExecution, &dir.join("se.log"));
    // The FMI 3.0 controller offers Scheduled Execution, so `auto` takes it.
    let (auto, auto_name) = lockstep(Interface::Auto, &dir.join("auto.log"));
    assert_eq!((cs_name, se_name, auto_name), ("cs", "se", "se"));
    assert_eq!(se.encoder, cs.encoder, "Scheduled Execution against Co-Simulation");
    assert_eq!(auto.encoder, se.encoder);
    let bridge: Vec<i64> = se.encoder.iter().map(|&c| i64::from(c)).collect();
    assert_eq!(bridge, cosim.encoder_counts, "the bridge against the master");
    // The master with the controller in Scheduled Execution too (`--interface controller=se`).
    let interfaces =
        master::Interfaces { scheduled_execution: vec!["controller".into()], ..Default::default() };
    let mut sim = master::System::load_as(&dist("fmi3/InchwormSystemOpen.ssp"), &interfaces)
        .unwrap()
        .initialise(&opts)
        .unwrap();
    let mut trace = inchworm::trace::Trace::new(sim.record_names().to_vec());
    trace.push(0.0, sim.sample().unwrap());
    for _ in 0..sim.n_steps() {
        sim.step().unwrap();
        let row = sim.sample().unwrap();
        trace.push(sim.time(), row);
    }
    sim.terminate().unwrap();
    let master_se = LoopView::new(&trace).unwrap();
    assert_eq!(bridge, master_se.encoder_counts, "the bridge against the master's SE run");

    // gait_step: none through Co-Simulation (no clocks there), through Scheduled Execution
    // an event of the run log at each tick whose sample ended a gait step.
    let clock_events = |name: &str| -> Vec<u32> {
        read_log(&dir.join(name))
            .unwrap()
            .records
            .iter()
            .filter_map(|r| match r {
                Record::Event { tick, text } if text == "output clock gait_step ticked" => {
                    Some(*tick)
                }
                _ => None,
            })
            .collect()
    };
    assert_eq!((cs.clock_ticks, clock_events("cs.log").len()), (0, 0));
    let ticks = clock_events("se.log");
    assert!(ticks.len() >= 3, "the gait ran: gait_step at {ticks:?}");
    assert_eq!(ticks.len() as u64, se.clock_ticks);
    assert_eq!(ticks.iter().map(|t| t - se.first_tick).collect::<Vec<_>>(), {
        let a = clock_events("auto.log");
        a.iter().map(|t| t - auto.first_tick).collect::<Vec<_>>()
    });
    // gait_step clocks the estimator's update: in the master's run the disturbance
    // estimate changes at exactly the ticks (the rows' times over 2 ms) where the bridge
    // logged the clock.
    let estimate = &cosim.disturbance_estimate;
    let changed: Vec<u32> = (1..estimate.len())
        .filter(|&k| estimate[k].to_bits() != estimate[k - 1].to_bits())
        .map(|k| (cosim.time[k] / 0.002).round() as u32)
        .collect();
    let relative: Vec<u32> = ticks.iter().map(|t| t - se.first_tick).collect();
    assert_eq!(changed, relative, "gait_step ticks where the estimates change");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn scheduled_execution_of_an_fmu_without_it_is_refused_with_the_reason() {
    let _turn = turn();
    let run = |args: &[&str]| {
        let out = Command::new(BIN).args(args).output().unwrap();
        assert!(!out.status.success(), "{args:?}");
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    let fmi2 = dist("InchwormController.fmu");
    let e = run(&[
        "bridge",
        "--role",
        "controller",
        "--interface",
        "se",
        "--addr",
        "127.0.0.1:9",
        "--fmu",
        fmi2.to_str().unwrap(),
    ]);
    assert!(
        e.contains("does not offer Scheduled Execution")
            && e.contains("lacks <ScheduledExecution>"),
        "{e}"
    );
    let e = run(&["bridge", "--role", "board", "--interface", "cs", "--addr", "127.0.0.1:0"]);
    assert!(e.contains("--interface is a controller option (--role controller)"), "{e}");
    let e = run(&["bridge", "--role", "controller", "--interface", "me"]);
    assert!(e.contains("invalid value 'me' for '--interface"), "{e}");
}
