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
pub mod dac;
pub mod estimator;
pub mod feedforward;
pub mod gait;
pub mod measurements;
pub mod params;
pub mod prefilter;
mod state;
pub mod waveform;

pub use dac::{volts_of_code, DAC_FULL_SCALE, DAC_MAX_CODE};
pub use params::{Params, CALIBRATED_DISTURBANCE, CALIBRATED_WEIGHTS, NOMINAL_WEIGHTS};
pub use state::STATE_VERSION;

use analog::Analog;
use basis::Basis;
use bdmap::DisturbanceMap;
use compensator::{Law, Loop};
use dac::quantize;
use estimator::Estimator;
use gait::{Direction, Timing};
use waveform::Plan;

/// Controller sample period (s).
pub const SAMPLE_PERIOD: f64 = 0.002;

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
    /// The last tick ended a gait step and updated the estimator with its measurements.
    estimated: bool,
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
            estimated: false,
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

    /// Whether the last tick ended a gait step and updated the estimator (the scale-factor
    /// weights and the disturbance estimate) with the step's measurements. Not part of the
    /// saved state: a restored controller says false until its next tick.
    pub fn estimated(&self) -> bool {
        self.estimated
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
        self.estimated = false;
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
                    self.estimated = true;
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
                let p = &self.params;
                let law = if p.single_integrator {
                    Law::Proportional(p.single_integrator_gain)
                } else {
                    Law::Lead
                };
                let d = self.feedback.iterate(
                    law,
                    &p.gains,
                    reference,
                    y_measured,
                    p.prefilter,
                    p.feedforward,
                    p.deadband,
                );
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
}
