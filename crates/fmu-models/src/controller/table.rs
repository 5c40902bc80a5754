//! The `InchwormController` FMU's variable table: every variable once, with its accessor;
//! the model's identity and units.

use inchworm_board::ENCODER_RESOLUTION;
use inchworm_controller::{CALIBRATED_DISTURBANCE, CALIBRATED_WEIGHTS, SAMPLE_PERIOD};
use inchworm_fmi_export::{Kind, ModelInfo, Unit, Var, Variable};

use super::ControllerFmu;

/// The value references of the two clocks, which the clocked rows name.
pub(super) const SAMPLE_CLOCK_VR: u32 = 5;
const GAIT_CLOCK_VR: u32 = 25;

const V: Option<&str> = Some("V");
const M: Option<&str> = Some("m");

#[rustfmt::skip]
inchworm_fmi_export::table!(ControllerFmu, pub(super) TABLE;
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
    FEEDFORWARD: Variable::boolean_parameter("feedforward", 100, true, "Feed the reference increment forward (feedback sees it one iteration later)").boolean(|m| m.params.feedforward, |m, x| m.params.feedforward = x),
    PREFILTER: Variable::boolean_parameter("prefilter", 101, false, "Prefilter the reference").boolean(|m| m.params.prefilter, |m, x| m.params.prefilter = x),
    USE_SCALE_FACTOR_ESTIMATE: Variable::boolean_parameter("use_scale_factor_estimate", 102, true, "Use the estimated inverse scale factor (else scale_weights_start)").boolean(|m| m.params.use_scale_factor_estimate, |m, x| m.params.use_scale_factor_estimate = x),
    USE_DISTURBANCE_ESTIMATE: Variable::boolean_parameter("use_disturbance_estimate", 103, true, "Use the estimated brake disturbance (else 0)").boolean(|m| m.params.use_disturbance_estimate, |m, x| m.params.use_disturbance_estimate = x),
    DEADBAND: Variable::parameter("deadband", 104, 0.0, M, "No step while |reference - position| is below this (0 = always step)").real(|m| m.params.deadband, |m, x| m.params.deadband = x),
    SAMPLES_PER_STEP: Variable::integer_parameter("samples_per_step", 105, 100, None, "Samples of 2 ms per step (7..10000)").integer(|m| m.params.samples_per_step as i32, |m, x| m.params.samples_per_step = x.max(0) as u32),
    COMPENSATOR_GAIN: Variable::parameter("compensator_gain", 106, 0.36, None, "K of C(z) = K (z - a)/(z - 1)").real(|m| m.params.gains.k, |m, x| m.params.gains.k = x),
    COMPENSATOR_ZERO: Variable::parameter("compensator_zero", 107, 0.8, None, "a of C(z) = K (z - a)/(z - 1)").real(|m| m.params.gains.a, |m, x| m.params.gains.a = x),
    PREFILTER_POLE: Variable::parameter("prefilter_pole", 108, 0.8, None, "Prefilter r_f <- p r_f + (1 - p) r").real(|m| m.params.gains.prefilter_pole, |m, x| m.params.gains.prefilter_pole = x),
    WEIGHT_PRIOR: Variable::parameter("weight_prior", 109, 0.05, None, "Prior 1-sigma of each scale-factor weight").real(|m| m.params.noise.weight_prior, |m, x| m.params.noise.weight_prior = x),
    DISTURBANCE_PRIOR: Variable::parameter("disturbance_prior", 110, 5e-6, M, "Prior 1-sigma of the disturbance").real(|m| m.params.noise.disturbance_prior, |m, x| m.params.noise.disturbance_prior = x),
    WEIGHT_PROCESS_NOISE: Variable::parameter("weight_process_noise", 111, 1e-3, None, "Process noise of the weights per sqrt(s)").real(|m| m.params.noise.weight_process, |m, x| m.params.noise.weight_process = x),
    DISTURBANCE_PROCESS_NOISE: Variable::parameter("disturbance_process_noise", 112, 0.1e-6, M, "Process noise of the disturbance per sqrt(s)").real(|m| m.params.noise.disturbance_process, |m, x| m.params.noise.disturbance_process = x),
    EXT_CMD_NOISE: Variable::parameter("ext_cmd_noise", 113, 5e-3, None, "Measurement noise of EXT_cmd").real(|m| m.params.noise.ext_cmd_measurement, |m, x| m.params.noise.ext_cmd_measurement = x),
    BD_NOISE: Variable::parameter("bd_noise", 114, 0.05e-6, M, "Measurement noise of BD").real(|m| m.params.noise.bd_measurement, |m, x| m.params.noise.bd_measurement = x),
    Q_ENC: Variable::parameter("q_enc", 115, ENCODER_RESOLUTION, M, "Encoder resolution per count").real(|m| m.params.q_enc, |m, x| m.params.q_enc = x),
    DISTURBANCE_START: Variable::parameter("disturbance_start", 116, CALIBRATED_DISTURBANCE, M, "Initial disturbance estimate (fia20 calibration)").real(|m| m.params.disturbance_start, |m, x| m.params.disturbance_start = x),
    BASIS_PEAK_1: Variable::parameter("basis_peak[1]", 120, -2.4e-05, M, "Peak 1 of the fuzzy basis (strictly increasing, 5 < 0 < 6)").array("Peaks of the fuzzy basis of the extension command (strictly increasing, peak 5 < 0 < peak 6)").real(|m| m.params.basis_peaks[0], |m, x| m.params.basis_peaks[0] = x),
    BASIS_PEAK_2: Variable::parameter("basis_peak[2]", 121, -1.6e-05, M, "Peak 2 of the fuzzy basis (strictly increasing, 5 < 0 < 6)").real(|m| m.params.basis_peaks[1], |m, x| m.params.basis_peaks[1] = x),
    BASIS_PEAK_3: Variable::parameter("basis_peak[3]", 122, -8e-06, M, "Peak 3 of the fuzzy basis (strictly increasing, 5 < 0 < 6)").real(|m| m.params.basis_peaks[2], |m, x| m.params.basis_peaks[2] = x),
    BASIS_PEAK_4: Variable::parameter("basis_peak[4]", 123, -3e-06, M, "Peak 4 of the fuzzy basis (strictly increasing, 5 < 0 < 6)").real(|m| m.params.basis_peaks[3], |m, x| m.params.basis_peaks[3] = x),
    BASIS_PEAK_5: Variable::parameter("basis_peak[5]", 124, -1e-06, M, "Peak 5 of the fuzzy basis (strictly increasing, 5 < 0 < 6)").real(|m| m.params.basis_peaks[4], |m, x| m.params.basis_peaks[4] = x),
    BASIS_PEAK_6: Variable::parameter("basis_peak[6]", 125, 1e-06, M, "Peak 6 of the fuzzy basis (strictly increasing, 5 < 0 < 6)").real(|m| m.params.basis_peaks[5], |m, x| m.params.basis_peaks[5] = x),
    BASIS_PEAK_7: Variable::parameter("basis_peak[7]", 126, 3e-06, M, "Peak 7 of the fuzzy basis (strictly increasing, 5 < 0 < 6)").real(|m| m.params.basis_peaks[6], |m, x| m.params.basis_peaks[6] = x),
    BASIS_PEAK_8: Variable::parameter("basis_peak[8]", 127, 8e-06, M, "Peak 8 of the fuzzy basis (strictly increasing, 5 < 0 < 6)").real(|m| m.params.basis_peaks[7], |m, x| m.params.basis_peaks[7] = x),
    BASIS_PEAK_9: Variable::parameter("basis_peak[9]", 128, 1.6e-05, M, "Peak 9 of the fuzzy basis (strictly increasing, 5 < 0 < 6)").real(|m| m.params.basis_peaks[8], |m, x| m.params.basis_peaks[8] = x),
    BASIS_PEAK_10: Variable::parameter("basis_peak[10]", 129, 2.4e-05, M, "Peak 10 of the fuzzy basis (strictly increasing, 5 < 0 < 6)").real(|m| m.params.basis_peaks[9], |m, x| m.params.basis_peaks[9] = x),
    SCALE_WEIGHTS_START_1: Variable::parameter("scale_weights_start[1]", 130, CALIBRATED_WEIGHTS[0], None, "Initial inverse scale factor weight 1 (fia20 calibration)").array("Initial inverse scale factor weights (fia20 calibration)").real(|m| m.params.scale_weights_start[0], |m, x| m.params.scale_weights_start[0] = x),
    SCALE_WEIGHTS_START_2: Variable::parameter("scale_weights_start[2]", 131, CALIBRATED_WEIGHTS[1], None, "Initial inverse scale factor weight 2 (fia20 calibration)").real(|m| m.params.scale_weights_start[1], |m, x| m.params.scale_weights_start[1] = x),
    SCALE_WEIGHTS_START_3: Variable::parameter("scale_weights_start[3]", 132, CALIBRATED_WEIGHTS[2], None, "Initial inverse scale factor weight 3 (fia20 calibration)").real(|m| m.params.scale_weights_start[2], |m, x| m.params.scale_weights_start[2] = x),
    SCALE_WEIGHTS_START_4: Variable::parameter("scale_weights_start[4]", 133, CALIBRATED_WEIGHTS[3], None, "Initial inverse scale factor weight 4 (fia20 calibration)").real(|m| m.params.scale_weights_start[3], |m, x| m.params.scale_weights_start[3] = x),
    SCALE_WEIGHTS_START_5: Variable::parameter("scale_weights_start[5]", 134, CALIBRATED_WEIGHTS[4], None, "Initial inverse scale factor weight 5 (fia20 calibration)").real(|m| m.params.scale_weights_start[4], |m, x| m.params.scale_weights_start[4] = x),
    SCALE_WEIGHTS_START_6: Variable::parameter("scale_weights_start[6]", 135, CALIBRATED_WEIGHTS[5], None, "Initial inverse scale factor weight 6 (fia20 calibration)").real(|m| m.params.scale_weights_start[5], |m, x| m.params.scale_weights_start[5] = x),
    SCALE_WEIGHTS_START_7: Variable::parameter("scale_weights_start[7]", 136, CALIBRATED_WEIGHTS[6], None, "Initial inverse scale factor weight 7 (fia20 calibration)").real(|m| m.params.scale_weights_start[6], |m, x| m.params.scale_weights_start[6] = x),
    SCALE_WEIGHTS_START_8: Variable::parameter("scale_weights_start[8]", 137, CALIBRATED_WEIGHTS[7], None, "Initial inverse scale factor weight 8 (fia20 calibration)").real(|m| m.params.scale_weights_start[7], |m, x| m.params.scale_weights_start[7] = x),
    SCALE_WEIGHTS_START_9: Variable::parameter("scale_weights_start[9]", 138, CALIBRATED_WEIGHTS[8], None, "Initial inverse scale factor weight 9 (fia20 calibration)").real(|m| m.params.scale_weights_start[8], |m, x| m.params.scale_weights_start[8] = x),
    SCALE_WEIGHTS_START_10: Variable::parameter("scale_weights_start[10]", 139, CALIBRATED_WEIGHTS[9], None, "Initial inverse scale factor weight 10 (fia20 calibration)").real(|m| m.params.scale_weights_start[9], |m, x| m.params.scale_weights_start[9] = x),
    ANALOG: Variable::boolean_parameter("analog", 140, false, "Analog mode near the target: hold in DRIVE with the extension under a loop of its own instead of stepping (deadband must be 0)").boolean(|m| m.params.analog, |m, x| m.params.analog = x),
    ANALOG_RANGE: Variable::parameter("analog_range", 141, 2.5e-6, M, "Analog mode: enter at an iteration with |reference - position| below this, leave above twice it (0 < 2 x range < (5 V - analog_recentre_band) x analog_gain)").with_range(0.0, 2e-5).real(|m| m.params.analog_params.range, |m, x| m.params.analog_params.range = x),
    ANALOG_GAIN: Variable::parameter("analog_gain", 142, 1.7e-6, Some("m/V"), "Analog mode: DRIVE gain of the extension the loop is designed on, m per DAC volt (> 0)").with_range(1e-8, 1e-4).real(|m| m.params.analog_params.gain, |m, x| m.params.analog_params.gain = x),
    ANALOG_LOOP_GAIN: Variable::parameter("analog_loop_gain", 143, 0.3, None, "Analog mode: integrator gain k_I per sample, u += (k_I / analog_gain) e (0 < k_I < 1)").with_range(0.0, 1.0).real(|m| m.params.analog_params.loop_gain, |m, x| m.params.analog_params.loop_gain = x),
    ANALOG_RECENTRE_BAND: Variable::parameter("analog_recentre_band", 144, 1.5, V, "Analog mode: re-centre the extension when its command leaves [band, 10 V - band] (0.5 <= band < 4 V)").with_range(0.5, 4.0).real(|m| m.params.analog_params.recentre_band, |m, x| m.params.analog_params.recentre_band = x),
    DISTURBANCE_MAP: Variable::boolean_parameter("disturbance_map", 145, false, "Estimate the brake-disturbance map over the extension command (a second Kalman filter, 9 weights)").boolean(|m| m.params.disturbance_map, |m, x| m.params.disturbance_map = x),
    USE_DISTURBANCE_MAP: Variable::boolean_parameter("use_disturbance_map", 146, false, "Plan with the map's prediction for the coming step (needs disturbance_map and use_disturbance_estimate)").boolean(|m| m.params.use_disturbance_map, |m, x| m.params.use_disturbance_map = x),
    SINGLE_INTEGRATOR: Variable::boolean_parameter("single_integrator", 147, false, "Single-integrator compensator C(z) = single_integrator_gain instead of K (z - a)/(z - 1) (needs use_disturbance_map)").boolean(|m| m.params.single_integrator, |m, x| m.params.single_integrator = x),
    SINGLE_INTEGRATOR_GAIN: Variable::parameter("single_integrator_gain", 148, 0.6, None, "k of the single-integrator compensator, loop k/(z - 1) (0 < k < 2)").with_range(0.0, 2.0).real(|m| m.params.single_integrator_gain, |m, x| m.params.single_integrator_gain = x),
    SAMPLE_CLOCK: Variable::periodic_clock("sample_clock", SAMPLE_CLOCK_VR, SAMPLE_PERIOD, "The 2 ms sample: at each tick the controller writes the DAC sample of the inputs latched at the tick before and latches encoder_counts and reference (FMI 3.0)").clock_in(),
    GAIT_STEP: Variable::output_clock("gait_step", GAIT_CLOCK_VR, "Ticks at the sample that ends a gait step and updates the estimator: scale_weights and disturbance_estimate change only then (FMI 3.0)").clock_out(|m| m.gait_ticked),
);

impl ControllerFmu {
    /// The DAC outputs (V), earth brake, non-earth brake, extension: the plant's
    /// `PlantFmu::DAC_INPUTS`.
    pub const DAC_OUTPUTS: [Var<ControllerFmu>; 3] =
        [Self::DAC_EARTH, Self::DAC_NONEARTH, Self::DAC_EXTENSION];
    /// The DAC codes of the same three channels.
    pub const DAC_CODES: [Var<ControllerFmu>; 3] =
        [Self::DAC_EARTH_CODE, Self::DAC_NONEARTH_CODE, Self::DAC_EXTENSION_CODE];
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
