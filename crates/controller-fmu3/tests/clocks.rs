//! The FMI 3.0 controller's clocks through its exported C functions: the same encoder
//! input (the check trace's, `tests/data/plant-check-trace-fia20-passive.csv`) run in plain
//! Co-Simulation (2 ms steps), in Co-Simulation with event mode (`fmi3SetClock` of
//! `sample_clock` at each tick) and in Scheduled Execution (`fmi3ActivateModelPartition`
//! every 2 ms) gives the same DAC codes at every one of the 500 samples, and the output
//! clock `gait_step` ticks at the same samples in both clocked runs, exactly where the
//! estimates it clocks change.

use std::ffi::{c_void, CString};
use std::sync::Mutex;

use inchworm_controller_fmu3 as fmu;
use inchworm_fmi_export::fmi3::ffi::*;
use inchworm_fmi_export::fmi3::testing::{log_callback, Log};
use inchworm_fmu_models::ControllerFmu;

const H: f64 = 0.002;
const SAMPLES: usize = 500;
const REFERENCE: f64 = 30e-6;

#[path = "../../../tests/support/check_encoder.rs"]
mod check_encoder;

/// The encoder the controller reads at instant k: the plant's after step k - 1.
fn encoder() -> Vec<i32> {
    check_encoder::encoder(SAMPLES)
}

/// What a run records at each instant k = 0 … 500: the three DAC codes written there,
/// whether `gait_step` ticked, and the disturbance estimate and first weight.
#[derive(Debug, Default, PartialEq)]
struct Run {
    codes: Vec<[i32; 3]>,
    gait: Vec<bool>,
    estimates: Vec<[u64; 2]>,
}

struct Instance {
    c: fmi3Instance,
    _log: Box<Log>,
}

impl Instance {
    /// Instantiated for `kind`, initialized at t = 0 to stop 1 s with the reference set.
    fn new(kind: &str, clock_update: fmi3ClockUpdateCallback, env: *mut c_void) -> Instance {
        let log = Box::new(Log(Default::default()));
        let (log_env, logger) = log_callback(&log);
        let token =
            CString::new(inchworm_fmi_export::model_description::guid::<ControllerFmu>()).unwrap();
        let (name, null) = (c"controller".as_ptr(), std::ptr::null());
        let c = unsafe {
            match kind {
                "plain" | "events" => fmu::fmi3InstantiateCoSimulation(
                    name,
                    token.as_ptr(),
                    null,
                    false,
                    false,
                    kind == "events",
                    false,
                    std::ptr::null(),
                    0,
                    log_env,
                    logger,
                    None,
                ),
                _ => fmu::fmi3InstantiateScheduledExecution(
                    name,
                    token.as_ptr(),
                    null,
                    false,
                    false,
                    env,
                    None,
                    clock_update,
                    None,
                    None,
                ),
            }
        };
        assert!(!c.is_null(), "{kind}: {:?}", log.0.lock().unwrap());
        let vr = ControllerFmu::REFERENCE.vr();
        unsafe {
            assert_eq!(fmu::fmi3EnterInitializationMode(c, false, 0.0, 0.0, true, 1.0), fmi3OK);
            assert_eq!(fmu::fmi3SetFloat64(c, &vr, 1, &REFERENCE, 1), fmi3OK);
            assert_eq!(fmu::fmi3ExitInitializationMode(c), fmi3OK);
        }
        Instance { c, _log: log }
    }

    fn set_encoder(&self, counts: i32) {
        let vr = ControllerFmu::ENCODER_COUNTS.vr();
        assert_eq!(unsafe { fmu::fmi3SetInt32(self.c, &vr, 1, &counts, 1) }, fmi3OK);
    }

    /// The DAC codes and estimates now, into `run`.
    fn record(&self, run: &mut Run) {
        let vrs = [
            ControllerFmu::DAC_EARTH_CODE.vr(),
            ControllerFmu::DAC_NONEARTH_CODE.vr(),
            ControllerFmu::DAC_EXTENSION_CODE.vr(),
        ];
        let mut codes = [0; 3];
        let estimates =
            [ControllerFmu::DISTURBANCE_ESTIMATE.vr(), ControllerFmu::SCALE_WEIGHTS_1.vr()];
        let mut values = [0.0; 11];
        unsafe {
            assert_eq!(fmu::fmi3GetInt32(self.c, vrs.as_ptr(), 3, codes.as_mut_ptr(), 3), fmi3OK);
            assert_eq!(
                fmu::fmi3GetFloat64(self.c, estimates.as_ptr(), 2, values.as_mut_ptr(), 11),
                fmi3OK
            );
        }
        run.codes.push(codes);
        run.estimates.push([values[0].to_bits(), values[1].to_bits()]);
    }

    fn gait_step(&self) -> bool {
        let (vr, mut ticked) = (ControllerFmu::GAIT_STEP.vr(), false);
        assert_eq!(unsafe { fmu::fmi3GetClock(self.c, &vr, 1, &mut ticked) }, fmi3OK);
        ticked
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        unsafe { fmu::fmi3FreeInstance(self.c) };
    }
}

/// Plain Co-Simulation: the step from instant k writes the sample of instant k + 1, so
/// instant 0 holds the parked outputs (read before the first step).
fn plain(enc: &[i32]) -> Run {
    let i = Instance::new("plain", None, std::ptr::null_mut());
    let mut run = Run::default();
    i.record(&mut run);
    let (mut ev, mut term, mut early, mut last) = (true, true, true, f64::NAN);
    for (k, &counts) in enc[..SAMPLES].iter().enumerate() {
        i.set_encoder(counts);
        let t = k as f64 * H;
        let s =
            unsafe { fmu::fmi3DoStep(i.c, t, H, true, &mut ev, &mut term, &mut early, &mut last) };
        assert_eq!((s, ev, early, term), (fmi3OK, false, false, false), "step {k}");
        i.record(&mut run);
    }
    run
}

/// Event mode: at each tick the importer sets the encoder, activates `sample_clock`,
/// updates, reads the outputs and the output clock, and steps to the next tick.
fn events(enc: &[i32]) -> Run {
    let i = Instance::new("events", None, std::ptr::null_mut());
    let (sample, mut run) = (ControllerFmu::SAMPLE_CLOCK.vr(), Run::default());
    for (k, &counts) in enc.iter().enumerate() {
        i.set_encoder(counts);
        let (mut a, mut b, mut c, mut d, mut e, mut next) = (true, true, true, true, false, 0.0);
        unsafe {
            assert_eq!(fmu::fmi3SetClock(i.c, &sample, 1, &true), fmi3OK);
            let s = fmu::fmi3UpdateDiscreteStates(
                i.c, &mut a, &mut b, &mut c, &mut d, &mut e, &mut next,
            );
            assert_eq!((s, b, e), (fmi3OK, false, true), "update at tick {k}");
        }
        i.record(&mut run);
        run.gait.push(i.gait_step());
        if k == SAMPLES {
            break;
        }
        let t = k as f64 * H;
        assert!((next - (t + H)).abs() < 1e-12, "the next tick");
        let (mut ev, mut term, mut early, mut last) = (false, true, true, f64::NAN);
        unsafe {
            assert_eq!(fmu::fmi3EnterStepMode(i.c), fmi3OK);
            let s = fmu::fmi3DoStep(i.c, t, H, true, &mut ev, &mut term, &mut early, &mut last);
            assert_eq!(
                (s, ev, early, term),
                (fmi3OK, true, false, false),
                "step {k} ends at a tick"
            );
            assert_eq!(fmu::fmi3EnterEventMode(i.c), fmi3OK);
        }
    }
    run
}

/// The instants at which `clockUpdate` was called, in the order of activation.
static UPDATES: Mutex<Vec<usize>> = Mutex::new(Vec::new());
/// The instant being activated.
static NOW: Mutex<usize> = Mutex::new(0);

unsafe extern "C" fn clock_update(_env: *mut c_void) {
    let now = *NOW.lock().unwrap();
    UPDATES.lock().unwrap().push(now);
}

/// Scheduled Execution: the scheduler sets the encoder and activates the sample partition
/// every 2 ms; `clockUpdate` says when `gait_step` ticked, and reading it resets it.
fn scheduled(enc: &[i32]) -> Run {
    let i = Instance::new("scheduled", Some(clock_update), std::ptr::null_mut());
    let (sample, mut run) = (ControllerFmu::SAMPLE_CLOCK.vr(), Run::default());
    for (k, &counts) in enc.iter().enumerate() {
        i.set_encoder(counts);
        *NOW.lock().unwrap() = k;
        let signalled = UPDATES.lock().unwrap().len();
        assert_eq!(unsafe { fmu::fmi3ActivateModelPartition(i.c, sample, k as f64 * H) }, fmi3OK);
        i.record(&mut run);
        let ticked = UPDATES.lock().unwrap().len() > signalled;
        assert_eq!(i.gait_step(), ticked, "gait_step reads what clockUpdate said at {k}");
        assert!(!i.gait_step(), "and reads false once read");
        run.gait.push(ticked);
    }
    run
}

#[test]
fn plain_event_mode_and_scheduled_execution_give_the_same_dac_codes() {
    let enc = encoder();
    let p = plain(&enc);
    let e = events(&enc);
    let s = scheduled(&enc);
    assert_eq!(p.codes.len(), SAMPLES + 1);
    for k in 0..=SAMPLES {
        assert_eq!(e.codes[k], p.codes[k], "event mode, sample {k}");
        assert_eq!(s.codes[k], p.codes[k], "scheduled execution, sample {k}");
        assert_eq!(
            (e.estimates[k], s.estimates[k]),
            (p.estimates[k], p.estimates[k]),
            "estimates at {k}"
        );
    }
    let distinct: std::collections::BTreeSet<_> = p.codes.iter().collect();
    assert!(distinct.len() > 10, "the gait ran: {} distinct DAC code triples", distinct.len());

    // gait_step ticks at the same samples in both, exactly where the estimates it clocks
    // change.
    assert_eq!(e.gait, s.gait);
    let ticks: Vec<usize> = (0..=SAMPLES).filter(|&k| e.gait[k]).collect();
    let changed: Vec<usize> =
        (1..=SAMPLES).filter(|&k| p.estimates[k] != p.estimates[k - 1]).collect();
    assert!(ticks.len() >= 3, "gait steps ended at {ticks:?}");
    assert_eq!(changed, ticks, "the estimates change exactly at gait_step's ticks");
}
