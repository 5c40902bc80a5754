//! The inchworm controller of docs/model.md §3 and §4 (the paper's section 3): stepping
//! gait, raw measurements, asynchronous compensator with prefilter and feedforward,
//! Kalman estimator of the inverse scale factor and the brake disturbance, waveform
//! generation. Plain Rust: no FFI, no globals, no I/O; the per-sample path does not
//! allocate (buffers are sized at construction), so it can move into board firmware.
//!
//! # Timing
//! The controller samples every `T_s` = 2 ms. Number the intervals `[j T_s, (j + 1) T_s)`,
//! j = 0, 1, …, and call [`Controller::tick`] at communication point `t = j T_s` tick j.
//! Tick j receives the encoder count that holds at `t`, which is the end of interval
//! j − 1, and returns the DAC sample to hold during interval j + 1. The sample held during
//! interval j was returned by tick j − 1 (interval 0 holds the parked sample a controller
//! starts with). That is a digital controller's one-sample delay: a plain Jacobi master
//! at 2 ms, which hands each side the other's outputs from the previous communication
//! point, closes the loop correctly.
//!
//! A step of `n` samples whose sample 1 is held during interval m (sample k during
//! interval m + k − 1):
//!
//! | tick | encoder holds | work | returns |
//! |---|---|---|---|
//! | m | `w_enc(n)` of the previous step | estimator update for the previous step; then, if its move is done, the control iteration with `y_k = s7` of that step | sample 2 |
//! | m + k − 2, k = 3..n | `w_enc(k − 2)` | record | sample k |
//! | m + n − 1 | `w_enc(n − 1)` | record | sample 1 (all zeros) of the next step |
//!
//! Sample 1 of every step is all zeros in both gaits, so it is returned before the move
//! is known and the move is chosen while it is out. Tick 0 takes the parked interval 0 as
//! sample 1 of the first step: nothing to measure yet, so it iterates from the encoder
//! count at t = 0 (which also starts the prefilter and the feedforward's previous
//! reference there).

pub mod analog;
pub mod basis;
pub mod bdmap;
pub mod compensator;
pub mod estimator;
pub mod feedforward;
pub mod gait;
pub mod measurements;
pub mod prefilter;
pub mod waveform;

use analog::{Analog, AnalogParams};
use basis::Basis;
use bdmap::DisturbanceMap;
use compensator::{Gains, Loop};
use estimator::{Estimator, Noise};
use gait::{Direction, Timing};
use waveform::Plan;

/// Layout version of [`Controller::save_state`]; raise it whenever the layout changes.
pub const STATE_VERSION: u8 = 1;

/// Controller sample period (s).
pub const SAMPLE_PERIOD: f64 = 0.002;
/// Full scale of the 16-bit DACs (V).
pub const DAC_FULL_SCALE: f64 = 10.0;
pub const DAC_MAX_CODE: u16 = u16::MAX;

/// Estimates the estimator converges to on the fia20 plant in regulation (weights of the
/// inverse scale factor at the default basis peaks, and the brake disturbance in m). See
/// docs/controller-design.md for the run that produced them and how to redo it.
pub const CALIBRATED_WEIGHTS: [f64; 10] = [
    -1.172492, -0.833551, -0.444175, -0.174458, -0.054124, 0.052323, 0.176492, 0.436781, 0.872245,
    1.105740,
];
pub const CALIBRATED_DISTURBANCE: f64 = 4.7012e-6;

/// The nominal linear inverse scale factor of the 20 µm device: weight = peak / 20 µm.
pub const NOMINAL_WEIGHTS: [f64; 10] = [-1.2, -0.8, -0.4, -0.15, -0.05, 0.05, 0.15, 0.4, 0.8, 1.2];

#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    pub feedforward: bool,
    pub prefilter: bool,
    pub use_scale_factor_estimate: bool,
    pub use_disturbance_estimate: bool,
    /// No step while |reference − position| is below this (m); 0 = always step.
    pub deadband: f64,
    pub samples_per_step: u32,
    pub gains: Gains,
    pub noise: Noise,
    pub basis_peaks: [f64; 10],
    pub scale_weights_start: [f64; 10],
    pub disturbance_start: f64,
    /// Encoder resolution (m per count).
    pub q_enc: f64,
    /// Analog mode near the target ([`analog`], docs/model.md §4.2); default off.
    pub analog: bool,
    pub analog_params: AnalogParams,
    /// Estimate the brake-disturbance map over the extension command ([`bdmap`]).
    pub disturbance_map: bool,
    /// Plan with the map's prediction for the coming step instead of the latest estimate
    /// (needs `disturbance_map` and `use_disturbance_estimate`).
    pub use_disturbance_map: bool,
    /// The single-integrator compensator `C(z) = single_integrator_gain` instead of
    /// `K (z − a)/(z − 1)` (needs `use_disturbance_map`).
    pub single_integrator: bool,
    pub single_integrator_gain: f64,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            feedforward: true,
            prefilter: false,
            use_scale_factor_estimate: true,
            use_disturbance_estimate: true,
            deadband: 0.0,
            samples_per_step: 100,
            gains: Gains::default(),
            noise: Noise::default(),
            basis_peaks: basis::FIA20_PEAKS,
            scale_weights_start: CALIBRATED_WEIGHTS,
            disturbance_start: CALIBRATED_DISTURBANCE,
            q_enc: 1.2e-9,
            analog: false,
            analog_params: AnalogParams::default(),
            disturbance_map: false,
            use_disturbance_map: false,
            single_integrator: false,
            single_integrator_gain: 0.6,
        }
    }
}

impl Params {
    /// Checks every value; the error names the parameter.
    pub fn validate(&self) -> Result<(), String> {
        let finite = |name: &str, v: f64| {
            if v.is_finite() {
                Ok(())
            } else {
                Err(format!("{name} must be finite, got {v}"))
            }
        };
        let positive = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be > 0, got {v}"))
            }
        };
        if !(self.deadband.is_finite() && self.deadband >= 0.0) {
            return Err(format!("deadband must be >= 0, got {}", self.deadband));
        }
        if !(7..=10_000).contains(&self.samples_per_step) {
            return Err(format!(
                "samples_per_step must be within 7..10000, got {}",
                self.samples_per_step
            ));
        }
        positive("compensator_gain", self.gains.k)?;
        if !(0.0..1.0).contains(&self.gains.a) {
            return Err(format!("compensator_zero must be in [0, 1), got {}", self.gains.a));
        }
        if !(0.0..1.0).contains(&self.gains.prefilter_pole) {
            return Err(format!(
                "prefilter_pole must be in [0, 1), got {}",
                self.gains.prefilter_pole
            ));
        }
        let n = &self.noise;
        for (name, v) in [
            ("weight_prior", n.weight_prior),
            ("disturbance_prior", n.disturbance_prior),
            ("weight_process_noise", n.weight_process),
            ("disturbance_process_noise", n.disturbance_process),
            ("ext_cmd_noise", n.ext_cmd_measurement),
            ("bd_noise", n.bd_measurement),
        ] {
            positive(name, v)?;
        }
        Basis::new(self.basis_peaks).map_err(|e| format!("basis_peak: {e}"))?;
        for (i, w) in self.scale_weights_start.iter().enumerate() {
            finite(&format!("scale_weights_start[{}]", i + 1), *w)?;
        }
        finite("disturbance_start", self.disturbance_start)?;
        positive("q_enc", self.q_enc)?;
        if self.use_disturbance_map && !(self.disturbance_map && self.use_disturbance_estimate) {
            return Err(
                "use_disturbance_map needs disturbance_map and use_disturbance_estimate on".into(),
            );
        }
        if self.single_integrator {
            if !self.use_disturbance_map {
                return Err("single_integrator needs use_disturbance_map on (the map's prediction replaces the second integrator)".into());
            }
            let k = self.single_integrator_gain;
            if !(k > 0.0 && k < 2.0) {
                return Err(format!("single_integrator_gain must be in (0, 2), got {k}"));
            }
        }
        if self.analog {
            self.analog_params.validate()?;
            if self.deadband > 0.0 {
                return Err(format!(
                    "deadband must be 0 with analog on (analog mode holds the target instead of parking), got {}",
                    self.deadband
                ));
            }
        }
        Ok(())
    }
}

/// What the controller drives during one step.
#[derive(Clone, Copy, Debug, PartialEq)]
enum StepKind {
    /// Parked: all samples zero (deadband, or before the first move).
    Idle,
    Gait {
        direction: Direction,
        amplitude: f64,
    },
}

/// What one tick returns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Quantized DAC volts (earth, non-earth, extension) to hold over the next interval.
    pub dac: [f64; 3],
    pub codes: [u16; 3],
    /// reference − encoder position (m).
    pub servo_error: f64,
    pub disturbance_estimate: f64,
    pub step_forward: f64,
    pub step_backward: f64,
    pub n_steps: u32,
    pub fraction: f64,
    pub scale_weights: [f64; 10],
    pub moving: bool,
    /// A control iteration ran at this tick.
    pub iterated: bool,
    /// The inverse scale factor had no root in its bracket at this iteration.
    pub no_root: bool,
}

#[derive(Clone, Debug)]
pub struct Controller {
    params: Params,
    basis: Basis,
    timing: Timing,
    estimator: Estimator,
    feedback: Loop,
    /// Sample (1-based) of the current step held during the current interval.
    sample: usize,
    current: StepKind,
    /// Whether the current step is the first tick's pseudo-step (nothing to measure).
    first: bool,
    /// `w_enc(k)` (m) and `w_ext(k)` of the current step.
    enc: Vec<f64>,
    ext: Vec<f64>,
    full_steps_left: u32,
    move_direction: Direction,
    fraction_left: Option<f64>,
    plan: Option<Plan>,
    iterations: u64,
    analog: Analog,
    bdmap: Option<DisturbanceMap>,
    /// At a tick that updated the estimator with the map on: the measured BD, and it
    /// minus the latest estimate and minus the map's prediction, both from before the
    /// update.
    bd_residuals: Option<(f64, f64, f64)>,
}

/// The plan of a move `d` with the disturbance the map predicts for each of its steps
/// from the latest estimate `level`:
/// the full steps' at ±1, the fraction's at its own amplitude (a fixed point, three
/// passes: the map is flat to a few percent over a step's change of amplitude).
fn mapped_plan(basis: &Basis, theta: &[f64; 10], map: &DisturbanceMap, level: f64, d: f64) -> Plan {
    let predict = |c: f64| map.predict_from(level, c);
    let full = predict(if d >= 0.0 { 1.0 } else { -1.0 });
    let mut plan = waveform::plan(basis, theta, full, d);
    let sd = if d >= 0.0 { plan.step_forward } else { plan.step_backward };
    let frac_d = d - f64::from(plan.n_steps) * sd.unwrap_or(0.0);
    let mut y = basis.eval(frac_d - full, theta).clamp(-1.0, 1.0);
    for _ in 0..3 {
        y = basis.eval(frac_d - predict(y), theta).clamp(-1.0, 1.0);
    }
    plan.fraction = y;
    plan
}

fn quantize(v: f64) -> (f64, u16) {
    let code = (v / DAC_FULL_SCALE * f64::from(DAC_MAX_CODE))
        .round()
        .clamp(0.0, f64::from(DAC_MAX_CODE)) as u16;
    (volts_of_code(code), code)
}

/// The volts a DAC code stands for: the inverse of the controller's quantizer, and the
/// very value it holds as its quantized output. Whoever turns codes back into volts (a
/// board, a co-simulation) calls this, so the plant sees the same bits either way.
pub fn volts_of_code(code: u16) -> f64 {
    f64::from(code) * DAC_FULL_SCALE / f64::from(DAC_MAX_CODE)
}

impl Controller {
    pub fn new(params: Params) -> Result<Controller, String> {
        params.validate()?;
        let basis = Basis::new(params.basis_peaks)?;
        let n = params.samples_per_step as usize;
        let estimator =
            Estimator::new(params.scale_weights_start, params.disturbance_start, &params.noise);
        Ok(Controller {
            timing: Timing::new(n),
            basis,
            estimator,
            feedback: Loop::default(),
            sample: 1,
            current: StepKind::Idle,
            first: true,
            enc: vec![0.0; n],
            ext: vec![0.0; n],
            full_steps_left: 0,
            move_direction: Direction::Forward,
            fraction_left: None,
            plan: None,
            iterations: 0,
            analog: Analog::new(params.disturbance_start / params.analog_params.gain),
            bdmap: params.disturbance_map.then(|| {
                DisturbanceMap::new(
                    params.disturbance_start,
                    params.noise.disturbance_prior,
                    params.noise.disturbance_process,
                    params.noise.bd_measurement,
                )
            }),
            bd_residuals: None,
            params,
        })
    }

    pub fn params(&self) -> &Params {
        &self.params
    }

    pub fn estimator(&self) -> &Estimator {
        &self.estimator
    }

    /// The analog mode's state (phase, extension command, entries and re-centrings).
    pub fn analog(&self) -> &Analog {
        &self.analog
    }

    /// The brake-disturbance map, when `disturbance_map` is on.
    pub fn disturbance_map(&self) -> Option<&DisturbanceMap> {
        self.bdmap.as_ref()
    }

    /// Set at a tick that updated the estimator, with the map on: (measured BD, measured
    /// BD − latest estimate, measured BD − map prediction), both before the update.
    pub fn bd_residuals(&self) -> Option<(f64, f64, f64)> {
        self.bd_residuals
    }

    /// Control iterations run so far.
    pub fn iterations(&self) -> u64 {
        self.iterations
    }

    /// The weights and disturbance the waveform generator uses, per the flags.
    fn estimates(&self) -> ([f64; 10], f64) {
        let theta = if self.params.use_scale_factor_estimate {
            self.estimator.weights()
        } else {
            self.params.scale_weights_start
        };
        let bd =
            if self.params.use_disturbance_estimate { self.estimator.disturbance() } else { 0.0 };
        (theta, bd)
    }

    /// One 2 ms tick: `encoder_counts` holds now; returns the sample for the next interval.
    pub fn tick(&mut self, encoder_counts: i64, reference: f64) -> Sample {
        let n = self.timing.samples;
        let y_now = encoder_counts as f64 * self.params.q_enc;
        let mut iterated = false;
        let mut no_root = false;
        if self.bdmap.is_some() {
            self.bd_residuals = None;
        }
        if self.analog.active() {
            let volts = self.analog.tick(&self.params.analog_params, y_now, reference);
            if !self.analog.active() {
                // Parked again: the next tick starts a step with nothing to measure, and
                // the stepping loop's feedforward from where the runner was held.
                self.feedback.hold(self.analog.tracked(), y_now);
                self.sample = 1;
                self.first = true;
                self.current = StepKind::Idle;
            }
            return self.output(volts, reference, y_now, false, false);
        }
        if self.sample == 1 {
            // The encoder reads w_enc(n) of the step that just finished.
            let mut y_measured = y_now;
            if !self.first {
                self.enc[n - 1] = y_now;
                let direction = match self.current {
                    StepKind::Gait { direction, .. } => Some(direction),
                    StepKind::Idle => None,
                };
                let raw = measurements::raw(
                    &self.timing,
                    direction.unwrap_or(Direction::Forward),
                    &self.enc,
                    &self.ext,
                );
                if direction.is_some() {
                    let t_step = n as f64 * SAMPLE_PERIOD;
                    if let Some(m) = &mut self.bdmap {
                        let level = self.estimator.disturbance();
                        self.bd_residuals = Some((
                            raw.bd,
                            raw.bd - level,
                            raw.bd - m.predict_from(level, raw.ext_cmd),
                        ));
                        m.update(t_step, raw.ext_cmd, raw.bd);
                    }
                    self.estimator.update(&self.basis, t_step, raw.ext_cmd, raw.ext_moved, raw.bd);
                }
                y_measured = raw.s[6];
            }
            self.first = false;
            if self.params.analog
                && self.full_steps_left == 0
                && self.fraction_left.is_none()
                && (reference - y_measured).abs() < self.params.analog_params.range
            {
                // Near the target: hold in DRIVE instead of stepping. The feedforward takes
                // the reference as its previous one, as in the deadband.
                self.feedback.hold(reference, y_measured);
                self.iterations += 1;
                self.analog.offset =
                    if self.params.use_disturbance_estimate && self.analog.entries == 0 {
                        self.estimator.disturbance() / self.params.analog_params.gain
                    } else {
                        self.analog.offset
                    };
                self.analog.enter();
                let volts = self.analog.tick(&self.params.analog_params, y_now, reference);
                return self.output(volts, reference, y_now, true, false);
            }
            if self.full_steps_left == 0 && self.fraction_left.is_none() {
                let d = if self.params.single_integrator {
                    self.feedback.iterate_single(
                        self.params.single_integrator_gain,
                        &self.params.gains,
                        reference,
                        y_measured,
                        self.params.prefilter,
                        self.params.feedforward,
                        self.params.deadband,
                    )
                } else {
                    self.feedback.iterate(
                        &self.params.gains,
                        reference,
                        y_measured,
                        self.params.prefilter,
                        self.params.feedforward,
                        self.params.deadband,
                    )
                };
                self.iterations += 1;
                iterated = true;
                if d != 0.0 || self.params.deadband == 0.0 {
                    let (theta, bd) = self.estimates();
                    let plan = match (&self.bdmap, self.params.use_disturbance_map) {
                        (Some(m), true) => mapped_plan(&self.basis, &theta, m, bd, d),
                        _ => waveform::plan(&self.basis, &theta, bd, d),
                    };
                    no_root = plan.no_root;
                    self.full_steps_left = plan.n_steps;
                    self.move_direction =
                        if plan.direction >= 0 { Direction::Forward } else { Direction::Backward };
                    self.fraction_left = Some(plan.fraction);
                    self.plan = Some(plan);
                }
            }
            self.current = if self.full_steps_left > 0 {
                self.full_steps_left -= 1;
                StepKind::Gait { direction: self.move_direction, amplitude: 1.0 }
            } else if let Some(f) = self.fraction_left.take() {
                let direction = if f >= 0.0 { Direction::Forward } else { Direction::Backward };
                StepKind::Gait { direction, amplitude: f.abs() }
            } else {
                StepKind::Idle
            };
            self.ext[0] = 0.0;
        } else {
            self.enc[self.sample - 2] = y_now;
        }

        // The sample for the next interval.
        let next = if self.sample == n { 1 } else { self.sample + 1 };
        let volts = match (next, self.current) {
            (1, _) | (_, StepKind::Idle) => [0.0; 3],
            (k, StepKind::Gait { direction, amplitude }) => {
                self.timing.volts(direction, amplitude, k)
            }
        };
        if next > 1 {
            self.ext[next - 1] = volts[2] / DAC_FULL_SCALE;
        }
        self.sample = next;
        self.output(volts, reference, y_now, iterated, no_root)
    }

    /// The sample for commanded `volts`, with the plan outputs of the latest move.
    fn output(
        &self,
        volts: [f64; 3],
        reference: f64,
        y_now: f64,
        iterated: bool,
        no_root: bool,
    ) -> Sample {
        let q = volts.map(quantize);
        let plan = self.plan.unwrap_or(Plan {
            step_forward: None,
            step_backward: None,
            n_steps: 0,
            direction: 1,
            fraction: 0.0,
            no_root: false,
        });
        Sample {
            dac: q.map(|(v, _)| v),
            codes: q.map(|(_, c)| c),
            servo_error: reference - y_now,
            disturbance_estimate: self.estimator.disturbance(),
            step_forward: plan.step_forward.unwrap_or(0.0),
            step_backward: plan.step_backward.unwrap_or(0.0),
            n_steps: plan.n_steps,
            fraction: plan.fraction,
            scale_weights: self.estimator.weights(),
            moving: matches!(self.current, StepKind::Gait { .. }) || self.analog.active(),
            iterated,
            no_root,
        }
    }

    /// Appends the complete dynamic state (not the parameters), little-endian, headed by
    /// [`STATE_VERSION`] and the samples per step it was taken with.
    pub fn save_state(&self, out: &mut Vec<u8>) {
        let mut w = inchworm_state_bytes::Writer(out);
        w.u8(STATE_VERSION);
        w.u64(self.timing.samples as u64);
        for v in self.estimator.x.iter().chain(self.estimator.p.iter()) {
            w.f64(*v);
        }
        self.feedback.save(&mut w);
        w.u64(self.sample as u64);
        match self.current {
            StepKind::Idle => {
                w.u8(0);
                w.f64(0.0);
            }
            StepKind::Gait { direction, amplitude } => {
                w.u8(if direction == Direction::Forward { 1 } else { 2 });
                w.f64(amplitude);
            }
        }
        w.u8(u8::from(self.first));
        for v in self.enc.iter().chain(self.ext.iter()) {
            w.f64(*v);
        }
        w.u64(u64::from(self.full_steps_left));
        w.u8(if self.move_direction == Direction::Forward { 1 } else { 2 });
        match self.fraction_left {
            None => w.u8(0),
            Some(f) => {
                w.u8(1);
                w.f64(f);
            }
        }
        match self.plan {
            None => w.u8(0),
            Some(p) => {
                w.u8(1);
                w.f64(p.step_forward.unwrap_or(f64::NAN));
                w.f64(p.step_backward.unwrap_or(f64::NAN));
                w.u64(u64::from(p.n_steps));
                w.u8(p.direction as u8);
                w.f64(p.fraction);
                w.u8(u8::from(p.no_root));
            }
        }
        w.u64(self.iterations);
        // Only with the option on, so the default layout is unchanged.
        if self.params.analog {
            self.analog.save(&mut w);
        }
        if let Some(m) = &self.bdmap {
            m.save(&mut w);
        }
    }

    /// Restores what `save_state` wrote, for a controller with the same parameters; on
    /// error the controller is unchanged.
    pub fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        let mut r = inchworm_state_bytes::Reader::new(bytes, "controller state");
        let version = r.u8()?;
        if version != STATE_VERSION {
            return Err(format!("controller state has version {version}, this controller reads version {STATE_VERSION}"));
        }
        let samples = r.u64()?;
        if samples != self.timing.samples as u64 {
            return Err(format!("controller state was taken with samples_per_step = {samples}, this controller has {}", self.timing.samples));
        }
        let mut next = self.clone();
        for v in next.estimator.x.iter_mut() {
            *v = r.f64()?;
        }
        for v in next.estimator.p.iter_mut() {
            *v = r.f64()?;
        }
        next.feedback = Loop::load(&mut r)?;
        next.sample = r.u64()? as usize;
        let kind = r.u8()?;
        let amplitude = r.f64()?;
        next.current = match kind {
            0 => StepKind::Idle,
            1 => StepKind::Gait { direction: Direction::Forward, amplitude },
            2 => StepKind::Gait { direction: Direction::Backward, amplitude },
            k => return Err(format!("controller state: invalid step kind {k}")),
        };
        next.first = r.bool()?;
        for v in next.enc.iter_mut().chain(next.ext.iter_mut()) {
            *v = r.f64()?;
        }
        next.full_steps_left =
            u32::try_from(r.u64()?).map_err(|_| "controller state: step count out of range")?;
        next.move_direction = match r.u8()? {
            1 => Direction::Forward,
            2 => Direction::Backward,
            d => return Err(format!("controller state: invalid move direction {d}")),
        };
        next.fraction_left = if r.bool()? { Some(r.f64()?) } else { None };
        next.plan = if r.bool()? {
            let opt = |v: f64| (!v.is_nan()).then_some(v);
            Some(Plan {
                step_forward: opt(r.f64()?),
                step_backward: opt(r.f64()?),
                n_steps: u32::try_from(r.u64()?)
                    .map_err(|_| "controller state: n_steps out of range")?,
                direction: r.u8()? as i8,
                fraction: r.f64()?,
                no_root: r.bool()?,
            })
        } else {
            None
        };
        next.iterations = r.u64()?;
        if self.params.analog {
            next.analog = Analog::load(&mut r)?;
        }
        if let Some(m) = &mut next.bdmap {
            m.load(&mut r)?;
        }
        r.finish()?;
        if !(1..=self.timing.samples).contains(&next.sample) {
            return Err(format!("controller state: sample {} outside the step", next.sample));
        }
        *self = next;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validate_names_the_field() {
        assert_eq!(Params::default().validate(), Ok(()));
        let d = Params::default;
        let mut peaks = basis::FIA20_PEAKS;
        peaks.swap(1, 2);
        let mut weights = NOMINAL_WEIGHTS;
        weights[3] = f64::NAN;
        let cases: [(&str, Params); 11] = [
            ("deadband", Params { deadband: -1e-9, ..d() }),
            ("samples_per_step", Params { samples_per_step: 6, ..d() }),
            ("compensator_gain", Params { gains: Gains { k: 0.0, ..Gains::default() }, ..d() }),
            ("compensator_zero", Params { gains: Gains { a: 1.0, ..Gains::default() }, ..d() }),
            (
                "prefilter_pole",
                Params { gains: Gains { prefilter_pole: -0.1, ..Gains::default() }, ..d() },
            ),
            (
                "weight_process_noise",
                Params {
                    noise: Noise { weight_process: f64::INFINITY, ..Noise::default() },
                    ..d()
                },
            ),
            (
                "bd_noise",
                Params { noise: Noise { bd_measurement: 0.0, ..Noise::default() }, ..d() },
            ),
            ("basis_peak", Params { basis_peaks: peaks, ..d() }),
            ("scale_weights_start[4]", Params { scale_weights_start: weights, ..d() }),
            ("disturbance_start", Params { disturbance_start: f64::NAN, ..d() }),
            ("q_enc", Params { q_enc: 0.0, ..d() }),
        ];
        for (field, p) in cases {
            let e = p.validate().expect_err(field);
            assert!(e.starts_with(field), "error for {field}: {e:?}");
            assert!(Controller::new(p).is_err());
        }
    }

    #[test]
    fn analog_options_are_checked_together() {
        let on = || Params { analog: true, ..Params::default() };
        assert_eq!(on().validate(), Ok(()));
        let a = AnalogParams::default;
        let cases: [(&str, Params); 5] = [
            ("deadband", Params { deadband: 1e-9, ..on() }),
            ("analog_range", Params { analog_params: AnalogParams { range: 3e-6, ..a() }, ..on() }),
            ("analog_gain", Params { analog_params: AnalogParams { gain: 0.0, ..a() }, ..on() }),
            (
                "analog_loop_gain",
                Params { analog_params: AnalogParams { loop_gain: 1.0, ..a() }, ..on() },
            ),
            (
                "analog_recentre_band",
                Params { analog_params: AnalogParams { recentre_band: 4.0, ..a() }, ..on() },
            ),
        ];
        for (field, p) in cases {
            let e = p.validate().expect_err(field);
            assert!(e.starts_with(field), "error for {field}: {e:?}");
            // Off, the analog values are not looked at.
            assert_eq!(Params { analog: false, deadband: 0.0, ..p }.validate(), Ok(()));
        }
    }

    #[test]
    fn the_disturbance_map_flag_needs_the_map_and_the_estimate() {
        let e = Params { use_disturbance_map: true, ..Params::default() }.validate().unwrap_err();
        assert!(e.starts_with("use_disturbance_map"), "{e}");
        let p = Params {
            use_disturbance_map: true,
            disturbance_map: true,
            use_disturbance_estimate: false,
            ..Params::default()
        };
        assert!(p.validate().is_err());
        assert_eq!(Params { use_disturbance_map: false, ..p }.validate(), Ok(()));
        let e = Params { single_integrator: true, ..Params::default() }.validate().unwrap_err();
        assert!(e.starts_with("single_integrator"), "{e}");
        let p = Params {
            single_integrator: true,
            single_integrator_gain: 2.0,
            disturbance_map: true,
            use_disturbance_map: true,
            ..Params::default()
        };
        assert!(p.validate().unwrap_err().starts_with("single_integrator_gain"));
        assert_eq!(Params { single_integrator_gain: 0.6, ..p }.validate(), Ok(()));
    }

    #[test]
    fn disturbance_map_state_round_trips() {
        let p = Params { disturbance_map: true, use_disturbance_map: true, ..Params::default() };
        let mut c = Controller::new(p.clone()).unwrap();
        for k in 0..1000 {
            c.tick(k / 10, 30e-6);
        }
        let mut bytes = Vec::new();
        c.save_state(&mut bytes);
        let mut d = Controller::new(p).unwrap();
        d.load_state(&bytes).unwrap();
        assert_eq!(c.disturbance_map(), d.disturbance_map());
        for k in 1000..1500 {
            assert_eq!(c.tick(k / 10, 30e-6), d.tick(k / 10, 30e-6), "tick {k}");
        }
    }

    #[test]
    fn analog_state_is_saved_only_with_the_option_on() {
        let mut off = Vec::new();
        Controller::new(Params::default()).unwrap().save_state(&mut off);
        let mut c = Controller::new(Params { analog: true, ..Params::default() }).unwrap();
        // Into analog hold: the first iteration is within range of the reference.
        for _ in 0..20 {
            c.tick(0, 1e-6);
        }
        assert!(c.analog().active());
        let mut on = Vec::new();
        c.save_state(&mut on);
        assert!(on.len() > off.len());
        let mut d = Controller::new(Params { analog: true, ..Params::default() }).unwrap();
        d.load_state(&on).unwrap();
        for k in 0..200 {
            assert_eq!(c.tick(k, 1e-6), d.tick(k, 1e-6), "tick {k}");
        }
    }

    #[test]
    fn dac_quantization_is_16_bit_over_10_v() {
        assert_eq!(quantize(0.0), (0.0, 0));
        assert_eq!(quantize(10.0), (10.0, 65535));
        assert_eq!(quantize(12.0).1, 65535, "clamped to full scale");
        let (v, c) = quantize(3.0);
        assert_eq!(c, 19661, "3 V = 0.3 × 65535 = 19660.5, rounded half away from zero");
        assert_eq!(v, 19661.0 * 10.0 / 65535.0);
    }

    #[test]
    fn volts_of_code_inverts_the_quantizer_bit_for_bit() {
        for code in 0..=DAC_MAX_CODE {
            let v = volts_of_code(code);
            // The quantizer's own volts for that code, and the formula boards used before.
            assert_eq!(quantize(v), (v, code), "code {code}");
            assert_eq!(v.to_bits(), (f64::from(code) * 10.0 / 65535.0).to_bits(), "code {code}");
        }
        assert_eq!((volts_of_code(0), volts_of_code(DAC_MAX_CODE)), (0.0, DAC_FULL_SCALE));
    }
}
