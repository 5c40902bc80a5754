//! `inchworm gait`: the plant FMU open loop through the docs/model.md §2.9 gait sequence.

use super::Text;
use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;

use inchworm_cosim::fmu::{CsFmu, FmuError};
use inchworm_scenarios::gait::{self, CHECK_TOLERANCE_UM};
use inchworm_scenarios::plant::{GaitRun, Plant};
use inchworm_scenarios::plot;

#[derive(Args)]
pub struct GaitArgs {
    /// The plant FMU (built by `cargo run --release -p fmu-build`).
    #[arg(long, default_value = "dist/InchwormPlant.fmu")]
    pub fmu: PathBuf,
    /// Output directory for gait.csv and gait.png (created if missing).
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// Run the five-step sequence this many times back to back (the check values apply to
    /// the first run, which starts from rest).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    pub repeat: u32,
    /// TrueType font for the plot labels.
    #[arg(long, default_value = plot::DEFAULT_FONT)]
    pub font: PathBuf,
    /// Turn on the FMU's debug logging (fmi2 loggingOn) and print its info messages.
    #[arg(long)]
    pub fmi_logging: bool,
}

fn load_plant(path: &Path, logging: bool) -> Result<Plant, String> {
    let fmu = CsFmu::load(path, "plant", logging).map_err(|e| match e {
        FmuError::Missing(_) => {
            format!("{e}: build it first with `cargo run --release -p fmu-build`")
        }
        e => e.to_string(),
    })?;
    Plant::new(fmu).map_err(|e| e.to_string())
}

pub fn run(args: &GaitArgs) -> Result<(), String> {
    // Fail on a missing font or output directory before the run, not after it.
    plot::load_font(&args.font).text()?;
    super::create_dir(&args.out)?;

    let mut plant = load_plant(&args.fmu, args.fmi_logging)?;
    let steps = gait::check_sequence(args.repeat as usize);
    let wall = Instant::now();
    let run = GaitRun::run(&mut plant, &steps).text()?;
    let wall = wall.elapsed().as_secs_f64();
    plant.terminate().text()?;

    print_measurements(&run);
    let last = run.samples.last().expect("a run has at least its initial point");
    let sim_time = last.time;
    println!(
        "\n{:.3} s simulated in {:.3} s of wall time ({:.0}x real time); {} slip events (entries into FREE); final mode {}",
        sim_time,
        wall,
        sim_time / wall,
        last.out.slip_events,
        format!("{:?}", last.out.mode).to_uppercase()
    );
    super::write_file(&args.out.join("gait.csv"), |w| run.write_csv(w))?;
    super::write_png(&args.out.join("gait.png"), |p| plot::gait_png(&run, p))
}

/// The docs/model.md §3.3 raw measurements of every step, in µm, beside the docs/model.md §2.9 check values
/// for the first five (the check run starts from rest with the default `fia20` parameters).
fn print_measurements(run: &GaitRun) {
    println!("raw measurements (docs/model.md §3.3) from the encoder (µm); [§2.9 check value] and deviation, tolerance ±{CHECK_TOLERANCE_UM} µm");
    let head = |name: &str| format!("{name:>9} {:>9} {:>7} ", "[check]", "Δ");
    println!(
        "{:>4} {:>5} {:>8}  {}  {}  {}",
        "step",
        "y",
        "EXT_cmd",
        head("EXT_moved"),
        head("BD"),
        head("s7")
    );
    let mut worst: Option<(f64, String)> = None;
    let mut outside = 0;
    let mut checked = 0;
    let check = gait::check_values("fia20");
    for (i, step) in run.steps.iter().enumerate() {
        let m = run.measurements(i);
        let got = [m.ext_moved * 1e6, m.bd * 1e6, m.position_after() * 1e6];
        let mut cols = Vec::with_capacity(3);
        for (j, &g) in got.iter().enumerate() {
            match check.get(i) {
                Some(c) => {
                    let want = [c.ext_moved_um, c.bd_um, c.position_after_um][j];
                    let d = g - want;
                    checked += 1;
                    let within = d.abs() <= CHECK_TOLERANCE_UM;
                    if !within {
                        outside += 1;
                    }
                    let mark = if within { " " } else { "!" };
                    let name = ["EXT_moved", "BD", "s7"][j];
                    if worst.as_ref().is_none_or(|w| d.abs() > w.0) {
                        worst = Some((d.abs(), format!("step {} {name}", i + 1)));
                    }
                    cols.push(format!("{g:>9.4} [{want:>7.3}] {d:>+7.4}{mark}"));
                }
                None => cols.push(format!("{g:>9.4}{:19}", "")),
            }
        }
        println!(
            "{:>4} {:>+5.1} {:>8.4}  {}  {}  {}",
            i + 1,
            step.amplitude(),
            m.ext_cmd,
            cols[0],
            cols[1],
            cols[2]
        );
    }
    if let Some((d, at)) = worst {
        let verdict = if outside == 0 { "all within" } else { "NOT all within" };
        println!(
            "check values: {} of {checked} within {CHECK_TOLERANCE_UM} µm ({verdict} tolerance; largest deviation {d:.4} µm, {at})",
            checked - outside
        );
    }
}
