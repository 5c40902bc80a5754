//! The mirror mount: three actuator chains and the mount's kinematics in
//! `dist/MirrorMount.ssp`, commanded in piston and tip, measured in pointing.

use super::*;
use crate::holding::{HoldingRms, Settle};
use inchworm_fmu_models::{MountFmu, PlantFmu};

pub use inchworm_fmu_models::mount::{MIRROR_PISTON, MIRROR_TIP, MIRROR_TIP_TIME};
/// The mirror run: 10 s, regulation from 8 s.
pub const MIRROR_DURATION: f64 = 10.0;
pub const MIRROR_REGULATION: f64 = 8.0;
/// Settled: piston within 0.1 µm, pointing within 0.1 µrad of the command.
pub const MIRROR_PISTON_TOL: f64 = 0.1e-6;
pub const MIRROR_POINTING_TOL: f64 = 0.1e-6;

/// What `inchworm scenario mirror` records of `MirrorMount.ssp`.
pub fn mirror_recorded() -> Vec<String> {
    let pose = [MountFmu::PISTON, MountFmu::TIP, MountFmu::TILT];
    let mut v: Vec<String> = pose.iter().map(|p| format!("mount.{}", p.name())).collect();
    for x in ["a", "b", "c"] {
        v.push(format!("plant_{x}.{}", PlantFmu::RUNNER_POSITION.name()));
        v.push(format!("plant_{x}.{}", PlantFmu::ENCODER_COUNTS.name()));
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
        .filter_map(|x| trace.index(&format!("plant_{x}.{}", PlantFmu::ENCODER_COUNTS.name())))
        .collect();
    (7..trace.rows.len())
        .filter(|&i| {
            enc.iter().all(|&c| (i - 7..i).all(|j| trace.rows[j].1[c] == trace.rows[i].1[c]))
        })
        .collect()
}

/// When a signal settles, measured from `from`: the [`Settle`] time of the parked rows at
/// or after `from`, a row outside the band where `bad` holds.
fn settle(
    trace: &Trace,
    parked: &[usize],
    from: f64,
    bad: impl Fn(f64, &[f64]) -> bool,
) -> Option<f64> {
    let mut settle = Settle::default();
    for (t, v) in parked.iter().map(|&i| &trace.rows[i]).filter(|(t, _)| *t >= from) {
        settle.push(*t, bad(*t, v));
    }
    settle.time().map(|t| t - from)
}

/// Runs `MirrorMount.ssp` by the master (Jacobi, 2 ms, no input: the commands are the
/// references' bindings) and measures it on the parked samples, as the paper's figures
/// are measured.
pub fn mirror_run(ssp: &Path) -> Result<MirrorRun, super::Error> {
    mirror_run_timed(ssp).map(|(run, _)| run)
}

/// [`mirror_run`], with where its wall time went.
pub fn mirror_run_timed(ssp: &Path) -> Result<(MirrorRun, Timing), super::Error> {
    let opts = Options {
        stop_time: Some(MIRROR_DURATION),
        step_size: Some(SAMPLE_PERIOD),
        coupling: Coupling::Jacobi,
        params: vec![],
        parameter_set: None,
        input: None,
        outputs: mirror_recorded(),
    };
    let (trace, timing) = master::run_timed(ssp, &opts, |_| {})?;
    Ok((MirrorRun::measure(trace), timing))
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
        // The holding RMS of each error over the parked rows from the regulation on.
        let (mut pointing_rms, mut piston_rms) = (
            HoldingRms::new(MIRROR_REGULATION, f64::INFINITY),
            HoldingRms::new(MIRROR_REGULATION, f64::INFINITY),
        );
        for (t, v) in parked.iter().map(|&i| &trace.rows[i]) {
            pointing_rms.push(*t, pointing(*t, v));
            piston_rms.push(*t, v[piston] - MIRROR_PISTON);
        }
        let pointing_rms = pointing_rms.value().unwrap_or(0.0);
        let piston_rms = piston_rms.value().unwrap_or(0.0);
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
pub fn mirror(dist: &Path, out: &Path, font: &Path) -> Result<(), super::Error> {
    crate::plot::load_font(font)?;
    std::fs::create_dir_all(out)
        .map_err(|source| super::Error::Write { path: out.into(), source })?;
    let ssp = dist.join("MirrorMount.ssp");
    let (run, timing) = mirror_run_timed(&ssp)?;
    println!(
        "Mirror mount: three inchworm chains 120° apart on a 50 mm radius ({}, Jacobi 2 ms)",
        ssp.display()
    );
    for l in run.summary().lines() {
        println!("  {l}");
    }
    println!("{timing}");
    let csv = out.join("mirror.csv");
    let mut text = Vec::new();
    let write = |source| super::Error::Write { path: csv.clone(), source };
    run.trace.write_csv(&mut text).map_err(write)?;
    inchworm_cosim::output::write(&csv, &text).map_err(write)?;
    println!("wrote {}", csv.display());
    let png = out.join("mirror.png");
    crate::plot::trace_png(
        "Mirror mount: piston 30 um, then tip 4 urad at 4 s",
        &run.plot_trace(),
        &png,
    )
    .map_err(|source| super::Error::Plot { path: png.clone(), source })?;
    println!("wrote {}", png.display());
    Ok(())
}
