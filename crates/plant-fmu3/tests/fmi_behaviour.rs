//! The FMI 3.0 boundary of InchwormPlant, called as a master calls it: call order, NaN,
//! out-of-range and unknown value references, parameters, state round trips and corrupt
//! blobs, eight threads, the committed modelDescription, and the FMI 2.0 FMU's trace on
//! the passive check trace bit for bit. The `fmi3*` functions are called in-process
//! through the rlib, the same code the shared library exports.

use std::ffi::CString;
use std::sync::Mutex;

use inchworm_fmi_export::fmi3::ffi::*;
use inchworm_fmi_export::fmi3::testing::log_callback;
use inchworm_fmi_export::testing::{callbacks, Log};
use inchworm_fmi_export::{ffi as fmi2, model_description};
use inchworm_fmu_models::PlantFmu;
use inchworm_plant_fmu as fmu2;
use inchworm_plant_fmu3 as fmu;

const TIME: u32 = 0;
const DAC_EARTH: u32 = 1;
const DAC_NONEARTH: u32 = 2;
const DAC_EXTENSION: u32 = 3;
const ENCODER_COUNTS: u32 = 10;
const RUNNER_POSITION: u32 = 12;
const MODE: u32 = 17;
const EARTH_CLOSED: u32 = 18;
const M_P: u32 = 100;
const PLAY_RADIUS_2: u32 = 114;
const H: f64 = 0.002;

struct Instance {
    c: fmi3Instance,
    log: Box<Log>,
}

// The FMU promises independent instances usable from any thread.
unsafe impl Send for Instance {}

fn token() -> CString {
    CString::new(model_description::guid::<PlantFmu>()).unwrap()
}

impl Instance {
    fn try_new(name: &str, token: &CString, event_mode: bool) -> (fmi3Instance, Box<Log>) {
        let log = Box::new(Log(Mutex::new(Vec::new())));
        let (env, logger) = log_callback(&log);
        let name = CString::new(name).unwrap();
        let c = unsafe {
            fmu::fmi3InstantiateCoSimulation(
                name.as_ptr(),
                token.as_ptr(),
                std::ptr::null(),
                false,
                false,
                event_mode,
                false,
                std::ptr::null(),
                0,
                env,
                logger,
                None,
            )
        };
        (c, log)
    }

    fn new(name: &str) -> Instance {
        let (c, log) = Instance::try_new(name, &token(), false);
        assert!(!c.is_null(), "fmi3InstantiateCoSimulation failed: {:?}", log.0.lock().unwrap());
        Instance { c, log }
    }

    fn enter(&self) -> fmi3Status {
        unsafe { fmu::fmi3EnterInitializationMode(self.c, false, 0.0, 0.0, false, 0.0) }
    }

    fn init(name: &str) -> Instance {
        let i = Instance::new(name);
        assert_eq!(i.enter(), fmi3OK);
        assert_eq!(unsafe { fmu::fmi3ExitInitializationMode(i.c) }, fmi3OK);
        i
    }

    fn set_real(&self, vr: u32, v: f64) -> fmi3Status {
        unsafe { fmu::fmi3SetFloat64(self.c, &vr, 1, &v, 1) }
    }

    fn real(&self, vr: u32) -> (fmi3Status, f64) {
        let mut v = f64::NAN;
        let s = unsafe { fmu::fmi3GetFloat64(self.c, &vr, 1, &mut v, 1) };
        (s, v)
    }

    fn integer(&self, vr: u32) -> (fmi3Status, i32) {
        let mut v = -1;
        let s = unsafe { fmu::fmi3GetInt32(self.c, &vr, 1, &mut v, 1) };
        (s, v)
    }

    /// fmi3DoStep and its four results.
    fn step_full(&self, t: f64, h: f64) -> (fmi3Status, [bool; 3], f64) {
        let (mut ev, mut term, mut early, mut last) = (true, true, true, f64::NAN);
        let s = unsafe {
            fmu::fmi3DoStep(self.c, t, h, true, &mut ev, &mut term, &mut early, &mut last)
        };
        (s, [ev, term, early], last)
    }

    fn step(&self, t: f64, h: f64) -> fmi3Status {
        self.step_full(t, h).0
    }

    fn logged(&self) -> Vec<String> {
        self.log.0.lock().unwrap().clone()
    }

    fn saw(&self, status: fmi3Status, parts: &[&str]) -> bool {
        self.logged()
            .iter()
            .any(|m| m.starts_with(&format!("{status}|")) && parts.iter().all(|p| m.contains(p)))
    }

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
                assert_eq!(self.set_real(vr, v), fmi3OK);
            }
            let t = (k0 + k - 1) as f64 * H;
            assert_eq!(self.step(t, H), fmi3OK, "doStep at t = {t}: {:?}", self.logged());
            out.push((self.integer(ENCODER_COUNTS).1, self.real(RUNNER_POSITION).1));
        }
        out
    }

    fn get_state(&self) -> fmi3FMUState {
        let mut s: fmi3FMUState = std::ptr::null_mut();
        assert_eq!(unsafe { fmu::fmi3GetFMUState(self.c, &mut s) }, fmi3OK);
        s
    }

    fn serialize(&self) -> Vec<u8> {
        let mut s = self.get_state();
        let mut size = 0usize;
        assert_eq!(unsafe { fmu::fmi3SerializedFMUStateSize(self.c, s, &mut size) }, fmi3OK);
        let mut bytes = vec![0u8; size];
        assert_eq!(
            unsafe { fmu::fmi3SerializeFMUState(self.c, s, bytes.as_mut_ptr(), size) },
            fmi3OK
        );
        assert_eq!(unsafe { fmu::fmi3FreeFMUState(self.c, &mut s) }, fmi3OK);
        assert!(s.is_null());
        bytes
    }

    /// Deserializes `bytes` and sets the state; the status of the first refusal.
    fn deserialize(&self, bytes: &[u8]) -> fmi3Status {
        let mut s: fmi3FMUState = std::ptr::null_mut();
        let st =
            unsafe { fmu::fmi3DeserializeFMUState(self.c, bytes.as_ptr(), bytes.len(), &mut s) };
        if st != fmi3OK {
            return st;
        }
        let st = unsafe { fmu::fmi3SetFMUState(self.c, s) };
        assert_eq!(unsafe { fmu::fmi3FreeFMUState(self.c, &mut s) }, fmi3OK);
        st
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        unsafe { fmu::fmi3FreeInstance(self.c) };
    }
}

#[test]
fn calls_out_of_order_are_refused_and_logged() {
    let i = Instance::new("order");
    assert_eq!(i.step(0.0, H), fmi3Error);
    assert!(i.saw(fmi3Error, &["fmi3DoStep", "illegal call sequence", "Instantiated"]));
    assert_eq!(unsafe { fmu::fmi3ExitInitializationMode(i.c) }, fmi3Error);
    assert_eq!(unsafe { fmu::fmi3Terminate(i.c) }, fmi3Error);
    assert_eq!(i.real(ENCODER_COUNTS).0, fmi3Error, "no getting before initialization");
    assert_eq!(i.enter(), fmi3OK);
    assert_eq!(i.enter(), fmi3Error);
    assert_eq!(unsafe { fmu::fmi3ExitInitializationMode(i.c) }, fmi3OK);
    assert_eq!(i.step(0.0, H), fmi3OK);
    assert_eq!(unsafe { fmu::fmi3Terminate(i.c) }, fmi3OK);
    assert_eq!(i.step(H, H), fmi3Error);
    assert!(i.saw(fmi3Error, &["fmi3DoStep", "Terminated"]));
    assert_eq!(unsafe { fmu::fmi3Reset(i.c) }, fmi3OK);
    assert_eq!(i.enter(), fmi3OK, "reset returns to Instantiated");
}

#[test]
fn null_and_foreign_pointers_are_refused_without_a_crash() {
    assert_eq!(unsafe { fmu::fmi3ExitInitializationMode(std::ptr::null_mut()) }, fmi3Error);
    let mut junk = [0u64; 16];
    let foreign = junk.as_mut_ptr() as fmi3Instance;
    assert_eq!(
        unsafe {
            fmu::fmi3DoStep(
                foreign,
                0.0,
                H,
                true,
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                std::ptr::null_mut(),
            )
        },
        fmi3Error
    );
    unsafe { fmu::fmi3FreeInstance(std::ptr::null_mut()) };
    let i = Instance::init("null");
    let vr = ENCODER_COUNTS;
    assert_eq!(unsafe { fmu::fmi3GetInt32(i.c, &vr, 1, std::ptr::null_mut(), 1) }, fmi3Error);
    let mut v = 0;
    assert_eq!(unsafe { fmu::fmi3GetInt32(i.c, &vr, 1, &mut v, 2) }, fmi3Error);
    assert!(i.saw(fmi3Error, &["nValues 2 differs from nValueReferences 1"]));
    let mut last = 0.0;
    let s = unsafe {
        fmu::fmi3DoStep(
            i.c,
            0.0,
            H,
            true,
            std::ptr::null_mut(),
            std::ptr::null_mut(),
            std::ptr::null_mut(),
            &mut last,
        )
    };
    assert_eq!(s, fmi3Error);
    assert_eq!(i.step(0.0, H), fmi3OK, "the refused step changed nothing");
}

#[test]
fn instantiate_refuses_a_wrong_token_event_mode_and_other_interfaces() {
    let wrong = CString::new("{00000000-0000-0000-0000-000000000000}").unwrap();
    let (c, log) = Instance::try_new("wrong", &wrong, false);
    assert!(c.is_null());
    assert!(log.0.lock().unwrap().iter().any(|m| m.contains("instantiationToken")));
    let (c, log) = Instance::try_new("event", &token(), true);
    assert!(c.is_null());
    assert!(log.0.lock().unwrap().iter().any(|m| m.contains("hasEventMode")));
    let log = Box::new(Log(Mutex::new(Vec::new())));
    let (env, logger) = log_callback(&log);
    let name = CString::new("me").unwrap();
    let c = unsafe {
        fmu::fmi3InstantiateModelExchange(
            name.as_ptr(),
            token().as_ptr(),
            std::ptr::null(),
            false,
            false,
            env,
            logger,
        )
    };
    assert!(c.is_null());
    assert!(log.0.lock().unwrap().iter().any(|m| m.contains("Co-Simulation only")));
}

#[test]
fn do_step_results_and_time() {
    let i = Instance::init("results");
    assert_eq!(i.real(TIME), (fmi3OK, 0.0));
    let (s, flags, last) = i.step_full(0.0, H);
    assert_eq!((s, flags, last), (fmi3OK, [false, false, false], H));
    assert_eq!(i.real(TIME), (fmi3OK, H));
    let (s, flags, last) = i.step_full(1.0, H);
    assert_eq!(
        (s, flags, last),
        (fmi3Error, [false, false, false], H),
        "refused: lastSuccessfulTime unchanged"
    );
    assert!(i.saw(fmi3Error, &["does not match the FMU time"]));
    assert_eq!(i.step(H, -1.0), fmi3Error);
    assert_eq!(i.step(H, f64::NAN), fmi3Error);
    assert_eq!(i.set_real(TIME, 1.0), fmi3Error, "time is not settable");
}

#[test]
fn nan_input_is_refused_and_the_instance_stays_usable() {
    let i = Instance::init("nan");
    assert_eq!(i.set_real(DAC_EARTH, 4.0), fmi3OK);
    assert_eq!(i.set_real(DAC_EARTH, f64::NAN), fmi3Error);
    assert!(i.saw(fmi3Error, &["dac_earth", "finite", "keeping 4"]));
    assert_eq!(i.real(DAC_EARTH), (fmi3OK, 4.0));
    assert_eq!(i.step(0.0, H), fmi3OK);
}

#[test]
fn out_of_range_volts_are_clamped_with_a_warning() {
    let i = Instance::init("range");
    assert_eq!(i.set_real(DAC_EXTENSION, 12.0), fmi3Warning);
    assert!(i.saw(fmi3Warning, &["fmi3SetFloat64", "dac_extension", "clamped to 10"]));
    assert_eq!(i.real(DAC_EXTENSION), (fmi3OK, 10.0));
    assert_eq!(i.set_real(DAC_EXTENSION, -1.0), fmi3Warning);
    assert_eq!(i.real(DAC_EXTENSION), (fmi3OK, 0.0));
}

#[test]
fn unknown_value_references_and_wrong_types_are_errors() {
    let i = Instance::init("vr");
    assert_eq!(i.real(9999).0, fmi3Error);
    assert!(i.saw(fmi3Error, &["unknown value reference 9999"]));
    assert_eq!(i.real(ENCODER_COUNTS).0, fmi3Error);
    assert!(i.saw(fmi3Error, &["encoder_counts", "is Int32, not Float64"]));
    assert_eq!(i.integer(DAC_EARTH).0, fmi3Error);
    let vr = MODE;
    let mut v = 0u8;
    assert_eq!(unsafe { fmu::fmi3GetUInt8(i.c, &vr, 1, &mut v, 1) }, fmi3Error);
    assert!(i.saw(fmi3Error, &["mode", "not UInt8"]));
    assert_eq!(unsafe { fmu::fmi3GetUInt8(i.c, &vr, 0, &mut v, 0) }, fmi3OK, "nothing asked");
    let vr = EARTH_CLOSED;
    let mut b = [0u8; 1];
    let s = unsafe { fmu::fmi3GetBoolean(i.c, &vr, 1, b.as_mut_ptr() as *mut bool, 1) };
    assert_eq!(s, fmi3OK);
    assert!(b[0] <= 1, "a C bool is 0 or 1");
    let byte = 2u8;
    let s = unsafe { fmu::fmi3SetBoolean(i.c, &vr, 1, &byte as *const u8 as *const bool, 1) };
    assert_eq!(s, fmi3Error, "an output cannot be set");
}

#[test]
fn bad_parameters_fail_initialization_naming_the_parameter() {
    for (vr, value, name) in [(M_P, -0.025, "m_p"), (PLAY_RADIUS_2, 5.0, "play_radius[2]")] {
        let i = Instance::new("params");
        assert_eq!(i.set_real(vr, value), fmi3OK, "validated at initialization, as a whole");
        assert_eq!(i.enter(), fmi3OK);
        assert_eq!(unsafe { fmu::fmi3ExitInitializationMode(i.c) }, fmi3Error);
        assert!(
            i.saw(fmi3Error, &["fmi3ExitInitializationMode", name]),
            "{name}: {:?}",
            i.logged()
        );
        assert_eq!(i.step(0.0, H), fmi3Error);
        assert_eq!(unsafe { fmu::fmi3Reset(i.c) }, fmi3OK, "reset recovers the instance");
    }
    let i = Instance::new("nan-param");
    assert_eq!(i.set_real(M_P, f64::NAN), fmi3Error);
    let i = Instance::init("fixed");
    assert_eq!(i.set_real(M_P, 0.03), fmi3Error);
    assert!(i.saw(fmi3Error, &["m_p", "cannot be set in state StepMode"]));
}

#[test]
fn unsupported_functions_return_error_with_a_reason() {
    let i = Instance::init("unsupported");
    assert_eq!(unsafe { fmu::fmi3EnterEventMode(i.c) }, fmi3Error);
    assert_eq!(unsafe { fmu::fmi3EnterConfigurationMode(i.c) }, fmi3Error);
    assert_eq!(unsafe { fmu::fmi3EnterContinuousTimeMode(i.c) }, fmi3Error);
    assert_eq!(unsafe { fmu::fmi3SetTime(i.c, 0.0) }, fmi3Error);
    assert_eq!(unsafe { fmu::fmi3EvaluateDiscreteStates(i.c) }, fmi3Error);
    for part in [
        "hasEventMode is false",
        "no structural parameters",
        "Co-Simulation only",
        "providesEvaluateDiscreteStates",
    ] {
        assert!(i.saw(fmi3Error, &["not supported", part]), "{part}: {:?}", i.logged());
    }
    assert_eq!(i.step(0.0, H), fmi3OK, "refusals leave the instance usable");
}

#[test]
fn get_and_set_state_replays_the_trajectory_bit_for_bit() {
    let i = Instance::init("state");
    i.gait(0, 1.0);
    let mut s = i.get_state();
    let ahead = i.gait(100, 0.5);
    assert_eq!(unsafe { fmu::fmi3SetFMUState(i.c, s) }, fmi3OK);
    assert_eq!(i.gait(100, 0.5), ahead);
    assert_eq!(unsafe { fmu::fmi3FreeFMUState(i.c, &mut s) }, fmi3OK);
    let mut junk = [0u8; 64];
    assert_eq!(unsafe { fmu::fmi3SetFMUState(i.c, junk.as_mut_ptr() as fmi3FMUState) }, fmi3Error);
}

#[test]
fn serialized_state_continues_bit_for_bit_in_a_fresh_instance() {
    let a = Instance::init("a");
    a.gait(0, 1.0);
    let blob = a.serialize();
    let ahead = a.gait(100, 0.3);
    let b = Instance::new("b");
    assert_eq!(b.deserialize(&blob), fmi3OK, "{:?}", b.logged());
    assert_eq!(b.gait(100, 0.3), ahead);
}

#[test]
fn a_state_serialized_by_the_fmi2_fmu_restores_in_the_fmi3_fmu() {
    let log = Log(Mutex::new(Vec::new()));
    let functions = callbacks(&log);
    let name = CString::new("fmi2").unwrap();
    let c2 = unsafe {
        fmu2::fmi2Instantiate(
            name.as_ptr(),
            fmi2::fmi2CoSimulation,
            token().as_ptr(),
            std::ptr::null(),
            &functions,
            0,
            0,
        )
    };
    assert!(!c2.is_null());
    unsafe {
        assert_eq!(fmu2::fmi2SetupExperiment(c2, 0, 0.0, 0.0, 0, 0.0), 0);
        assert_eq!(fmu2::fmi2EnterInitializationMode(c2), 0);
        assert_eq!(fmu2::fmi2ExitInitializationMode(c2), 0);
        let x = 10.0;
        assert_eq!(fmu2::fmi2SetReal(c2, &DAC_EXTENSION, 1, &x), 0);
        for k in 0..20 {
            assert_eq!(fmu2::fmi2DoStep(c2, k as f64 * H, H, 1), 0);
        }
        let mut s: fmi2::fmi2FMUstate = std::ptr::null_mut();
        assert_eq!(fmu2::fmi2GetFMUstate(c2, &mut s), 0);
        let mut size = 0;
        assert_eq!(fmu2::fmi2SerializedFMUstateSize(c2, s, &mut size), 0);
        let mut blob = vec![0u8; size];
        assert_eq!(fmu2::fmi2SerializeFMUstate(c2, s, blob.as_mut_ptr() as *mut _, size), 0);
        let i = Instance::new("from-fmi2");
        assert_eq!(i.deserialize(&blob), fmi3OK, "{:?}", i.logged());
        assert_eq!(i.real(TIME), (fmi3OK, 20.0 * H));
        for k in 20..40 {
            assert_eq!(fmu2::fmi2DoStep(c2, k as f64 * H, H, 1), 0);
            assert_eq!(i.step(k as f64 * H, H), fmi3OK);
            let mut r2 = 0.0;
            assert_eq!(fmu2::fmi2GetReal(c2, &RUNNER_POSITION, 1, &mut r2), 0);
            assert_eq!(i.real(RUNNER_POSITION).1.to_bits(), r2.to_bits());
        }
        assert_eq!(fmu2::fmi2FreeFMUstate(c2, &mut s), 0);
        fmu2::fmi2FreeInstance(c2);
    }
}

#[test]
fn corrupt_truncated_and_foreign_state_blobs_are_refused() {
    let a = Instance::init("corrupt");
    a.gait(0, 1.0);
    let blob = a.serialize();
    let before = a.real(RUNNER_POSITION).1;
    for at in [0, 5, blob.len() / 2, blob.len() - 1] {
        let mut bad = blob.clone();
        bad[at] ^= 0x21;
        assert_eq!(a.deserialize(&bad), fmi3Error, "flipped byte {at}");
    }
    assert_eq!(a.deserialize(&blob[..blob.len() - 3]), fmi3Error);
    assert_eq!(a.deserialize(&[]), fmi3Error);
    assert!(a.saw(fmi3Error, &["fmi3DeserializeFMUState", "corrupt"]));
    assert_eq!(a.real(RUNNER_POSITION).1, before, "refusals leave the instance as it was");
    assert_eq!(a.step(0.2, H), fmi3OK);
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
fn the_passive_check_trace_through_fmi3_equals_fmi2_bit_for_bit() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/plant-check-trace-fia20-passive.csv"
    );
    let text = std::fs::read_to_string(path).unwrap();
    let rows: Vec<Vec<f64>> =
        text.lines().skip(1).map(|l| l.split(',').map(|x| x.parse().unwrap()).collect()).collect();
    assert_eq!(rows.len(), 500);
    let log = Log(Mutex::new(Vec::new()));
    let functions = callbacks(&log);
    let name = CString::new("fmi2").unwrap();
    let i = Instance::init("fmi3");
    unsafe {
        let c2 = fmu2::fmi2Instantiate(
            name.as_ptr(),
            fmi2::fmi2CoSimulation,
            token().as_ptr(),
            std::ptr::null(),
            &functions,
            0,
            0,
        );
        assert_eq!(fmu2::fmi2SetupExperiment(c2, 0, 0.0, 0.0, 0, 0.0), 0);
        assert_eq!(fmu2::fmi2EnterInitializationMode(c2), 0);
        assert_eq!(fmu2::fmi2ExitInitializationMode(c2), 0);
        let outputs: Vec<u32> = (10..=16).collect();
        let mut worst = 0;
        for (k, r) in rows.iter().enumerate() {
            let t = k as f64 * H;
            for (vr, v) in [(DAC_EARTH, r[1]), (DAC_NONEARTH, r[2]), (DAC_EXTENSION, r[3])] {
                assert_eq!(fmu2::fmi2SetReal(c2, &vr, 1, &v), 0);
                assert_eq!(i.set_real(vr, v), fmi3OK);
            }
            assert_eq!(fmu2::fmi2DoStep(c2, t, H, 1), 0);
            assert_eq!(i.step(t, H), fmi3OK);
            let (mut c, mut m) = (0, 0);
            assert_eq!(fmu2::fmi2GetInteger(c2, &ENCODER_COUNTS, 1, &mut c), 0);
            assert_eq!(fmu2::fmi2GetInteger(c2, &MODE, 1, &mut m), 0);
            assert_eq!(i.integer(ENCODER_COUNTS), (fmi3OK, c), "encoder at sample {k}");
            assert_eq!(i.integer(MODE), (fmi3OK, m), "mode at sample {k}");
            for vr in outputs.iter().filter(|&&vr| vr != ENCODER_COUNTS) {
                let mut v2 = 0.0;
                assert_eq!(fmu2::fmi2GetReal(c2, vr, 1, &mut v2), 0);
                assert_eq!(i.real(*vr).1.to_bits(), v2.to_bits(), "vr {vr} at sample {k}");
            }
            worst = worst.max((c - r[4] as i32).abs());
        }
        assert!(worst <= 1, "the check trace is held within 1 count, as for FMI 2.0");
        fmu2::fmi2FreeInstance(c2);
    }
}

#[test]
fn committed_model_description_matches_the_variable_table() {
    let path =
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../modelDescription/fmi3/InchwormPlant.xml");
    let committed = std::fs::read_to_string(path).unwrap();
    assert!(
        committed == inchworm_fmi_export::fmi3::model_description::model_description::<PlantFmu>(),
        "{path} differs from the variable table: run `cargo run --release -p fmu-build` and commit modelDescription/fmi3/"
    );
}

impl Instance {
    fn take_logged(&self) -> Vec<String> {
        std::mem::take(&mut *self.log.0.lock().unwrap())
    }

    fn set_debug_logging(&self, on: bool, categories: &[*const std::ffi::c_char]) -> fmi3Status {
        unsafe { fmu::fmi3SetDebugLogging(self.c, on, categories.len(), categories.as_ptr()) }
    }
}

fn debug_categories(lines: &[String]) -> Vec<String> {
    assert!(lines.iter().all(|l| l.starts_with("0|")), "{lines:?}");
    inchworm_fmi_export::testing::categories_of(lines)
}

#[test]
fn debug_logging_enables_exactly_the_named_categories() {
    let i = Instance::init("logging");
    i.gait(0, 1.0);
    assert_eq!(i.take_logged(), Vec::<String>::new(), "no debug messages without debug logging");
    assert_eq!(i.set_debug_logging(true, &[c"logEvents".as_ptr()]), fmi3OK);
    i.gait(100, 1.0);
    let events = i.take_logged();
    assert_eq!(debug_categories(&events), ["logEvents"]);
    assert!(events.iter().all(|l| l.contains("brake switch")), "{events:?}");
    assert_eq!(i.set_debug_logging(true, &[]), fmi3OK);
    i.gait(200, 1.0);
    let all = i.take_logged();
    assert_eq!(debug_categories(&all), ["logAll", "logEvents"]);
    assert_eq!(all.iter().filter(|l| l.ends_with("|logAll|logging: fmi3DoStep")).count(), 100);
    assert_eq!(i.set_debug_logging(false, &[]), fmi3OK);
    i.take_logged();
    i.gait(300, 1.0);
    assert_eq!(i.take_logged(), Vec::<String>::new());
    assert_eq!(i.set_real(DAC_EARTH, 12.0), fmi3Warning, "warnings still go out");
    let warned = i.take_logged();
    assert_eq!(warned.len(), 1, "{warned:?}");
    assert!(warned[0].starts_with("1|logStatusWarning|logging: fmi3SetFloat64: dac_earth = 12 V"));
}

#[test]
fn unknown_or_null_log_categories_are_refused_and_change_nothing() {
    let i = Instance::init("bad categories");
    assert_eq!(i.set_debug_logging(true, &[c"logEvents".as_ptr()]), fmi3OK);
    let bad = [c"logAll".as_ptr(), c"logNonsense".as_ptr()];
    assert_eq!(i.set_debug_logging(true, &bad), fmi3Error);
    assert!(i.saw(fmi3Error, &["fmi3SetDebugLogging", "unknown log category \"logNonsense\""]));
    assert_eq!(i.set_debug_logging(false, &[std::ptr::null()]), fmi3Error);
    assert!(i.saw(fmi3Error, &["a category name is NULL"]));
    assert_eq!(unsafe { fmu::fmi3SetDebugLogging(i.c, true, 1, std::ptr::null()) }, fmi3Error);
    i.take_logged();
    i.gait(0, 1.0);
    assert_eq!(debug_categories(&i.take_logged()), ["logEvents"]);
}
