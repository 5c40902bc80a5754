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

use inchworm_controller::{
    Controller, Params, Sample, CALIBRATED_DISTURBANCE, CALIBRATED_WEIGHTS, SAMPLE_PERIOD,
};
// The layer's `same_time`: communication points within 1e-9 relative (a few ulps at 0) are
// one point, so an instant the master reaches up to rounding counts as reached.
use inchworm_fmi_export::same_time;
use inchworm_fmi_export::{
    EventUpdate, Kind, Model, ModelExchange, ModelInfo, Reader, StepLog, Unit, Variable, Writer,
};

mod vr {
    pub const ENCODER_COUNTS: u32 = 1;
    pub const REFERENCE: u32 = 2;
    pub const DAC_EARTH: u32 = 10;
    pub const DAC_NONEARTH: u32 = 11;
    pub const DAC_EXTENSION: u32 = 12;
    pub const DAC_EARTH_CODE: u32 = 13;
    pub const DAC_NONEARTH_CODE: u32 = 14;
    pub const DAC_EXTENSION_CODE: u32 = 15;
    pub const SERVO_ERROR: u32 = 16;
    pub const DISTURBANCE_ESTIMATE: u32 = 17;
    pub const STEP_FORWARD: u32 = 18;
    pub const STEP_BACKWARD: u32 = 19;
    pub const N_STEPS: u32 = 20;
    pub const FRACTION: u32 = 21;
    pub const MOVING: u32 = 22;
    pub const SCALE_WEIGHTS: u32 = 30; // ..=39
    pub const FEEDFORWARD: u32 = 100;
    pub const PREFILTER: u32 = 101;
    pub const USE_SCALE_FACTOR_ESTIMATE: u32 = 102;
    pub const USE_DISTURBANCE_ESTIMATE: u32 = 103;
    pub const DEADBAND: u32 = 104;
    pub const SAMPLES_PER_STEP: u32 = 105;
    pub const COMPENSATOR_GAIN: u32 = 106;
    pub const COMPENSATOR_ZERO: u32 = 107;
    pub const PREFILTER_POLE: u32 = 108;
    pub const WEIGHT_PRIOR: u32 = 109;
    pub const DISTURBANCE_PRIOR: u32 = 110;
    pub const WEIGHT_PROCESS_NOISE: u32 = 111;
    pub const DISTURBANCE_PROCESS_NOISE: u32 = 112;
    pub const EXT_CMD_NOISE: u32 = 113;
    pub const BD_NOISE: u32 = 114;
    pub const Q_ENC: u32 = 115;
    pub const DISTURBANCE_START: u32 = 116;
    pub const BASIS_PEAK: u32 = 120; // ..=129
    pub const SCALE_WEIGHTS_START: u32 = 130; // ..=139
    pub const ANALOG: u32 = 140;
    pub const ANALOG_RANGE: u32 = 141;
    pub const ANALOG_GAIN: u32 = 142;
    pub const ANALOG_LOOP_GAIN: u32 = 143;
    pub const ANALOG_RECENTRE_BAND: u32 = 144;
    pub const DISTURBANCE_MAP: u32 = 145;
    pub const USE_DISTURBANCE_MAP: u32 = 146;
    pub const SINGLE_INTEGRATOR: u32 = 147;
    pub const SINGLE_INTEGRATOR_GAIN: u32 = 148;
}

const V: Option<&str> = Some("V");
const M: Option<&str> = Some("m");

#[rustfmt::skip]
static VARIABLES: [Variable; 71] = [
    Variable::input("reference", vr::REFERENCE, 0.0, M, "Reference position of the runner"),
    Variable::integer_input("encoder_counts", vr::ENCODER_COUNTS, 0, None, "Encoder reading of the plant (counts of q_enc)"),
    Variable::output("dac_earth", vr::DAC_EARTH, Kind::Real, V, "Earth-brake DAC volts to hold over the next 2 ms sample (16-bit quantized)").discrete(),
    Variable::output("dac_nonearth", vr::DAC_NONEARTH, Kind::Real, V, "Non-earth-brake DAC volts (16-bit quantized)").discrete(),
    Variable::output("dac_extension", vr::DAC_EXTENSION, Kind::Real, V, "Extension DAC volts (16-bit quantized)").discrete(),
    Variable::output("dac_earth_code", vr::DAC_EARTH_CODE, Kind::Integer, None, "16-bit DAC code (0-65535) of dac_earth"),
    Variable::output("dac_nonearth_code", vr::DAC_NONEARTH_CODE, Kind::Integer, None, "16-bit DAC code (0-65535) of dac_nonearth"),
    Variable::output("dac_extension_code", vr::DAC_EXTENSION_CODE, Kind::Integer, None, "16-bit DAC code (0-65535) of dac_extension"),
    Variable::output("servo_error", vr::SERVO_ERROR, Kind::Real, M, "reference - encoder position").discrete(),
    Variable::output("disturbance_estimate", vr::DISTURBANCE_ESTIMATE, Kind::Real, M, "Kalman estimate of the brake disturbance per step").discrete(),
    Variable::output("step_forward", vr::STEP_FORWARD, Kind::Real, M, "Estimated full forward step (with the disturbance)").discrete(),
    Variable::output("step_backward", vr::STEP_BACKWARD, Kind::Real, M, "Estimated full backward step (negative)").discrete(),
    Variable::output("n_steps", vr::N_STEPS, Kind::Integer, None, "Full steps of the current move"),
    Variable::output("fraction", vr::FRACTION, Kind::Real, None, "Amplitude of the current move's fractional step (-1..1)").discrete(),
    Variable::output("moving", vr::MOVING, Kind::Boolean, None, "A step is being executed"),
    Variable::output("scale_weights[1]", vr::SCALE_WEIGHTS, Kind::Real, None, "Estimated inverse scale factor weight 1").discrete().array("Estimated inverse scale factor: the weights of the ten basis functions"),
    Variable::output("scale_weights[2]", vr::SCALE_WEIGHTS + 1, Kind::Real, None, "Estimated inverse scale factor weight 2").discrete(),
    Variable::output("scale_weights[3]", vr::SCALE_WEIGHTS + 2, Kind::Real, None, "Estimated inverse scale factor weight 3").discrete(),
    Variable::output("scale_weights[4]", vr::SCALE_WEIGHTS + 3, Kind::Real, None, "Estimated inverse scale factor weight 4").discrete(),
    Variable::output("scale_weights[5]", vr::SCALE_WEIGHTS + 4, Kind::Real, None, "Estimated inverse scale factor weight 5").discrete(),
    Variable::output("scale_weights[6]", vr::SCALE_WEIGHTS + 5, Kind::Real, None, "Estimated inverse scale factor weight 6").discrete(),
    Variable::output("scale_weights[7]", vr::SCALE_WEIGHTS + 6, Kind::Real, None, "Estimated inverse scale factor weight 7").discrete(),
    Variable::output("scale_weights[8]", vr::SCALE_WEIGHTS + 7, Kind::Real, None, "Estimated inverse scale factor weight 8").discrete(),
    Variable::output("scale_weights[9]", vr::SCALE_WEIGHTS + 8, Kind::Real, None, "Estimated inverse scale factor weight 9").discrete(),
    Variable::output("scale_weights[10]", vr::SCALE_WEIGHTS + 9, Kind::Real, None, "Estimated inverse scale factor weight 10").discrete(),
    Variable::boolean_parameter("feedforward", vr::FEEDFORWARD, true, "Feed the reference increment forward (feedback sees it one iteration later)"),
    Variable::boolean_parameter("prefilter", vr::PREFILTER, false, "Prefilter the reference"),
    Variable::boolean_parameter("use_scale_factor_estimate", vr::USE_SCALE_FACTOR_ESTIMATE, true, "Use the estimated inverse scale factor (else scale_weights_start)"),
    Variable::boolean_parameter("use_disturbance_estimate", vr::USE_DISTURBANCE_ESTIMATE, true, "Use the estimated brake disturbance (else 0)"),
    Variable::parameter("deadband", vr::DEADBAND, 0.0, M, "No step while |reference - position| is below this (0 = always step)"),
    Variable::integer_parameter("samples_per_step", vr::SAMPLES_PER_STEP, 100, None, "Samples of 2 ms per step (7..10000)"),
    Variable::parameter("compensator_gain", vr::COMPENSATOR_GAIN, 0.36, None, "K of C(z) = K (z - a)/(z - 1)"),
    Variable::parameter("compensator_zero", vr::COMPENSATOR_ZERO, 0.8, None, "a of C(z) = K (z - a)/(z - 1)"),
    Variable::parameter("prefilter_pole", vr::PREFILTER_POLE, 0.8, None, "Prefilter r_f <- p r_f + (1 - p) r"),
    Variable::parameter("weight_prior", vr::WEIGHT_PRIOR, 0.05, None, "Prior 1-sigma of each scale-factor weight"),
    Variable::parameter("disturbance_prior", vr::DISTURBANCE_PRIOR, 5e-6, M, "Prior 1-sigma of the disturbance"),
    Variable::parameter("weight_process_noise", vr::WEIGHT_PROCESS_NOISE, 1e-3, None, "Process noise of the weights per sqrt(s)"),
    Variable::parameter("disturbance_process_noise", vr::DISTURBANCE_PROCESS_NOISE, 0.1e-6, M, "Process noise of the disturbance per sqrt(s)"),
    Variable::parameter("ext_cmd_noise", vr::EXT_CMD_NOISE, 5e-3, None, "Measurement noise of EXT_cmd"),
    Variable::parameter("bd_noise", vr::BD_NOISE, 0.05e-6, M, "Measurement noise of BD"),
    Variable::parameter("q_enc", vr::Q_ENC, 1.2e-9, M, "Encoder resolution per count"),
    Variable::parameter("disturbance_start", vr::DISTURBANCE_START, CALIBRATED_DISTURBANCE, M, "Initial disturbance estimate (fia20 calibration)"),
    Variable::parameter("basis_peak[1]", vr::BASIS_PEAK, -2.4e-05, M, "Peak 1 of the fuzzy basis (strictly increasing, 5 < 0 < 6)").array("Peaks of the fuzzy basis of the extension command (strictly increasing, peak 5 < 0 < peak 6)"),
    Variable::parameter("basis_peak[2]", vr::BASIS_PEAK + 1, -1.6e-05, M, "Peak 2 of the fuzzy basis (strictly increasing, 5 < 0 < 6)"),
    Variable::parameter("basis_peak[3]", vr::BASIS_PEAK + 2, -8e-06, M, "Peak 3 of the fuzzy basis (strictly increasing, 5 < 0 < 6)"),
    Variable::parameter("basis_peak[4]", vr::BASIS_PEAK + 3, -3e-06, M, "Peak 4 of the fuzzy basis (strictly increasing, 5 < 0 < 6)"),
    Variable::parameter("basis_peak[5]", vr::BASIS_PEAK + 4, -1e-06, M, "Peak 5 of the fuzzy basis (strictly increasing, 5 < 0 < 6)"),
    Variable::parameter("basis_peak[6]", vr::BASIS_PEAK + 5, 1e-06, M, "Peak 6 of the fuzzy basis (strictly increasing, 5 < 0 < 6)"),
    Variable::parameter("basis_peak[7]", vr::BASIS_PEAK + 6, 3e-06, M, "Peak 7 of the fuzzy basis (strictly increasing, 5 < 0 < 6)"),
    Variable::parameter("basis_peak[8]", vr::BASIS_PEAK + 7, 8e-06, M, "Peak 8 of the fuzzy basis (strictly increasing, 5 < 0 < 6)"),
    Variable::parameter("basis_peak[9]", vr::BASIS_PEAK + 8, 1.6e-05, M, "Peak 9 of the fuzzy basis (strictly increasing, 5 < 0 < 6)"),
    Variable::parameter("basis_peak[10]", vr::BASIS_PEAK + 9, 2.4e-05, M, "Peak 10 of the fuzzy basis (strictly increasing, 5 < 0 < 6)"),
    Variable::parameter("scale_weights_start[1]", vr::SCALE_WEIGHTS_START, CALIBRATED_WEIGHTS[0], None, "Initial inverse scale factor weight 1 (fia20 calibration)").array("Initial inverse scale factor weights (fia20 calibration)"),
    Variable::parameter("scale_weights_start[2]", vr::SCALE_WEIGHTS_START + 1, CALIBRATED_WEIGHTS[1], None, "Initial inverse scale factor weight 2 (fia20 calibration)"),
    Variable::parameter("scale_weights_start[3]", vr::SCALE_WEIGHTS_START + 2, CALIBRATED_WEIGHTS[2], None, "Initial inverse scale factor weight 3 (fia20 calibration)"),
    Variable::parameter("scale_weights_start[4]", vr::SCALE_WEIGHTS_START + 3, CALIBRATED_WEIGHTS[3], None, "Initial inverse scale factor weight 4 (fia20 calibration)"),
    Variable::parameter("scale_weights_start[5]", vr::SCALE_WEIGHTS_START + 4, CALIBRATED_WEIGHTS[4], None, "Initial inverse scale factor weight 5 (fia20 calibration)"),
    Variable::parameter("scale_weights_start[6]", vr::SCALE_WEIGHTS_START + 5, CALIBRATED_WEIGHTS[5], None, "Initial inverse scale factor weight 6 (fia20 calibration)"),
    Variable::parameter("scale_weights_start[7]", vr::SCALE_WEIGHTS_START + 6, CALIBRATED_WEIGHTS[6], None, "Initial inverse scale factor weight 7 (fia20 calibration)"),
    Variable::parameter("scale_weights_start[8]", vr::SCALE_WEIGHTS_START + 7, CALIBRATED_WEIGHTS[7], None, "Initial inverse scale factor weight 8 (fia20 calibration)"),
    Variable::parameter("scale_weights_start[9]", vr::SCALE_WEIGHTS_START + 8, CALIBRATED_WEIGHTS[8], None, "Initial inverse scale factor weight 9 (fia20 calibration)"),
    Variable::parameter("scale_weights_start[10]", vr::SCALE_WEIGHTS_START + 9, CALIBRATED_WEIGHTS[9], None, "Initial inverse scale factor weight 10 (fia20 calibration)"),
    Variable::boolean_parameter("analog", vr::ANALOG, false, "Analog mode near the target: hold in DRIVE with the extension under a loop of its own instead of stepping (deadband must be 0)"),
    Variable::parameter("analog_range", vr::ANALOG_RANGE, 2.5e-6, M, "Analog mode: enter at an iteration with |reference - position| below this, leave above twice it (0 < 2 x range < (5 V - analog_recentre_band) x analog_gain)").with_range(0.0, 2e-5),
    Variable::parameter("analog_gain", vr::ANALOG_GAIN, 1.7e-6, Some("m/V"), "Analog mode: DRIVE gain of the extension the loop is designed on, m per DAC volt (> 0)").with_range(1e-8, 1e-4),
    Variable::parameter("analog_loop_gain", vr::ANALOG_LOOP_GAIN, 0.3, None, "Analog mode: integrator gain k_I per sample, u += (k_I / analog_gain) e (0 < k_I < 1)").with_range(0.0, 1.0),
    Variable::parameter("analog_recentre_band", vr::ANALOG_RECENTRE_BAND, 1.5, V, "Analog mode: re-centre the extension when its command leaves [band, 10 V - band] (0.5 <= band < 4 V)").with_range(0.5, 4.0),
    Variable::boolean_parameter("disturbance_map", vr::DISTURBANCE_MAP, false, "Estimate the brake-disturbance map over the extension command (a second Kalman filter, 9 weights)"),
    Variable::boolean_parameter("use_disturbance_map", vr::USE_DISTURBANCE_MAP, false, "Plan with the map's prediction for the coming step (needs disturbance_map and use_disturbance_estimate)"),
    Variable::boolean_parameter("single_integrator", vr::SINGLE_INTEGRATOR, false, "Single-integrator compensator C(z) = single_integrator_gain instead of K (z - a)/(z - 1) (needs use_disturbance_map)"),
    Variable::parameter("single_integrator_gain", vr::SINGLE_INTEGRATOR_GAIN, 0.6, None, "k of the single-integrator compensator, loop k/(z - 1) (0 < k < 2)").with_range(0.0, 2.0),
];

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

fn real_param(p: &mut Params, r: u32) -> Option<&mut f64> {
    Some(match r {
        vr::DEADBAND => &mut p.deadband,
        vr::COMPENSATOR_GAIN => &mut p.gains.k,
        vr::COMPENSATOR_ZERO => &mut p.gains.a,
        vr::PREFILTER_POLE => &mut p.gains.prefilter_pole,
        vr::WEIGHT_PRIOR => &mut p.noise.weight_prior,
        vr::DISTURBANCE_PRIOR => &mut p.noise.disturbance_prior,
        vr::WEIGHT_PROCESS_NOISE => &mut p.noise.weight_process,
        vr::DISTURBANCE_PROCESS_NOISE => &mut p.noise.disturbance_process,
        vr::EXT_CMD_NOISE => &mut p.noise.ext_cmd_measurement,
        vr::BD_NOISE => &mut p.noise.bd_measurement,
        vr::Q_ENC => &mut p.q_enc,
        vr::DISTURBANCE_START => &mut p.disturbance_start,
        vr::ANALOG_RANGE => &mut p.analog_params.range,
        vr::ANALOG_GAIN => &mut p.analog_params.gain,
        vr::ANALOG_LOOP_GAIN => &mut p.analog_params.loop_gain,
        vr::ANALOG_RECENTRE_BAND => &mut p.analog_params.recentre_band,
        vr::SINGLE_INTEGRATOR_GAIN => &mut p.single_integrator_gain,
        r if (vr::BASIS_PEAK..vr::BASIS_PEAK + 10).contains(&r) => {
            &mut p.basis_peaks[(r - vr::BASIS_PEAK) as usize]
        }
        r if (vr::SCALE_WEIGHTS_START..vr::SCALE_WEIGHTS_START + 10).contains(&r) => {
            &mut p.scale_weights_start[(r - vr::SCALE_WEIGHTS_START) as usize]
        }
        _ => return None,
    })
}

fn bool_param(p: &mut Params, r: u32) -> Option<&mut bool> {
    Some(match r {
        vr::FEEDFORWARD => &mut p.feedforward,
        vr::PREFILTER => &mut p.prefilter,
        vr::USE_SCALE_FACTOR_ESTIMATE => &mut p.use_scale_factor_estimate,
        vr::USE_DISTURBANCE_ESTIMATE => &mut p.use_disturbance_estimate,
        vr::ANALOG => &mut p.analog,
        vr::DISTURBANCE_MAP => &mut p.disturbance_map,
        vr::USE_DISTURBANCE_MAP => &mut p.use_disturbance_map,
        vr::SINGLE_INTEGRATOR => &mut p.single_integrator,
        _ => return None,
    })
}

/// The most sample instants one call runs: a step or an event update runs every instant
/// it passes (some 0.1 µs each here), so that no time a master gives makes a call take
/// more than about a second. 10^7 samples are 20 000 s of simulated time.
const MAX_SAMPLES_PER_CALL: f64 = 1e7;

impl ControllerFmu {
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

    /// The Real `r`: an output of the sample `s`, an input or a parameter.
    fn real(&self, s: &Sample, r: u32) -> Result<f64, String> {
        Ok(match r {
            vr::REFERENCE => self.reference,
            vr::DAC_EARTH => s.dac[0],
            vr::DAC_NONEARTH => s.dac[1],
            vr::DAC_EXTENSION => s.dac[2],
            vr::SERVO_ERROR => s.servo_error,
            vr::DISTURBANCE_ESTIMATE => s.disturbance_estimate,
            vr::STEP_FORWARD => s.step_forward,
            vr::STEP_BACKWARD => s.step_backward,
            vr::FRACTION => s.fraction,
            r if (vr::SCALE_WEIGHTS..vr::SCALE_WEIGHTS + 10).contains(&r) => {
                s.scale_weights[(r - vr::SCALE_WEIGHTS) as usize]
            }
            _ => {
                let mut p = self.params.clone();
                *real_param(&mut p, r)
                    .ok_or_else(|| format!("no Real variable with value reference {r}"))?
            }
        })
    }

    /// The Integer `r`: an output of the sample `s`, an input or a parameter.
    fn integer(&self, s: &Sample, r: u32) -> Result<i32, String> {
        Ok(match r {
            vr::ENCODER_COUNTS => self.encoder_counts,
            vr::DAC_EARTH_CODE => i32::from(s.codes[0]),
            vr::DAC_NONEARTH_CODE => i32::from(s.codes[1]),
            vr::DAC_EXTENSION_CODE => i32::from(s.codes[2]),
            vr::N_STEPS => s.n_steps.min(i32::MAX as u32) as i32,
            vr::SAMPLES_PER_STEP => self.params.samples_per_step as i32,
            _ => return Err(format!("no Integer variable with value reference {r}")),
        })
    }
}

impl Model for ControllerFmu {
    fn info() -> &'static ModelInfo {
        &INFO
    }

    fn variables() -> &'static [Variable] {
        &VARIABLES
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

    fn get_real(&self, r: u32) -> Result<f64, String> {
        self.with_sample(|s| self.real(s, r))
    }

    fn get_integer(&self, r: u32) -> Result<i32, String> {
        self.with_sample(|s| self.integer(s, r))
    }

    fn get_boolean(&self, r: u32) -> Result<bool, String> {
        match r {
            vr::MOVING => Ok(self.with_sample(|s| s.moving)),
            _ => {
                let mut p = self.params.clone();
                bool_param(&mut p, r)
                    .map(|b| *b)
                    .ok_or_else(|| format!("no Boolean variable with value reference {r}"))
            }
        }
    }

    fn set_real(&mut self, r: u32, value: f64) -> Result<(), String> {
        if r == vr::REFERENCE {
            self.reference = value;
            return Ok(());
        }
        // Parameters are validated together at fmi2ExitInitializationMode.
        *real_param(&mut self.params, r)
            .ok_or_else(|| format!("no settable Real variable with value reference {r}"))? = value;
        Ok(())
    }

    fn set_integer(&mut self, r: u32, value: i32) -> Result<(), String> {
        match r {
            vr::ENCODER_COUNTS => self.encoder_counts = value,
            vr::SAMPLES_PER_STEP => self.params.samples_per_step = value.max(0) as u32,
            _ => return Err(format!("no settable Integer variable with value reference {r}")),
        }
        Ok(())
    }

    fn set_boolean(&mut self, r: u32, value: bool) -> Result<(), String> {
        *bool_param(&mut self.params, r)
            .ok_or_else(|| format!("no settable Boolean variable with value reference {r}"))? =
            value;
        Ok(())
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
