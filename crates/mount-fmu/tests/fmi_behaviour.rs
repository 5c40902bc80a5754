//! The FMI boundary of InchwormMount: piston, tip and tilt of three positions 120° apart,
//! the inverse used for commands, refused parameters, state round trips, and the committed
//! modelDescription.

use inchworm_fmi_export::ffi::*;
use inchworm_fmi_export::model_description;
use inchworm_fmi_export::testing::Harness;
use inchworm_fmi_export::Var;
use inchworm_fmu_models::mount::{actuator_positions, pose, ANGLE_A_DEG, RADIUS};
use inchworm_fmu_models::MountFmu;

type H = Harness<MountFmu>;

/// The three actuators' positions, a, b, c.
const POSITIONS: [Var<MountFmu>; 3] =
    [MountFmu::POSITION_A, MountFmu::POSITION_B, MountFmu::POSITION_C];

/// Sets the positions before step `k` and takes it: the outputs then hold the pose of the
/// positions that held during the step.
fn set_positions(h: &H, k: usize, z: [f64; 3]) {
    for (var, z) in POSITIONS.iter().zip(z) {
        assert_eq!(h.set_real(var.vr(), z), fmi2OK);
    }
    assert_eq!(
        h.real(MountFmu::PISTON.vr()).1,
        h.real(MountFmu::PISTON.vr()).1,
        "unchanged until the step"
    );
    assert_eq!(h.step(k as f64 * 0.002, 0.002), fmi2OK);
}

#[test]
fn piston_tip_and_tilt_of_three_positions() {
    let h = H::init("mount");
    // All three equal: pure piston.
    set_positions(&h, 0, [30e-6; 3]);
    assert!((h.real(MountFmu::PISTON.vr()).1 - 30e-6).abs() < 1e-18);
    assert!(
        h.real(MountFmu::TIP.vr()).1.abs() < 1e-15 && h.real(MountFmu::TILT.vr()).1.abs() < 1e-15
    );
    // Actuator a (on +y, 50 mm) up by 0.3 um, b and c (at y = -R/2) down 0.15: tip 6 urad.
    set_positions(&h, 1, [0.3e-6, -0.15e-6, -0.15e-6]);
    assert!(h.real(MountFmu::PISTON.vr()).1.abs() < 1e-20);
    assert!(
        (h.real(MountFmu::TIP.vr()).1 - 0.3e-6 / RADIUS).abs() < 1e-15,
        "{}",
        h.real(MountFmu::TIP.vr()).1
    );
    assert!(h.real(MountFmu::TILT.vr()).1.abs() < 1e-15);
    // b (210 deg) and c (330 deg) opposite: tilt about y, x_c - x_b = R sqrt 3.
    set_positions(&h, 2, [0.0, -1e-6, 1e-6]);
    assert!((h.real(MountFmu::TILT.vr()).1 - 2e-6 / (RADIUS * 3f64.sqrt())).abs() < 1e-15);
    assert!(h.real(MountFmu::TIP.vr()).1.abs() < 1e-15);
    // Sample and hold: new positions show after the next step only.
    assert_eq!(h.set_real(MountFmu::POSITION_A.vr(), 1.0), fmi2OK);
    assert!(
        h.real(MountFmu::TILT.vr()).1 > 0.0 && h.real(MountFmu::PISTON.vr()).1.abs() < 1e-18,
        "still the held pose"
    );
}

#[test]
fn the_offset_is_the_pose_with_the_runners_at_zero() {
    let h = H::new("offset");
    assert_eq!((h.setup(), h.enter()), (fmi2OK, fmi2OK));
    let offset = [-7.5e-6, 3e-6, -4.25e-6];
    let offsets = [MountFmu::PISTON_OFFSET, MountFmu::TIP_OFFSET, MountFmu::TILT_OFFSET];
    let outputs = [MountFmu::PISTON, MountFmu::TIP, MountFmu::TILT];
    for (var, x) in offsets.iter().zip(offset) {
        assert_eq!(h.set_real(var.vr(), x), fmi2OK);
    }
    assert_eq!(h.exit(), fmi2OK);
    // Before any step, the runners at zero: the pose is the offset, exactly.
    assert_eq!(outputs.map(|v| h.real(v.vr()).1), offset);
    // The runners' kinematics add to it: the positions that undo the offset bring the
    // optic to zero (within rounding).
    let z = actuator_positions(-offset[0], -offset[1], -offset[2], RADIUS, ANGLE_A_DEG);
    set_positions(&h, 0, z);
    for v in outputs {
        assert!(h.real(v.vr()).1.abs() < 1e-18, "{}: {}", v.name(), h.real(v.vr()).1);
    }
}

#[test]
fn actuator_positions_invert_the_pose() {
    for (p, tip, tilt) in [(30e-6, 4e-6, 0.0), (-5e-6, -2e-6, 7e-6), (0.0, 0.0, 1e-6)] {
        let z = actuator_positions(p, tip, tilt, RADIUS, ANGLE_A_DEG);
        let [p2, tip2, tilt2] = pose(z, RADIUS, ANGLE_A_DEG);
        assert!(
            (p - p2).abs() < 1e-18 && (tip - tip2).abs() < 1e-15 && (tilt - tilt2).abs() < 1e-15
        );
    }
}

#[test]
fn bad_values_are_refused() {
    let h = H::new("params");
    assert_eq!((h.setup(), h.enter()), (fmi2OK, fmi2OK));
    assert_eq!(h.set_real(MountFmu::RADIUS.vr(), 0.0), fmi2OK);
    assert_eq!(h.exit(), fmi2Error);
    assert!(
        h.saw(fmi2Error, &["fmi2ExitInitializationMode", MountFmu::RADIUS.name()]),
        "{:?}",
        h.logged()
    );
    let h = H::init("inputs");
    assert_eq!(h.set_real(MountFmu::POSITION_A.vr(), f64::NAN), fmi2Error);
    assert_eq!(h.set_real(MountFmu::TIP.vr(), 1.0), fmi2Error, "outputs cannot be set");
}

#[test]
fn state_round_trips() {
    let a = H::init("a");
    set_positions(&a, 0, [1e-6, 2e-6, 4e-6]);
    let bytes = a.serialize();
    let b = H::new("b");
    assert_eq!(b.deserialize(&bytes), fmi2OK, "{:?}", b.logged());
    for vr in [MountFmu::PISTON, MountFmu::TIP, MountFmu::TILT].map(Var::vr) {
        assert_eq!(b.real(vr), a.real(vr));
    }
}

#[test]
fn committed_model_description_matches_the_variable_table() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../modelDescription/InchwormMount.xml");
    let committed = std::fs::read_to_string(path).unwrap_or_default();
    assert!(
        committed == model_description::model_description::<MountFmu>(),
        "{path} differs from the variable table: run `cargo run --release -p fmu-build` and commit modelDescription/"
    );
}
