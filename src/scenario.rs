//! Named scenarios of the paper (docs/model.md §4.1): closed loops run by the master on
//! `InchwormSystem.ssp` or with the crates coupled directly, and the open-loop slews of
//! Fig. 11; each variant one [`Trace`], written as CSV and PNG by `inchworm scenario`.

use std::path::Path;

use inchworm_controller::{Params, NOMINAL_WEIGHTS, SAMPLE_PERIOD};
use inchworm_plant::PlantParams;

use crate::closed_loop::{self, LoopView};
use crate::master::{self, Coupling, InputTable, Options};
use crate::trace::Trace;

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
    /// The same reference as `(time, position)` points, for the reference component.
    pub reference_points: Vec<(f64, f64)>,
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
    InputTable::steps("reference", &staircase_points()).expect("the staircase times increase")
}

fn constant(value: f64) -> InputTable {
    InputTable::steps("reference", &[(0.0, value)]).expect("one finite row")
}

/// The name under which the closed system records its reference.
const REFERENCE_OUTPUT: &str = "reference.reference";

/// Each level from 20 s after its change to its end.
fn staircase_regulation() -> Vec<(f64, f64)> {
    (0..STAIRCASE_UM.len()).map(|k| (k as f64 * 100.0 + 20.0, (k + 1) as f64 * 100.0)).collect()
}

pub const NAMES: [&str; 5] = ["fig5", "staircase", "calibration", "fia6", "stall"];

fn closed(name: &str, plant: PlantParams, params: Params) -> Variant {
    Variant { name: name.into(), plant, drive: Drive::Controller(Box::new(params)) }
}

pub fn by_name(name: &str) -> Option<Scenario> {
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
            reference_points: vec![(0.0, 100e-6)],
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
            reference_points: staircase_points(),
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
            reference_points: staircase_points(),
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
            reference_points: vec![(0.0, 30e-6)],
            variants: vec![closed("full control", PlantParams::fia6(), crate::controller::fia6())],
            regulation: vec![(10.0, 20.0)],
        },
        "stall" => Scenario {
            name: "stall",
            title: "Fig. 11: open-loop slews stall when the brake disturbance falls with the environment load",
            // 200 full steps of 0.2 s.
            duration: 40.0,
            reference: constant(0.0),
            reference_points: vec![(0.0, 0.0)],
            variants: [0.0, 10.0]
                .into_iter()
                .map(|gamma| Variant {
                    name: format!("gamma = {gamma}"),
                    plant: PlantParams { gamma, ..fia20() },
                    drive: Drive::OpenLoopSlew,
                })
                .collect(),
            regulation: vec![],
        },
        _ => return None,
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

    /// The same on the closed system: the reference as the reference component's table,
    /// recorded as its output (renamed `reference` in the trace by [`Scenario::run_variant`]).
    pub fn closed_options(&self, plant: &PlantParams, controller: &Params) -> Options {
        let mut o = self.options(plant, controller);
        o.input = None;
        let n = self.reference_points.len();
        o.params.push(("reference.profile".into(), "0".into()));
        o.params.push(("reference.n_points".into(), n.to_string()));
        for (i, (t, p)) in self.reference_points.iter().enumerate() {
            o.params.push((format!("reference.times[{}]", i + 1), format!("{t:e}")));
            o.params.push((format!("reference.positions[{}]", i + 1), format!("{p:e}")));
        }
        for name in o.outputs.iter_mut().filter(|n| n.as_str() == "reference") {
            *name = REFERENCE_OUTPUT.into();
        }
        o
    }

    /// Runs one variant. An open-loop slew has no FMU system, so it runs the plant crate
    /// whatever `via` says.
    pub fn run_variant(&self, v: &Variant, via: Via) -> Result<Trace, String> {
        match (&v.drive, via) {
            (Drive::OpenLoopSlew, _) => closed_loop::open_loop_slew(
                v.plant.clone(),
                (self.duration / (100.0 * SAMPLE_PERIOD)).round() as usize,
            ),
            (Drive::Controller(p), Via::Direct) => closed_loop::run(
                v.plant.clone(),
                (**p).clone(),
                |t| self.reference.value(0, t),
                self.duration,
            ),
            (Drive::Controller(p), Via::System(ssp)) => {
                // The closed system carries its reference as a component of that name.
                let closed = crate::ssp::Archive::open(ssp)?
                    .system
                    .components
                    .iter()
                    .any(|c| c.name == "reference");
                if !closed {
                    return master::run(ssp, &self.options(&v.plant, p), |_| {});
                }
                let mut trace = master::run(ssp, &self.closed_options(&v.plant, p), |_| {})?;
                for name in trace.names.iter_mut().filter(|n| n.as_str() == REFERENCE_OUTPUT) {
                    *name = "reference".into();
                }
                Ok(trace)
            }
        }
    }

    /// Every variant, in order.
    pub fn run(&self, via: Via) -> Result<Vec<Trace>, String> {
        self.variants.iter().map(|v| self.run_variant(v, via)).collect()
    }

    /// How the runs went through `via`, for the report's first line.
    pub fn via_text(&self, via: Via) -> String {
        if self.variants.iter().all(|v| matches!(v.drive, Drive::OpenLoopSlew)) {
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
        match v.drive {
            Drive::OpenLoopSlew => {
                let um = |i: usize| r.encoder_position[i] * 1e6;
                let per_step =
                    |s: usize| um((s + 1) * 100 - 1) - if s == 0 { 0.0 } else { um(s * 100 - 1) };
                let steps = r.time.len() / 100;
                format!(
                    "{:<14} first step {:.2} µm, step {} {:.2} µm, step {} {:.2} µm, final position {:.1} µm",
                    v.name,
                    per_step(0),
                    steps / 2,
                    per_step(steps / 2 - 1),
                    steps,
                    per_step(steps - 1),
                    um(r.time.len() - 1)
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
    fn every_name_is_a_scenario() {
        for n in NAMES {
            let s = by_name(n).unwrap_or_else(|| panic!("{n}"));
            assert_eq!(s.name, n);
            assert!(!s.variants.is_empty());
        }
        assert!(by_name("fig6").is_none());
    }
}
