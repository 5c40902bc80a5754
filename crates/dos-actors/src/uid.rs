//! The unique identifiers (UIDs) of the inchworm's signals: one type per signal, its data
//! type the FMU variable's (Real `f64`, Integer `i32`), and a const parameter `ID`, the
//! actuator's chain (0, 1, 2 for a mount's a, b, c), so three actuators' encoders are three
//! channels. [`FmiName`] gives each the name of the FMU variable it is, taken from the
//! FMUs' variable tables (`C::name_of(C::DAC_EARTH)`), which [`crate::FmuClient`]
//! resolves in the FMU's `modelDescription.xml`.

use inchworm_fmu_models::{ControllerFmu as C, MountFmu, PlantFmu as P};
use interface::UniqueIdentifier;

/// The FMU variable a UID stands for (a client may map it to another name:
/// [`crate::FmuClient::rename`]).
pub trait FmiName {
    const NAME: &'static str;
}

macro_rules! chain_uid {
    ($($(#[$doc:meta])* $uid:ident: $ty:ty = $name:expr;)+) => {$(
        $(#[$doc])*
        pub enum $uid<const ID: u8> {}
        impl<const ID: u8> UniqueIdentifier for $uid<ID> {
            type DataType = $ty;
        }
        impl<const ID: u8> FmiName for $uid<ID> {
            const NAME: &'static str = $name;
        }
        $crate::fmu_io!(@one [const ID: u8] $uid<ID>);
    )+};
}

chain_uid! {
    /// Reference position of the runner (m): the controller's input.
    Reference: f64 = C::name_of(C::REFERENCE);
    /// Earth-brake DAC volts, 16-bit quantized, held over the next 2 ms sample.
    DacEarth: f64 = C::name_of(C::DAC_EARTH);
    /// Non-earth-brake DAC volts.
    DacNonearth: f64 = C::name_of(C::DAC_NONEARTH);
    /// Extension DAC volts.
    DacExtension: f64 = C::name_of(C::DAC_EXTENSION);
    /// The 16-bit code (0-65535) of the earth-brake DAC.
    DacEarthCode: i32 = C::name_of(C::DAC_EARTH_CODE);
    /// The 16-bit code of the non-earth-brake DAC.
    DacNonearthCode: i32 = C::name_of(C::DAC_NONEARTH_CODE);
    /// The 16-bit code of the extension DAC.
    DacExtensionCode: i32 = C::name_of(C::DAC_EXTENSION_CODE);
    /// Encoder reading (counts of 1.2 nm): the plant's output, the controller's input.
    EncoderCounts: i32 = P::name_of(P::ENCODER_COUNTS);
    /// True runner position (m).
    RunnerPosition: f64 = P::name_of(P::RUNNER_POSITION);
    /// Reference minus encoder position (m).
    ServoError: f64 = C::name_of(C::SERVO_ERROR);
    /// The Kalman estimate of the brake disturbance per step (m).
    DisturbanceEstimate: f64 = C::name_of(C::DISTURBANCE_ESTIMATE);
    /// The estimated full forward step, disturbance included (m).
    StepForward: f64 = C::name_of(C::STEP_FORWARD);
    /// The estimated full backward step (m, negative).
    StepBackward: f64 = C::name_of(C::STEP_BACKWARD);
}

macro_rules! mount_uid {
    ($($(#[$doc:meta])* $uid:ident = $name:expr;)+) => {$(
        $(#[$doc])*
        pub enum $uid {}
        impl UniqueIdentifier for $uid {
            type DataType = f64;
        }
        impl FmiName for $uid {
            const NAME: &'static str = $name;
        }
        $crate::fmu_io!($uid);
    )+};
}

mount_uid! {
    /// Piston of the optic: the mean of the three runner positions (m).
    Piston = MountFmu::name_of(MountFmu::PISTON);
    /// Tip of the optic: rotation about x (rad).
    Tip = MountFmu::name_of(MountFmu::TIP);
    /// Tilt of the optic: rotation about y (rad).
    Tilt = MountFmu::name_of(MountFmu::TILT);
}

/// The mount input each chain's runner position feeds: `position_a`, `_b`, `_c`.
pub const MOUNT_INPUTS: [&str; 3] = [
    MountFmu::name_of(MountFmu::POSITION_A),
    MountFmu::name_of(MountFmu::POSITION_B),
    MountFmu::name_of(MountFmu::POSITION_C),
];
