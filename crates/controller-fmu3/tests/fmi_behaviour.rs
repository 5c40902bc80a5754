//! What is specific to the FMI 3.0 InchwormController: its outputs equal the FMI 2.0
//! FMU's bit for bit in a closed loop, its exported symbols are the generic entry points,
//! and its committed modelDescription. Every behaviour of the layer itself is tested once
//! for both standards in `crates/fmi-export/tests/behaviour.rs`.

use inchworm_controller_fmu3 as fmu;
use inchworm_fmi_export::fmi3::api::Fmi3;
use inchworm_fmi_export::fmi3::ffi::*;
use inchworm_fmi_export::testing::Harness;
use inchworm_fmu_models::ControllerFmu;

const H: f64 = 0.002;

#[test]
fn outputs_equal_the_fmi2_fmu_bit_for_bit() {
    let two = Harness::<ControllerFmu>::init("fmi2");
    let three = Harness::<ControllerFmu, Fmi3>::init("fmi3");
    let r = 40e-6;
    assert_eq!(
        (
            two.set_real(ControllerFmu::REFERENCE.vr(), r),
            three.set_real(ControllerFmu::REFERENCE.vr(), r)
        ),
        (0, 0)
    );
    let mut counts = 0;
    for k in 0..1500 {
        assert_eq!(
            (
                two.set_integer(ControllerFmu::ENCODER_COUNTS.vr(), counts),
                three.set_integer(ControllerFmu::ENCODER_COUNTS.vr(), counts)
            ),
            (0, 0)
        );
        assert_eq!((two.step(k as f64 * H, H), three.step(k as f64 * H, H)), (0, 0));
        for var in ControllerFmu::DAC_OUTPUTS {
            let (vr, name) = (var.vr(), var.name());
            assert_eq!(
                three.real(vr).1.to_bits(),
                two.real(vr).1.to_bits(),
                "{name} at sample {k}"
            );
        }
        for var in [
            ControllerFmu::DAC_EARTH_CODE,
            ControllerFmu::DAC_NONEARTH_CODE,
            ControllerFmu::DAC_EXTENSION_CODE,
            ControllerFmu::N_STEPS,
        ] {
            let (vr, name) = (var.vr(), var.name());
            assert_eq!(three.integer(vr), two.integer(vr), "{name} at sample {k}");
        }
        counts += (three.real(ControllerFmu::DAC_NONEARTH.vr()).1 > 5.0) as i32 * 2;
    }
    assert_ne!(counts, 0, "the loop moved");
}

#[test]
fn the_exported_symbols_drive_the_same_instance_as_the_generic_entry_points() {
    let h = Harness::<ControllerFmu, Fmi3>::init("exported");
    let r = 100e-6;
    unsafe {
        assert_eq!(fmu::fmi3SetFloat64(h.c, &ControllerFmu::REFERENCE.vr(), 1, &r, 1), fmi3OK);
        let (mut ev, mut term, mut early, mut last) = (true, true, true, f64::NAN);
        assert_eq!(
            fmu::fmi3DoStep(h.c, 0.0, H, true, &mut ev, &mut term, &mut early, &mut last),
            fmi3OK
        );
        assert_eq!((ev, term, early, last), (false, false, false, H));
        // Any step size: 3 ms from 2 ms reaches the instant at 4 ms.
        assert_eq!(
            fmu::fmi3DoStep(h.c, H, 0.003, true, &mut ev, &mut term, &mut early, &mut last),
            fmi3OK
        );
        assert_eq!((ev, term, early, last), (false, false, false, H + 0.003));
        assert_eq!(
            fmu::fmi3DoStep(h.c, H + 0.003, -1.0, true, &mut ev, &mut term, &mut early, &mut last),
            fmi3Error
        );
    }
    assert_eq!(h.integer(ControllerFmu::N_STEPS.vr()), (0, 3));
    assert!(h.saw(fmi3Error, &["fmi3DoStep", "must be finite and > 0"]), "{:?}", h.logged());
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
