//! The `InchwormController` FMU's variable table: its inputs, outputs and clocks, each once
//! with its accessor, and the parameters declared on `inchworm_controller::Params`; the
//! model's identity and units.

use inchworm_controller::{Params, SAMPLE_PERIOD};
use inchworm_fmi_export::{Kind, ModelInfo, Unit, Var, Variable};

use super::ControllerFmu;

/// The value references of the two clocks, which the clocked rows name.
pub(super) const SAMPLE_CLOCK_VR: u32 = 5;
const GAIT_CLOCK_VR: u32 = 25;

const V: Option<&str> = Some("V");
const M: Option<&str> = Some("m");

#[rustfmt::skip]
inchworm_fmi_export::table!(ControllerFmu, pub(super) TABLE;
    {
    REFERENCE: Variable::input("reference", 2, 0.0, M, "Reference position of the runner").clocked_by(SAMPLE_CLOCK_VR).real(|m| m.reference, |m, x| m.reference = x),
    ENCODER_COUNTS: Variable::integer_input("encoder_counts", 1, 0, None, "Encoder reading of the plant (counts of q_enc)").clocked_by(SAMPLE_CLOCK_VR).integer(|m| m.encoder_counts, |m, x| m.encoder_counts = x),
    DAC_EARTH: Variable::output("dac_earth", 10, Kind::Real, V, "Earth-brake DAC volts to hold over the next 2 ms sample (16-bit quantized)").discrete().clocked_by(SAMPLE_CLOCK_VR).real_out(|m| m.with_sample(|s| s.dac[0])),
    DAC_NONEARTH: Variable::output("dac_nonearth", 11, Kind::Real, V, "Non-earth-brake DAC volts (16-bit quantized)").discrete().clocked_by(SAMPLE_CLOCK_VR).real_out(|m| m.with_sample(|s| s.dac[1])),
    DAC_EXTENSION: Variable::output("dac_extension", 12, Kind::Real, V, "Extension DAC volts (16-bit quantized)").discrete().clocked_by(SAMPLE_CLOCK_VR).real_out(|m| m.with_sample(|s| s.dac[2])),
    DAC_EARTH_CODE: Variable::output("dac_earth_code", 13, Kind::Integer, None, "16-bit DAC code (0-65535) of dac_earth").clocked_by(SAMPLE_CLOCK_VR).integer_out(|m| m.with_sample(|s| i32::from(s.codes[0]))),
    DAC_NONEARTH_CODE: Variable::output("dac_nonearth_code", 14, Kind::Integer, None, "16-bit DAC code (0-65535) of dac_nonearth").clocked_by(SAMPLE_CLOCK_VR).integer_out(|m| m.with_sample(|s| i32::from(s.codes[1]))),
    DAC_EXTENSION_CODE: Variable::output("dac_extension_code", 15, Kind::Integer, None, "16-bit DAC code (0-65535) of dac_extension").clocked_by(SAMPLE_CLOCK_VR).integer_out(|m| m.with_sample(|s| i32::from(s.codes[2]))),
    SERVO_ERROR: Variable::output("servo_error", 16, Kind::Real, M, "reference - encoder position").discrete().clocked_by(SAMPLE_CLOCK_VR).real_out(|m| m.with_sample(|s| s.servo_error)),
    DISTURBANCE_ESTIMATE: Variable::output("disturbance_estimate", 17, Kind::Real, M, "Kalman estimate of the brake disturbance per step").discrete().clocked_by(GAIT_CLOCK_VR).real_out(|m| m.with_sample(|s| s.disturbance_estimate)),
    STEP_FORWARD: Variable::output("step_forward", 18, Kind::Real, M, "Estimated full forward step (with the disturbance)").discrete().clocked_by(SAMPLE_CLOCK_VR).real_out(|m| m.with_sample(|s| s.step_forward)),
    STEP_BACKWARD: Variable::output("step_backward", 19, Kind::Real, M, "Estimated full backward step (negative)").discrete().clocked_by(SAMPLE_CLOCK_VR).real_out(|m| m.with_sample(|s| s.step_backward)),
    N_STEPS: Variable::output("n_steps", 20, Kind::Integer, None, "Full steps of the current move").clocked_by(SAMPLE_CLOCK_VR).integer_out(|m| m.with_sample(|s| s.n_steps.min(i32::MAX as u32) as i32)),
    FRACTION: Variable::output("fraction", 21, Kind::Real, None, "Amplitude of the current move's fractional step (-1..1)").discrete().clocked_by(SAMPLE_CLOCK_VR).real_out(|m| m.with_sample(|s| s.fraction)),
    MOVING: Variable::output("moving", 22, Kind::Boolean, None, "A step is being executed").clocked_by(SAMPLE_CLOCK_VR).boolean_out(|m| m.with_sample(|s| s.moving)),
    SCALE_WEIGHTS_1: Variable::output("scale_weights[1]", 30, Kind::Real, None, "Estimated inverse scale factor weight 1").discrete().array("Estimated inverse scale factor: the weights of the ten basis functions").clocked_by(GAIT_CLOCK_VR).real_out(|m| m.with_sample(|s| s.scale_weights[0])),
    SCALE_WEIGHTS_2: Variable::output("scale_weights[2]", 31, Kind::Real, None, "Estimated inverse scale factor weight 2").discrete().clocked_by(GAIT_CLOCK_VR).real_out(|m| m.with_sample(|s| s.scale_weights[1])),
    SCALE_WEIGHTS_3: Variable::output("scale_weights[3]", 32, Kind::Real, None, "Estimated inverse scale factor weight 3").discrete().clocked_by(GAIT_CLOCK_VR).real_out(|m| m.with_sample(|s| s.scale_weights[2])),
    SCALE_WEIGHTS_4: Variable::output("scale_weights[4]", 33, Kind::Real, None, "Estimated inverse scale factor weight 4").discrete().clocked_by(GAIT_CLOCK_VR).real_out(|m| m.with_sample(|s| s.scale_weights[3])),
    SCALE_WEIGHTS_5: Variable::output("scale_weights[5]", 34, Kind::Real, None, "Estimated inverse scale factor weight 5").discrete().clocked_by(GAIT_CLOCK_VR).real_out(|m| m.with_sample(|s| s.scale_weights[4])),
    SCALE_WEIGHTS_6: Variable::output("scale_weights[6]", 35, Kind::Real, None, "Estimated inverse scale factor weight 6").discrete().clocked_by(GAIT_CLOCK_VR).real_out(|m| m.with_sample(|s| s.scale_weights[5])),
    SCALE_WEIGHTS_7: Variable::output("scale_weights[7]", 36, Kind::Real, None, "Estimated inverse scale factor weight 7").discrete().clocked_by(GAIT_CLOCK_VR).real_out(|m| m.with_sample(|s| s.scale_weights[6])),
    SCALE_WEIGHTS_8: Variable::output("scale_weights[8]", 37, Kind::Real, None, "Estimated inverse scale factor weight 8").discrete().clocked_by(GAIT_CLOCK_VR).real_out(|m| m.with_sample(|s| s.scale_weights[7])),
    SCALE_WEIGHTS_9: Variable::output("scale_weights[9]", 38, Kind::Real, None, "Estimated inverse scale factor weight 9").discrete().clocked_by(GAIT_CLOCK_VR).real_out(|m| m.with_sample(|s| s.scale_weights[8])),
    SCALE_WEIGHTS_10: Variable::output("scale_weights[10]", 39, Kind::Real, None, "Estimated inverse scale factor weight 10").discrete().clocked_by(GAIT_CLOCK_VR).real_out(|m| m.with_sample(|s| s.scale_weights[9])),
    },
    fields(Params, 100),
    {
    SAMPLE_CLOCK: Variable::periodic_clock("sample_clock", SAMPLE_CLOCK_VR, SAMPLE_PERIOD, "The 2 ms sample: at each tick the controller writes the DAC sample of the inputs latched at the tick before and latches encoder_counts and reference (FMI 3.0)").clock_in(),
    GAIT_STEP: Variable::output_clock("gait_step", GAIT_CLOCK_VR, "Ticks at the sample that ends a gait step and updates the estimator: scale_weights and disturbance_estimate change only then (FMI 3.0)").clock_out(|m| m.gait_ticked),
    },
);

impl ControllerFmu {
    /// The DAC outputs (V), earth brake, non-earth brake, extension: the plant's
    /// `PlantFmu::DAC_INPUTS`.
    pub const DAC_OUTPUTS: [Var<ControllerFmu>; 3] =
        [Self::DAC_EARTH, Self::DAC_NONEARTH, Self::DAC_EXTENSION];
    /// The DAC codes of the same three channels.
    pub const DAC_CODES: [Var<ControllerFmu>; 3] =
        [Self::DAC_EARTH_CODE, Self::DAC_NONEARTH_CODE, Self::DAC_EXTENSION_CODE];
    /// The estimated inverse scale factor's ten weights, `scale_weights[1]` first.
    pub const SCALE_WEIGHTS: [Var<ControllerFmu>; 10] = [
        Self::SCALE_WEIGHTS_1,
        Self::SCALE_WEIGHTS_2,
        Self::SCALE_WEIGHTS_3,
        Self::SCALE_WEIGHTS_4,
        Self::SCALE_WEIGHTS_5,
        Self::SCALE_WEIGHTS_6,
        Self::SCALE_WEIGHTS_7,
        Self::SCALE_WEIGHTS_8,
        Self::SCALE_WEIGHTS_9,
        Self::SCALE_WEIGHTS_10,
    ];
}

pub(super) static UNITS: [Unit; 3] = [
    Unit { name: "m", kg: 0, m: 1, s: 0, a: 0 },
    Unit { name: "V", kg: 1, m: 2, s: -3, a: -1 },
    Unit { name: "m/V", kg: -1, m: -1, s: 3, a: 1 },
];

pub(super) static INFO: ModelInfo = ModelInfo {
    model_name: "InchwormController",
    model_identifier: "InchwormController",
    description: "JPL flight inchworm actuator controller: stepping gait, asynchronous compensator with prefilter and feedforward, Kalman estimator of the inverse scale factor and brake disturbance",
    version: env!("CARGO_PKG_VERSION"),
    default_start_time: 0.0,
    default_stop_time: 1.0,
    default_step_size: 0.002,
    default_tolerance: 1e-9,
    units: &UNITS,
    log_events: "Model events: control iterations (full steps, fraction, disturbance estimate)",
    documentation_html: include_str!("../controller.html"),
};
