//! The closed loop with the two crates coupled directly (no FMI): plant and controller
//! exchange DAC volts and encoder counts every 2 ms as a Jacobi master would, the
//! controller's output at `t` being the sample for `[t + h, t + 2h)`.
//!
//! It is the reference the FMU runs are tested against, so it records what the master
//! records on `InchwormSystem.ssp` ([`recorded`]), under the same names and with the same
//! t = 0 row; [`LoopView`] reads either trace for the closed-loop analysis of docs/model.md §4.1.

use std::path::Path;

use inchworm_controller::{Controller, Params, Sample, SAMPLE_PERIOD};
use inchworm_plant::{Dac, Outputs, Plant, PlantParams};

use crate::gait::Step;
use crate::holding::{Held, HoldingRms, Parked, Settle};
use inchworm_cosim::ssp::Archive;
use inchworm_cosim::Trace;
use inchworm_fmu_models::{ControllerFmu, PlantFmu, ReferenceFmu};

/// What a directly coupled run reports: a model crate's error as it is.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The plant crate refused its parameters.
    #[error(transparent)]
    PlantParams(#[from] inchworm_plant::ParamError),
    /// The plant crate's step failed.
    #[error(transparent)]
    PlantStep(#[from] inchworm_plant::StepError),
    /// The controller crate refused its parameters (its message).
    #[error("{0}")]
    Controller(String),
    #[error(transparent)]
    Gait(#[from] crate::gait::AmplitudeError),
}

/// What the closed-loop analysis finds missing in a trace.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TraceError {
    /// A trace without a variable the analysis reads.
    #[error("the trace has no `{0}`")]
    NoVariable(String),
    /// A trace without a row.
    #[error("the trace is empty")]
    Empty,
}

/// The plan flag of the controller crate's sample: the controller FMU has no such output,
/// so only the direct coupling records it (see [`LoopView::iterated`]).
pub const ITERATED: &str = "iterated";

/// `"component.variable"` as a `&'static str` constant, the variable's name read from its
/// model's table at compile time: the loop's trace names are the declared names.
/// `recorded_name!(prefix, sep, name)` joins with another separator.
macro_rules! recorded_name {
    ($component:expr, $name:expr) => {
        $crate::closed_loop::recorded_name!($component, ".", $name)
    };
    ($component:expr, $sep:expr, $name:expr) => {{
        const C: &str = $component;
        const S: &str = $sep;
        const V: &str = $name;
        const BYTES: &[u8; C.len() + S.len() + V.len()] = &$crate::closed_loop::join_names(C, S, V);
        match std::str::from_utf8(BYTES) {
            Ok(s) => s,
            Err(_) => panic!("a component or variable name that is not UTF-8"),
        }
    }};
}
pub(crate) use recorded_name;

/// The bytes of `a`, `sep` and `b` in a row.
pub(crate) const fn join_names<const N: usize>(a: &str, sep: &str, b: &str) -> [u8; N] {
    let mut out = [0; N];
    let mut n = 0;
    let parts = [a.as_bytes(), sep.as_bytes(), b.as_bytes()];
    let mut p = 0;
    while p < parts.len() {
        let mut i = 0;
        while i < parts[p].len() {
            out[n] = parts[p][i];
            n += 1;
            i += 1;
        }
        p += 1;
    }
    assert!(n == N);
    out
}

/// The components of the closed-loop systems (`fmu-build`'s SSPs and the direct coupling).
pub(crate) const PLANT: &str = "plant";
const CONTROLLER: &str = "controller";

/// The reference as an open system records it: its system input (`InchwormSystemOpen.ssp`),
/// or the controller FMU's own input.
pub const REFERENCE: &str = ControllerFmu::name_of(ControllerFmu::REFERENCE);
/// The reference as the closed system (`InchwormSystem.ssp`) records it: the output of its
/// component `reference`.
pub const REFERENCE_OUTPUT: &str =
    recorded_name!("reference", ReferenceFmu::name_of(ReferenceFmu::REFERENCE));
pub const ENCODER_COUNTS: &str = recorded_name!(PLANT, PlantFmu::name_of(PlantFmu::ENCODER_COUNTS));
pub(crate) const ENCODER_POSITION: &str =
    recorded_name!(PLANT, PlantFmu::name_of(PlantFmu::ENCODER_POSITION));
const RUNNER_POSITION: &str = recorded_name!(PLANT, PlantFmu::name_of(PlantFmu::RUNNER_POSITION));
pub(crate) const DAC: [&str; 3] = [
    recorded_name!(CONTROLLER, ControllerFmu::name_of(ControllerFmu::DAC_EARTH)),
    recorded_name!(CONTROLLER, ControllerFmu::name_of(ControllerFmu::DAC_NONEARTH)),
    recorded_name!(CONTROLLER, ControllerFmu::name_of(ControllerFmu::DAC_EXTENSION)),
];
pub(crate) const DISTURBANCE_ESTIMATE: &str =
    recorded_name!(CONTROLLER, ControllerFmu::name_of(ControllerFmu::DISTURBANCE_ESTIMATE));
pub(crate) const SLIP_EVENTS: &str =
    recorded_name!(PLANT, PlantFmu::name_of(PlantFmu::SLIP_EVENTS));
const N_STEPS: &str = recorded_name!(CONTROLLER, ControllerFmu::name_of(ControllerFmu::N_STEPS));
const FRACTION: &str = recorded_name!(CONTROLLER, ControllerFmu::name_of(ControllerFmu::FRACTION));

/// `controller.scale_weights[i + 1]`.
fn scale_weight(i: usize) -> String {
    format!("{CONTROLLER}.{}", ControllerFmu::SCALE_WEIGHTS[i].name())
}

/// The variables of a closed-loop trace, as `component.variable` of the systems (the
/// reference as `InchwormSystemOpen.ssp`'s system input, by its connector name; the closed
/// system records it as [`REFERENCE_OUTPUT`], see [`reference_name`]).
pub fn recorded() -> Vec<String> {
    recorded_as(REFERENCE)
}

/// [`recorded`], the reference named `reference`.
pub fn recorded_as(reference: &str) -> Vec<String> {
    let mut names: Vec<String> = [reference, ENCODER_COUNTS, ENCODER_POSITION, RUNNER_POSITION]
        .iter()
        .chain(&DAC)
        .chain(&[DISTURBANCE_ESTIMATE, N_STEPS, FRACTION])
        .map(|s| s.to_string())
        .collect();
    names.extend((0..10).map(scale_weight));
    names
}

/// The name under which `system` records the reference: its reference component's output
/// where it has that component (`InchwormSystem.ssp`), else `reference`, the system input
/// of an open system or a single FMU's own variable (the controller FMU's input).
pub fn reference_name(system: &Path) -> Result<&'static str, inchworm_cosim::Error> {
    let is_ssp = system.extension().is_some_and(|e| e.eq_ignore_ascii_case("ssp"));
    if !is_ssp {
        return Ok(REFERENCE);
    }
    let closed = Archive::open(system)?.system.components.iter().any(|c| c.name == "reference");
    Ok(if closed { REFERENCE_OUTPUT } else { REFERENCE })
}

/// Where the variables `names` hold the reference, under either of its names.
pub fn reference_index(names: &[String]) -> Option<usize> {
    names.iter().position(|n| n == REFERENCE || n == REFERENCE_OUTPUT)
}

/// One row in the order of [`recorded`], then [`ITERATED`]: the reference and the plant's
/// outputs at the row's time, the controller's outputs after its latest tick (as the FMU
/// shows them once its step to that time is done).
fn row(reference: f64, o: &Outputs, s: &Sample) -> Vec<f64> {
    let mut v = vec![
        reference,
        o.encoder_counts as f64,
        o.encoder_position,
        o.runner_position,
        s.dac[0],
        s.dac[1],
        s.dac[2],
        s.disturbance_estimate,
        f64::from(s.n_steps),
        s.fraction,
    ];
    v.extend(s.scale_weights);
    v.push(f64::from(u8::from(s.iterated)));
    v
}

/// A controller sample with no plan: `dac` commanded, nothing stepping.
fn parked(dac: [f64; 3], disturbance_estimate: f64, scale_weights: [f64; 10]) -> Sample {
    Sample {
        dac,
        codes: [0; 3],
        servo_error: 0.0,
        disturbance_estimate,
        step_forward: 0.0,
        step_backward: 0.0,
        n_steps: 0,
        fraction: 0.0,
        scale_weights,
        moving: false,
        iterated: false,
        no_root: false,
    }
}

/// The crates coupled directly over `duration` s: [`recorded`] and [`ITERATED`] at every
/// communication point `k h`, k ≥ 0.
pub fn run(
    plant: PlantParams,
    controller: Params,
    reference: impl Fn(f64) -> f64,
    duration: f64,
) -> Result<Trace, Error> {
    let mut plant = Plant::new(plant)?;
    // Before its first tick the controller FMU shows the parked sample with the start
    // estimates; the t = 0 row shows the same.
    let start = parked([0.0; 3], controller.disturbance_start, controller.scale_weights_start);
    let mut ctrl = Controller::new(controller).map_err(Error::Controller)?;
    let h = SAMPLE_PERIOD;
    let n = (duration / h).round() as usize;
    let mut names = recorded();
    names.push(ITERATED.into());
    let mut trace = Trace::new(names);
    trace.rows.reserve(n + 1);
    trace.push(0.0, row(reference(0.0), &plant.outputs(), &start));
    let mut held = [0.0; 3];
    for k in 0..n {
        let t = k as f64 * h;
        let s = ctrl.tick(plant.outputs().encoder_counts, reference(t));
        plant.step(Dac { earth: held[0], nonearth: held[1], extension: held[2] }, h)?;
        let t = (k + 1) as f64 * h;
        trace.push(t, row(reference(t), &plant.outputs(), &s));
        held = s.dac;
    }
    Ok(trace)
}

/// The plant alone driven open loop by `steps` full forward steps from rest (the paper's
/// Fig. 11), recorded like the loop so the same analysis, CSV and plot read it: the gait's
/// volts stand in the controller's DAC columns, the reference and the estimates are 0.
pub fn open_loop_slew(plant: PlantParams, steps: usize) -> Result<Trace, Error> {
    let step = Step::new(1.0)?;
    let volts: Vec<Dac> = (0..steps).flat_map(|_| step.samples()).collect();
    let mut plant = Plant::new(plant)?;
    // The volts commanded at sample k are held over the next one; none after the last.
    let commanded = |k: usize| {
        let d = volts.get(k).copied().unwrap_or_default();
        parked([d.earth, d.nonearth, d.extension], 0.0, [0.0; 10])
    };
    let mut names = recorded();
    names.push(ITERATED.into());
    let mut trace = Trace::new(names);
    trace.push(0.0, row(0.0, &plant.outputs(), &commanded(0)));
    for (k, &dac) in volts.iter().enumerate() {
        plant.step(dac, SAMPLE_PERIOD)?;
        trace.push((k + 1) as f64 * SAMPLE_PERIOD, row(0.0, &plant.outputs(), &commanded(k + 1)));
    }
    Ok(trace)
}

/// A closed-loop trace read for the analysis: one entry per communication point
/// `t_k = k h`, k ≥ 1, holding the plant outputs at `t_k` and the DAC volts that were held
/// during `[t_{k-1}, t_k)`.
#[derive(Clone, Debug, Default)]
pub struct LoopView {
    pub time: Vec<f64>,
    pub reference: Vec<f64>,
    pub encoder_counts: Vec<i64>,
    /// Counts × `q_enc`, as the plant computes it (m).
    pub encoder_position: Vec<f64>,
    pub runner_position: Vec<f64>,
    pub dac: Vec<[f64; 3]>,
    pub disturbance_estimate: Vec<f64>,
    pub n_steps: Vec<u32>,
    pub fraction: Vec<f64>,
    /// A control iteration ran at this point: the controller crate's flag where the trace
    /// has it, else a change of the plan outputs (`n_steps`, `fraction`).
    pub iterated: Vec<bool>,
    /// The estimate at the end of the run.
    pub scale_weights: [f64; 10],
}

impl LoopView {
    /// Reads a trace holding [`recorded`] (and [`ITERATED`] if it has it).
    pub fn new(trace: &Trace) -> Result<LoopView, TraceError> {
        let missing = |name: &str| TraceError::NoVariable(name.to_owned());
        let col = |name: &str| trace.column(name).ok_or_else(|| missing(name));
        if trace.rows.is_empty() {
            return Err(TraceError::Empty);
        }
        let after = |v: Vec<f64>| v[1..].to_vec();
        let dac: Vec<Vec<f64>> = DAC.iter().map(|n| col(n)).collect::<Result<_, _>>()?;
        let n_steps = col(N_STEPS)?;
        let fraction = col(FRACTION)?;
        let iterated = match trace.column(ITERATED) {
            Some(v) => v[1..].iter().map(|&x| x != 0.0).collect(),
            None => (1..trace.rows.len())
                .map(|i| {
                    (n_steps[i], fraction[i].to_bits())
                        != (n_steps[i - 1], fraction[i - 1].to_bits())
                })
                .collect(),
        };
        let last = &trace.rows[trace.rows.len() - 1].1;
        let mut scale_weights = [0.0; 10];
        for (i, w) in scale_weights.iter_mut().enumerate() {
            let name = scale_weight(i);
            *w = last[trace.index(&name).ok_or_else(|| missing(&name))?];
        }
        Ok(LoopView {
            time: after(trace.times()),
            reference: after(
                reference_index(&trace.names)
                    .and_then(|i| trace.column(&trace.names[i]))
                    .ok_or_else(|| missing(REFERENCE))?,
            ),
            encoder_counts: after(col(ENCODER_COUNTS)?).iter().map(|&c| c as i64).collect(),
            encoder_position: after(col(ENCODER_POSITION)?),
            runner_position: after(col(RUNNER_POSITION)?),
            // What the controller commanded at t_{k-1} is what was held up to t_k.
            dac: (0..trace.rows.len() - 1).map(|i| [dac[0][i], dac[1][i], dac[2][i]]).collect(),
            disturbance_estimate: after(col(DISTURBANCE_ESTIMATE)?),
            n_steps: n_steps[1..].iter().map(|&n| n as u32).collect(),
            fraction: after(fraction),
            iterated,
            scale_weights,
        })
    }

    /// CSV of the run: one row per communication point.
    pub fn write_csv(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        let [earth, nonearth, extension] = ControllerFmu::DAC_OUTPUTS.map(|v| v.name());
        let header = [
            "time",
            ControllerFmu::REFERENCE.name(),
            PlantFmu::ENCODER_COUNTS.name(),
            PlantFmu::RUNNER_POSITION.name(),
            earth,
            nonearth,
            extension,
            ControllerFmu::DISTURBANCE_ESTIMATE.name(),
            ControllerFmu::N_STEPS.name(),
            ControllerFmu::FRACTION.name(),
        ];
        writeln!(w, "{}", header.join(","))?;
        for i in 0..self.time.len() {
            let d = self.dac[i];
            writeln!(
                w,
                "{},{:e},{},{:e},{},{},{},{:e},{},{}",
                self.time[i],
                self.reference[i],
                self.encoder_counts[i],
                self.runner_position[i],
                d[0],
                d[1],
                d[2],
                self.disturbance_estimate[i],
                self.n_steps[i],
                self.fraction[i]
            )?;
        }
        Ok(())
    }

    /// Indices of the samples that `rule` judges, fed every sample's held DAC volts in turn.
    fn judged(&self, mut rule: impl FnMut(&[f64; 3]) -> bool) -> Vec<usize> {
        let mut out = Vec::new();
        for (i, dac) in self.dac.iter().enumerate() {
            if rule(dac) {
                out.push(i);
            }
        }
        out
    }

    /// Indices of the parked samples (docs/model.md §4.1, [`Parked`]).
    pub fn parked(&self) -> Vec<usize> {
        let mut parked = Parked::default();
        self.judged(|dac| parked.next(dac))
    }

    /// Position error (m) of sample `i`: reference − encoder position.
    pub fn error(&self, i: usize) -> f64 {
        self.reference[i] - self.encoder_position[i]
    }

    /// The [`Settle`] time of the samples `judged` within `tol` of the reference.
    fn settle(&self, judged: impl IntoIterator<Item = usize>, tol: f64) -> Option<f64> {
        let mut settle = Settle::default();
        for i in judged {
            settle.push(self.time[i], self.error(i).abs() > tol);
        }
        settle.time()
    }

    /// The [`HoldingRms`] of the samples `judged` in `[from, to)` s; 0 if none is in it.
    fn holding_rms(&self, judged: Vec<usize>, from: f64, to: f64) -> f64 {
        let mut rms = HoldingRms::new(from, to);
        for i in judged {
            rms.push(self.time[i], self.error(i));
        }
        rms.value().unwrap_or(0.0)
    }

    /// First time after which every parked sample is within `tol` of the reference.
    pub fn settle_time(&self, tol: f64) -> Option<f64> {
        self.settle(self.parked(), tol)
    }

    /// RMS error of the parked samples in `[from, to)` s; 0 if none is in it.
    pub fn parked_rms(&self, from: f64, to: f64) -> f64 {
        self.holding_rms(self.parked(), from, to)
    }
}

/// An open-loop slew read gait by gait (the paper's Fig. 11): the runner position at the end
/// of every gait (the parked sample 100) and the advance each gait made.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SlewView {
    /// End time of each gait (s).
    pub time: Vec<f64>,
    /// True runner position at the end of each gait (m).
    pub position: Vec<f64>,
    /// Advance of each gait (m); the first is from rest.
    pub advance: Vec<f64>,
}

impl SlewView {
    /// Reads a slew of back-to-back gaits of `samples_per_gait` samples.
    pub fn new(r: &LoopView, samples_per_gait: usize) -> SlewView {
        let ends: Vec<usize> =
            (1..=r.time.len() / samples_per_gait).map(|g| g * samples_per_gait - 1).collect();
        let position: Vec<f64> = ends.iter().map(|&i| r.runner_position[i]).collect();
        let advance = position
            .iter()
            .scan(0.0, |prev, &x| {
                let a = x - *prev;
                *prev = x;
                Some(a)
            })
            .collect();
        SlewView { time: ends.iter().map(|&i| r.time[i]).collect(), position, advance }
    }

    /// The largest change of the advance from one gait to the next after the first (m).
    pub fn largest_change(&self) -> f64 {
        self.advance.windows(2).skip(1).map(|w| (w[1] - w[0]).abs()).fold(0.0, f64::max)
    }

    /// Gaits that moved the runner backward.
    pub fn backward(&self) -> usize {
        self.advance.iter().filter(|&&a| a < 0.0).count()
    }

    /// CSV `gait,time,position,advance` (s, m).
    pub fn write_csv(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        writeln!(w, "gait,time,runner_position,advance")?;
        for g in 0..self.time.len() {
            writeln!(w, "{},{},{:e},{:e}", g + 1, self.time[g], self.position[g], self.advance[g])?;
        }
        Ok(())
    }
}

/// Reading a run of the options of docs/model.md §4.2, where the runner is
/// also held in DRIVE (analog mode) and the gait may be short.
impl LoopView {
    /// Samples a position is judged at under these options ([`Held`]).
    pub fn held(&self) -> Vec<usize> {
        let mut held = Held::default();
        self.judged(|dac| held.next(dac))
    }

    /// First time after `from` after which every [`LoopView::held`] sample is within `tol`.
    pub fn held_settle_time(&self, tol: f64, from: f64) -> Option<f64> {
        let held = self.held().into_iter().filter(|&i| self.time[i] > from);
        self.settle(held, tol)
    }

    /// RMS error of the [`LoopView::held`] samples in `[from, to)` s; 0 if none is in it.
    pub fn held_rms(&self, from: f64, to: f64) -> f64 {
        self.holding_rms(self.held(), from, to)
    }

    /// Mean speed (m/s) between 10 % and 90 % of a move from 0 to `distance` > 0.
    pub fn slew_rate(&self, distance: f64) -> Option<f64> {
        let at = |f: f64| {
            self.encoder_position.iter().position(|&y| y >= f * distance).map(|i| self.time[i])
        };
        Some(0.8 * distance / (at(0.9)? - at(0.1)?))
    }
}

/// The brake-disturbance map of a run (docs/model.md §4.2): the measured `(EXT_cmd, BD)`
/// of every step, the map at its end, and the residuals of the coming step's disturbance
/// against the latest estimate and against the map's prediction, from `from` s on.
#[derive(Clone, Debug, Default)]
pub struct MapRun {
    pub pairs: Vec<(f64, f64)>,
    /// The final map at EXT_cmd = −1, −0.98, …, 1.
    pub curve: Vec<(f64, f64)>,
    pub rms_last: f64,
    pub rms_map: f64,
    pub steps: usize,
}

/// Runs the loop directly coupled, as [`run`], with `controller.disturbance_map` on.
pub fn disturbance_map_run(
    plant: PlantParams,
    controller: Params,
    reference: impl Fn(f64) -> f64,
    duration: f64,
    from: f64,
) -> Result<MapRun, Error> {
    let controller = Params { disturbance_map: true, ..controller };
    let mut plant = Plant::new(plant)?;
    let mut ctrl = Controller::new(controller).map_err(Error::Controller)?;
    let mut held = [0.0; 3];
    let mut out = MapRun::default();
    let (mut a, mut b) = (0.0, 0.0);
    for k in 0..(duration / SAMPLE_PERIOD).round() as usize {
        let t = k as f64 * SAMPLE_PERIOD;
        let s = ctrl.tick(plant.outputs().encoder_counts, reference(t));
        if let Some((bd, last, map)) = ctrl.bd_residuals() {
            let m = ctrl.disturbance_map().expect("the map is on");
            // The update just made: its command, and the BD it measured.
            out.pairs.push((m.last_command, bd));
            if t >= from {
                a += last * last;
                b += map * map;
                out.steps += 1;
            }
        }
        plant.step(Dac { earth: held[0], nonearth: held[1], extension: held[2] }, SAMPLE_PERIOD)?;
        held = s.dac;
    }
    let n = out.steps.max(1) as f64;
    out.rms_last = (a / n).sqrt();
    out.rms_map = (b / n).sqrt();
    let m = ctrl.disturbance_map().expect("the map is on");
    out.curve = (-50..=50).map(|k| (k as f64 / 50.0, m.predict(k as f64 / 50.0))).collect();
    Ok(out)
}

#[cfg(test)]
mod slew_tests {
    use super::*;

    #[test]
    fn slew_view_reads_each_gait_end_and_its_advance() {
        let mut r = LoopView::default();
        for k in 0..300 {
            r.time.push((k + 1) as f64 * 0.002);
            // 20 µm in the first gait, 18 in the second, 19 in the third.
            let g = k / 100;
            r.runner_position.push([20e-6, 38e-6, 57e-6][g] * ((k % 100 + 1) as f64 / 100.0));
        }
        let s = SlewView::new(&r, 100);
        assert_eq!(s.time, vec![0.2, 0.4, 0.6]);
        assert_eq!(s.position, vec![20e-6, 38e-6, 57e-6]);
        let um: Vec<f64> = s.advance.iter().map(|a| (a * 1e6 * 1e6).round() / 1e6).collect();
        assert_eq!(um, vec![20.0, 18.0, 19.0]);
        assert!((s.largest_change() - 1e-6).abs() < 1e-15);
        assert_eq!(s.backward(), 0);
    }
}
