//! Named scenarios of the paper (docs/model.md §4.1): closed loops run by the master on
//! `InchwormSystem.ssp` or with the crates coupled directly, and the open-loop slews of
//! Fig. 11; each variant one [`Trace`], written as CSV and PNG by `inchworm scenario`.

use std::path::Path;

use inchworm_controller::{Params, NOMINAL_WEIGHTS, SAMPLE_PERIOD};
use inchworm_fmi_export::Var;
use inchworm_fmu_models::ReferenceFmu;
use inchworm_plant::PlantParams;

use crate::closed_loop::{self, LoopView, REFERENCE_OUTPUT};
use inchworm_cosim::master::{self, Coupling, InputTable, Options, Timing};
use inchworm_cosim::Trace;

/// What a scenario reports: the engine's or a directly coupled run's error as it is, what
/// the analysis found missing in a trace, or a file it could not write.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    #[error(transparent)]
    Engine(#[from] inchworm_cosim::Error),
    #[error(transparent)]
    ClosedLoop(#[from] closed_loop::Error),
    #[error(transparent)]
    Trace(#[from] closed_loop::TraceError),
    #[error(transparent)]
    Font(#[from] crate::plot::FontError),
    /// A file the scenario writes (its folder, its CSV) cannot be written.
    #[error("{}: {source}", path.display())]
    Write {
        path: std::path::PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A plot cannot be drawn.
    #[error("{}: cannot draw the plot: {source}", path.display())]
    Plot {
        path: std::path::PathBuf,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
}

/// What drives the plant in one variant.
#[derive(Clone, Debug)]
pub enum Drive {
    /// The controller with these parameters, in closed loop.
    Controller(Box<Params>),
    /// Full forward steps open loop, back to back from rest, for the whole duration.
    OpenLoopSlew,
}

/// One run of a scenario: a plant and what drives it.
#[derive(Clone, Debug)]
pub struct Variant {
    pub name: String,
    pub plant: PlantParams,
    pub drive: Drive,
}

pub struct Scenario {
    pub name: &'static str,
    pub title: &'static str,
    pub duration: f64,
    /// The reference (m), held piecewise constant: the system input `reference` of an
    /// open system, the reference component's table in the closed `InchwormSystem.ssp`;
    /// the direct coupling reads the same table, so every path sees the same value at
    /// every point.
    pub reference: InputTable,
    pub variants: Vec<Variant>,
    /// Windows (s) in which the loop regulates, for the RMS of the parked samples.
    pub regulation: Vec<(f64, f64)>,
}

/// How the closed loops run.
#[derive(Clone, Copy, Debug)]
pub enum Via<'a> {
    /// The crates coupled directly (the reference the FMU runs are tested against).
    Direct,
    /// The master on this SSP (`InchwormSystem.ssp`), Jacobi at 2 ms.
    System(&'a Path),
}

/// Reference levels of the Figs. 6–7 staircase (µm), 100 s each.
pub const STAIRCASE_UM: [f64; 7] = [100.0, 60.0, 250.0, 245.0, 130.0, 131.5, 20.0];

/// The staircase as `(time, position)` points: level k from `100 k` s.
pub fn staircase_points() -> Vec<(f64, f64)> {
    STAIRCASE_UM.iter().enumerate().map(|(k, um)| (k as f64 * 100.0, um * 1e-6)).collect()
}

/// The staircase as the reference table.
pub fn staircase() -> InputTable {
    InputTable::steps(closed_loop::REFERENCE, &staircase_points())
        .expect("the staircase times increase")
}

fn constant(value: f64) -> InputTable {
    InputTable::steps(closed_loop::REFERENCE, &[(0.0, value)]).expect("one finite row")
}

/// Each level from 20 s after its change to its end.
fn staircase_regulation() -> Vec<(f64, f64)> {
    (0..STAIRCASE_UM.len()).map(|k| (k as f64 * 100.0 + 20.0, (k + 1) as f64 * 100.0)).collect()
}

/// Every scenario `inchworm scenario` runs, in order, and what it shows: the one list the
/// command's help, its error for an unknown name and the README's table come from (a test
/// holds the README to it).
pub const SCENARIOS: [(&str, &str); 11] = [
    ("fig5", "Fig. 5: a 100 µm step from rest, full control and feedback only"),
    ("staircase", "Figs. 6–7: the 700 s reference staircase with the prefilter"),
    ("calibration", "the staircase from the nominal inverse scale factor and zero disturbance"),
    ("fia6", "the 6 µm device: a 30 µm step"),
    ("mirror", "three actuators and the mount (dist/MirrorMount.ssp): piston, tip and tilt"),
    ("slew", "open loop: full forward gaits over 40 mm"),
    ("stall", "open loop, Fig. 11: 600 gaits, with and without the brake disturbance growing with the load"),
    ("analog", "controller option: analog mode near the target"),
    ("fastgait", "controller option: the 50 Hz gait on a 2 mm move"),
    ("combined", "controller options: the 50 Hz gait and analog mode together, on a 2 mm move"),
    ("bdmap", "controller option: the brake-disturbance map with the single integrator, on the staircase"),
];

/// Earlier names still accepted, and not listed: (old name, scenario).
pub const ALIASES: [(&str, &str); 1] = [("future", "combined")];

/// The scenarios' names, in the order of [`SCENARIOS`].
pub fn names() -> Vec<&'static str> {
    SCENARIOS.iter().map(|(n, _)| *n).collect()
}

/// The scenario `name` means: itself if listed, the scenario an alias stands for, or `None`.
pub fn resolve(name: &str) -> Option<&'static str> {
    let listed = SCENARIOS.iter().map(|(n, _)| (*n, *n));
    listed.chain(ALIASES).find(|(n, _)| *n == name).map(|(_, s)| s)
}

/// Points the reference FMU's table holds (`InchwormReference`'s `n_points` range; a test
/// holds the two together).
pub const REFERENCE_TABLE_POINTS: usize = 16;

/// Samples of one gait of the open-loop slews.
pub const SAMPLES_PER_GAIT: usize = 100;

/// Full forward gaits open loop on fia20 with the brake disturbance's load growth `gamma`.
fn slew(name: &str, gamma: f64) -> Variant {
    Variant {
        name: name.into(),
        plant: PlantParams { gamma, ..PlantParams::fia20() },
        drive: Drive::OpenLoopSlew,
    }
}

fn closed(name: &str, plant: PlantParams, params: Params) -> Variant {
    Variant { name: name.into(), plant, drive: Drive::Controller(Box::new(params)) }
}

/// The scenario `name` (or an alias of it, [`resolve`]); `None` for `mirror`, which is not
/// a loop of one actuator ([`mirror`]), and for an unknown name.
pub fn by_name(name: &str) -> Option<Scenario> {
    let name = resolve(name)?;
    let feedback_only = Params {
        feedforward: false,
        use_scale_factor_estimate: false,
        use_disturbance_estimate: false,
        ..Params::default()
    };
    let fia20 = PlantParams::fia20;
    Some(match name {
        "fig5" => Scenario {
            name: "fig5",
            title: "Fig. 5: runner at rest at 0, reference 100 µm from t = 0",
            duration: 10.0,
            reference: constant(100e-6),
            variants: vec![
                closed("full control", fia20(), Params::default()),
                closed("feedback only", fia20(), feedback_only),
            ],
            regulation: vec![(6.0, 10.0)],
        },
        "staircase" => Scenario {
            name: "staircase",
            title: "Figs. 6-7: reference staircase with the prefilter on",
            duration: 700.0,
            reference: staircase(),
            variants: vec![closed(
                "full control + prefilter",
                fia20(),
                Params { prefilter: true, ..Params::default() },
            )],
            regulation: staircase_regulation(),
        },
        "calibration" => Scenario {
            name: "calibration",
            title: "Calibration: the staircase from the nominal inverse scale factor and zero disturbance",
            duration: 700.0,
            reference: staircase(),
            variants: vec![closed(
                "from nominal",
                fia20(),
                Params {
                    prefilter: true,
                    scale_weights_start: NOMINAL_WEIGHTS,
                    disturbance_start: 0.0,
                    ..Params::default()
                },
            )],
            regulation: staircase_regulation(),
        },
        "fia6" => Scenario {
            name: "fia6",
            title: "The 6 µm device (fia6): reference 30 µm, estimator started from the nominal 6 µm map",
            duration: 20.0,
            reference: constant(30e-6),
            variants: vec![closed("full control", PlantParams::fia6(), crate::controller::fia6())],
            regulation: vec![(10.0, 20.0)],
        },
        "slew" => Scenario {
            name: "slew",
            title: "Open-loop slew of full forward gaits over 40 mm (gamma = 0)",
            // 5040 gaits of 0.2 s: past 40 mm.
            duration: 1008.0,
            reference: constant(0.0),
            variants: vec![slew("gamma = 0", 0.0)],
            regulation: vec![],
        },
        "stall" => Scenario {
            name: "stall",
            title: "Fig. 11: open-loop slews stall when the brake disturbance grows with the load (600 gaits)",
            duration: 120.0,
            reference: constant(0.0),
            variants: vec![slew("gamma = 0", 0.0), slew("gamma = 10", 10.0)],
            regulation: vec![],
        },
        _ => return controller_options(name),
    })
}

impl Scenario {
    /// The master's options for a closed-loop variant on the open system: the plant's
    /// and the controller's parameters in full, the reference table on the system input,
    /// every variable of [`closed_loop::recorded`].
    pub fn options(&self, plant: &PlantParams, controller: &Params) -> Options {
        let mut params = crate::plant::parameters(plant);
        params.extend(crate::controller::parameters(controller));
        Options {
            stop_time: Some(self.duration),
            step_size: Some(SAMPLE_PERIOD),
            coupling: Coupling::Jacobi,
            params,
            parameter_set: None,
            input: Some(self.reference.clone()),
            outputs: closed_loop::recorded(),
        }
    }

    /// Whether every variant is an open-loop slew (read gait by gait, not as a loop).
    pub fn open_loop(&self) -> bool {
        self.variants.iter().all(|v| matches!(v.drive, Drive::OpenLoopSlew))
    }

    /// The same on the closed system: the reference as the reference component's table,
    /// recorded as its output (renamed `reference` in the trace by [`Scenario::run_variant`]).
    pub fn closed_options(&self, plant: &PlantParams, controller: &Params) -> Options {
        let mut o = self.options(plant, controller);
        o.input = None;
        let points = self.reference.points(0);
        let param = |v: Var<ReferenceFmu>, x: String| (format!("reference.{}", v.name()), x);
        o.params.push(param(ReferenceFmu::PROFILE, "0".into()));
        o.params.push(param(ReferenceFmu::N_POINTS, points.len().to_string()));
        for (i, (t, p)) in points.iter().enumerate() {
            o.params.push(param(ReferenceFmu::TIMES_1.element(i), format!("{t:e}")));
            o.params.push(param(ReferenceFmu::POSITIONS_1.element(i), format!("{p:e}")));
        }
        o.outputs = closed_loop::recorded_as(REFERENCE_OUTPUT);
        o
    }

    /// Runs one variant. An open-loop slew has no FMU system, so it runs the plant crate
    /// whatever `via` says.
    pub fn run_variant(&self, v: &Variant, via: Via) -> Result<Trace, Error> {
        self.run_variant_timed(v, via).map(|(trace, _)| trace)
    }

    /// [`Scenario::run_variant`], with where its wall time went (a run of the crates has
    /// nothing to load: all of it is loop).
    pub fn run_variant_timed(&self, v: &Variant, via: Via) -> Result<(Trace, Timing), Error> {
        let start = std::time::Instant::now();
        let crates = |trace: Trace| {
            let loop_s = start.elapsed().as_secs_f64();
            Ok((trace, Timing { load_s: 0.0, loop_s, simulated_s: self.duration }))
        };
        match (&v.drive, via) {
            (Drive::OpenLoopSlew, _) => crates(closed_loop::open_loop_slew(
                v.plant.clone(),
                (self.duration / (SAMPLES_PER_GAIT as f64 * SAMPLE_PERIOD)).round() as usize,
            )?),
            (Drive::Controller(p), Via::Direct) => crates(closed_loop::run(
                v.plant.clone(),
                (**p).clone(),
                |t| self.reference.value(0, t),
                self.duration,
            )?),
            (Drive::Controller(p), Via::System(ssp)) => {
                // The closed system carries its reference as a component of that name.
                if closed_loop::reference_name(ssp)? != REFERENCE_OUTPUT {
                    return Ok(master::run_timed(ssp, &self.options(&v.plant, p), |_| {})?);
                }
                // A reference of more points than the reference FMU's table holds runs on
                // the open sibling, fed from the system input.
                if self.reference.points(0).len() > REFERENCE_TABLE_POINTS {
                    let open = ssp.with_file_name("InchwormSystemOpen.ssp");
                    return Ok(master::run_timed(&open, &self.options(&v.plant, p), |_| {})?);
                }
                let (mut trace, timing) =
                    master::run_timed(ssp, &self.closed_options(&v.plant, p), |_| {})?;
                for name in trace.names.iter_mut().filter(|n| n.as_str() == REFERENCE_OUTPUT) {
                    *name = closed_loop::REFERENCE.into();
                }
                Ok((trace, timing))
            }
        }
    }

    /// Every variant, in order.
    pub fn run(&self, via: Via) -> Result<Vec<Trace>, Error> {
        self.run_timed(via).map(|(traces, _)| traces)
    }

    /// [`Scenario::run`], with where the runs' wall time went, all variants together.
    pub fn run_timed(&self, via: Via) -> Result<(Vec<Trace>, Timing), Error> {
        let mut all = Timing::default();
        let mut traces = Vec::new();
        for v in &self.variants {
            let (trace, timing) = self.run_variant_timed(v, via)?;
            traces.push(trace);
            all = all.and(timing);
        }
        Ok((traces, all))
    }

    /// How the runs went through `via`, for the report's first line.
    pub fn via_text(&self, via: Via) -> String {
        if self.open_loop() {
            return "plant crate, open loop".into();
        }
        match via {
            Via::Direct => "plant and controller crates coupled directly".into(),
            Via::System(p) => format!("{}, Jacobi 2 ms", p.display()),
        }
    }

    /// One line on a variant's run: settling and regulation for a closed loop, the
    /// distance per step for a slew.
    pub fn summary(&self, v: &Variant, r: &LoopView) -> String {
        if is_controller_option(self.name) {
            return options_summary(self, v, r);
        }
        match v.drive {
            Drive::OpenLoopSlew => {
                let g = closed_loop::SlewView::new(r, SAMPLES_PER_GAIT);
                let (first, last) = (g.advance[0], *g.advance.last().unwrap_or(&0.0));
                format!(
                    "{:<12} {} gaits, {:.3} mm; advance per gait: first {:.3} µm (from rest), second {:.3} µm, last {:.3} µm; largest gait-to-gait change {:.4} µm; {} backward",
                    v.name,
                    g.advance.len(),
                    g.position.last().unwrap_or(&0.0) * 1e3,
                    first * 1e6,
                    g.advance.get(1).unwrap_or(&0.0) * 1e6,
                    last * 1e6,
                    g.largest_change() * 1e6,
                    g.backward()
                )
            }
            Drive::Controller(_) => {
                let settle =
                    r.settle_time(1e-6).map_or("does not settle within 1 µm".into(), |t| {
                        format!("settles within 1 µm at {t:.3} s")
                    });
                let rms: Vec<String> = self
                    .regulation
                    .iter()
                    .map(|&(a, b)| format!("{:.3}", r.parked_rms(a, b) * 1e9))
                    .collect();
                format!(
                    "{:<26} {settle}; parked RMS in regulation {} nm; final disturbance estimate {:.3} µm",
                    v.name,
                    rms.join(" / "),
                    r.disturbance_estimate.last().copied().unwrap_or(0.0) * 1e6
                )
            }
        }
    }
}

mod mirror;
mod options;

pub use mirror::*;
pub use options::*;

#[cfg(test)]
mod tests {
    use super::*;

    /// The table must be the staircase at every communication point of the 700 s runs,
    /// boundaries included, or the scenario traces would change with the move to a table.
    #[test]
    fn staircase_table_is_the_level_of_every_point() {
        let table = staircase();
        for k in 0..=350_000usize {
            let t = k as f64 * SAMPLE_PERIOD;
            let level = STAIRCASE_UM[((t / 100.0) as usize).min(STAIRCASE_UM.len() - 1)] * 1e-6;
            assert_eq!(table.value(0, t), level, "t = {t}");
        }
    }

    #[test]
    fn the_reference_table_size_is_the_reference_fmus() {
        assert_eq!(REFERENCE_TABLE_POINTS, inchworm_fmu_models::reference::MAX_POINTS);
    }

    #[test]
    fn every_name_is_a_scenario() {
        for n in names().into_iter().filter(|&n| n != "mirror") {
            let s = by_name(n).unwrap_or_else(|| panic!("{n}"));
            assert_eq!(s.name, n);
            assert!(!s.variants.is_empty());
        }
        assert!(by_name("fig6").is_none());
        assert!(by_name("mirror").is_none(), "the mount is not a loop of one actuator");
        for (old, new) in ALIASES {
            assert!(!names().contains(&old), "an alias is not listed");
            assert_eq!(by_name(old).map(|s| s.name), Some(new));
        }
    }
}
