//! The `InchwormController` FMU: the controller of docs/model.md §3 and §4 behind the FMI
//! 2.0 / 3.0 Co-Simulation interface of docs/model.md §5.
//!
//! Timing contract, that of a sampled controller on a board: the sample instants are
//! `s_n = t0 + n × 2 ms` (t0 the start time, n counted, never accumulated). At each
//! instant the board latches the inputs (`encoder_counts`, `reference`) and writes to the
//! DAC the sample computed from the inputs latched one instant earlier: sample n + 1
//! (held during `[s_(n+1), s_(n+2))`) comes from the inputs that held at `s_n`. That is
//! the one-sample delay the controller is designed with (docs/model.md §4, Timing).
//!
//! `fmi2DoStep(t, h)` accepts any `h > 0` and runs the instants its step reaches: the
//! latch at every `s_n` in `[t, t + h)` (the input held during the step is the value at
//! `s_n`) and the DAC write at every `s_n` in `(t, t + h]` (so the output the master reads
//! at `t + h` is the sample that holds from the last instant `<= t + h` on). An instant
//! within the layer's 1e-9 relative tolerance of `t + h` counts as `t + h`. Between
//! instants the outputs hold. At `h = k × 2 ms` this is exactly k ticks of the controller:
//! every step latches and writes k times, all from the inputs held at `t`, and ends with
//! the sample for `[t + h, t + h + 2 ms)`; a plain Jacobi master at 2 ms runs the loop
//! correctly. At `h = 2 ms / m` the loop is the 2 ms loop: the latch at `s_n` reads the
//! plant's encoder at `s_n` and the write reaches the plant at `s_(n+1)`. Other steps
//! add the master's staleness: a latch reads the value of the last communication point
//! `<= s_n` (< h old) and a write reaches the plant at the first one `>= s_(n+1)` (< h
//! late). docs/model.md §5 has the table.
//!
//! As Model Exchange the controller has no continuous states and one time event per
//! sample instant (`nextEventTime`). The event update at `T` runs what a step ending at `T`
//! runs (every write at an instant `<= T` not yet made), then the latch at `T` itself if `T`
//! is an instant: the same instants, inputs and samples as Co-Simulation, so a master that
//! hands the plant's encoder to the controller at each event closes the same loop as a
//! Jacobi master at 2 ms. Between events the outputs hold.

use inchworm_board::ENCODER_RESOLUTION;
use inchworm_controller::{
    Controller, Params, Sample, CALIBRATED_DISTURBANCE, CALIBRATED_WEIGHTS, SAMPLE_PERIOD,
};
// The layer's `same_time`: communication points within 1e-9 relative (a few ulps at 0) are
// one point, so an instant the master reaches up to rounding counts as reached.
use inchworm_fmi_export::same_time;
use inchworm_fmi_export::{
    EventUpdate, Kind, Model, ModelExchange, ModelInfo, Reader, Row, StepLog, Unit, Variable,
    Writer,
};

const V: Option<&str> = Some("V");
const M: Option<&str> = Some("m");

#[rustfmt::skip]
inchworm_fmi_export::table!(ControllerFmu, TABLE;
    REFERENCE: Variable::input("reference", 2, 0.0, M, "Reference position of the runner").real(|m| m.reference, |m, x| m.reference = x),
    ENCODER_COUNTS: Variable::integer_input("encoder_counts", 1, 0, None, "Encoder reading of the plant (counts of q_enc)").integer(|m| m.encoder_counts, |m, x| m.encoder_counts = x),
    DAC_EARTH: Variable::output("dac_earth", 10, Kind::Real, V, "Earth-brake DAC volts to hold over the next 2 ms sample (16-bit quantized)").discrete().real_out(|m| m.with_sample(|s| s.dac[0])),
    DAC_NONEARTH: Variable::output("dac_nonearth", 11, Kind::Real, V, "Non-earth-brake DAC volts (16-bit quantized)").discrete().real_out(|m| m.with_sample(|s| s.dac[1])),
    DAC_EXTENSION: Variable::output("dac_extension", 12, Kind::Real, V, "Extension DAC volts (16-bit quantized)").discrete().real_out(|m| m.with_sample(|s| s.dac[2])),
    DAC_EARTH_CODE: Variable::output("dac_earth_code", 13, Kind::Integer, None, "16-bit DAC code (0-65535) of dac_earth").integer_out(|m| m.with_sample(|s| i32::from(s.codes[0]))),
    DAC_NONEARTH_CODE: Variable::output("dac_nonearth_code", 14, Kind::Integer, None, "16-bit DAC code (0-65535) of dac_nonearth").integer_out(|m| m.with_sample(|s| i32::from(s.codes[1]))),
    DAC_EXTENSION_CODE: Variable::output("dac_extension_code", 15, Kind::Integer, None, "16-bit DAC code (0-65535) of dac_extension").integer_out(|m| m.with_sample(|s| i32::from(s.codes[2]))),
    SERVO_ERROR: Variable::output("servo_error", 16, Kind::Real, M, "reference - encoder position").discrete().real_out(|m| m.with_sample(|s| s.servo_error)),
    DISTURBANCE_ESTIMATE: Variable::output("disturbance_estimate", 17, Kind::Real, M, "Kalman estimate of the brake disturbance per step").discrete().real_out(|m| m.with_sample(|s| s.disturbance_estimate)),
    STEP_FORWARD: Variable::output("step_forward", 18, Kind::Real, M, "Estimated full forward step (with the disturbance)").discrete().real_out(|m| m.with_sample(|s| s.step_forward)),
    STEP_BACKWARD: Variable::output("step_backward", 19, Kind::Real, M, "Estimated full backward step (negative)").discrete().real_out(|m| m.with_sample(|s| s.step_backward)),
    N_STEPS: Variable::output("n_steps", 20, Kind::Integer, None, "Full steps of the current move").integer_out(|m| m.with_sample(|s| s.n_steps.min(i32::MAX as u32) as i32)),
    FRACTION: Variable::output("fraction", 21, Kind::Real, None, "Amplitude of the current move's fractional step (-1..1)").discrete().real_out(|m| m.with_sample(|s| s.fraction)),
    MOVING: Variable::output("moving", 22, Kind::Boolean, None, "A step is being executed").boolean_out(|m| m.with_sample(|s| s.moving)),
    SCALE_WEIGHTS_1: Variable::output("scale_weights[1]", 30, Kind::Real, None, "Estimated inverse scale factor weight 1").discrete().array("Estimated inverse scale factor: the weights of the ten basis functions").real_out(|m| m.with_sample(|s| s.scale_weights[0])),
    SCALE_WEIGHTS_2: Variable::output("scale_weights[2]", 31, Kind::Real, None, "Estimated inverse scale factor weight 2").discrete().real_out(|m| m.with_sample(|s| s.scale_weights[1])),
    SCALE_WEIGHTS_3: Variable::output("scale_weights[3]", 32, Kind::Real, None, "Estimated inverse scale factor weight 3").discrete().real_out(|m| m.with_sample(|s| s.scale_weights[2])),
    SCALE_WEIGHTS_4: Variable::output("scale_weights[4]", 33, Kind::Real, None, "Estimated inverse scale factor weight 4").discrete().real_out(|m| m.with_sample(|s| s.scale_weights[3])),
    SCALE_WEIGHTS_5: Variable::output("scale_weights[5]", 34, Kind::Real, None, "Estimated inverse scale factor weight 5").discrete().real_out(|m| m.with_sample(|s| s.scale_weights[4])),
    SCALE_WEIGHTS_6: Variable::output("scale_weights[6]", 35, Kind::Real, None, "Estimated inverse scale factor weight 6").discrete().real_out(|m| m.with_sample(|s| s.scale_weights[5])),
    SCALE_WEIGHTS_7: Variable::output("scale_weights[7]", 36, Kind::Real, None, "Estimated inverse scale factor weight 7").discrete().real_out(|m| m.with_sample(|s| s.scale_weights[6])),
    SCALE_WEIGHTS_8: Variable::output("scale_weights[8]", 37, Kind::Real, None, "Estimated inverse scale factor weight 8").discrete().real_out(|m| m.with_sample(|s| s.scale_weights[7])),
    SCALE_WEIGHTS_9: Variable::output("scale_weights[9]", 38, Kind::Real, None, "Estimated inverse scale factor weight 9").discrete().real_out(|m| m.with_sample(|s| s.scale_weights[8])),
    SCALE_WEIGHTS_10: Variable::output("scale_weights[10]", 39, Kind::Real, None, "Estimated inverse scale factor weight 10").discrete().real_out(|m| m.with_sample(|s| s.scale_weights[9])),
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
);

static UNITS: [Unit; 3] = [
    Unit { name: "m", kg: 0, m: 1, s: 0, a: 0 },
    Unit { name: "V", kg: 1, m: 2, s: -3, a: -1 },
    Unit { name: "m/V", kg: -1, m: -1, s: 3, a: 1 },
];

static INFO: ModelInfo = ModelInfo {
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
    documentation_html: include_str!("controller.html"),
};

#[derive(Clone, Debug)]
pub struct ControllerFmu {
    params: Params,
    encoder_counts: i32,
    reference: f64,
    controller: Option<Controller>,
    last: Option<Sample>,
    clock: Clock,
}

/// Where the controller is on its sample grid `s_n = origin + n × SAMPLE_PERIOD`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Clock {
    /// `s_0`. `None` only in a state restored from format 1 (which held no clock and was
    /// always taken at a sample instant): the next step's `t` is then `s_0`.
    origin: Option<f64>,
    /// Samples written so far: the outputs are those of the write at `s_ticks`.
    ticks: u64,
    /// The inputs latched at `s_ticks` while the write at `s_(ticks+1)` is still ahead;
    /// `None` exactly when the communication point is a sample instant.
    latch: Option<(i32, f64)>,
}

/// `s` lies before `end` and is not `end` up to rounding.
fn before(s: f64, end: f64) -> bool {
    s < end && !same_time(s, end)
}

/// `s` lies after `end` and is not `end` up to rounding.
fn after(s: f64, end: f64) -> bool {
    s > end && !same_time(s, end)
}

/// The most sample instants one call runs: a step or an event update runs every instant
/// it passes (some 0.1 µs each here), so that no time a master gives makes a call take
/// more than about a second. 10^7 samples are 20 000 s of simulated time.
const MAX_SAMPLES_PER_CALL: f64 = 1e7;

impl ControllerFmu {
    /// A model that will run `params` (validated at initialization, as a master's).
    pub fn with_params(params: Params) -> Self {
        ControllerFmu { params, ..Model::new() }
    }

    /// Refuses an `end` more than [`MAX_SAMPLES_PER_CALL`] sample instants past the last
    /// sample written (before any is, `t` is the origin).
    fn within_reach(&self, t: f64, end: f64) -> Result<(), String> {
        let last = self.clock.origin.unwrap_or(t) + self.clock.ticks as f64 * SAMPLE_PERIOD;
        let samples = (end - last) / SAMPLE_PERIOD;
        if samples > MAX_SAMPLES_PER_CALL {
            return Err(format!(
                "{end} s is {samples:.4e} sample instants past the last sample at {last} s; one call runs at most {MAX_SAMPLES_PER_CALL:e} (take shorter steps, or stop at every time event)"
            ));
        }
        Ok(())
    }

    /// Runs the instants of a step from `t` to `end`: the latch at every `s_n` in
    /// `[t, end)`, the write at every `s_n` in `(t, end]`; only `end` and the clock decide
    /// which (`t` names the step in messages and anchors a clock restored from format 1).
    fn advance(&mut self, t: f64, end: f64, log: &mut StepLog) -> Result<(), String> {
        let c = self.controller.as_mut().ok_or("the controller is not initialized")?;
        let clock = &mut self.clock;
        let origin = *clock.origin.get_or_insert(t);
        // Counted instants: s_n is the same number whichever steps led to it.
        let instant = |n: u64| origin + n as f64 * SAMPLE_PERIOD;
        loop {
            let (counts, reference) = match clock.latch {
                Some(latched) => latched,
                // The latch at s_ticks, if this step holds it: [t, end).
                None if before(instant(clock.ticks), end) => (self.encoder_counts, self.reference),
                None => break,
            };
            // The write at s_(ticks+1), if this step reaches it: (t, end].
            if after(instant(clock.ticks + 1), end) {
                clock.latch = Some((counts, reference));
                break;
            }
            clock.latch = None;
            clock.ticks += 1;
            let s = c.tick(i64::from(counts), reference);
            if s.no_root {
                log.warning(format_args!(
                    "at t = {t} s the estimated inverse scale factor has no root for a full step in its bracket (non-monotone map): no full steps this move"
                ));
            }
            if s.iterated {
                log.event(format_args!(
                    "control iteration near t = {t} s: {} full step(s) and fraction {:.4}, disturbance estimate {:.4} um",
                    s.n_steps,
                    s.fraction,
                    s.disturbance_estimate * 1e6
                ));
            }
            self.last = Some(s);
        }
        Ok(())
    }

    /// `read` of the outputs now: the last sample written, read where it lies (a master
    /// reads the three DAC volts every 2 ms, and a `Sample` is some 170 bytes), or the
    /// parked one before the first write.
    fn with_sample<T>(&self, read: impl FnOnce(&Sample) -> T) -> T {
        match &self.last {
            Some(s) => read(s),
            None => read(&self.parked()),
        }
    }

    /// The outputs before the first write: the parked sample, estimates at their start,
    /// the servo error of the inputs latched at s_0 once a step has passed it (so the
    /// outputs hold until s_1), of the current inputs before.
    fn parked(&self) -> Sample {
        let (counts, reference) = self.clock.latch.unwrap_or((self.encoder_counts, self.reference));
        Sample {
            dac: [0.0; 3],
            codes: [0; 3],
            servo_error: reference - f64::from(counts) * self.params.q_enc,
            disturbance_estimate: self.params.disturbance_start,
            step_forward: 0.0,
            step_backward: 0.0,
            n_steps: 0,
            fraction: 0.0,
            scale_weights: self.params.scale_weights_start,
            moving: false,
            iterated: false,
            no_root: false,
        }
    }
}

impl Model for ControllerFmu {
    fn info() -> &'static ModelInfo {
        &INFO
    }

    fn table() -> &'static [Row<Self>] {
        &TABLE
    }

    fn new() -> Self {
        ControllerFmu {
            params: Params::default(),
            encoder_counts: 0,
            reference: 0.0,
            controller: None,
            last: None,
            clock: Clock::default(),
        }
    }

    fn exit_initialization(&mut self, start_time: f64) -> Result<(), String> {
        if self.params.samples_per_step == 0 || self.params.samples_per_step > i32::MAX as u32 {
            return Err(format!(
                "invalid parameter samples_per_step: {}",
                self.params.samples_per_step
            ));
        }
        let c =
            Controller::new(self.params.clone()).map_err(|e| format!("invalid parameter {e}"))?;
        self.controller = Some(c);
        self.clock = Clock { origin: Some(start_time), ticks: 0, latch: None };
        Ok(())
    }

    fn check_step(&self, t: f64, h: f64) -> Result<(), String> {
        self.within_reach(t, t + h)
    }

    fn check_time(&self, t: f64) -> Result<(), String> {
        self.within_reach(t, t)
    }

    fn do_step(&mut self, t: f64, h: f64, log: &mut StepLog) -> Result<(), String> {
        self.advance(t, t + h, log)
    }

    fn model_exchange() -> Option<&'static ModelExchange> {
        static ME: ModelExchange =
            ModelExchange { states: &[], event_indicators: &[], directional_derivatives: false };
        Some(&ME)
    }

    fn update_discrete_states(&mut self, t: f64, log: &mut StepLog) -> Result<EventUpdate, String> {
        self.advance(t, t, log)?;
        let origin = self.clock.origin.unwrap_or(t);
        let instant = |n: u64| origin + n as f64 * SAMPLE_PERIOD;
        if self.clock.latch.is_none() && same_time(instant(self.clock.ticks), t) {
            self.clock.latch = Some((self.encoder_counts, self.reference));
        }
        // The write at s_(ticks+1) when inputs are latched, else the latch at s_ticks.
        let next = instant(self.clock.ticks + u64::from(self.clock.latch.is_some()));
        Ok(EventUpdate { states_changed: false, next_event_time: Some(next) })
    }

    fn save_state(&self, w: &mut Writer) {
        w.f64(f64::from(self.encoder_counts));
        w.f64(self.reference);
        w.u8(u8::from(self.last.is_some()));
        if let Some(s) = &self.last {
            let (e, d, f, b) =
                (s.servo_error, s.disturbance_estimate, s.step_forward, s.step_backward);
            for v in s.dac.iter().chain(&[e, d, f, b, s.fraction]).chain(&s.scale_weights) {
                w.f64(*v);
            }
            // The board's widths: 16-bit DAC codes, a 32-bit step count.
            s.codes.iter().for_each(|c| w.0.extend_from_slice(&c.to_le_bytes()));
            w.0.extend_from_slice(&s.n_steps.to_le_bytes());
            [s.moving, s.iterated, s.no_root].into_iter().for_each(|b| w.u8(u8::from(b)));
        }
        match &self.controller {
            None => w.u8(0),
            Some(c) => {
                // Format 2: the marker 2 and the clock, then the controller's own bytes.
                w.u8(2);
                let Clock { origin, ticks, latch } = self.clock;
                w.f64(origin.unwrap_or(f64::NAN));
                w.u64(ticks);
                w.u8(u8::from(latch.is_some()));
                let (counts, reference) = latch.unwrap_or((0, 0.0));
                w.0.extend_from_slice(&counts.to_le_bytes());
                w.f64(reference);
                c.save_state(w.0);
            }
        }
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        // The last sample and the clock have fixed sizes, so the controller's own bytes
        // start at a known offset: inputs, marker, sample, controller marker, clock.
        let marker_at = if bytes.get(16) == Some(&1) { 17 + SAMPLE_BYTES } else { 17 };
        let head = marker_at + 1 + if bytes.get(marker_at) == Some(&2) { CLOCK_BYTES } else { 0 };
        let (head, own) = bytes.split_at_checked(head).ok_or("controller FMU state truncated")?;
        let mut r = Reader::new(head, "controller FMU state");
        self.encoder_counts = r.f64()? as i32;
        self.reference = r.f64()?;
        if r.bool()? {
            let mut f = [0.0; 18];
            for v in f.iter_mut() {
                *v = r.f64()?;
            }
            let mut code = || Ok::<_, String>(u16::from_le_bytes(le(&mut r)?));
            let codes = [code()?, code()?, code()?];
            let n_steps = u32::from_le_bytes(le(&mut r)?);
            self.last = Some(Sample {
                dac: [f[0], f[1], f[2]],
                codes,
                servo_error: f[3],
                disturbance_estimate: f[4],
                step_forward: f[5],
                step_backward: f[6],
                fraction: f[7],
                scale_weights: std::array::from_fn(|i| f[8 + i]),
                n_steps,
                moving: r.bool()?,
                iterated: r.bool()?,
                no_root: r.bool()?,
            });
        }
        let controller = r.u8()?;
        if controller > 2 {
            return Err(format!("controller FMU state: unknown controller marker {controller}"));
        }
        // Format 1 (marker 1) held no clock: it was always taken at a sample instant
        // (steps were whole samples), so the next step's t is s_0 and nothing is latched.
        self.clock = Clock::default();
        if controller == 2 {
            let origin = r.f64()?;
            let ticks = r.u64()?;
            let latched = r.bool()?;
            let counts = i32::from_le_bytes(le(&mut r)?);
            let reference = r.f64()?;
            if !origin.is_finite() || !reference.is_finite() {
                return Err("controller FMU state: a non-finite sample clock".into());
            }
            self.clock = Clock {
                origin: Some(origin),
                ticks,
                latch: latched.then_some((counts, reference)),
            };
        }
        if controller != 0 {
            let mut c = Controller::new(self.params.clone())
                .map_err(|e| format!("state holds invalid parameters: {e}"))?;
            c.load_state(own)?;
            self.controller = Some(c);
        } else if !own.is_empty() {
            return Err(
                "controller FMU state: trailing bytes after an uninitialized controller".into()
            );
        }
        r.finish()
    }
}

/// A saved [`Sample`]: 18 f64, three u16 codes, a u32 step count and three flags.
const SAMPLE_BYTES: usize = 18 * 8 + 3 * 2 + 4 + 3;

/// The saved [`Clock`] of format 2: origin f64, ticks u64, latch flag, latched counts i32
/// and reference f64 (zeros when nothing is latched).
const CLOCK_BYTES: usize = 8 + 8 + 1 + 4 + 8;

/// `N` little-endian bytes: the state-bytes Reader reads no u16 or u32.
fn le<const N: usize>(r: &mut Reader) -> Result<[u8; N], String> {
    let mut b = [0; N];
    for x in b.iter_mut() {
        *x = r.u8()?;
    }
    Ok(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What `do_step(t, k × 2 ms)` must give: k ticks of the controller, all with the
    /// inputs held at t.
    fn former(c: &mut Controller, counts: i32, reference: f64, k: usize) -> Sample {
        (0..k).map(|_| c.tick(i64::from(counts), reference)).last().unwrap()
    }

    /// Whole-sample steps give those k ticks' outputs bit for bit, with the master's time
    /// accumulated as `t += h` (so the instants are met only up to rounding), and leave
    /// nothing latched: a state saved there is at a sample instant.
    #[test]
    fn whole_sample_steps_are_the_former_contract_bit_for_bit() {
        for k in [1, 2, 3, 7] {
            let mut fmu = ControllerFmu::new();
            fmu.reference = 60e-6;
            fmu.exit_initialization(0.0).unwrap();
            let mut c = Controller::new(Params::default()).unwrap();
            let (h, mut t, mut counts, mut moved) = (k as f64 * SAMPLE_PERIOD, 0.0, 0, 0);
            for _ in 0..1200 / k {
                fmu.encoder_counts = counts;
                fmu.do_step(t, h, &mut StepLog::new(false)).unwrap();
                let s = former(&mut c, counts, 60e-6, k);
                assert_eq!(
                    format!("{:?}", fmu.last.unwrap()),
                    format!("{s:?}"),
                    "k = {k}, t = {t}"
                );
                assert_eq!(fmu.clock.latch, None);
                counts += (s.dac[1] > 5.0) as i32 * 2;
                moved += s.moving as usize;
                t += h;
            }
            assert_eq!(fmu.clock.ticks, (1200 / k * k) as u64);
            assert!(moved > 0, "the synthetic loop moved");
        }
    }

    /// A format-1 state (controller marker 1, no clock) restores at a sample instant and
    /// anchors the grid at the next step's t.
    #[test]
    fn a_format_1_state_restores_and_anchors_the_grid_at_the_next_step() {
        let mut a = ControllerFmu::new();
        a.reference = 30e-6;
        a.exit_initialization(0.0).unwrap();
        let mut log = StepLog::new(false);
        for k in 0..40 {
            a.do_step(k as f64 * SAMPLE_PERIOD, SAMPLE_PERIOD, &mut log).unwrap();
        }
        let mut bytes = Vec::new();
        a.save_state(&mut Writer(&mut bytes));
        // Format 1: the same bytes with marker 1 and no clock.
        let at = 17 + SAMPLE_BYTES;
        assert_eq!(bytes[at], 2);
        let mut old = bytes[..at].to_vec();
        old.push(1);
        old.extend_from_slice(&bytes[at + 1 + CLOCK_BYTES..]);
        let mut b = ControllerFmu::new();
        b.load_state(&old).unwrap();
        assert_eq!(b.clock, Clock::default());
        let mut c = ControllerFmu::new();
        c.load_state(&bytes).unwrap();
        assert_eq!(c.clock, a.clock);
        // Half-sample steps from the restored instant: writes at the same instants.
        for k in 0..200 {
            let t = 0.08 + k as f64 * 0.001;
            a.do_step(t, 0.001, &mut log).unwrap();
            b.do_step(t, 0.001, &mut log).unwrap();
            c.do_step(t, 0.001, &mut log).unwrap();
            let s = format!("{:?}", a.last);
            assert_eq!((format!("{:?}", b.last), format!("{:?}", c.last)), (s.clone(), s));
        }
        assert_eq!(b.clock.ticks + 40, a.clock.ticks);
        let mut bad = bytes.clone();
        bad[at] = 3;
        assert_eq!(
            ControllerFmu::new().load_state(&bad),
            Err("controller FMU state: unknown controller marker 3".into())
        );
    }
}
