//! The kinematics of a three-actuator mirror mount (the `InchwormMount` FMU's, which
//! re-exports these, and the segmented mirror's in `inchworm-phasing`): three runners push the optic at points 120° apart on a circle of
//! radius `radius`, actuator a at `angle_a` from the x axis; for small angles the optic's
//! plane is `z(x, y) = piston + tip y + tilt x`.

/// The mount's default geometry: 50 mm radius, actuator a on the +y axis.
pub const RADIUS: f64 = 0.05;
pub const ANGLE_A_DEG: f64 = 90.0;

/// The angles of the three actuators (rad).
pub fn angles(angle_a_deg: f64) -> [f64; 3] {
    std::array::from_fn(|i| (angle_a_deg + 120.0 * i as f64).to_radians())
}

/// Piston, tip and tilt of three positions.
pub fn pose(z: [f64; 3], radius: f64, angle_a_deg: f64) -> [f64; 3] {
    let phi = angles(angle_a_deg);
    let k = 2.0 / (3.0 * radius);
    let piston = (z[0] + z[1] + z[2]) / 3.0;
    let tip = k * (0..3).map(|i| z[i] * phi[i].sin()).sum::<f64>();
    let tilt = k * (0..3).map(|i| z[i] * phi[i].cos()).sum::<f64>();
    [piston, tip, tilt]
}

/// The three positions that give `piston`, `tip` and `tilt`.
pub fn actuator_positions(
    piston: f64,
    tip: f64,
    tilt: f64,
    radius: f64,
    angle_a_deg: f64,
) -> [f64; 3] {
    let phi = angles(angle_a_deg);
    std::array::from_fn(|i| piston + radius * (tip * phi[i].sin() + tilt * phi[i].cos()))
}
