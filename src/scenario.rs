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

pub const NAMES: [&str; 6] = ["fig5", "staircase", "calibration", "fia6", "slew", "stall"];

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
        "slew" => Scenario {
            name: "slew",
            title: "Open-loop slew of full forward gaits over 40 mm (gamma = 0)",
            // 5040 gaits of 0.2 s: past 40 mm.
            duration: 1008.0,
            reference: constant(0.0),
            reference_points: vec![(0.0, 0.0)],
            variants: vec![slew("gamma = 0", 0.0)],
            regulation: vec![],
        },
        "stall" => Scenario {
            name: "stall",
            title: "Fig. 11: open-loop slews stall when the brake disturbance grows with the load (600 gaits)",
            duration: 120.0,
            reference: constant(0.0),
            reference_points: vec![(0.0, 0.0)],
            variants: vec![slew("gamma = 0", 0.0), slew("gamma = 10", 10.0)],
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

    /// Whether every variant is an open-loop slew (read gait by gait, not as a loop).
    pub fn open_loop(&self) -> bool {
        self.variants.iter().all(|v| matches!(v.drive, Drive::OpenLoopSlew))
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
                (self.duration / (SAMPLES_PER_GAIT as f64 * SAMPLE_PERIOD)).round() as usize,
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

/// The mirror mount's command, as `fmu-build` writes it into `MirrorMount.ssp` (each
/// reference's default binding): piston from t = 0, the tip on top of it from
/// [`MIRROR_TIP_TIME`].
pub const MIRROR_PISTON: f64 = 30e-6;
pub const MIRROR_TIP: f64 = 4e-6;
pub const MIRROR_TIP_TIME: f64 = 4.0;
/// The mirror run: 10 s, regulation from 8 s.
pub const MIRROR_DURATION: f64 = 10.0;
pub const MIRROR_REGULATION: f64 = 8.0;
/// Settled: piston within 0.1 µm, pointing within 0.1 µrad of the command.
pub const MIRROR_PISTON_TOL: f64 = 0.1e-6;
pub const MIRROR_POINTING_TOL: f64 = 0.1e-6;

/// What `inchworm scenario mirror` records of `MirrorMount.ssp`.
pub fn mirror_recorded() -> Vec<String> {
    let mut v: Vec<String> = ["mount.piston", "mount.tip", "mount.tilt"].map(String::from).to_vec();
    for x in ["a", "b", "c"] {
        v.push(format!("plant_{x}.runner_position"));
        v.push(format!("plant_{x}.encoder_counts"));
    }
    v
}

/// The mirror mount's run and its figures.
pub struct MirrorRun {
    pub trace: Trace,
    /// From the piston command (t = 0) until the piston stays within tolerance.
    pub piston_settle: Option<f64>,
    /// From the tip command until the pointing error stays within tolerance.
    pub tip_settle: Option<f64>,
    /// RMS of the pointing error |(tip, tilt) - command| over the parked samples from
    /// [`MIRROR_REGULATION`] on (rad).
    pub pointing_rms: f64,
    /// RMS of the piston error in the same window (m).
    pub piston_rms: f64,
}

/// Rows at which all three runners are parked: every encoder still for the last 8
/// samples (between moves; during a step a runner travels micrometres and back).
fn parked_rows(trace: &Trace) -> Vec<usize> {
    let enc: Vec<usize> = ["a", "b", "c"]
        .iter()
        .filter_map(|x| trace.index(&format!("plant_{x}.encoder_counts")))
        .collect();
    (7..trace.rows.len())
        .filter(|&i| {
            enc.iter().all(|&c| (i - 7..i).all(|j| trace.rows[j].1[c] == trace.rows[i].1[c]))
        })
        .collect()
}

/// When a signal settles, measured from `from`: the first parked row after the last
/// parked row at or after `from` where `bad` holds.
fn settle(
    trace: &Trace,
    parked: &[usize],
    from: f64,
    bad: impl Fn(f64, &[f64]) -> bool,
) -> Option<f64> {
    let rows: Vec<&(f64, Vec<f64>)> =
        parked.iter().map(|&i| &trace.rows[i]).filter(|(t, _)| *t >= from).collect();
    match rows.iter().rposition(|(t, v)| bad(*t, v)) {
        None => rows.first().map(|(t, _)| t - from),
        Some(j) if j + 1 < rows.len() => Some(rows[j + 1].0 - from),
        Some(_) => None,
    }
}

/// Runs `MirrorMount.ssp` by the master (Jacobi, 2 ms, no input: the commands are the
/// references' bindings) and measures it on the parked samples, as the paper's figures
/// are measured.
pub fn mirror_run(ssp: &Path) -> Result<MirrorRun, String> {
    let opts = Options {
        stop_time: Some(MIRROR_DURATION),
        step_size: Some(SAMPLE_PERIOD),
        coupling: Coupling::Jacobi,
        params: vec![],
        parameter_set: None,
        input: None,
        outputs: mirror_recorded(),
    };
    let trace = master::run(ssp, &opts, |_| {})?;
    Ok(MirrorRun::measure(trace))
}

impl MirrorRun {
    /// The figures of a trace recorded as [`mirror_recorded`].
    pub fn measure(trace: Trace) -> MirrorRun {
        let (piston, tip, tilt) = (0, 1, 2);
        let pointing = |t: f64, v: &[f64]| {
            let cmd = if t >= MIRROR_TIP_TIME { MIRROR_TIP } else { 0.0 };
            (v[tip] - cmd).hypot(v[tilt])
        };
        let parked = parked_rows(&trace);
        let piston_settle = settle(&trace, &parked, 0.0, |_, v| {
            (v[piston] - MIRROR_PISTON).abs() > MIRROR_PISTON_TOL
        });
        let tip_settle =
            settle(&trace, &parked, MIRROR_TIP_TIME, |t, v| pointing(t, v) > MIRROR_POINTING_TOL);
        let window: Vec<&(f64, Vec<f64>)> = parked
            .iter()
            .map(|&i| &trace.rows[i])
            .filter(|(t, _)| *t >= MIRROR_REGULATION)
            .collect();
        let rms =
            |e: Vec<f64>| (e.iter().map(|x| x * x).sum::<f64>() / e.len().max(1) as f64).sqrt();
        let pointing_rms = rms(window.iter().map(|(t, v)| pointing(*t, v)).collect());
        let piston_rms = rms(window.iter().map(|(_, v)| v[piston] - MIRROR_PISTON).collect());
        MirrorRun { trace, piston_settle, tip_settle, pointing_rms, piston_rms }
    }
}

impl MirrorRun {
    /// The report's lines.
    pub fn summary(&self) -> String {
        let s = |x: Option<f64>| x.map_or("does not settle".into(), |t| format!("{t:.3} s"));
        format!(
            "piston {:.0} µm from t = 0: settles within {:.1} µm after {}\n\
             tip {:.1} µrad from t = {MIRROR_TIP_TIME} s: pointing settles within {:.0} nrad after {}\n\
             parked samples in regulation (t >= {MIRROR_REGULATION} s): pointing RMS {:.1} nrad, piston RMS {:.2} nm",
            MIRROR_PISTON * 1e6,
            MIRROR_PISTON_TOL * 1e6,
            s(self.piston_settle),
            MIRROR_TIP * 1e6,
            MIRROR_POINTING_TOL * 1e9,
            s(self.tip_settle),
            self.pointing_rms * 1e9,
            self.piston_rms * 1e9
        )
    }

    /// The plotted view: piston (µm), tip and tilt (µrad), pointing error (nrad), runners a
    /// and b (µm).
    pub fn plot_trace(&self) -> Trace {
        let mut t = Trace::new(
            [
                "piston (um)",
                "tip (urad)",
                "tilt (urad)",
                "pointing error (nrad)",
                "runner a (um)",
                "runner b (um)",
            ]
            .map(String::from)
            .to_vec(),
        );
        for (time, v) in &self.trace.rows {
            let cmd = if *time >= MIRROR_TIP_TIME { MIRROR_TIP } else { 0.0 };
            let err = (v[1] - cmd).hypot(v[2]);
            t.push(
                *time,
                vec![v[0] * 1e6, v[1] * 1e6, v[2] * 1e6, err * 1e9, v[3] * 1e6, v[5] * 1e6],
            );
        }
        t
    }
}

/// `inchworm scenario mirror`: runs `<dist>/MirrorMount.ssp`, prints its figures, writes
/// `<out>/mirror.csv` (the recorded variables) and `<out>/mirror.png`.
pub fn mirror(dist: &Path, out: &Path, font: &Path) -> Result<(), String> {
    crate::plot::load_font(font)?;
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let ssp = dist.join("MirrorMount.ssp");
    let wall = std::time::Instant::now();
    let run = mirror_run(&ssp)?;
    let wall = wall.elapsed().as_secs_f64();
    println!(
        "Mirror mount: three inchworm chains 120° apart on a 50 mm radius ({}, Jacobi 2 ms)",
        ssp.display()
    );
    for l in run.summary().lines() {
        println!("  {l}");
    }
    println!(
        "{MIRROR_DURATION:.0} s simulated in {wall:.2} s ({:.0}x real time)",
        MIRROR_DURATION / wall
    );
    let csv = out.join("mirror.csv");
    let mut text = Vec::new();
    run.trace.write_csv(&mut text).map_err(|e| e.to_string())?;
    std::fs::write(&csv, text).map_err(|e| format!("{}: {e}", csv.display()))?;
    println!("wrote {}", csv.display());
    let png = out.join("mirror.png");
    crate::plot::trace_png(
        "Mirror mount: piston 30 um, then tip 4 urad at 4 s",
        &run.plot_trace(),
        &png,
    )
    .map_err(|e| format!("{}: cannot draw the plot: {e}", png.display()))?;
    println!("wrote {}", png.display());
    Ok(())
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
