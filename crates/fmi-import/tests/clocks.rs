//! FMI 3.0 clocks through the import layer, against the built controller FMU
//! (`dist/fmi3/InchwormController.fmu`): its clock declarations as read from the
//! description, the same encoder input (the check trace's) run in plain Co-Simulation,
//! with event mode (a `CsFmu` from `load_event_mode`) and in Scheduled Execution (an
//! `SeFmu`) giving the same DAC codes at every one of 500 samples, `gait_step` seen at
//! the same samples through `fmi3GetClock` and `clockUpdate`, and the refusals.

mod common;

use common::dist;
use inchworm_fmi_import::{
    Causality, CsFmu, FmuError, Interface, IntervalQualifier, IntervalVariability, SeFmu, VarType,
};
use inchworm_fmu_models::{ControllerFmu, ControllerParams};

const H: f64 = 0.002;
const SAMPLES: usize = 500;
const REFERENCE: f64 = 30e-6;

fn controller() -> std::path::PathBuf {
    dist("fmi3/InchwormController.fmu")
}

#[path = "../../../tests/support/check_encoder.rs"]
mod check_encoder;

/// The encoder the controller reads at instant k: the plant's after step k - 1.
fn encoder() -> Vec<i32> {
    check_encoder::encoder(SAMPLES)
}

#[test]
fn the_controller_declares_its_clocks_event_mode_and_scheduled_execution() {
    let fmu = CsFmu::load(&controller(), "controller", false).unwrap();
    let md = fmu.description();
    assert!(md.co_simulation.as_ref().unwrap().has_event_mode);
    let se = md.scheduled_execution.as_ref().unwrap();
    assert_eq!(se.model_identifier, "InchwormController");
    assert_eq!(md.clocks.len(), 2);
    let sample = md.clock(5).unwrap();
    assert_eq!(
        (sample.name.as_str(), sample.causality, sample.interval_variability),
        (ControllerFmu::SAMPLE_CLOCK.name(), Causality::Input, IntervalVariability::Constant)
    );
    assert_eq!(
        (sample.interval_decimal, sample.shift_decimal, sample.priority),
        (Some(0.002), 0.0, Some(0))
    );
    assert!(sample.is_periodic());
    let gait = md.clock(25).unwrap();
    assert_eq!(
        (gait.name.as_str(), gait.causality, gait.interval_variability, gait.interval_decimal),
        (ControllerFmu::GAIT_STEP.name(), Causality::Output, IntervalVariability::Triggered, None)
    );
    assert!(!gait.is_periodic());
    let clocks = |name: &str| md.variable(name).unwrap().clocks.clone();
    assert_eq!(clocks(ControllerFmu::ENCODER_COUNTS.name()), [5]);
    assert_eq!(clocks(ControllerFmu::DAC_EXTENSION_CODE.name()), [5]);
    assert_eq!(clocks(ControllerFmu::DISTURBANCE_ESTIMATE.name()), [25]);
    assert_eq!(clocks(ControllerFmu::SCALE_WEIGHTS[2].name()), [25]);
    assert_eq!(clocks(ControllerParams::Q_ENC.name()), Vec::<u32>::new());
    // Clocks are not scalar values: the master addresses them with the clock calls.
    assert!(matches!(
        fmu.var(ControllerFmu::SAMPLE_CLOCK.name()),
        Err(FmuError::UnknownVariable { .. })
    ));
    for i in
        [Interface::CoSimulation, Interface::CoSimulationEventMode, Interface::ScheduledExecution]
    {
        assert!(i.offered_by(md), "{i:?}");
    }
}

/// What a run records at each instant k = 0 … 500: the DAC codes and whether `gait_step`
/// ticked.
#[derive(Debug, Default, PartialEq)]
struct Run {
    codes: Vec<[i32; 3]>,
    gait: Vec<bool>,
}

fn initialize(fmu: &mut inchworm_fmi_import::Instance) {
    fmu.enter_initialization(None, 0.0, Some(1.0)).unwrap();
    let r = fmu.var_of(ControllerFmu::REFERENCE.name(), VarType::Real).unwrap().vr;
    fmu.set_real(&[r], &[REFERENCE]).unwrap();
    fmu.exit_initialization().unwrap();
}

fn codes(fmu: &mut inchworm_fmi_import::Instance) -> [i32; 3] {
    let vrs = fmu.vrs_of(&ControllerFmu::DAC_CODES.map(|v| v.name()), VarType::Integer).unwrap();
    let mut out = [0; 3];
    fmu.get_integer(&vrs, &mut out).unwrap();
    out
}

fn plain(enc: &[i32]) -> Run {
    let mut fmu = CsFmu::load(&controller(), "plain", false).unwrap();
    initialize(&mut fmu);
    let e = fmu.var_of(ControllerFmu::ENCODER_COUNTS.name(), VarType::Integer).unwrap().vr;
    let mut run = Run { codes: vec![codes(&mut fmu)], gait: Vec::new() };
    for &counts in &enc[..SAMPLES] {
        fmu.set_integer(&[e], &[counts]).unwrap();
        fmu.do_step(H).unwrap();
        run.codes.push(codes(&mut fmu));
    }
    run
}

/// Event mode through the import layer: at each tick set the encoder and the clock,
/// update, read; then step to the next tick, which ends the step with
/// `eventHandlingNeeded`.
fn events(enc: &[i32]) -> Run {
    let mut fmu = CsFmu::load_event_mode(&controller(), "events", false).unwrap();
    assert!(fmu.event_mode_used());
    initialize(&mut fmu);
    let e = fmu.var_of(ControllerFmu::ENCODER_COUNTS.name(), VarType::Integer).unwrap().vr;
    let interval = fmu.intervals(&[5]).unwrap()[0];
    assert_eq!(interval.value, 0.002);
    assert_eq!(interval.qualifier, IntervalQualifier::Unchanged, "a constant clock's");
    let mut run = Run::default();
    for (k, &counts) in enc.iter().enumerate() {
        fmu.set_integer(&[e], &[counts]).unwrap();
        fmu.set_clocks(&[5], &[true]).unwrap();
        let update = fmu.update_discrete_states().unwrap();
        assert!(!update.needs_update && !update.terminate, "{update:?}");
        let t = k as f64 * H;
        assert!((update.next_event_time.unwrap() - (t + H)).abs() < 1e-12, "the next tick");
        run.codes.push(codes(&mut fmu));
        let mut ticked = [false];
        fmu.get_clocks(&[25], &mut ticked).unwrap();
        run.gait.push(ticked[0]);
        if k == SAMPLES {
            break;
        }
        fmu.enter_step_mode().unwrap();
        let end = fmu.do_step_to((k + 1) as f64 * H).unwrap();
        assert!(end.event_handling_needed && !end.terminate, "step {k}: {end:?}");
        assert_eq!(fmu.time(), (k + 1) as f64 * H);
        fmu.enter_event_mode().unwrap();
    }
    run
}

fn scheduled(enc: &[i32]) -> (Run, u64) {
    let mut fmu = SeFmu::load(&controller(), "scheduled", false).unwrap();
    initialize(&mut fmu);
    let e = fmu.var_of(ControllerFmu::ENCODER_COUNTS.name(), VarType::Integer).unwrap().vr;
    let (mut run, mut locks) = (Run::default(), 0);
    for (k, &counts) in enc.iter().enumerate() {
        fmu.set_integer(&[e], &[counts]).unwrap();
        let done = fmu.activate_model_partition(5, k as f64 * H).unwrap();
        assert!(done.clock_updates <= 1, "at {k}: {done:?}");
        locks += done.preemption_locks;
        run.codes.push(codes(&mut fmu));
        let mut ticked = [true];
        fmu.get_clocks(&[25], &mut ticked).unwrap();
        assert_eq!(
            ticked[0],
            done.clock_updates == 1,
            "gait_step reads what clockUpdate said at {k}"
        );
        run.gait.push(ticked[0]);
    }
    assert_eq!(fmu.time(), SAMPLES as f64 * H);
    (run, locks)
}

#[test]
fn plain_event_mode_and_scheduled_execution_give_the_same_dac_codes() {
    let enc = encoder();
    let p = plain(&enc);
    let e = events(&enc);
    let (s, locks) = scheduled(&enc);
    assert_eq!(p.codes.len(), SAMPLES + 1);
    assert_eq!(e.codes, p.codes, "event mode");
    assert_eq!(s.codes, p.codes, "scheduled execution");
    let distinct: std::collections::BTreeSet<_> = p.codes.iter().collect();
    assert!(distinct.len() > 10, "the gait ran: {} distinct DAC code triples", distinct.len());
    assert_eq!(e.gait, s.gait, "gait_step at the same samples");
    let ticks = e.gait.iter().filter(|&&t| t).count();
    assert!(ticks >= 3, "gait steps ended {ticks} times");
    assert!(locks >= (SAMPLES + 1) as u64, "every sample ran with preemption locked ({locks})");
}

#[test]
fn clocks_are_refused_where_they_are_not_offered() {
    // An FMI 2.0 FMU has no Scheduled Execution, no event mode, no clocks.
    let fmi2 = dist("InchwormController.fmu");
    let e = SeFmu::load(&fmi2, "se2", false).unwrap_err();
    assert!(matches!(e, FmuError::NotOffered { interface: Interface::ScheduledExecution, .. }));
    assert_eq!(
        e.to_string(),
        "InchwormController: the FMU (fmiVersion 2.0) does not offer Scheduled Execution: its modelDescription.xml lacks <ScheduledExecution> (FMI 2.0 has no clocks, event mode in Co-Simulation nor Scheduled Execution)"
    );
    let e = CsFmu::load_event_mode(&fmi2, "ev2", false).unwrap_err();
    assert!(e.to_string().contains("does not offer Co-Simulation with event mode"), "{e}");
    let mut plain2 = CsFmu::load(&fmi2, "plain2", false).unwrap();
    let e = plain2.set_clocks(&[5], &[true]).unwrap_err();
    assert!(e.to_string().contains("value reference 5 is no <Clock>"), "{e}");

    // An FMI 3.0 FMU without clocks: the plant.
    let plant = dist("fmi3/InchwormPlant.fmu");
    let e = SeFmu::load(&plant, "se3", false).unwrap_err();
    assert_eq!(
        e.to_string(),
        "InchwormPlant: the FMU (fmiVersion 3.0) does not offer Scheduled Execution: its modelDescription.xml lacks <ScheduledExecution>"
    );

    // The controller in plain Co-Simulation has no event mode and no clock calls.
    let mut fmu = CsFmu::load(&controller(), "plain", false).unwrap();
    initialize(&mut fmu);
    let e = fmu.enter_event_mode().unwrap_err();
    assert!(matches!(e, FmuError::Unsupported { function: "fmi3EnterEventMode", .. }), "{e}");
    let e = fmu.do_step_to(0.002).unwrap_err();
    assert!(e.to_string().contains("made without event mode"), "{e}");
    let e = fmu.set_clocks(&[5], &[true]).unwrap_err();
    assert!(e.to_string().contains("event mode or for Scheduled Execution"), "{e}");

    // Scheduled Execution: no steps, partitions of input clocks only, known clocks only.
    let mut se = SeFmu::load(&controller(), "se", false).unwrap();
    initialize(&mut se);
    let e = se.activate_model_partition(25, 0.0).unwrap_err();
    assert_eq!(
        e.to_string(),
        "InchwormController: fmi3ActivateModelPartition: value reference 25 is no input <Clock>"
    );
    let e = se.activate_model_partition(5, f64::NAN).unwrap_err();
    assert!(matches!(e, FmuError::InvalidArgument { .. }), "{e}");
    // A time that is not a tick: the FMU refuses it (its log says why).
    let e = se.activate_model_partition(5, 0.001).unwrap_err();
    assert!(matches!(e, FmuError::Call { function: "fmi3ActivateModelPartition", .. }), "{e}");
    let e = se.set_clocks(&[5, 25], &[true]).unwrap_err();
    assert!(e.to_string().contains("2 clocks and 1 values"), "{e}");
}
