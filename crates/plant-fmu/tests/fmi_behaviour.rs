//! The FMI boundary of InchwormPlant, called as a master calls it: statuses, log
//! messages, state handling and threads. The exported `fmi2*` functions are called
//! in-process through the rlib, the same code the shared library exports.

use std::ffi::CString;
use std::sync::Mutex;

use inchworm_fmi_export::ffi::*;
use inchworm_fmi_export::model_description;
use inchworm_fmi_export::testing::{callbacks, categories_of, payload_of, Harness, Log};
use inchworm_fmu_models::{ControllerFmu, PlantFmu};
use inchworm_plant_fmu as fmu;

const DAC_EARTH: u32 = 1;
const DAC_NONEARTH: u32 = 2;
const DAC_EXTENSION: u32 = 3;
const ENCODER_COUNTS: u32 = 10;
const RUNNER_POSITION: u32 = 12;
const MODE: u32 = 17;
const EARTH_CLOSED: u32 = 18;
const M_P: u32 = 100;
const PLAY_RADIUS_2: u32 = 114;

struct Instance {
    c: fmi2Component,
    log: Box<Log>,
    _functions: Box<fmi2CallbackFunctions>,
}

// The FMU promises independent instances usable from any thread.
unsafe impl Send for Instance {}

impl Instance {
    fn new(name: &str) -> Instance {
        let log = Box::new(Log(Mutex::new(Vec::new())));
        let functions = Box::new(callbacks(&log));
        let name = CString::new(name).unwrap();
        let guid = CString::new(model_description::guid::<PlantFmu>()).unwrap();
        let c = unsafe {
            fmu::fmi2Instantiate(
                name.as_ptr(),
                fmi2CoSimulation,
                guid.as_ptr(),
                std::ptr::null(),
                &*functions,
                fmi2False,
                fmi2False,
            )
        };
        assert!(!c.is_null(), "fmi2Instantiate failed: {:?}", log.0.lock().unwrap());
        Instance { c, log, _functions: functions }
    }

    fn init(name: &str) -> Instance {
        let i = Instance::new(name);
        assert_eq!(i.setup(), fmi2OK);
        assert_eq!(unsafe { fmu::fmi2EnterInitializationMode(i.c) }, fmi2OK);
        assert_eq!(unsafe { fmu::fmi2ExitInitializationMode(i.c) }, fmi2OK);
        i
    }

    fn setup(&self) -> fmi2Status {
        unsafe { fmu::fmi2SetupExperiment(self.c, fmi2False, 0.0, 0.0, fmi2False, 0.0) }
    }

    fn set_real(&self, vr: u32, v: f64) -> fmi2Status {
        unsafe { fmu::fmi2SetReal(self.c, &vr, 1, &v) }
    }

    fn real(&self, vr: u32) -> (fmi2Status, f64) {
        let mut v = f64::NAN;
        let s = unsafe { fmu::fmi2GetReal(self.c, &vr, 1, &mut v) };
        (s, v)
    }

    fn integer(&self, vr: u32) -> (fmi2Status, i32) {
        let mut v = -1;
        let s = unsafe { fmu::fmi2GetInteger(self.c, &vr, 1, &mut v) };
        (s, v)
    }

    fn step(&self, t: f64, h: f64) -> fmi2Status {
        unsafe { fmu::fmi2DoStep(self.c, t, h, fmi2True) }
    }

    fn logged(&self) -> Vec<String> {
        self.log.0.lock().unwrap().clone()
    }

    fn take_logged(&self) -> Vec<String> {
        std::mem::take(&mut *self.log.0.lock().unwrap())
    }

    fn set_debug_logging(
        &self,
        on: fmi2Boolean,
        categories: &[*const std::ffi::c_char],
    ) -> fmi2Status {
        unsafe { fmu::fmi2SetDebugLogging(self.c, on, categories.len(), categories.as_ptr()) }
    }

    /// Whether a message containing every part was logged with this status.
    fn saw(&self, status: fmi2Status, parts: &[&str]) -> bool {
        self.logged()
            .iter()
            .any(|m| m.starts_with(&format!("{status}|")) && parts.iter().all(|p| m.contains(p)))
    }

    /// A forward gait of amplitude `y` from sample `k0` (2 ms samples); returns (counts, runner) per sample.
    fn gait(&self, k0: usize, y: f64) -> Vec<(i32, f64)> {
        let mut out = Vec::new();
        for k in 1..=100 {
            let (e, n, x) = match k {
                1..=14 => (0.0, 0.0, 0.0),
                15..=29 => (0.0, 10.0, 0.0),
                30..=43 => (10.0, 10.0, 0.0),
                44..=58 => (10.0, 10.0, 10.0 * y),
                59..=71 => (0.0, 10.0, 10.0 * y),
                72..=86 => (0.0, 0.0, 10.0 * y),
                _ => (0.0, 0.0, 0.0),
            };
            for (vr, v) in [(DAC_EARTH, e), (DAC_NONEARTH, n), (DAC_EXTENSION, x)] {
                assert_eq!(self.set_real(vr, v), fmi2OK);
            }
            let t = (k0 + k - 1) as f64 * 0.002;
            assert_eq!(self.step(t, 0.002), fmi2OK, "doStep at t = {t}: {:?}", self.logged());
            out.push((self.integer(ENCODER_COUNTS).1, self.real(RUNNER_POSITION).1));
        }
        out
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        unsafe { fmu::fmi2FreeInstance(self.c) };
    }
}

#[test]
fn calls_out_of_order_are_refused_and_logged() {
    let i = Instance::new("order");
    assert_eq!(i.step(0.0, 0.002), fmi2Error);
    assert!(
        i.saw(fmi2Error, &["fmi2DoStep", "illegal call sequence", "Instantiated"]),
        "{:?}",
        i.logged()
    );
    assert_eq!(unsafe { fmu::fmi2ExitInitializationMode(i.c) }, fmi2Error);
    assert_eq!(unsafe { fmu::fmi2Terminate(i.c) }, fmi2Error);
    // The refusals changed nothing: the normal sequence still works.
    assert_eq!(i.setup(), fmi2OK);
    assert_eq!(unsafe { fmu::fmi2EnterInitializationMode(i.c) }, fmi2OK);
    assert_eq!(i.setup(), fmi2Error, "SetupExperiment is only allowed before initialization");
    assert_eq!(unsafe { fmu::fmi2ExitInitializationMode(i.c) }, fmi2OK);
    assert_eq!(i.step(0.0, 0.002), fmi2OK);
    assert_eq!(unsafe { fmu::fmi2Terminate(i.c) }, fmi2OK);
    assert_eq!(i.step(0.002, 0.002), fmi2Error);
    assert!(i.saw(fmi2Error, &["fmi2DoStep", "Terminated"]));
    assert_eq!(unsafe { fmu::fmi2Reset(i.c) }, fmi2OK);
    assert_eq!(i.setup(), fmi2OK);
}

#[test]
fn null_and_foreign_pointers_are_refused_without_a_crash() {
    let i = Instance::init("pointers");
    let vr = ENCODER_COUNTS;
    assert_eq!(unsafe { fmu::fmi2GetInteger(i.c, &vr, 1, std::ptr::null_mut()) }, fmi2Error);
    assert_eq!(
        unsafe { fmu::fmi2GetReal(std::ptr::null_mut(), &vr, 1, std::ptr::null_mut()) },
        fmi2Error
    );
    let mut bogus = [0u64; 16];
    assert_eq!(
        unsafe { fmu::fmi2DoStep(bogus.as_mut_ptr() as fmi2Component, 0.0, 0.002, fmi2True) },
        fmi2Error
    );
    assert_eq!(unsafe { fmu::fmi2SetFMUstate(i.c, bogus.as_mut_ptr() as fmi2FMUstate) }, fmi2Error);
    assert!(i.saw(fmi2Error, &["fmi2SetFMUstate", "not created"]));
}

#[test]
fn instantiate_refuses_a_wrong_guid_or_model_exchange() {
    let log = Box::new(Log(Mutex::new(Vec::new())));
    let functions = callbacks(&log);
    let guid = CString::new(model_description::guid::<PlantFmu>()).unwrap();
    let c = unsafe {
        fmu::fmi2Instantiate(
            c"x".as_ptr(),
            fmi2CoSimulation,
            c"{wrong}".as_ptr(),
            std::ptr::null(),
            &functions,
            0,
            0,
        )
    };
    assert!(c.is_null());
    let c = unsafe {
        fmu::fmi2Instantiate(
            c"x".as_ptr(),
            fmi2ModelExchange,
            guid.as_ptr(),
            std::ptr::null(),
            &functions,
            0,
            0,
        )
    };
    assert!(c.is_null());
    let c = unsafe {
        fmu::fmi2Instantiate(
            std::ptr::null(),
            fmi2CoSimulation,
            guid.as_ptr(),
            std::ptr::null(),
            &functions,
            0,
            0,
        )
    };
    assert!(c.is_null());
    let logged = log.0.lock().unwrap().clone();
    assert!(logged.iter().any(|m| m.contains("fmuGUID") && m.contains("{wrong}")), "{logged:?}");
    assert!(logged.iter().any(|m| m.contains("Co-Simulation only")), "{logged:?}");
    assert!(logged.iter().any(|m| m.contains("instanceName")), "{logged:?}");
}

#[test]
fn nan_input_is_refused_and_the_instance_stays_usable() {
    let i = Instance::init("nan");
    assert_eq!(i.set_real(DAC_EXTENSION, 4.0), fmi2OK);
    assert_eq!(i.set_real(DAC_EXTENSION, f64::NAN), fmi2Error);
    assert!(
        i.saw(fmi2Error, &["fmi2SetReal", "dac_extension", "NaN", "keeping 4 V"]),
        "{:?}",
        i.logged()
    );
    assert_eq!(
        i.logged(),
        ["3|logStatusError|fmi2SetReal: dac_extension = NaN refused: DAC volts must be finite; keeping 4 V"],
        "the function is named once, then the reason"
    );
    assert_eq!(i.real(DAC_EXTENSION), (fmi2OK, 4.0), "the last valid value is kept");
    assert_eq!(i.set_real(DAC_NONEARTH, f64::INFINITY), fmi2Error);
    assert_eq!(i.step(0.0, 0.002), fmi2OK, "a refused input leaves the instance usable");
    assert_eq!(i.set_real(DAC_EXTENSION, 5.0), fmi2OK);
    assert_eq!(i.step(0.002, 0.002), fmi2OK);
}

#[test]
fn out_of_range_volts_are_clamped_with_a_warning() {
    let i = Instance::init("range");
    assert_eq!(i.set_real(DAC_EARTH, 12.5), fmi2Warning);
    assert_eq!(
        i.logged(),
        ["1|logStatusWarning|fmi2SetReal: dac_earth = 12.5 V is outside the DAC range 0-10 V, clamped to 10 V"]
    );
    assert_eq!(i.real(DAC_EARTH), (fmi2OK, 10.0));
    assert_eq!(i.set_real(DAC_NONEARTH, -0.5), fmi2Warning);
    assert_eq!(i.real(DAC_NONEARTH), (fmi2OK, 0.0));
    // Several values in one call: each stands alone, the call reports the worst.
    let vrs = [DAC_EARTH, DAC_NONEARTH, DAC_EXTENSION];
    let vals = [1.0, f64::NAN, 11.0];
    assert_eq!(unsafe { fmu::fmi2SetReal(i.c, vrs.as_ptr(), 3, vals.as_ptr()) }, fmi2Error);
    assert_eq!(i.real(DAC_EARTH).1, 1.0);
    assert_eq!(i.real(DAC_NONEARTH).1, 0.0);
    assert_eq!(i.real(DAC_EXTENSION).1, 10.0);
}

#[test]
fn unknown_value_references_and_wrong_types_are_errors() {
    let i = Instance::init("vr");
    assert_eq!(i.real(999).0, fmi2Error);
    assert_eq!(i.logged(), ["3|logStatusError|fmi2GetReal: unknown value reference 999"]);
    assert_eq!(i.integer(RUNNER_POSITION).0, fmi2Error, "runner_position is Real");
    assert!(i.saw(fmi2Error, &["fmi2GetInteger", "runner_position", "Real"]));
    assert_eq!(i.set_real(RUNNER_POSITION, 1.0), fmi2Error, "outputs cannot be set");
    assert!(i.saw(fmi2Error, &["runner_position", "cannot be set"]));
    assert_eq!(
        i.set_real(M_P, 1.0),
        fmi2Error,
        "fixed parameters cannot be set after initialization"
    );
    let mut s: fmi2String = std::ptr::null();
    assert_eq!(unsafe { fmu::fmi2GetString(i.c, &7, 1, &mut s) }, fmi2Error);
    let mut b = 0;
    assert_eq!(unsafe { fmu::fmi2GetBoolean(i.c, &EARTH_CLOSED, 1, &mut b) }, fmi2OK);
    assert_eq!(b, fmi2True);
}

#[test]
fn bad_parameters_fail_initialization_naming_the_parameter() {
    for (vr, value, name) in [(M_P, -0.025, "m_p"), (PLAY_RADIUS_2, 5.0, "play_radius[2]")] {
        let i = Instance::new("params");
        assert_eq!(i.setup(), fmi2OK);
        assert_eq!(i.set_real(vr, value), fmi2OK, "validated at initialization, as a whole");
        assert_eq!(unsafe { fmu::fmi2EnterInitializationMode(i.c) }, fmi2OK);
        assert_eq!(unsafe { fmu::fmi2ExitInitializationMode(i.c) }, fmi2Error);
        assert!(
            i.saw(fmi2Error, &["fmi2ExitInitializationMode", name]),
            "{name}: {:?}",
            i.logged()
        );
        assert_eq!(i.step(0.0, 0.002), fmi2Error, "no stepping after a failed initialization");
        assert_eq!(unsafe { fmu::fmi2Reset(i.c) }, fmi2OK, "reset recovers the instance");
    }
    let i = Instance::new("nan-param");
    assert_eq!(i.set_real(M_P, f64::NAN), fmi2Error);
    assert!(i.saw(fmi2Error, &["m_p", "finite"]));
}

#[test]
fn step_time_and_size_are_checked_with_a_relative_tolerance() {
    let i = Instance::init("time");
    assert_eq!(i.step(0.0, 0.0), fmi2Error);
    assert_eq!(i.step(0.0, -0.002), fmi2Error);
    assert_eq!(i.step(0.0, f64::NAN), fmi2Error);
    assert!(i.saw(fmi2Error, &["communicationStepSize"]));
    let mut t = 0.0;
    for k in 0..1000 {
        assert_eq!(i.step(t, 0.002), fmi2OK);
        t += 0.002;
        // A master at t = k·h and one at t += h disagree by rounding: both are the same point.
        let kh = (k + 1) as f64 * 0.002;
        assert!((t - kh).abs() < 1e-12);
    }
    assert_eq!(i.step(1000.0 * 0.002, 0.002), fmi2OK, "k·h after 1000 steps of t += h");
    assert_eq!(
        i.step(2.002 + 1e-6, 0.002),
        fmi2Error,
        "a step that does not start at the FMU time"
    );
    assert!(i.saw(fmi2Error, &["currentCommunicationPoint", "does not match"]));
    let mut last = 0.0;
    assert_eq!(unsafe { fmu::fmi2GetRealStatus(i.c, fmi2LastSuccessfulTime, &mut last) }, fmi2OK);
    assert!((last - 2.002).abs() < 1e-12);
    let mut terminated = fmi2True;
    assert_eq!(unsafe { fmu::fmi2GetBooleanStatus(i.c, fmi2Terminated, &mut terminated) }, fmi2OK);
    assert_eq!(terminated, fmi2False);
    let mut status = -1;
    assert_eq!(unsafe { fmu::fmi2GetStatus(i.c, fmi2DoStepStatus, &mut status) }, fmi2OK);
    assert_eq!(status, fmi2OK);
}

#[test]
fn unsupported_functions_return_error_with_a_reason() {
    let i = Instance::init("unsupported");
    assert_eq!(unsafe { fmu::fmi2CancelStep(i.c) }, fmi2Error);
    assert!(i.saw(fmi2Error, &["fmi2CancelStep", "synchronously"]));
    let (vr, order, v) = (DAC_EARTH, 1, 0.0);
    assert_eq!(unsafe { fmu::fmi2SetRealInputDerivatives(i.c, &vr, 1, &order, &v) }, fmi2Error);
    assert!(i.saw(fmi2Error, &["fmi2SetRealInputDerivatives", "canInterpolateInputs"]));
    let mut out = 0.0;
    assert_eq!(
        unsafe { fmu::fmi2GetDirectionalDerivative(i.c, &vr, 1, &vr, 1, &v, &mut out) },
        fmi2Error
    );
    let mut s: fmi2String = std::ptr::null();
    assert_eq!(unsafe { fmu::fmi2GetStringStatus(i.c, fmi2PendingStatus, &mut s) }, fmi2Error);
}

/// Asserts that every line is a debug (fmi2OK) message and returns the categories seen.
fn debug_categories(lines: &[String]) -> Vec<String> {
    assert!(lines.iter().all(|l| l.starts_with("0|")), "{lines:?}");
    categories_of(lines)
}

#[test]
fn debug_logging_enables_exactly_the_named_categories() {
    let i = Instance::init("logging");
    i.gait(0, 1.0);
    assert_eq!(i.take_logged(), Vec::<String>::new(), "no debug messages without debug logging");

    // Only logEvents: the gait's brake switches and nothing of logAll's call trace.
    assert_eq!(i.set_debug_logging(fmi2True, &[c"logEvents".as_ptr()]), fmi2OK);
    i.gait(100, 1.0);
    let events = i.take_logged();
    assert_eq!(debug_categories(&events), ["logEvents"]);
    assert!(events.iter().all(|l| l.contains("brake switch")), "{events:?}");
    assert!(events.iter().any(|l| l.contains("Hold -> Locked")), "{events:?}");

    // None named: every category, so the trace of each call comes too.
    assert_eq!(i.set_debug_logging(fmi2True, &[]), fmi2OK);
    i.gait(200, 1.0);
    let all = i.take_logged();
    assert_eq!(debug_categories(&all), ["logAll", "logEvents"]);
    assert_eq!(all.iter().filter(|l| l.contains("|logEvents|")).count(), events.len());
    assert_eq!(all.iter().filter(|l| l.ends_with("|logAll|fmi2DoStep")).count(), 100);
    assert_eq!(all.iter().filter(|l| l.ends_with("|logAll|fmi2SetReal")).count(), 300);

    // Off with a category named disables that one only.
    assert_eq!(i.set_debug_logging(fmi2False, &[c"logAll".as_ptr()]), fmi2OK);
    // The call itself is traced under the setting it replaces.
    assert_eq!(i.take_logged(), ["0|logAll|fmi2SetDebugLogging"]);
    i.gait(300, 1.0);
    assert_eq!(debug_categories(&i.take_logged()), ["logEvents"]);

    // logAll alone selects every message.
    assert_eq!(i.set_debug_logging(fmi2True, &[c"logAll".as_ptr()]), fmi2OK);
    i.gait(400, 1.0);
    assert_eq!(debug_categories(&i.take_logged()), ["logAll", "logEvents"]);

    // Off with none named disables all; warnings and errors still go out.
    assert_eq!(i.set_debug_logging(fmi2False, &[]), fmi2OK);
    assert_eq!(i.take_logged(), ["0|logAll|fmi2SetDebugLogging"]);
    i.gait(500, 1.0);
    assert_eq!(i.take_logged(), Vec::<String>::new());
    assert_eq!(i.set_real(DAC_EARTH, 12.0), fmi2Warning);
    let warned = i.take_logged();
    assert_eq!(warned.len(), 1, "{warned:?}");
    assert!(
        warned[0].starts_with("1|logStatusWarning|fmi2SetReal: dac_earth = 12 V"),
        "{warned:?}"
    );
}

#[test]
fn unknown_or_null_log_categories_are_refused_and_change_nothing() {
    let i = Instance::init("bad categories");
    assert_eq!(i.set_debug_logging(fmi2True, &[c"logEvents".as_ptr()]), fmi2OK);
    let bad = [c"logAll".as_ptr(), c"logNonsense".as_ptr()];
    assert_eq!(i.set_debug_logging(fmi2True, &bad), fmi2Error);
    let refused = i.take_logged();
    assert_eq!(refused.len(), 1, "{refused:?}");
    assert!(
        refused[0].starts_with(
            "3|logStatusError|fmi2SetDebugLogging: unknown log category \"logNonsense\" (this FMU has logEvents, logStatusWarning, logStatusError, logAll)"
        ),
        "{refused:?}"
    );
    assert_eq!(i.set_debug_logging(fmi2False, &[std::ptr::null()]), fmi2Error);
    assert!(i.saw(fmi2Error, &["fmi2SetDebugLogging", "a category name is NULL"]));
    assert_eq!(unsafe { fmu::fmi2SetDebugLogging(i.c, fmi2True, 1, std::ptr::null()) }, fmi2Error);
    assert!(i.saw(fmi2Error, &["fmi2SetDebugLogging", "categories is NULL"]));
    i.take_logged();
    // Still logEvents only, as before the refused calls.
    i.gait(0, 1.0);
    assert_eq!(debug_categories(&i.take_logged()), ["logEvents"]);
}

#[test]
fn logging_on_at_instantiation_enables_every_category() {
    let h = Harness::<PlantFmu>::with_logging("on", true);
    assert_eq!(h.setup(), fmi2OK);
    assert_eq!(h.take_logged(), ["0|logAll|fmi2SetupExperiment"]);
    assert_eq!(h.set_debug_logging(false, &["logAll"]), fmi2OK);
    assert_eq!(h.take_logged(), ["0|logAll|fmi2SetDebugLogging"]);
    assert_eq!(h.enter(), fmi2OK);
    assert_eq!(h.take_logged(), Vec::<String>::new());
}

#[test]
fn get_and_set_state_replays_the_trajectory_bit_for_bit() {
    let i = Instance::init("state");
    i.gait(0, 1.0);
    i.gait(100, 0.3);
    let mut state: fmi2FMUstate = std::ptr::null_mut();
    assert_eq!(unsafe { fmu::fmi2GetFMUstate(i.c, &mut state) }, fmi2OK);
    let first = i.gait(200, 0.7);
    assert_eq!(unsafe { fmu::fmi2SetFMUstate(i.c, state) }, fmi2OK);
    let again = i.gait(200, 0.7);
    assert_eq!(first, again);
    assert!(first.iter().any(|&(c, _)| c != first[0].0), "the replayed gait moved the runner");
    assert_eq!(unsafe { fmu::fmi2FreeFMUstate(i.c, &mut state) }, fmi2OK);
    assert!(state.is_null());
    assert_eq!(
        unsafe { fmu::fmi2FreeFMUstate(i.c, &mut state) },
        fmi2OK,
        "freeing NULL is allowed"
    );
}

fn serialize(i: &Instance) -> Vec<u8> {
    let mut state: fmi2FMUstate = std::ptr::null_mut();
    assert_eq!(unsafe { fmu::fmi2GetFMUstate(i.c, &mut state) }, fmi2OK);
    let mut size = 0usize;
    assert_eq!(unsafe { fmu::fmi2SerializedFMUstateSize(i.c, state, &mut size) }, fmi2OK);
    let mut bytes = vec![0u8; size];
    assert_eq!(
        unsafe {
            fmu::fmi2SerializeFMUstate(i.c, state, bytes.as_mut_ptr() as *mut fmi2Byte, size)
        },
        fmi2OK
    );
    let mut small = vec![0u8; size - 1];
    assert_eq!(
        unsafe {
            fmu::fmi2SerializeFMUstate(i.c, state, small.as_mut_ptr() as *mut fmi2Byte, size - 1)
        },
        fmi2Error
    );
    assert_eq!(unsafe { fmu::fmi2FreeFMUstate(i.c, &mut state) }, fmi2OK);
    bytes
}

fn deserialize(i: &Instance, bytes: &[u8]) -> fmi2Status {
    let mut state: fmi2FMUstate = std::ptr::null_mut();
    let s = unsafe {
        fmu::fmi2DeSerializeFMUstate(
            i.c,
            bytes.as_ptr() as *const fmi2Byte,
            bytes.len(),
            &mut state,
        )
    };
    if s != fmi2OK {
        return s;
    }
    let s = unsafe { fmu::fmi2SetFMUstate(i.c, state) };
    unsafe { fmu::fmi2FreeFMUstate(i.c, &mut state) };
    s
}

#[test]
fn serialized_state_continues_bit_for_bit_in_a_fresh_instance() {
    let a = Instance::init("a");
    a.gait(0, 1.0);
    a.gait(100, 0.0);
    let bytes = serialize(&a);
    let first = a.gait(200, 0.5);

    let b = Instance::new("b");
    assert_eq!(deserialize(&b, &bytes), fmi2OK, "{:?}", b.logged());
    assert_eq!(b.gait(200, 0.5), first);
}

#[test]
fn corrupt_truncated_and_foreign_state_blobs_are_refused() {
    let a = Instance::init("a");
    a.gait(0, 1.0);
    let bytes = serialize(&a);
    let b = Instance::new("b");
    let mut flipped = bytes.clone();
    flipped[bytes.len() / 2] ^= 1;
    assert_eq!(deserialize(&b, &flipped), fmi2Error);
    assert!(b.saw(fmi2Error, &["fmi2DeSerializeFMUstate", "CRC-32"]), "{:?}", b.logged());
    assert_eq!(deserialize(&b, &bytes[..bytes.len() - 9]), fmi2Error);
    assert_eq!(deserialize(&b, b"not a state at all"), fmi2Error);
    assert!(b.saw(fmi2Error, &["no IWFS header"]));
    assert_eq!(deserialize(&b, &[]), fmi2Error);
    // The refusals left b untouched: it still initializes and steps from rest.
    assert_eq!(b.setup(), fmi2OK);
    assert_eq!(unsafe { fmu::fmi2EnterInitializationMode(b.c) }, fmi2OK);
    assert_eq!(unsafe { fmu::fmi2ExitInitializationMode(b.c) }, fmi2OK);
    assert_eq!(b.step(0.0, 0.002), fmi2OK);
    assert_eq!(b.integer(MODE), (fmi2OK, 1));
}

/// The payload of an uninitialized plant with m_p = 0.03, dac_nonearth = 3.5 and
/// noise_seed = -7, as the encoder before the table-driven parameter save wrote it
/// (state format 1): the parameters in table order as f64, the seed as its unsigned
/// pattern, the three DAC volts, then 0 for "no plant yet". The parameters include the
/// default hysteresis radii, so they changed with the passive form (15–75 V) and nothing
/// else did.
const PLANT_FORMAT_1: &str = concat!(
    "b81e85eb51b89e3f00000000389c7c410000000000002e407b14ae47e17aa43f00000000d0125341",
    "0000000000003440333333333333c33f000000000088d34000000000000024403bdf4f8d976ea23f",
    "00000000000000009a999999999921408dedb5a0f7c6d03e0000000000002e400000000000003e40",
    "00000000008046400000000000004e400000000000c052407b14ae47e17ab43fec51b81e85ebb13f",
    "b81e85eb51b8ae3f9a9999999999a93f7b14ae47e17aa43f0000000000e065400000000000000000",
    "00000000000049400000000000c0724000000000000024400000000000b07d404cce61e3a79d143e",
    "95d626e80b2e113e0000000000000000000020ffffffef4100000000000000000000000000000c40",
    "000000000000000000",
);

fn hex(s: &str) -> Vec<u8> {
    (0..s.len()).step_by(2).map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap()).collect()
}

#[test]
fn state_payload_keeps_format_1_byte_for_byte() {
    const NOISE_SEED: u32 = 132;
    let a = Harness::<PlantFmu>::new("format");
    // In initialization mode, where the restored copy may be read back.
    assert_eq!((a.setup(), a.enter()), (fmi2OK, fmi2OK));
    assert_eq!(a.set_real(M_P, 0.03), fmi2OK);
    assert_eq!(a.set_real(DAC_NONEARTH, 3.5), fmi2OK);
    assert_eq!(a.set_integer(NOISE_SEED, -7), fmi2OK);
    let blob = a.serialize();
    assert_eq!(payload_of::<PlantFmu>(&blob), hex(PLANT_FORMAT_1));
    let b = Harness::<PlantFmu>::new("restored");
    assert_eq!(b.deserialize(&blob), fmi2OK, "{:?}", b.logged());
    assert_eq!(b.real(M_P), (fmi2OK, 0.03));
    assert_eq!(b.real(DAC_NONEARTH), (fmi2OK, 3.5));
    assert_eq!(b.integer(NOISE_SEED), (fmi2OK, -7));
    assert_eq!(b.serialize(), blob);
}

#[test]
fn eight_instances_on_eight_threads_match_eight_serial_runs() {
    let amplitudes = [1.0, 0.9, 0.5, 0.3, 0.1, 0.2, 0.6, 0.75];
    let run = |y: f64| {
        let i = Instance::init(&format!("y{y}"));
        let mut out = i.gait(0, y);
        out.extend(i.gait(100, y));
        out
    };
    let serial: Vec<_> = amplitudes.iter().map(|&y| run(y)).collect();
    let threads: Vec<_> = amplitudes.iter().map(|&y| std::thread::spawn(move || run(y))).collect();
    let parallel: Vec<_> = threads.into_iter().map(|t| t.join().unwrap()).collect();
    assert_eq!(serial, parallel);
    assert!(serial[0] != serial[7]);
}

#[test]
fn committed_model_description_matches_the_variable_table() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../modelDescription/InchwormPlant.xml");
    let committed = std::fs::read_to_string(path).unwrap_or_default();
    let generated = model_description::model_description::<PlantFmu>();
    assert!(
        committed == generated,
        "{path} differs from the variable table: run `cargo run --release -p fmu-build` and commit modelDescription/"
    );
}

#[test]
fn the_guid_is_computed_once_per_model() {
    let (a, b) = (model_description::guid::<PlantFmu>(), model_description::guid::<PlantFmu>());
    assert!(std::ptr::eq(a, b), "the second call returned a fresh string");
    assert_ne!(a, model_description::guid::<ControllerFmu>());
    let xml = model_description::model_description::<PlantFmu>();
    assert!(xml.contains(&format!("guid=\"{a}\"")));
}
