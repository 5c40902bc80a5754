//! The `InchwormMount` FMU: the kinematics of a three-actuator mirror mount. Three inchworm
//! runners push the optic at points 120° apart on a circle of radius `radius`; for small
//! angles the optic's plane is `z(x, y) = piston + tip y + tilt x`, so from the three
//! runner positions `z_i` at angles `φ_i = angle_a + 120° i`:
//!
//! * `piston = (z_a + z_b + z_c) / 3`,
//! * `tip = 2 / (3 R) Σ z_i sin φ_i` (rad, rotation about x),
//! * `tilt = 2 / (3 R) Σ z_i cos φ_i` (rad, rotation about y),
//!
//! exact for three points 120° apart, plus the optic's pose with the three runners at zero
//! (`piston_offset`, `tip_offset`, `tilt_offset`: where the optic sits before any actuator
//! has moved, such as a segment's initial error; zero by default). The outputs are a sample and hold: after
//! `fmi2DoStep(t, h)` they are the pose of the positions that held during the step (set
//! before it), and before the first step that of the positions at initialization. So
//! every master shows the same pose at a communication point whether it transfers the
//! connections before or right after its steps (the inchworm master and FMPy before;
//! Ecos and libcosim after): the pose of the runners one step (2 ms) earlier.
//! [`actuator_positions`] is the inverse, for commands.

use inchworm_fmi_export::{Kind, Model, ModelInfo, Reader, Row, StepLog, Unit, Variable, Writer};

/// The kinematics, plain Rust in `inchworm-mount` (which the segmented mirror's loops in
/// `inchworm-phasing` share): the default geometry, the pose of three positions and its inverse.
pub use inchworm_mount::{actuator_positions, angles, pose, ANGLE_A_DEG, RADIUS};

/// The mirror mount's command, which `fmu-build` writes into `MirrorMount.ssp` and the
/// segmented mirrors (each reference's default binding) and `inchworm scenario mirror`
/// measures against: piston from t = 0, the tip on top of it from [`MIRROR_TIP_TIME`].
pub const MIRROR_PISTON: f64 = 30e-6;
pub const MIRROR_TIP: f64 = 4e-6;
pub const MIRROR_TIP_TIME: f64 = 4.0;

const M: Option<&str> = Some("m");
const RAD: Option<&str> = Some("rad");

#[rustfmt::skip]
inchworm_fmi_export::table!(MountFmu, TABLE;
    POSITION_A: Variable::input("position_a", 1, 0.0, M, "Runner position of actuator a (at angle_a)").real(|m| m.z[0], |m, x| m.z[0] = x),
    POSITION_B: Variable::input("position_b", 2, 0.0, M, "Runner position of actuator b (at angle_a + 120 deg)").real(|m| m.z[1], |m, x| m.z[1] = x),
    POSITION_C: Variable::input("position_c", 3, 0.0, M, "Runner position of actuator c (at angle_a + 240 deg)").real(|m| m.z[2], |m, x| m.z[2] = x),
    PISTON: Variable::output("piston", 10, Kind::Real, M, "Piston of the optic: the mean of the three positions").real_out(|m| m.held[0]),
    TIP: Variable::output("tip", 11, Kind::Real, RAD, "Tip of the optic: rotation about x, dz/dy").real_out(|m| m.held[1]),
    TILT: Variable::output("tilt", 12, Kind::Real, RAD, "Tilt of the optic: rotation about y, dz/dx").real_out(|m| m.held[2]),
    RADIUS: Variable::parameter("radius", 100, RADIUS, M, "Radius of the circle of the three actuators").with_range(1e-4, 10.0).real(|m| m.radius, |m, x| m.radius = x),
    ANGLE_A: Variable::parameter("angle_a", 101, ANGLE_A_DEG, Some("deg"), "Angle of actuator a from the x axis").real(|m| m.angle_a, |m, x| m.angle_a = x),
    PISTON_OFFSET: Variable::parameter("piston_offset", 102, 0.0, M, "Piston of the optic with the three runners at zero (its initial error)").with_range(-1.0, 1.0).real(|m| m.offset[0], |m, x| m.offset[0] = x),
    TIP_OFFSET: Variable::parameter("tip_offset", 103, 0.0, RAD, "Tip of the optic with the three runners at zero").with_range(-1.0, 1.0).real(|m| m.offset[1], |m, x| m.offset[1] = x),
    TILT_OFFSET: Variable::parameter("tilt_offset", 104, 0.0, RAD, "Tilt of the optic with the three runners at zero").with_range(-1.0, 1.0).real(|m| m.offset[2], |m, x| m.offset[2] = x),
);

static UNITS: [Unit; 3] = [
    Unit { name: "m", kg: 0, m: 1, s: 0, a: 0 },
    Unit { name: "rad", kg: 0, m: 0, s: 0, a: 0 },
    Unit { name: "deg", kg: 0, m: 0, s: 0, a: 0 },
];

static INFO: ModelInfo = ModelInfo {
    model_name: "InchwormMount",
    model_identifier: "InchwormMount",
    description: "Three-actuator mirror mount kinematics: three inchworm runner positions 120 deg apart to the piston, tip and tilt of the optic",
    version: env!("CARGO_PKG_VERSION"),
    default_start_time: 0.0,
    default_stop_time: 10.0,
    default_step_size: 0.002,
    default_tolerance: 1e-9,
    units: &UNITS,
    log_events: "Model events: none",
    documentation_html: include_str!("mount.html"),
};

#[derive(Clone, Debug)]
pub struct MountFmu {
    z: [f64; 3],
    /// Piston, tip and tilt latched at the last step (or initialization).
    held: [f64; 3],
    /// The optic's piston, tip and tilt with the runners at zero.
    offset: [f64; 3],
    radius: f64,
    angle_a: f64,
}

impl MountFmu {
    /// The optic's pose of the runner positions: the offset plus their kinematics.
    fn pose(&self) -> [f64; 3] {
        let p = pose(self.z, self.radius, self.angle_a);
        std::array::from_fn(|i| self.offset[i] + p[i])
    }
}

impl Model for MountFmu {
    fn info() -> &'static ModelInfo {
        &INFO
    }

    fn table() -> &'static [Row<Self>] {
        &TABLE
    }

    fn new() -> Self {
        MountFmu {
            z: [0.0; 3],
            held: [0.0; 3],
            offset: [0.0; 3],
            radius: RADIUS,
            angle_a: ANGLE_A_DEG,
        }
    }

    fn exit_initialization(&mut self, _start_time: f64) -> Result<(), String> {
        if !(1e-4..=10.0).contains(&self.radius) {
            return Err(format!("invalid parameter radius: {} m (1e-4 to 10 m)", self.radius));
        }
        self.held = self.pose();
        Ok(())
    }

    fn do_step(&mut self, _t: f64, _h: f64, _log: &mut StepLog) -> Result<(), String> {
        self.held = self.pose();
        Ok(())
    }

    fn save_state(&self, w: &mut Writer) {
        self.z.iter().chain(&self.held).for_each(|z| w.f64(*z));
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        let mut r = Reader::new(bytes, "mount FMU state");
        for z in self.z.iter_mut().chain(self.held.iter_mut()) {
            *z = r.f64()?;
        }
        r.finish()
    }
}
