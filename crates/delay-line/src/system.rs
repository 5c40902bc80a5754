//! The delay line closed around the fringe tracker (docs/delay-line.md §3): the inchworm
//! moving a cat's eye (optical path = 2 × runner displacement), on a cart on the ground or
//! alone in space, a fine stage optional, sampled every 2 ms with the inchworm's own
//! controller.
//!
//! Each sample the optics ([`crate::optics`]: the path, the cart, the tracker, the fine
//! stage, the offload) see the runner where it is and give the reference of the
//! controller's tick; the plant steps on the DAC volts of the tick before, as in the
//! `InchwormSystem` co-simulation.
//!
//! A sample where the tracker sees no fringes holds the fine stage and the offload: the
//! run reports it as lost lock. A runner beyond half the stroke ends the run early.

use inchworm_controller::{Controller, Params, SAMPLE_PERIOD};
use inchworm_declare::{Declare, Declared};
use inchworm_plant::{Dac, Plant, PlantParams};

use crate::fine_stage::{FineStageError, FineStageParams};
use crate::fringes::{self, H_BAND, N_BAND};
use crate::geometry::GeometryError;
use crate::optics::Optics;
use crate::tracker::{TrackerError, TrackerParams};

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

impl DelayLineParams {
    /// The 2 ms samples of one science frame (at least one): the run's figures and the
    /// FMU's frame outputs both count frames of this many samples.
    pub fn frame_samples(&self) -> u32 {
        ((self.science_frame / SAMPLE_PERIOD).round() as u32).max(1)
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
    /// Samples of a science frame ([`DelayLineParams::frame_samples`]).
    pub frame_samples: u32,
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
        let per_frame = self.frame_samples.max(1) as usize;
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

/// Runs the delay line for `duration` s with the inchworm's `plant` and `controller`.
pub fn run(
    p: &DelayLineParams,
    plant: PlantParams,
    controller: Params,
    duration: f64,
) -> Result<Run, Error> {
    if !(duration.is_finite() && duration > 0.0 && duration <= 1e5) {
        return Err(Error::Duration(duration));
    }
    let mut optics = Optics::new(p)?;
    let mut inchworm = Plant::new(plant)?;
    let mut ctrl = Controller::new(controller).map_err(Error::Controller)?;
    let n = (duration / SAMPLE_PERIOD).round() as usize;
    let mut out =
        Run { settle_time: p.settle_time, frame_samples: p.frame_samples(), ..Run::default() };
    let mut held = [0.0; 3];
    let half_stroke = p.stroke / 2.0;
    for k in 0..=n {
        let runner = inchworm.outputs().runner_position;
        let reference = optics.reference();
        let s = optics.sample(runner);
        out.sidereal_rate = out.sidereal_rate.max(optics.sidereal_rate(s.time).abs());
        out.time.push(s.time);
        out.path.push(s.path);
        out.cart.push(s.cart);
        out.runner.push(runner);
        out.fine.push(s.fine);
        out.residual.push(s.residual);
        out.locked.push(s.locked);
        if runner.abs() > half_stroke {
            out.end_of_stroke = Some(s.time);
            break;
        }
        if k == n {
            break;
        }
        let tick = ctrl.tick(inchworm.outputs().encoder_counts, reference);
        inchworm
            .step(Dac { earth: held[0], nonearth: held[1], extension: held[2] }, SAMPLE_PERIOD)?;
        held = tick.dac;
    }
    out.fine_saturated = optics.fine_saturated();
    Ok(out)
}
