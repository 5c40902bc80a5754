//! The `InchwormDelayLine` FMU: an interferometer's delay line around an inchworm
//! (docs/delay-line.md): the sidereal path and its disturbances, the cart, the fringe
//! tracker, the fine stage and the offload of `inchworm_delay_line::optics`, stepped once a
//! 2 ms sample around the runner position of an `InchwormPlant`, giving the reference of
//! the `InchwormController` that drives it (the system `InchwormDelayLine.ssp`).
//!
//! Timing, a sample and hold as the mount's: before the first step the outputs are those
//! of the runner position at initialization and `reference` that of the controller's
//! first tick; after `fmi2DoStep(t, h)` (`h` a whole number of 2 ms samples) they are
//! those of the step's last sample, on the runner position that held during the step, and
//! `reference` that of the controller's tick at `t + h`. So every master that transfers
//! the connections at the communication points runs the loop of
//! `inchworm_delay_line::system::run`, whose residual at `t` this FMU shows at `t + 2 ms`.

use inchworm_delay_line::fine_stage::FineStageParams;
use inchworm_delay_line::optics::{Frame, Optics, Sample, MAX_SAMPLES};
use inchworm_delay_line::system::DelayLineParams;
use inchworm_delay_line::tracker::TrackerParams;
use inchworm_fmi_export::inchworm_declare::{Declared, Has};
use inchworm_fmi_export::{Kind, Model, ModelInfo, Reader, Row, StepLog, Unit, Variable, Writer};

const SAMPLE: f64 = inchworm_controller::SAMPLE_PERIOD;
const M: Option<&str> = Some("m");

#[rustfmt::skip]
inchworm_fmi_export::table!(DelayLineFmu, TABLE;
    {
    RUNNER_POSITION: Variable::input("runner_position", 1, 0.0, M, "Runner position of the inchworm carrying the cat's eye (optical path 2x)").real(|m| m.runner, |m, x| m.runner = x),
    REFERENCE: Variable::output("reference", 10, Kind::Real, M, "Reference position of the runner for the controller's tick at this communication point: (path model ahead - cart + offload) / 2").discrete().real_out(|m| m.reference),
    PATH: Variable::output("path", 11, Kind::Real, M, "Optical path to add at the last sample: the sidereal delay since the start (or the move) and the disturbances").real_out(|m| m.seen.path),
    CART_PATH: Variable::output("cart_path", 12, Kind::Real, M, "Optical path of the cart at the last sample (ground)").real_out(|m| m.seen.cart),
    FINE_PATH: Variable::output("fine_path", 13, Kind::Real, M, "Optical path of the fine stage at the last sample").real_out(|m| m.seen.fine),
    RESIDUAL: Variable::output("residual", 14, Kind::Real, M, "Residual optical path at the last sample: path - cart_path - 2 runner_position - fine_path").real_out(|m| m.seen.residual),
    LOCKED: Variable::output("locked", 15, Kind::Boolean, None, "The fringe tracker saw fringes at the last sample").boolean_out(|m| m.seen.locked),
    VISIBILITY_H: Variable::output("visibility_h", 16, Kind::Real, None, "Fringe visibility at 1.65 um of the last complete science frame (1 before the first)").discrete().real_out(|m| m.frame_figures[0]),
    VISIBILITY_N: Variable::output("visibility_n", 17, Kind::Real, None, "Fringe visibility at 10 um of the last complete science frame (1 before the first)").discrete().real_out(|m| m.frame_figures[1]),
    NULL_N: Variable::output("null_n", 18, Kind::Real, None, "Null depth at 10 um of a two-beam nuller over the last complete science frame (0 before the first)").discrete().real_out(|m| m.frame_figures[2]),
    },
    fields(DelayLineParams, 100),
);

static UNITS: [Unit; 5] = [
    Unit { name: "m", kg: 0, m: 1, s: 0, a: 0 },
    Unit { name: "s", kg: 0, m: 0, s: 1, a: 0 },
    Unit { name: "m/s", kg: 0, m: 1, s: -1, a: 0 },
    Unit { name: "deg", kg: 0, m: 0, s: 0, a: 0 },
    Unit { name: "Hz", kg: 0, m: 0, s: -1, a: 0 },
];

static INFO: ModelInfo = ModelInfo {
    model_name: "InchwormDelayLine",
    model_identifier: "InchwormDelayLine",
    description: "Interferometer delay line on an inchworm: sidereal optical path, atmospheric piston or spacecraft vibration, cart, fringe tracker, fine stage and offload, sampled every 2 ms around the runner position; the reference of the inchworm's controller",
    version: env!("CARGO_PKG_VERSION"),
    default_start_time: 0.0,
    default_stop_time: 10.0,
    default_step_size: 0.002,
    default_tolerance: 1e-9,
    units: &UNITS,
    log_events: "Model events: none",
    documentation_html: include_str!("delay_line.html"),
};

/// What the outputs show before any sample.
const NOTHING_SEEN: Sample =
    Sample { time: 0.0, path: 0.0, cart: 0.0, fine: 0.0, residual: 0.0, locked: false };
const NO_FRAME: [f64; 3] = [1.0, 1.0, 0.0];

#[derive(Clone, Debug)]
pub struct DelayLineFmu {
    params: DelayLineParams,
    runner: f64,
    /// Built at initialization.
    optics: Option<Optics>,
    seen: Sample,
    reference: f64,
    frame: Frame,
    /// Visibility at 1.65 µm and 10 µm, null depth at 10 µm, of the last complete frame.
    frame_figures: [f64; 3],
}

impl Has<DelayLineParams> for DelayLineFmu {
    fn part(&self) -> &DelayLineParams {
        &self.params
    }
    fn part_mut(&mut self) -> &mut DelayLineParams {
        &mut self.params
    }
}

impl Has<TrackerParams> for DelayLineFmu {
    fn part(&self) -> &TrackerParams {
        &self.params.tracker
    }
    fn part_mut(&mut self) -> &mut TrackerParams {
        &mut self.params.tracker
    }
}

impl Has<FineStageParams> for DelayLineFmu {
    fn part(&self) -> &FineStageParams {
        &self.params.fine
    }
    fn part_mut(&mut self) -> &mut FineStageParams {
        &mut self.params.fine
    }
}

/// Samples one step may run (a step of 200 s at 2 ms): the work of a call is bounded.
pub const MAX_SAMPLES_PER_STEP: f64 = 1e5;

impl DelayLineFmu {
    /// The samples of a step of `h` s: a whole number of 2 ms samples, at least one.
    fn samples_of(h: f64) -> Result<u64, String> {
        let n = (h / SAMPLE).round();
        if !((1.0..=MAX_SAMPLES_PER_STEP).contains(&n) && (n * SAMPLE - h).abs() <= 1e-9 * h) {
            return Err(format!(
                "a step of {h} s: the delay line samples every {SAMPLE} s, a step is 1 to {MAX_SAMPLES_PER_STEP:e} whole samples"
            ));
        }
        Ok(n as u64)
    }
}

impl Model for DelayLineFmu {
    fn info() -> &'static ModelInfo {
        &INFO
    }

    fn table() -> &'static [Row<Self>] {
        &TABLE
    }

    fn new() -> Self {
        DelayLineFmu {
            params: DelayLineParams::declared(),
            runner: 0.0,
            optics: None,
            seen: NOTHING_SEEN,
            reference: 0.0,
            frame: Frame::default(),
            frame_figures: NO_FRAME,
        }
    }

    fn exit_initialization(&mut self, _start_time: f64) -> Result<(), String> {
        let optics = Optics::new(&self.params).map_err(|e| e.to_string())?;
        self.seen = Sample {
            path: optics.path(0.0),
            residual: optics.residual(self.runner),
            ..NOTHING_SEEN
        };
        self.reference = optics.reference();
        self.optics = Some(optics);
        Ok(())
    }

    fn check_step(&self, _t: f64, h: f64) -> Result<(), String> {
        let n = Self::samples_of(h)?;
        let done = self.optics.as_ref().map_or(0, Optics::samples);
        if done + n > MAX_SAMPLES {
            return Err(format!(
                "a step to sample {}: a run holds at most {MAX_SAMPLES} samples (1e5 s)",
                done + n
            ));
        }
        Ok(())
    }

    fn do_step(&mut self, t: f64, h: f64, _log: &mut StepLog) -> Result<(), String> {
        let n = Self::samples_of(h)?;
        let per_frame = self.params.frame_samples();
        let optics = self.optics.as_mut().ok_or("the delay line is not initialized")?;
        let half_stroke = self.params.stroke / 2.0;
        if self.runner.abs() > half_stroke {
            return Err(format!(
                "at t = {t} s the runner at {} m is beyond half the stroke ({half_stroke} m): the path has left the delay line's range",
                self.runner
            ));
        }
        for _ in 0..n {
            self.seen = optics.sample(self.runner);
            self.frame.add(self.seen.residual);
            if self.frame.len() == per_frame {
                let [vh, vn] = self.frame.visibility();
                self.frame_figures = [vh, vn, self.frame.null_depth()];
                self.frame = Frame::default();
            }
        }
        self.reference = optics.reference();
        Ok(())
    }

    fn save_state(&self, w: &mut Writer) {
        w.f64(self.runner);
        match &self.optics {
            None => w.u8(0),
            Some(o) => {
                w.u8(1);
                o.save_state(w);
            }
        }
        let s = &self.seen;
        for v in [s.time, s.path, s.cart, s.fine, s.residual, self.reference] {
            w.f64(v);
        }
        w.u8(u8::from(s.locked));
        self.frame.save_state(w);
        self.frame_figures.iter().for_each(|v| w.f64(*v));
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        let mut r = Reader::new(bytes, "delay line FMU state");
        self.runner = r.f64()?;
        self.optics = if r.bool()? {
            let mut o = Optics::new(&self.params).map_err(|e| e.to_string())?;
            o.load_state(&mut r)?;
            Some(o)
        } else {
            None
        };
        let mut v = [0.0; 6];
        for x in &mut v {
            *x = r.f64()?;
        }
        let [time, path, cart, fine, residual, reference] = v;
        self.seen = Sample { time, path, cart, fine, residual, locked: r.bool()? };
        self.reference = reference;
        self.frame.load_state(&mut r)?;
        for x in &mut self.frame_figures {
            *x = r.f64()?;
        }
        r.finish()
    }
}
