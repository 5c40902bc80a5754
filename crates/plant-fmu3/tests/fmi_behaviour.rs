//! What is specific to the FMI 3.0 InchwormPlant: its outputs equal the FMI 2.0 FMU's bit
//! for bit on the passive check trace, a state serialized by the FMI 2.0 FMU continues in
//! it, and its committed modelDescription. The FMI 3.0 side is called through the symbols
//! `export_fmi3!` exported (in-process, through the rlib); every behaviour of the layer
//! itself is tested once for both standards in `crates/fmi-export/tests/behaviour.rs`.

use std::ffi::CString;
use std::sync::Mutex;

use inchworm_fmi_export::fmi3::ffi::*;
use inchworm_fmi_export::fmi3::testing::log_callback;
use inchworm_fmi_export::model_description;
use inchworm_fmi_export::testing::{Harness, Log};
use inchworm_fmu_models::PlantFmu;
use inchworm_plant_fmu3 as fmu;

const H: f64 = 0.002;

/// An instance behind the exported `fmi3*` symbols.
struct Exported {
    c: fmi3Instance,
    log: Box<Log>,
}

impl Exported {
    fn init(name: &str) -> Exported {
        let log = Box::new(Log(Mutex::new(Vec::new())));
        let (env, logger) = log_callback(&log);
        let (name, token) = (
            CString::new(name).unwrap(),
            CString::new(model_description::guid::<PlantFmu>()).unwrap(),
        );
        let null = std::ptr::null();
        let c = unsafe {
            fmu::fmi3InstantiateCoSimulation(
                name.as_ptr(),
                token.as_ptr(),
                null,
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
        assert!(!c.is_null(), "{:?}", log.0.lock().unwrap());
        unsafe {
            assert_eq!(fmu::fmi3EnterInitializationMode(c, false, 0.0, 0.0, false, 0.0), fmi3OK);
            assert_eq!(fmu::fmi3ExitInitializationMode(c), fmi3OK);
        }
        Exported { c, log }
    }
    fn set_real(&self, vr: u32, v: f64) -> fmi3Status {
        unsafe { fmu::fmi3SetFloat64(self.c, &vr, 1, &v, 1) }
    }
    fn real(&self, vr: u32) -> (fmi3Status, f64) {
        let mut v = f64::NAN;
        (unsafe { fmu::fmi3GetFloat64(self.c, &vr, 1, &mut v, 1) }, v)
    }
    fn integer(&self, vr: u32) -> (fmi3Status, i32) {
        let mut v = i32::MIN;
        (unsafe { fmu::fmi3GetInt32(self.c, &vr, 1, &mut v, 1) }, v)
    }
    fn step(&self, t: f64, h: f64) -> fmi3Status {
        let (mut ev, mut term, mut early, mut last) = (true, true, true, f64::NAN);
        let s = unsafe {
            fmu::fmi3DoStep(self.c, t, h, true, &mut ev, &mut term, &mut early, &mut last)
        };
        assert_eq!((ev, early), (false, false));
        s
    }
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

impl Drop for Exported {
    fn drop(&mut self) {
        unsafe { fmu::fmi3FreeInstance(self.c) };
    }
}

/// A state of the FMI 2.0 plant is refused by the FMI 3.0 plant, by name: the payload is
/// the same, the states around it are not (a restored FMI 2.0 state gave the FMI 3.0
/// plant another next event time), and the refused instance runs on as it was.
#[test]
fn a_state_serialized_by_the_fmi2_fmu_is_refused_by_the_fmi3_fmu() {
    let two = Harness::<PlantFmu>::init("fmi2");
    assert_eq!(two.set_real(PlantFmu::var(inchworm_fmu_models::Dac::EXTENSION).vr(), 10.0), 0);
    for k in 0..20 {
        assert_eq!(two.step(k as f64 * H, H), 0);
    }
    let blob = two.serialize();
    let three = Exported::init("from-fmi2");
    let alone = Exported::init("alone");
    assert_eq!(three.deserialize(&blob), fmi3Error);
    let log = three.log.0.lock().unwrap().join("\n");
    assert!(
        log.contains("saved by the FMI 2.0 build of InchwormPlant, this is its FMI 3.0 build"),
        "{log}"
    );
    for k in 0..20 {
        assert_eq!((three.step(k as f64 * H, H), alone.step(k as f64 * H, H)), (fmi3OK, fmi3OK));
        let runner = |e: &Exported| e.real(PlantFmu::RUNNER_POSITION.vr()).1.to_bits();
        assert_eq!(runner(&three), runner(&alone));
    }
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
    let two = Harness::<PlantFmu>::init("fmi2");
    let three = Exported::init("fmi3");
    let mut worst = 0;
    for (k, r) in rows.iter().enumerate() {
        let t = k as f64 * H;
        for (var, v) in [
            (PlantFmu::var(inchworm_fmu_models::Dac::EARTH), r[1]),
            (PlantFmu::var(inchworm_fmu_models::Dac::NONEARTH), r[2]),
            (PlantFmu::var(inchworm_fmu_models::Dac::EXTENSION), r[3]),
        ] {
            let vr = var.vr();
            assert_eq!((two.set_real(vr, v), three.set_real(vr, v)), (0, fmi3OK));
        }
        assert_eq!((two.step(t, H), three.step(t, H)), (0, fmi3OK));
        let counts = two.integer(PlantFmu::ENCODER_COUNTS.vr());
        assert_eq!(three.integer(PlantFmu::ENCODER_COUNTS.vr()), counts, "encoder at sample {k}");
        assert_eq!(
            three.integer(PlantFmu::MODE.vr()),
            two.integer(PlantFmu::MODE.vr()),
            "mode at sample {k}"
        );
        for var in PlantFmu::REAL_OUTPUTS {
            assert_eq!(
                three.real(var.vr()).1.to_bits(),
                two.real(var.vr()).1.to_bits(),
                "{} at sample {k}",
                var.name()
            );
        }
        worst = worst.max((counts.1 - r[4] as i32).abs());
    }
    assert!(worst <= 1, "the check trace is held within 1 count, as for FMI 2.0");
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
