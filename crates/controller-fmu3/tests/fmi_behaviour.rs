//! The FMI 3.0 boundary of InchwormController, called in-process as a master calls it:
//! the timing contract, refused inputs and parameters, state round trips and corrupt
//! blobs, eight threads, the FMI 2.0 FMU's outputs bit for bit, and the committed
//! modelDescription.

use std::ffi::CString;
use std::sync::Mutex;

use inchworm_controller_fmu as fmu2;
use inchworm_controller_fmu3 as fmu;
use inchworm_fmi_export::fmi3::ffi::*;
use inchworm_fmi_export::fmi3::testing::log_callback;
use inchworm_fmi_export::testing::{callbacks, Log};
use inchworm_fmi_export::{ffi as fmi2, model_description};
use inchworm_fmu_models::ControllerFmu;

const ENCODER_COUNTS: u32 = 1;
const REFERENCE: u32 = 2;
const DAC_EARTH: u32 = 10;
const DAC_NONEARTH: u32 = 11;
const DAC_NONEARTH_CODE: u32 = 14;
const N_STEPS: u32 = 20;
const MOVING: u32 = 22;
const FEEDFORWARD: u32 = 100;
const SAMPLES_PER_STEP: u32 = 105;
const BASIS_PEAK_5: u32 = 124;
const H: f64 = 0.002;

fn token() -> CString {
    CString::new(model_description::guid::<ControllerFmu>()).unwrap()
}

struct I {
    c: fmi3Instance,
    log: Box<Log>,
}

unsafe impl Send for I {}

impl I {
    fn new(name: &str) -> I {
        let log = Box::new(Log(Mutex::new(Vec::new())));
        let (env, logger) = log_callback(&log);
        let name = CString::new(name).unwrap();
        let c = unsafe {
            fmu::fmi3InstantiateCoSimulation(
                name.as_ptr(),
                token().as_ptr(),
                std::ptr::null(),
                false,
                false,
                false,
                false,
                std::ptr::null(),
                0,
                env,
                logger,
                None,
            )
        };
        assert!(!c.is_null());
        I { c, log }
    }
    fn enter(&self) -> fmi3Status {
        unsafe { fmu::fmi3EnterInitializationMode(self.c, false, 0.0, 0.0, false, 0.0) }
    }
    fn exit(&self) -> fmi3Status {
        unsafe { fmu::fmi3ExitInitializationMode(self.c) }
    }
    fn init(name: &str) -> I {
        let i = I::new(name);
        assert_eq!(i.enter(), fmi3OK);
        assert_eq!(i.exit(), fmi3OK);
        i
    }
    fn set_real(&self, vr: u32, v: f64) -> fmi3Status {
        unsafe { fmu::fmi3SetFloat64(self.c, &vr, 1, &v, 1) }
    }
    fn set_integer(&self, vr: u32, v: i32) -> fmi3Status {
        unsafe { fmu::fmi3SetInt32(self.c, &vr, 1, &v, 1) }
    }
    fn set_boolean(&self, vr: u32, v: bool) -> fmi3Status {
        unsafe { fmu::fmi3SetBoolean(self.c, &vr, 1, &v, 1) }
    }
    fn real(&self, vr: u32) -> (fmi3Status, f64) {
        let mut v = f64::NAN;
        (unsafe { fmu::fmi3GetFloat64(self.c, &vr, 1, &mut v, 1) }, v)
    }
    fn integer(&self, vr: u32) -> (fmi3Status, i32) {
        let mut v = -1;
        (unsafe { fmu::fmi3GetInt32(self.c, &vr, 1, &mut v, 1) }, v)
    }
    fn boolean(&self, vr: u32) -> (fmi3Status, bool) {
        let mut v = [7u8];
        let s = unsafe { fmu::fmi3GetBoolean(self.c, &vr, 1, v.as_mut_ptr() as *mut bool, 1) };
        assert!(v[0] <= 1);
        (s, v[0] == 1)
    }
    fn step(&self, t: f64, h: f64) -> fmi3Status {
        let (mut ev, mut term, mut early, mut last) = (true, true, true, f64::NAN);
        let s = unsafe {
            fmu::fmi3DoStep(self.c, t, h, true, &mut ev, &mut term, &mut early, &mut last)
        };
        if s == fmi3OK {
            assert_eq!((ev, term, early, last), (false, false, false, t + h));
        }
        s
    }
    fn logged(&self) -> Vec<String> {
        self.log.0.lock().unwrap().clone()
    }
    fn saw(&self, status: fmi3Status, parts: &[&str]) -> bool {
        self.logged()
            .iter()
            .any(|m| m.starts_with(&format!("{status}|")) && parts.iter().all(|p| m.contains(p)))
    }
    fn serialize(&self) -> Vec<u8> {
        let mut s: fmi3FMUState = std::ptr::null_mut();
        let mut size = 0;
        unsafe {
            assert_eq!(fmu::fmi3GetFMUState(self.c, &mut s), fmi3OK);
            assert_eq!(fmu::fmi3SerializedFMUStateSize(self.c, s, &mut size), fmi3OK);
            let mut b = vec![0u8; size];
            assert_eq!(fmu::fmi3SerializeFMUState(self.c, s, b.as_mut_ptr(), size), fmi3OK);
            assert_eq!(fmu::fmi3FreeFMUState(self.c, &mut s), fmi3OK);
            b
        }
    }
    fn deserialize(&self, b: &[u8]) -> fmi3Status {
        let mut s: fmi3FMUState = std::ptr::null_mut();
        unsafe {
            let st = fmu::fmi3DeserializeFMUState(self.c, b.as_ptr(), b.len(), &mut s);
            if st != fmi3OK {
                return st;
            }
            let st = fmu::fmi3SetFMUState(self.c, s);
            assert_eq!(fmu::fmi3FreeFMUState(self.c, &mut s), fmi3OK);
            st
        }
    }
}

impl Drop for I {
    fn drop(&mut self) {
        unsafe { fmu::fmi3FreeInstance(self.c) };
    }
}

/// As the FMI 2.0 test: a synthetic encoder moving 2 nm per powered sample.
fn drive(h: &I, k0: usize, samples: usize) -> Vec<(i32, f64, i32)> {
    let mut out = Vec::new();
    let mut counts = 0;
    for k in k0..k0 + samples {
        assert_eq!(h.set_integer(ENCODER_COUNTS, counts), fmi3OK);
        assert_eq!(h.step(k as f64 * H, H), fmi3OK, "{:?}", h.logged());
        let (_, dac_n) = h.real(DAC_NONEARTH);
        counts += (dac_n > 5.0) as i32 * 2;
        out.push((h.integer(DAC_NONEARTH_CODE).1, h.real(DAC_EARTH).1, h.integer(N_STEPS).1));
    }
    out
}

#[test]
fn timing_contract_one_sample_delay_and_whole_samples_only() {
    let h = I::init("timing");
    assert_eq!(h.set_real(REFERENCE, 100e-6), fmi3OK);
    assert_eq!(h.real(DAC_NONEARTH), (fmi3OK, 0.0));
    assert_eq!(h.step(0.0, H), fmi3OK);
    assert_eq!(h.integer(N_STEPS), (fmi3OK, 3));
    assert_eq!(h.boolean(MOVING), (fmi3OK, true));
    assert_eq!(h.step(0.002, 0.024), fmi3OK, "12 samples in one call");
    assert_eq!(h.real(DAC_NONEARTH).1, 0.0, "sample 14");
    assert_eq!(h.step(0.026, H), fmi3OK);
    assert_eq!(h.real(DAC_NONEARTH).1, 10.0, "sample 15");
    assert_eq!(h.step(0.028, 0.003), fmi3Error);
    assert!(h.saw(fmi3Error, &["fmi3DoStep", "0.003", "2 ms"]), "{:?}", h.logged());
    assert_eq!(h.step(0.028, H), fmi3OK);
}

#[test]
fn bad_inputs_and_parameters_are_refused_with_a_message() {
    let h = I::init("inputs");
    assert_eq!(h.set_real(REFERENCE, 5e-6), fmi3OK);
    assert_eq!(h.set_real(REFERENCE, f64::NAN), fmi3Error);
    assert!(h.saw(fmi3Error, &["reference", "NaN", "keeping 0.000005"]), "{:?}", h.logged());
    assert_eq!(h.real(REFERENCE), (fmi3OK, 5e-6));
    assert_eq!(h.step(0.0, H), fmi3OK);
    assert_eq!(h.real(999).0, fmi3Error);
    assert_eq!(h.set_real(DAC_EARTH, 1.0), fmi3Error, "outputs cannot be set");
    assert_eq!(h.set_boolean(FEEDFORWARD, false), fmi3Error);
    assert_eq!(h.set_integer(REFERENCE, 1), fmi3Error, "a Float64 set as Int32");
    assert!(h.saw(fmi3Error, &["is Float64, not Int32"]));
    for (what, vr, real) in
        [("samples_per_step", SAMPLES_PER_STEP, false), ("basis_peak", BASIS_PEAK_5, true)]
    {
        let h = I::new("params");
        let s = if real { h.set_real(vr, 2e-6) } else { h.set_integer(vr, 3) };
        assert_eq!(s, fmi3OK);
        assert_eq!(h.enter(), fmi3OK);
        assert_eq!(h.exit(), fmi3Error);
        assert!(
            h.saw(fmi3Error, &["fmi3ExitInitializationMode", what]),
            "{what}: {:?}",
            h.logged()
        );
        assert_eq!(unsafe { fmu::fmi3Reset(h.c) }, fmi3OK);
    }
}

#[test]
fn state_round_trips_replay_bit_for_bit_and_corrupt_blobs_are_refused() {
    let a = I::init("a");
    assert_eq!(a.set_real(REFERENCE, 60e-6), fmi3OK);
    drive(&a, 0, 150);
    let bytes = a.serialize();
    let first = drive(&a, 150, 400);
    let b = I::new("b");
    assert_eq!(b.deserialize(&bytes), fmi3OK, "{:?}", b.logged());
    assert_eq!(drive(&b, 150, 400), first);
    let mut bad = bytes.clone();
    bad[10] ^= 0x20;
    assert_eq!(b.deserialize(&bad), fmi3Error);
    assert!(b.saw(fmi3Error, &["fmi3DeserializeFMUState"]));
}

#[test]
fn eight_instances_on_eight_threads_match_eight_serial_runs() {
    let refs = [10e-6, 20e-6, 35e-6, 50e-6, -10e-6, -30e-6, 70e-6, 5e-6];
    let go = |r: f64| {
        let h = I::init("t");
        assert_eq!(h.set_real(REFERENCE, r), fmi3OK);
        drive(&h, 0, 600)
    };
    let serial: Vec<_> = refs.iter().map(|&r| go(r)).collect();
    let threads: Vec<_> = refs.iter().map(|&r| std::thread::spawn(move || go(r))).collect();
    let parallel: Vec<_> = threads.into_iter().map(|t| t.join().unwrap()).collect();
    assert_eq!(serial, parallel);
    assert_ne!(serial[0], serial[5]);
}

#[test]
fn outputs_equal_the_fmi2_fmu_bit_for_bit() {
    let log = Log(Mutex::new(Vec::new()));
    let functions = callbacks(&log);
    let name = CString::new("fmi2").unwrap();
    let h = I::init("fmi3");
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
        assert!(!c2.is_null());
        assert_eq!(fmu2::fmi2SetupExperiment(c2, 0, 0.0, 0.0, 0, 0.0), 0);
        assert_eq!(fmu2::fmi2EnterInitializationMode(c2), 0);
        assert_eq!(fmu2::fmi2ExitInitializationMode(c2), 0);
        let r = 40e-6;
        assert_eq!(fmu2::fmi2SetReal(c2, &REFERENCE, 1, &r), 0);
        assert_eq!(h.set_real(REFERENCE, r), fmi3OK);
        let mut counts = 0;
        for k in 0..1500 {
            assert_eq!(fmu2::fmi2SetInteger(c2, &ENCODER_COUNTS, 1, &counts), 0);
            assert_eq!(h.set_integer(ENCODER_COUNTS, counts), fmi3OK);
            assert_eq!(fmu2::fmi2DoStep(c2, k as f64 * H, H, 1), 0);
            assert_eq!(h.step(k as f64 * H, H), fmi3OK);
            for vr in 10..=12 {
                let mut v2 = 0.0;
                assert_eq!(fmu2::fmi2GetReal(c2, &vr, 1, &mut v2), 0);
                assert_eq!(h.real(vr).1.to_bits(), v2.to_bits(), "vr {vr} at sample {k}");
            }
            for vr in [13, 14, 15, N_STEPS] {
                let mut v2 = 0;
                assert_eq!(fmu2::fmi2GetInteger(c2, &vr, 1, &mut v2), 0);
                assert_eq!(h.integer(vr), (fmi3OK, v2), "vr {vr} at sample {k}");
            }
            counts += (h.real(DAC_NONEARTH).1 > 5.0) as i32 * 2;
        }
        fmu2::fmi2FreeInstance(c2);
    }
}

#[test]
fn committed_model_description_matches_the_variable_table() {
    let path =
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../modelDescription/fmi3/InchwormController.xml");
    let committed = std::fs::read_to_string(path).unwrap();
    assert!(
        committed == inchworm_fmi_export::fmi3::model_description::model_description::<ControllerFmu>(),
        "{path} differs from the variable table: run `cargo run --release -p fmu-build` and commit modelDescription/fmi3/"
    );
}
