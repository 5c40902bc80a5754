//! What is specific to InchwormPlant at its FMI boundary: the words of its messages, its
//! parameter checks, its brake events, its dynamic state replayed bit for bit and its
//! pinned payload, its modelDescription. The exported `fmi2*` functions are called
//! in-process through the rlib, the same code the shared library exports; every behaviour
//! of the layer itself is tested once for both standards in
//! `crates/fmi-export/tests/behaviour.rs`.

use std::ffi::CString;
use std::sync::Mutex;

use inchworm_fmi_export::ffi::*;
use inchworm_fmi_export::model_description;
use inchworm_fmi_export::testing::{callbacks, categories_of, payload_of, Harness, Log};
use inchworm_fmi_export::Var;
use inchworm_fmu_models::{ControllerFmu, PlantFmu};
use inchworm_plant_fmu as fmu;

/// The three DAC inputs: earth, non-earth, extension.
const DACS: [Var<PlantFmu>; 3] = PlantFmu::DAC_INPUTS;

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
            for (var, v) in DACS.into_iter().zip([e, n, x]) {
                assert_eq!(self.set_real(var.vr(), v), fmi2OK);
            }
            let t = (k0 + k - 1) as f64 * 0.002;
            assert_eq!(self.step(t, 0.002), fmi2OK, "doStep at t = {t}: {:?}", self.logged());
            out.push((
                self.integer(PlantFmu::ENCODER_COUNTS.vr()).1,
                self.real(PlantFmu::RUNNER_POSITION.vr()).1,
            ));
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
fn nan_input_is_refused_and_the_instance_stays_usable() {
    let i = Instance::init("nan");
    assert_eq!(i.set_real(PlantFmu::var(inchworm_fmu_models::Dac::EXTENSION).vr(), 4.0), fmi2OK);
    assert_eq!(
        i.set_real(PlantFmu::var(inchworm_fmu_models::Dac::EXTENSION).vr(), f64::NAN),
        fmi2Error
    );
    assert!(
        i.saw(
            fmi2Error,
            &[
                "fmi2SetReal",
                PlantFmu::var(inchworm_fmu_models::Dac::EXTENSION).name(),
                "NaN",
                "keeping 4 V"
            ]
        ),
        "{:?}",
        i.logged()
    );
    assert_eq!(
        i.logged(),
        ["3|logStatusError|fmi2SetReal: dac_extension = NaN refused: DAC volts must be finite; keeping 4 V"],
        "the function is named once, then the reason"
    );
    assert_eq!(
        i.real(PlantFmu::var(inchworm_fmu_models::Dac::EXTENSION).vr()),
        (fmi2OK, 4.0),
        "the last valid value is kept"
    );
    assert_eq!(
        i.set_real(PlantFmu::var(inchworm_fmu_models::Dac::NONEARTH).vr(), f64::INFINITY),
        fmi2Error
    );
    assert_eq!(i.step(0.0, 0.002), fmi2OK, "a refused input leaves the instance usable");
    assert_eq!(i.set_real(PlantFmu::var(inchworm_fmu_models::Dac::EXTENSION).vr(), 5.0), fmi2OK);
    assert_eq!(i.step(0.002, 0.002), fmi2OK);
}

#[test]
fn out_of_range_volts_are_clamped_with_a_warning() {
    let i = Instance::init("range");
    assert_eq!(i.set_real(PlantFmu::var(inchworm_fmu_models::Dac::EARTH).vr(), 12.5), fmi2Warning);
    assert_eq!(
        i.logged(),
        ["1|logStatusWarning|fmi2SetReal: dac_earth = 12.5 V is outside the DAC range 0-10 V, clamped to 10 V"]
    );
    assert_eq!(i.real(PlantFmu::var(inchworm_fmu_models::Dac::EARTH).vr()), (fmi2OK, 10.0));
    assert_eq!(
        i.set_real(PlantFmu::var(inchworm_fmu_models::Dac::NONEARTH).vr(), -0.5),
        fmi2Warning
    );
    assert_eq!(i.real(PlantFmu::var(inchworm_fmu_models::Dac::NONEARTH).vr()), (fmi2OK, 0.0));
    // Several values in one call: each stands alone, the call reports the worst.
    let vrs = DACS.map(Var::vr);
    let vals = [1.0, f64::NAN, 11.0];
    assert_eq!(unsafe { fmu::fmi2SetReal(i.c, vrs.as_ptr(), 3, vals.as_ptr()) }, fmi2Error);
    assert_eq!(i.real(PlantFmu::var(inchworm_fmu_models::Dac::EARTH).vr()).1, 1.0);
    assert_eq!(i.real(PlantFmu::var(inchworm_fmu_models::Dac::NONEARTH).vr()).1, 0.0);
    assert_eq!(i.real(PlantFmu::var(inchworm_fmu_models::Dac::EXTENSION).vr()).1, 10.0);
}

/// FMPy's linear interpolation of the inputs hands the plant 10.000000000000002 V for a DAC
/// at 10 V: that is 10 V, stored as it without a warning (a check-trace run through FMPy
/// logged 1 831 of them before).
#[test]
fn volts_a_rounding_past_the_dac_range_are_its_limits_without_a_warning() {
    let i = Instance::init("rounding");
    i.take_logged();
    let vrs = DACS.map(Var::vr);
    let vals = [10.000000000000002, -1e-15, 9.999999999999998];
    assert_eq!(unsafe { fmu::fmi2SetReal(i.c, vrs.as_ptr(), 3, vals.as_ptr()) }, fmi2OK);
    assert_eq!(i.logged(), Vec::<String>::new());
    assert_eq!(
        i.real(PlantFmu::var(inchworm_fmu_models::Dac::EARTH).vr()).1.to_bits(),
        10.0f64.to_bits()
    );
    assert_eq!(
        i.real(PlantFmu::var(inchworm_fmu_models::Dac::NONEARTH).vr()).1.to_bits(),
        0.0f64.to_bits()
    );
    assert_eq!(
        i.real(PlantFmu::var(inchworm_fmu_models::Dac::EXTENSION).vr()).1,
        9.999999999999998,
        "inside the range: as given"
    );
}

#[test]
fn bad_parameters_fail_initialization_naming_the_parameter() {
    for (var, value) in [
        (PlantFmu::var(inchworm_fmu_models::PlantParams::M_P), -0.025),
        (PlantFmu::var(inchworm_fmu_models::PlantParams::PLAY_RADIUS).element(1), 5.0),
    ] {
        let (vr, name) = (var.vr(), var.name());
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
    assert_eq!(
        i.set_real(PlantFmu::var(inchworm_fmu_models::PlantParams::M_P).vr(), f64::NAN),
        fmi2Error
    );
    assert!(
        i.saw(fmi2Error, &[PlantFmu::var(inchworm_fmu_models::PlantParams::M_P).name(), "finite"])
    );
}

/// Asserts that every line is a debug (fmi2OK) message and returns the categories seen.
fn debug_categories(lines: &[String]) -> Vec<String> {
    assert!(lines.iter().all(|l| l.starts_with("0|")), "{lines:?}");
    categories_of(lines)
}

#[test]
fn debug_logging_shows_the_plants_brake_events() {
    let i = Instance::init("logging");
    i.gait(0, 1.0);
    assert_eq!(i.take_logged(), Vec::<String>::new(), "no debug messages without debug logging");
    assert_eq!(i.set_debug_logging(fmi2True, &[c"logEvents".as_ptr()]), fmi2OK);
    i.gait(100, 1.0);
    let events = i.take_logged();
    assert_eq!(debug_categories(&events), ["logEvents"]);
    assert!(events.iter().all(|l| l.contains("brake switch")), "{events:?}");
    assert!(events.iter().any(|l| l.contains("Hold -> Locked")), "{events:?}");
    assert_eq!(i.set_debug_logging(fmi2False, &[]), fmi2OK);
    assert_eq!(
        i.set_real(PlantFmu::var(inchworm_fmu_models::Dac::EARTH).vr(), 12.0),
        fmi2Warning,
        "warnings still go out"
    );
    assert!(i.take_logged()[0].starts_with("1|logStatusWarning|fmi2SetReal: dac_earth = 12 V"));
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
    let a = Harness::<PlantFmu>::new("format");
    // In initialization mode, where the restored copy may be read back.
    assert_eq!((a.setup(), a.enter()), (fmi2OK, fmi2OK));
    assert_eq!(a.set_real(PlantFmu::var(inchworm_fmu_models::PlantParams::M_P).vr(), 0.03), fmi2OK);
    assert_eq!(a.set_real(PlantFmu::var(inchworm_fmu_models::Dac::NONEARTH).vr(), 3.5), fmi2OK);
    assert_eq!(
        a.set_integer(PlantFmu::var(inchworm_fmu_models::PlantParams::NOISE_SEED).vr(), -7),
        fmi2OK
    );
    let blob = a.serialize();
    assert_eq!(payload_of::<PlantFmu>(&blob), hex(PLANT_FORMAT_1));
    let b = Harness::<PlantFmu>::new("restored");
    assert_eq!(b.deserialize(&blob), fmi2OK, "{:?}", b.logged());
    assert_eq!(b.real(PlantFmu::var(inchworm_fmu_models::PlantParams::M_P).vr()), (fmi2OK, 0.03));
    assert_eq!(b.real(PlantFmu::var(inchworm_fmu_models::Dac::NONEARTH).vr()), (fmi2OK, 3.5));
    assert_eq!(
        b.integer(PlantFmu::var(inchworm_fmu_models::PlantParams::NOISE_SEED).vr()),
        (fmi2OK, -7)
    );
    assert_eq!(b.serialize(), blob);
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
