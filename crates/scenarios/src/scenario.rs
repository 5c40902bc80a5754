//! Named scenarios of the paper (docs/model.md §4.1): closed loops run by the master on
//! `InchwormSystem.ssp` or with the crates coupled directly, and the open-loop slews of
//! Fig. 11; each variant one [`Trace`], written as CSV and PNG by `inchworm scenario`.

use std::path::Path;

use inchworm_controller::{Params, NOMINAL_WEIGHTS, SAMPLE_PERIOD};
use inchworm_plant::PlantParams;

use crate::closed_loop::{self, LoopView};
use inchworm_cosim::master::{self, Coupling, InputTable, Options};
use inchworm_cosim::Trace;

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
        o.params.push(("reference.profile".into(), "0".into()));
        o.params.push(("reference.n_points".into(), points.len().to_string()));
        for (i, (t, p)) in points.iter().enumerate() {
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
    pub fn run_variant(&self, v: &Variant, via: Via) -> Result<Trace, crate::Error> {
        match (&v.drive, via) {
            (Drive::OpenLoopSlew, _) => Ok(closed_loop::open_loop_slew(
                v.plant.clone(),
                (self.duration / (SAMPLES_PER_GAIT as f64 * SAMPLE_PERIOD)).round() as usize,
            )?),
            (Drive::Controller(p), Via::Direct) => Ok(closed_loop::run(
                v.plant.clone(),
                (**p).clone(),
                |t| self.reference.value(0, t),
                self.duration,
            )?),
            (Drive::Controller(p), Via::System(ssp)) => {
                // The closed system carries its reference as a component of that name.
                let closed = inchworm_cosim::ssp::Archive::open(ssp)?
                    .system
                    .components
                    .iter()
                    .any(|c| c.name == "reference");
                if !closed {
                    return Ok(master::run(ssp, &self.options(&v.plant, p), |_| {})?);
                }
                // A reference of more points than the reference FMU's table holds runs on
                // the open sibling, fed from the system input.
                if self.reference.points(0).len() > REFERENCE_TABLE_POINTS {
                    let open = ssp.with_file_name("InchwormSystemOpen.ssp");
                    return Ok(master::run(&open, &self.options(&v.plant, p), |_| {})?);
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
    pub fn run(&self, via: Via) -> Result<Vec<Trace>, crate::Error> {
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
pub fn mirror_run(ssp: &Path) -> Result<MirrorRun, crate::Error> {
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
pub fn mirror(dist: &Path, out: &Path, font: &Path) -> Result<(), crate::Error> {
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

// ---- The controller's options of docs/model.md §4.2, beyond the paper: analog mode, the
// 50 Hz gait, both, and the brake-disturbance map. ----

/// The scenarios of the controller's options, one per feature and one combining two.
pub const CONTROLLER_OPTIONS: [&str; 4] = ["analog", "fastgait", "combined", "bdmap"];

pub fn is_controller_option(name: &str) -> bool {
    CONTROLLER_OPTIONS.contains(&name)
}

/// The 50 Hz gait: 10 samples of 2 ms per step.
pub fn fast_gait() -> Params {
    Params { samples_per_step: 10, ..Params::default() }
}

/// Analog mode near the target, with the 5 Hz gait for large moves.
pub fn analog() -> Params {
    Params { analog: true, ..Params::default() }
}

/// The analog scenario's reference (µm): 100 µm, +100 nm at 10 s, +1 µm at 11 s, a walk
/// of +1 µm every 0.2 s from 12 s to 16 s (re-centrings), a 40 µm jump at 20 s.
fn analog_reference() -> InputTable {
    let mut rows = vec![(0.0, 100.0), (10.0, 100.1), (11.0, 101.1)];
    rows.extend((1..=20).map(|k| (12.0 + 0.2 * (k - 1) as f64, 101.1 + k as f64)));
    rows.push((20.0, 161.1));
    let rows: Vec<(f64, f64)> = rows.into_iter().map(|(t, um)| (t, um * 1e-6)).collect();
    InputTable::steps("reference", &rows).expect("times increase")
}

fn controller_options(name: &str) -> Option<Scenario> {
    let fia20 = PlantParams::fia20;
    Some(match name {
        "analog" => Scenario {
            name: "analog",
            title: "Analog mode near the target: hold in DRIVE, 100 nm and 1 µm changes, a 20 µm walk (re-centring), a 40 µm jump",
            duration: 25.0,
            reference: analog_reference(),
            variants: vec![
                closed("baseline", fia20(), Params::default()),
                closed("analog", fia20(), analog()),
            ],
            regulation: vec![(6.0, 10.0), (23.0, 25.0)],
        },
        "fastgait" => Scenario {
            name: "fastgait",
            title: "A 2 mm move: the 5 Hz gait (100 samples per step) and the 50 Hz gait (10)",
            duration: 40.0,
            reference: constant(2e-3),
            variants: vec![
                closed("5 Hz gait", fia20(), Params::default()),
                closed("50 Hz gait", fia20(), fast_gait()),
            ],
            regulation: vec![(30.0, 40.0)],
        },
        "combined" => Scenario {
            name: "combined",
            title: "A 2 mm move, then 100 nm and 1 µm changes: baseline and the 50 Hz gait with analog mode",
            duration: 30.0,
            reference: InputTable::steps(
                "reference",
                &[(0.0, 2e-3), (25.0, 2.0001e-3), (26.0, 2.0011e-3)],
            )
            .expect("times increase"),
            variants: vec![
                closed("baseline", fia20(), Params::default()),
                closed("50 Hz gait + analog", fia20(), Params { analog: true, ..fast_gait() }),
            ],
            regulation: vec![(23.0, 25.0), (27.0, 30.0)],
        },
        "bdmap" => Scenario {
            name: "bdmap",
            title: "Figs. 6-7 staircase: the disturbance from the latest estimate, and from the map (with the single integrator)",
            duration: 700.0,
            reference: staircase(),
            variants: vec![
                closed("latest estimate", fia20(), Params { prefilter: true, ..Params::default() }),
                closed("map + single integrator", fia20(), Params {
                    prefilter: true,
                    disturbance_map: true,
                    use_disturbance_map: true,
                    single_integrator: true,
                    ..Params::default()
                }),
            ],
            regulation: staircase_regulation(),
        },
        _ => return None,
    })
}

/// What a controller-option scenario adds to its traces: for `bdmap`, the map learned over the
/// staircase, as CSV and a figure, and the residuals of the coming step's disturbance
/// over the staircase and over a 2 mm slew after it (printed). Nothing for the others.
pub fn write_extras(name: &str, out: &Path) -> Result<(), crate::Error> {
    if name != "bdmap" {
        return Ok(());
    }
    let p = Params { prefilter: true, ..Params::default() };
    let fia20 = PlantParams::fia20;
    let table = staircase();
    let st =
        closed_loop::disturbance_map_run(fia20(), p.clone(), |t| table.value(0, t), 700.0, 100.0)?;
    let slew = |t: f64| if t < 700.0 { table.value(0, t) } else { 2.02e-3 };
    let sl = closed_loop::disturbance_map_run(fia20(), p, slew, 725.0, 700.0)?;
    for (what, r) in [("staircase (from 100 s)", &st), ("2 mm slew after it", &sl)] {
        println!(
            "  BD of the coming step, {what}, {} steps: RMS residual {:.4} µm with the latest estimate, {:.4} µm with the map",
            r.steps,
            r.rms_last * 1e6,
            r.rms_map * 1e6
        );
    }
    let csv = out.join("bdmap_map.csv");
    let mut text = String::from("ext_cmd,bd_map_staircase\n");
    for (c, b) in &st.curve {
        text.push_str(&format!("{c},{b:e}\n"));
    }
    std::fs::write(&csv, text).map_err(|e| format!("{}: {e}", csv.display()))?;
    println!("wrote {}", csv.display());
    let png = out.join("bdmap_map.png");
    map_png(&st, &png).map_err(|e| format!("{}: cannot draw the plot: {e}", png.display()))?;
    println!("wrote {}", png.display());
    Ok(())
}

fn map_png(r: &closed_loop::MapRun, path: &Path) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let orange = RGBColor(220, 80, 0);
    let root = BitMapBackend::new(path, (1000, 650)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(
        "Brake disturbance against the extension command: every step of the staircase, and the map at its end",
        ("sans-serif", 18),
    )?;
    let mut chart = ChartBuilder::on(&root)
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(-1.05f64..1.05f64, 3.5f64..6.0f64)?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .x_desc("EXT_cmd (fraction of a full step; negative backward)")
        .y_desc("BD (µm)")
        .label_style(("sans-serif", 14))
        .draw()?;
    chart
        .draw_series(
            r.pairs.iter().map(|&(c, b)| Circle::new((c, b * 1e6), 2, BLUE.mix(0.3).filled())),
        )?
        .label(format!("measured BD, {} steps", r.pairs.len()))
        .legend(|(x, y)| Circle::new((x + 10, y), 3, BLUE.filled()));
    chart
        .draw_series(LineSeries::new(
            r.curve.iter().map(|&(c, b)| (c, b * 1e6)),
            orange.stroke_width(3),
        ))?
        .label(format!(
            "map at the end; coming-step residual {:.4} µm (latest estimate {:.4} µm)",
            r.rms_map * 1e6,
            r.rms_last * 1e6
        ))
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], orange.stroke_width(3)));
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 13))
        .draw()?;
    root.present()?;
    Ok(())
}

/// Settling (within 1 µm and 2 nm), holding RMS and slew rate, judged on the held samples
/// (step boundaries and analog hold, [`LoopView::held`]).
fn options_summary(s: &Scenario, v: &Variant, r: &LoopView) -> String {
    let settle = |tol: f64| {
        r.held_settle_time(tol, 0.0).map_or("not settled".to_string(), |t| format!("{t:.3} s"))
    };
    let rms: Vec<String> =
        s.regulation.iter().map(|&(a, b)| format!("{:.3}", r.held_rms(a, b) * 1e9)).collect();
    let target = r.reference.first().copied().unwrap_or(0.0);
    let slew = r
        .slew_rate(target)
        .filter(|_| target > 1e-3)
        .map_or(String::new(), |v| format!("; slew {:.0} µm/s (10-90 %)", v * 1e6));
    format!(
        "{:<22} within 1 µm from {}, within 2 nm from {}; held RMS in regulation {} nm{slew}",
        v.name,
        settle(1e-6),
        settle(2e-9),
        rms.join(" / ")
    )
}

/// The figure of a controller-option scenario: position on top, |error| of the held samples
/// (log scale, nm) below.
pub fn options_png(
    title: &str,
    names: &[&str],
    runs: &[LoopView],
    path: &Path,
) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let colors = [BLUE, RGBColor(220, 80, 0), RGBColor(0, 140, 0)];
    let root = BitMapBackend::new(path, (1400, 900)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(title, ("sans-serif", 22))?;
    let (top, bottom) = root.split_vertically(430);
    let t_end = runs.iter().filter_map(|r| r.time.last()).fold(1.0f64, |a, &b| a.max(b));
    let (lo, hi) = runs
        .iter()
        .flat_map(|r| r.encoder_position.iter().chain(&r.reference))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x * 1e6), b.max(x * 1e6)));
    let pad = (hi - lo).max(1.0) * 0.05;
    let mut chart = ChartBuilder::on(&top)
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..t_end, (lo - pad)..(hi + pad))?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .y_desc("encoder position (µm)")
        .label_style(("sans-serif", 14))
        .draw()?;
    if let Some(r) = runs.first() {
        chart
            .draw_series(LineSeries::new(
                r.time.iter().zip(&r.reference).map(|(&t, &x)| (t, x * 1e6)),
                BLACK.stroke_width(1),
            ))?
            .label("reference")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK));
    }
    for (i, (r, name)) in runs.iter().zip(names).enumerate() {
        let c = colors[i % colors.len()];
        chart
            .draw_series(LineSeries::new(
                r.time.iter().zip(&r.encoder_position).map(|(&t, &x)| (t, x * 1e6)),
                c.stroke_width(2),
            ))?
            .label(name.to_string())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 15))
        .draw()?;
    let mut chart = ChartBuilder::on(&bottom)
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..t_end, (0.1f64..1e5f64).log_scale())?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .x_desc("time (s)")
        .y_desc("|error| at held samples (nm)")
        .label_style(("sans-serif", 14))
        .draw()?;
    for (i, r) in runs.iter().enumerate() {
        let c = colors[i % colors.len()];
        let pts: Vec<(f64, f64)> = r
            .held()
            .into_iter()
            .map(|i| (r.time[i], (r.error(i).abs() * 1e9).clamp(0.1, 1e5)))
            .collect();
        chart.draw_series(pts.into_iter().map(|p| Circle::new(p, 1, c.filled())))?;
    }
    for (tol, label) in [(1e3, "1 µm"), (2.0, "2 nm")] {
        chart.draw_series(LineSeries::new([(0.0, tol), (t_end, tol)], BLACK.mix(0.5)))?;
        chart.draw_series(std::iter::once(Text::new(
            label,
            (t_end * 0.005, tol * 1.3),
            ("sans-serif", 14),
        )))?;
    }
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod controller_option_tests {
    use super::*;

    #[test]
    fn every_controller_option_is_a_scenario_with_a_distinct_variant() {
        for n in CONTROLLER_OPTIONS {
            let s = by_name(n).unwrap_or_else(|| panic!("{n}"));
            assert!(names().contains(&n) && is_controller_option(s.name));
            assert_eq!(s.variants.len(), 2);
        }
        let r = analog_reference();
        assert!((r.value(0, 16.0) - 121.1e-6).abs() < 1e-15);
        assert!((r.value(0, 20.0) - 161.1e-6).abs() < 1e-15);
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
