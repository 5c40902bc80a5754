//! The delay line closed around the fringe tracker (docs/delay-line.md §3): the inchworm
//! moving a cat's eye (optical path = 2 × runner displacement), on a cart on the ground or
//! alone in space, a fine stage optional, sampled every 2 ms with the inchworm's own
//! controller.
//!
//! Each sample `k`, at `t = k h`:
//! 1. the path to add: on the ground the sidereal delay since the start `D(t) − D(0)` plus
//!    the atmosphere's piston; in space a retargeting move, a slow drift and vibration
//!    lines (no Earth rotation: the interferometer is one spacecraft);
//! 2. the cart (ground, where there is one) follows the sidereal delay, rate-limited, with
//!    its tracking error; its metrology gives the cart's path to the inchworm;
//! 3. the inchworm's reference is the known model of the path (the sidereal delay, the
//!    move) less the cart, plus the offload, all halved (the cat's eye doubles the path);
//!    its controller ticks and the plant steps;
//! 4. the residual `x = path − cart − 2 runner − fine` at the sample's end is what the
//!    fringe tracker measures; its estimate drives the fine stage, whose position is
//!    offloaded to the inchworm's reference by an integrator of time constant
//!    `offload_time` (without a fine stage the estimate itself is integrated into it).
//!
//! A sample where the tracker sees no fringes holds the fine stage and the offload: the
//! run reports it as lost lock. A runner beyond half the stroke ends the run early.

use inchworm_controller::{Controller, Params, SAMPLE_PERIOD};
use inchworm_declare::{Declare, Declared};
use inchworm_plant::{Dac, Plant, PlantParams};

use crate::disturbance::{GaussMarkov, Lines, PistonSpectrum};
use crate::fine_stage::{FineStage, FineStageError, FineStageParams};
use crate::fringes::{self, H_BAND, N_BAND};
use crate::geometry::{GeometryError, Sidereal};
use crate::tracker::{FringeTracker, Reading, TrackerError, TrackerParams};

/// The delay line, its sky and its disturbances: every parameter declared once on its
/// field (the start value is the default; docs/delay-line.md §5 lists them with their
/// sources).
#[derive(Clone, Debug, PartialEq, Declare)]
pub struct DelayLineParams {
    /// In space (true: a structurally connected interferometer, the inchworm alone) or on the ground (false: on a cart)
    #[var(start = false)]
    pub space: bool,
    /// Baseline length
    #[var(unit = "m", start = 10.0, min = 1e-3, max = 1e4)]
    pub baseline_length: f64,
    /// Baseline azimuth from north through east
    #[var(unit = "deg", start = 90.0, min = -360.0, max = 360.0)]
    pub baseline_azimuth: f64,
    /// Baseline elevation above the horizon
    #[var(unit = "deg", start = 0.0, min = -90.0, max = 90.0)]
    pub baseline_elevation: f64,
    /// Site latitude (Cerro Paranal)
    #[var(unit = "deg", start = -24.627, min = -90.0, max = 90.0)]
    pub latitude: f64,
    /// Star declination
    #[var(unit = "deg", start = -30.0, min = -90.0, max = 90.0)]
    pub declination: f64,
    /// Star hour angle at the start of the run
    #[var(unit = "deg", start = 0.0, min = -180.0, max = 180.0)]
    pub hour_angle: f64,
    /// Runner stroke of the inchworm (centimetre class, paper §1)
    #[var(unit = "m", start = 10e-3, min = 1e-6, max = 1.0)]
    pub stroke: f64,
    /// A cart carries the sidereal path (ground; false: the inchworm takes it all)
    #[var(start = true)]
    pub cart: bool,
    /// Largest rate of the cart in optical path (ground)
    #[var(unit = "m/s", start = 0.05, min = 0.0, max = 10.0)]
    pub cart_rate_limit: f64,
    /// RMS of the cart's tracking error in optical path (ground; a first-order process)
    #[var(unit = "m", start = 1e-6, min = 0.0, max = 1e-3)]
    pub cart_error: f64,
    /// Correlation time of the cart's tracking error
    #[var(unit = "s", start = 0.5, min = 1e-3, max = 1e4)]
    pub cart_error_time: f64,
    /// RMS of the atmospheric differential piston over 0.01-250 Hz (ground; a site's outer scale sets it)
    #[var(unit = "m", start = 2e-6, min = 0.0, max = 1e-3)]
    pub piston: f64,
    /// Wind speed carrying the turbulence (ground)
    #[var(unit = "m/s", start = 10.0, min = 0.1, max = 100.0)]
    pub wind_speed: f64,
    /// Telescope aperture diameter (ground)
    #[var(unit = "m", start = 1.8, min = 0.01, max = 50.0)]
    pub aperture: f64,
    /// RMS of the spacecraft's vibration lines in optical path (space)
    #[var(unit = "m", start = 10e-9, min = 0.0, max = 1e-3)]
    pub vibration: f64,
    /// Thermal drift rate of the path (space)
    #[var(unit = "m/s", start = 10e-9, min = -1e-2, max = 1e-2)]
    pub drift_rate: f64,
    /// A retargeting move of the path at the start (space): the inchworm slews it, the tracker finds the fringes after
    #[var(unit = "m", start = 0.0, min = -1e-1, max = 1e-1)]
    pub retarget: f64,
    /// Random disturbances on: the piston, the vibration lines, the cart's error (false: the sidereal path, the move and the drift only)
    #[var(start = true)]
    pub disturbances: bool,
    /// Time constant of the offload of the fine stage (or the tracker) to the inchworm
    #[var(unit = "s", start = 0.5, min = 1e-3, max = 1e4)]
    pub offload_time: f64,
    /// The inchworm follows the sidereal model (false: only the offload moves it)
    #[var(start = true)]
    pub feedforward: bool,
    /// Exposure of a science-camera frame
    #[var(unit = "s", start = 0.05, min = 2e-3, max = 100.0)]
    pub science_frame: f64,
    /// Time from the start left out of the figures (acquisition, settling)
    #[var(unit = "s", start = 2.0, min = 0.0, max = 1e5)]
    pub settle_time: f64,
    /// Seed of the disturbances
    #[var(start = 11)]
    pub seed: u64,
    #[var(flatten)]
    pub tracker: TrackerParams,
    #[var(flatten)]
    pub fine: FineStageParams,
}

impl Default for DelayLineParams {
    fn default() -> Self {
        DelayLineParams::declared()
    }
}

/// What refuses a run before it starts.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    #[error("delay line: {name}: {why}")]
    Range { name: &'static str, why: String },
    #[error(transparent)]
    Geometry(#[from] GeometryError),
    #[error(transparent)]
    Tracker(#[from] TrackerError),
    #[error(transparent)]
    FineStage(#[from] FineStageError),
    #[error("delay line: the plant: {0}")]
    Plant(#[from] inchworm_plant::ParamError),
    #[error("delay line: the plant's step: {0}")]
    Step(#[from] inchworm_plant::StepError),
    #[error("delay line: the controller: {0}")]
    Controller(String),
    #[error("delay line: a run of {0} s (it must be finite, 0 < T ≤ 1e5)")]
    Duration(f64),
}

/// One run, sample by sample (every column one entry per 2 ms point, the first at t = 0).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Run {
    pub time: Vec<f64>,
    /// The optical path to add (m).
    pub path: Vec<f64>,
    /// The cart's optical path (m).
    pub cart: Vec<f64>,
    /// The runner's position (m): optical path 2 ×.
    pub runner: Vec<f64>,
    /// The fine stage's optical path (m).
    pub fine: Vec<f64>,
    /// The residual optical path (m).
    pub residual: Vec<f64>,
    /// The fringe tracker saw fringes.
    pub locked: Vec<bool>,
    /// Where the run ended before its time: the runner at the end of its stroke.
    pub end_of_stroke: Option<f64>,
    /// The most the fine stage's command saturated (samples).
    pub fine_saturated: u32,
    /// The largest sidereal rate over the run (m/s).
    pub sidereal_rate: f64,
    pub settle_time: f64,
    pub science_frame: f64,
}

/// The figures a designer asks of a run (after `settle_time`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Figures {
    /// RMS of the residual in the fringe tracker's frame (every 2 ms sample) (m).
    pub tracker_rms: f64,
    /// RMS of the residual within science frames: the blur of their fringes (m).
    pub science_jitter: f64,
    /// RMS of the science frames' mean residual: their fringe phase error (m).
    pub science_offset: f64,
    /// Mean visibility of the science frames at 1.65 µm and 10 µm (unit contrast).
    pub visibility_h: f64,
    pub visibility_n: f64,
    /// Mean null depth at 10 µm over the samples.
    pub null_n: f64,
    /// Samples without fringes, and the first time one was lost.
    pub lost: usize,
    pub first_lost: Option<f64>,
}

impl Run {
    fn window(&self) -> usize {
        self.time.iter().position(|&t| t >= self.settle_time).unwrap_or(self.time.len())
    }

    /// The figures of the samples after `settle_time`.
    pub fn figures(&self) -> Figures {
        let from = self.window();
        let x = &self.residual[from..];
        let per_frame = ((self.science_frame / SAMPLE_PERIOD).round() as usize).max(1);
        let (mut jitter, mut offset, mut vh, mut vn, mut frames) = (0.0, 0.0, 0.0, 0.0, 0);
        for f in x.chunks_exact(per_frame) {
            let mean = f.iter().sum::<f64>() / f.len() as f64;
            jitter += f.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / f.len() as f64;
            offset += mean * mean;
            vh += fringes::visibility_of(f, H_BAND);
            vn += fringes::visibility_of(f, N_BAND);
            frames += 1;
        }
        let n = frames.max(1) as f64;
        let lost: Vec<usize> = (from..self.locked.len()).filter(|&k| !self.locked[k]).collect();
        Figures {
            tracker_rms: fringes::rms(x),
            science_jitter: (jitter / n).sqrt(),
            science_offset: (offset / n).sqrt(),
            visibility_h: if frames > 0 { vh / n } else { f64::NAN },
            visibility_n: if frames > 0 { vn / n } else { f64::NAN },
            null_n: fringes::null_depth_of(x, N_BAND),
            lost: lost.len(),
            first_lost: lost.first().map(|&k| self.time[k]),
        }
    }
}

/// The disturbance of the path, by regime.
enum Disturbance {
    None,
    Ground(Lines),
    Space(Lines),
}

impl Disturbance {
    fn at(&self, t: f64) -> f64 {
        match self {
            Disturbance::None => 0.0,
            Disturbance::Ground(lines) | Disturbance::Space(lines) => lines.at(t),
        }
    }
}

/// Runs the delay line for `duration` s with the inchworm's `plant` and `controller`.
pub fn run(
    p: &DelayLineParams,
    plant: PlantParams,
    controller: Params,
    duration: f64,
) -> Result<Run, Error> {
    if let Some((name, why)) = inchworm_declare::out_of_range(p) {
        return Err(Error::Range { name, why });
    }
    if !(duration.is_finite() && duration > 0.0 && duration <= 1e5) {
        return Err(Error::Duration(duration));
    }
    let h = SAMPLE_PERIOD;
    let sky = Sidereal::new(
        p.baseline_length,
        p.baseline_azimuth,
        p.baseline_elevation,
        p.latitude,
        p.declination,
    )?;
    let h0 = p.hour_angle.to_radians();
    sky.visible(h0)?;
    let d0 = sky.delay(h0);
    let sidereal = |t: f64| sky.delay(Sidereal::hour_angle(h0, t)) - d0;
    let disturbance = match (p.disturbances, p.space) {
        (false, _) => Disturbance::None,
        (true, false) => Disturbance::Ground(
            PistonSpectrum {
                baseline: p.baseline_length,
                aperture: p.aperture,
                wind: p.wind_speed,
            }
            .draw(p.piston, 0.01, 250.0, p.seed),
        ),
        // Reaction-wheel-like lines: a wheel's fundamental and harmonics, and a cryocooler.
        (true, true) => Disturbance::Space(
            Lines::new(&[(0.7, 1.0), (1.4, 0.5), (2.1, 0.3), (7.3, 0.4), (40.0, 0.2)], p.seed)
                .scaled_to(p.vibration),
        ),
    };
    let mut cart_error = GaussMarkov::new(p.cart_error, p.cart_error_time, h, p.seed ^ 0x5eed);
    let mut tracker = FringeTracker::new(p.tracker)?;
    let mut fine = FineStage::new(p.fine, h)?;
    let mut inchworm = Plant::new(plant)?;
    let mut ctrl = Controller::new(controller).map_err(Error::Controller)?;

    let n = (duration / h).round() as usize;
    let mut out =
        Run { settle_time: p.settle_time, science_frame: p.science_frame, ..Run::default() };
    // The path's known model: the sidereal delay on the ground, the move in space.
    let model = |t: f64| if p.space { p.retarget } else { sidereal(t) };
    // The drift (space) is deterministic and unknown to the model: it is not switched
    // with the random disturbances, a drift_rate of 0 turns it off.
    let drift = if p.space { p.drift_rate } else { 0.0 };
    let path = |t: f64| model(t) + drift * t + disturbance.at(t);
    let (mut cart_cmd, mut cart) = (0.0, 0.0);
    let mut offload = 0.0;
    let mut held = [0.0; 3];
    let record = |out: &mut Run, t: f64, cart: f64, runner: f64, fine: f64, locked: bool| {
        let x = path(t) - cart - 2.0 * runner - fine;
        out.time.push(t);
        out.path.push(path(t));
        out.cart.push(cart);
        out.runner.push(runner);
        out.fine.push(fine);
        out.residual.push(x);
        out.locked.push(locked);
        x
    };
    let mut x = record(&mut out, 0.0, 0.0, inchworm.outputs().runner_position, 0.0, true);
    let half_stroke = p.stroke / 2.0;
    for k in 0..n {
        let (t, t1) = (k as f64 * h, (k + 1) as f64 * h);
        if !p.space {
            out.sidereal_rate = out.sidereal_rate.max(sky.rate(Sidereal::hour_angle(h0, t)).abs());
        }
        // The cart moves continuously: at the sample's end it is on the sidereal model
        // (rate-limited), its error on top, and its metrology says where.
        if !p.space && p.cart {
            let step = p.cart_rate_limit * h;
            cart_cmd += (sidereal(t1) - cart_cmd).clamp(-step, step);
            if p.disturbances {
                cart_error.step();
            }
            cart = cart_cmd + if p.disturbances { cart_error.value() } else { 0.0 };
        }
        // The controller's reference is where the path will be at the sample's end: the
        // model is known ahead, the cart's metrology is read as it moves.
        let known = if p.feedforward { model(t1) } else { 0.0 };
        let reference = (known - cart + offload) / 2.0;
        let s = ctrl.tick(inchworm.outputs().encoder_counts, reference);
        inchworm.step(Dac { earth: held[0], nonearth: held[1], extension: held[2] }, h)?;
        held = s.dac;
        // The tracker sees the residual the sample leaves.
        let reading = tracker.measure(x);
        let estimate = match reading {
            Reading::Locked(e) => Some(e),
            Reading::Lost => None,
        };
        if p.fine.enabled {
            fine.step(estimate);
            if estimate.is_some() {
                offload += h / p.offload_time * fine.position();
            }
        } else if let Some(e) = estimate {
            offload += h / p.offload_time * e;
        }
        let runner = inchworm.outputs().runner_position;
        let fine_path = if p.fine.enabled { fine.position() } else { 0.0 };
        x = record(&mut out, t1, cart, runner, fine_path, estimate.is_some());
        if runner.abs() > half_stroke {
            out.end_of_stroke = Some(t1);
            break;
        }
    }
    out.fine_saturated = fine.saturated();
    Ok(out)
}
