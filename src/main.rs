//! `inchworm`: command-line co-simulation master of the inchworm actuator FMUs.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use clap::{Args, Parser, Subcommand};

use inchworm::fmu::{CsFmu, FmuError};
use inchworm::gait::{self, CHECK_TOLERANCE_UM, CHECK_VALUES};
use inchworm::plant::{mode_name, GaitRun, Plant};
use inchworm::plot;

#[derive(Parser)]
#[command(
    name = "inchworm",
    version,
    about = "Co-simulation of JPL's inchworm actuator: runs its FMI 2.0 FMUs, writes CSV and plots"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Drive the plant FMU open loop with the SPEC 2.9 gait sequence (steps of amplitude
    /// +1, +1, −1, +0.3, −0.3, 100 samples of 2 ms each), write <out>/gait.csv and
    /// <out>/gait.png, and print the SPEC 3.3 raw measurements beside the SPEC 2.9 check
    /// values.
    ///
    /// gait.csv has one row per 2 ms communication point from t = 0: the DAC volts held
    /// from that time over the next sample, and the plant outputs at that time, in SI
    /// units (s, V, m; mode 1 HOLD, 2 LOCKED, 3 DRIVE, 4 FREE).
    Gait(GaitArgs),
    /// Run a named closed-loop scenario of the paper (fig5, staircase, calibration) through
    /// the two FMUs (or the crates, with --direct), write <out>/<name>.csv and
    /// <out>/<name>.png, and print settle times, RMS and estimates.
    Scenario(ScenarioArgs),
    /// Run an SSP system (.ssp) or a single FMI 2.0 Co-Simulation FMU (.fmu) with a fixed
    /// communication step, and write the chosen variables at every communication point as
    /// CSV.
    Run(RunArgs),
}

#[derive(Args)]
struct RunArgs {
    /// The system (.ssp) or FMU (.fmu).
    file: PathBuf,
    /// Stop time (s); default: the file's default experiment, else 1 s.
    #[arg(long)]
    stop_time: Option<f64>,
    /// Communication step (s); default: the file's, else stop time / 500.
    #[arg(long)]
    step_size: Option<f64>,
    #[arg(long, value_enum, default_value = "jacobi")]
    coupling: CouplingArg,
    /// A start value or parameter: component.variable=value (variable=value for an FMU).
    #[arg(long = "param", value_name = "NAME=VALUE")]
    params: Vec<String>,
    /// A parameter set of the SSP, by name (resources/<name>.ssv).
    #[arg(long)]
    parameter_set: Option<String>,
    /// CSV `time,<input>,…` for the system's (or FMU's) unconnected inputs, held
    /// piecewise constant.
    #[arg(long)]
    input: Option<PathBuf>,
    /// A variable to record (component.variable, or a system output); repeatable;
    /// default: the system's outputs.
    #[arg(long = "output", value_name = "NAME")]
    outputs: Vec<String>,
    /// Where to write the results.
    #[arg(long, default_value = "out/run.csv")]
    out: PathBuf,
    /// Also draw the recorded variables (the first six) into this PNG.
    #[arg(long)]
    plot: Option<PathBuf>,
    #[arg(long, default_value = plot::DEFAULT_FONT)]
    font: PathBuf,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum CouplingArg {
    Jacobi,
    GaussSeidel,
}

#[derive(Args)]
struct ScenarioArgs {
    /// fig5 | staircase | calibration | fia6 | stall
    name: String,
    /// Folder holding InchwormPlant.fmu and InchwormController.fmu.
    #[arg(long, default_value = "dist")]
    dist: PathBuf,
    /// Couple the plant and controller crates directly instead of loading the FMUs.
    #[arg(long)]
    direct: bool,
    #[arg(long, default_value = "out")]
    out: PathBuf,
    #[arg(long, default_value = plot::DEFAULT_FONT)]
    font: PathBuf,
}

#[derive(Args)]
struct GaitArgs {
    /// The plant FMU (built by `cargo run --release -p fmu-build`).
    #[arg(long, default_value = "dist/InchwormPlant.fmu")]
    fmu: PathBuf,
    /// Output directory for gait.csv and gait.png (created if missing).
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Run the five-step sequence this many times back to back (the check values apply to
    /// the first run, which starts from rest).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    repeat: u32,
    /// TrueType font for the plot labels.
    #[arg(long, default_value = plot::DEFAULT_FONT)]
    font: PathBuf,
    /// Turn on the FMU's debug logging (fmi2 loggingOn) and print its info messages.
    #[arg(long)]
    fmi_logging: bool,
}

/// Prints the FMU's logger messages (which the `fmi` crate forwards as `log` records,
/// with the instance name as target) and the import layer's own warnings on stderr.
struct StderrLogger;

impl log::Log for StderrLogger {
    fn enabled(&self, metadata: &log::Metadata) -> bool {
        metadata.level() <= log::max_level()
    }
    fn log(&self, record: &log::Record) {
        if self.enabled(record.metadata()) {
            eprintln!("[{}] {}: {}", record.level(), record.target(), record.args());
        }
    }
    fn flush(&self) {}
}

static LOGGER: StderrLogger = StderrLogger;

fn main() -> ExitCode {
    // Rust ignores SIGPIPE, so printing into a closed pipe panics; a command-line tool
    // should just stop, as the shell expects.
    // SAFETY: setting a signal disposition to its default before any thread exists.
    #[cfg(unix)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    let level = match &cli.command {
        Command::Gait(args) if args.fmi_logging => log::LevelFilter::Info,
        _ => log::LevelFilter::Warn,
    };
    // Only fails if a logger is already installed, which nothing in this binary does.
    let _ = log::set_logger(&LOGGER);
    log::set_max_level(level);
    let result = match cli.command {
        Command::Gait(args) => run_gait(&args),
        Command::Run(args) => run_file(&args),
        Command::Scenario(args) => run_scenario(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run_stall(args: &ScenarioArgs) -> Result<(), String> {
    plot::load_font(&args.font)?;
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: cannot create the output directory: {e}", args.out.display()))?;
    let gammas = [0.0, 10.0];
    let runs = inchworm::scenario::open_loop_slew(&gammas, 200);
    println!("Fig. 11: open-loop slew of 200 full forward steps (plant crate, fia20)");
    let mut names = Vec::new();
    for (g, r) in gammas.iter().zip(&runs) {
        let per_step = |s: usize| (r.encoder_counts[(s + 1) * 100 - 1] - if s == 0 { 0 } else { r.encoder_counts[s * 100 - 1] }) as f64 * 1.2e-3;
        println!(
            "  gamma = {g:>4}: first step {:.2} µm, step 100 {:.2} µm, step 200 {:.2} µm, final position {:.1} µm",
            per_step(0),
            per_step(99),
            per_step(199),
            *r.encoder_counts.last().unwrap() as f64 * 1.2e-3
        );
        let path = args.out.join(format!("stall_gamma_{g}.csv"));
        let f = std::fs::File::create(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let mut w = std::io::BufWriter::new(f);
        r.write_csv(&mut w).and_then(|_| std::io::Write::flush(&mut w)).map_err(|e| format!("{}: {e}", path.display()))?;
        println!("wrote {}", path.display());
        names.push(format!("gamma = {g}"));
    }
    let png = args.out.join("stall.png");
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    plot::closed_loop_png("Fig. 11: open-loop slews stall when the brake disturbance falls with the environment load", &names, &runs, &png)
        .map_err(|e| format!("{}: cannot draw the plot: {e}", png.display()))?;
    println!("wrote {}", png.display());
    Ok(())
}

fn run_scenario(args: &ScenarioArgs) -> Result<(), String> {
    if args.name == "stall" {
        return run_stall(args);
    }
    let s = inchworm::scenario::by_name(&args.name)
        .ok_or_else(|| format!("unknown scenario `{}`; known: {}", args.name, inchworm::scenario::NAMES.join(", ")))?;
    plot::load_font(&args.font)?;
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: cannot create the output directory: {e}", args.out.display()))?;
    let wall = Instant::now();
    let runs = inchworm::scenario::run_scenario(&s, (!args.direct).then_some(args.dist.as_path()))?;
    let wall = wall.elapsed().as_secs_f64();
    let via = if args.direct { "plant and controller crates coupled directly" } else { "InchwormPlant.fmu + InchwormController.fmu, Jacobi 2 ms" };
    println!("{} ({via})", s.title);
    let mut written = Vec::new();
    for (v, r) in s.variants.iter().zip(&runs) {
        let settle = r.settle_time(1e-6).map_or("does not settle within 1 µm".into(), |t| format!("settles within 1 µm at {t:.3} s"));
        let rms: Vec<String> = s.regulation.iter().map(|&(a, b)| format!("{:.3}", r.parked_rms(a, b) * 1e9)).collect();
        println!(
            "  {:<26} {settle}; parked RMS in regulation {} nm; final disturbance estimate {:.3} µm",
            v.name,
            rms.join(" / "),
            r.disturbance_estimate.last().copied().unwrap_or(0.0) * 1e6
        );
        let slug: String = v.name.split(|c: char| !c.is_alphanumeric()).filter(|w| !w.is_empty()).collect::<Vec<_>>().join("_");
        let file = format!("{}_{slug}.csv", s.name);
        let path = args.out.join(file);
        let f = std::fs::File::create(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let mut w = std::io::BufWriter::new(f);
        r.write_csv(&mut w).and_then(|_| std::io::Write::flush(&mut w)).map_err(|e| format!("{}: {e}", path.display()))?;
        written.push(path);
    }
    let png = args.out.join(format!("{}.png", s.name));
    let names: Vec<&str> = s.variants.iter().map(|v| v.name).collect();
    plot::closed_loop_png(s.title, &names, &runs, &png).map_err(|e| format!("{}: cannot draw the plot: {e}", png.display()))?;
    written.push(png);
    let sim: f64 = s.duration * runs.len() as f64;
    println!("{sim:.0} s simulated in {wall:.2} s ({:.0}x real time)", sim / wall);
    for p in written {
        println!("wrote {}", p.display());
    }
    Ok(())
}

fn run_file(args: &RunArgs) -> Result<(), String> {
    use inchworm::master::{Coupling, InputTable, Options};
    use std::io::IsTerminal;
    let input = match &args.input {
        Some(p) => Some(InputTable::parse(&std::fs::read_to_string(p).map_err(|e| format!("{}: {e}", p.display()))?).map_err(|e| format!("{}: {e}", p.display()))?),
        None => None,
    };
    let params = args
        .params
        .iter()
        .map(|p| p.split_once('=').map(|(a, b)| (a.to_string(), b.to_string())).ok_or_else(|| format!("--param {p}: expected NAME=VALUE")))
        .collect::<Result<Vec<_>, _>>()?;
    let opts = Options {
        stop_time: args.stop_time,
        step_size: args.step_size,
        coupling: match args.coupling {
            CouplingArg::Jacobi => Coupling::Jacobi,
            CouplingArg::GaussSeidel => Coupling::GaussSeidel,
        },
        params,
        parameter_set: args.parameter_set.clone(),
        input,
        outputs: args.outputs.clone(),
    };
    let show = std::io::stderr().is_terminal();
    let mut shown = 0;
    let wall = Instant::now();
    let results = inchworm::master::run(&args.file, &opts, |f| {
        let pct = (f * 100.0) as u32;
        if show && pct >= shown + 5 {
            shown = pct;
            eprint!("\r{pct:>3} %");
        }
    })?;
    if show {
        eprintln!();
    }
    let wall = wall.elapsed().as_secs_f64();
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    let f = std::fs::File::create(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let mut w = std::io::BufWriter::new(f);
    results.write_csv(&mut w).and_then(|_| std::io::Write::flush(&mut w)).map_err(|e| format!("{}: {e}", args.out.display()))?;
    if let Some(png) = &args.plot {
        plot::load_font(&args.font)?;
        let title = format!("inchworm run {}", args.file.display());
        plot::results_png(&title, &results, png).map_err(|e| format!("{}: cannot draw the plot: {e}", png.display()))?;
        println!("wrote {}", png.display());
    }
    let end = results.rows.last().map_or(0.0, |r| r.0);
    println!("{end} s simulated in {wall:.3} s ({:.0}x real time); wrote {} ({} variables, {} rows)", end / wall, args.out.display(), results.names.len(), results.rows.len());
    Ok(())
}

fn load_plant(path: &Path, logging: bool) -> Result<Plant, String> {
    let fmu = CsFmu::load(path, "plant", logging).map_err(|e| match e {
        FmuError::Missing(_) => format!("{e}: build it first with `cargo run --release -p fmu-build`"),
        e => e.to_string(),
    })?;
    Plant::new(fmu).map_err(|e| e.to_string())
}

fn run_gait(args: &GaitArgs) -> Result<(), String> {
    // Fail on a missing font or output directory before the run, not after it.
    plot::load_font(&args.font)?;
    std::fs::create_dir_all(&args.out)
        .map_err(|e| format!("{}: cannot create the output directory: {e}", args.out.display()))?;

    let mut plant = load_plant(&args.fmu, args.fmi_logging)?;
    let steps = gait::check_sequence(args.repeat as usize);
    let wall = Instant::now();
    let run = GaitRun::run(&mut plant, &steps).map_err(|e| e.to_string())?;
    let wall = wall.elapsed().as_secs_f64();
    plant.terminate().map_err(|e| e.to_string())?;

    let csv_path = args.out.join("gait.csv");
    let file = std::fs::File::create(&csv_path).map_err(|e| format!("{}: {e}", csv_path.display()))?;
    let mut w = std::io::BufWriter::new(file);
    run.write_csv(&mut w)
        .and_then(|_| std::io::Write::flush(&mut w))
        .map_err(|e| format!("{}: {e}", csv_path.display()))?;
    let png_path = args.out.join("gait.png");
    plot::gait_png(&run, &png_path).map_err(|e| format!("{}: cannot draw the plot: {e}", png_path.display()))?;

    print_measurements(&run);
    let last = run.samples.last().expect("a run has at least its initial point");
    let sim_time = last.time;
    println!(
        "\n{:.3} s simulated in {:.3} s of wall time ({:.0}x real time); {} slip events (entries into FREE); final mode {}",
        sim_time,
        wall,
        sim_time / wall,
        last.out.slip_events,
        mode_name(last.out.mode)
    );
    println!("wrote {} and {}", csv_path.display(), png_path.display());
    Ok(())
}

/// The SPEC 3.3 raw measurements of every step, in µm, beside the SPEC 2.9 check values
/// for the first five (the check run starts from rest with the default `fia20` parameters).
fn print_measurements(run: &GaitRun) {
    println!("SPEC 3.3 raw measurements from the encoder (µm); [SPEC 2.9 check value] and deviation, tolerance ±{CHECK_TOLERANCE_UM} µm");
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
    for (i, step) in run.steps.iter().enumerate() {
        let m = run.measurements(i);
        let got = [m.ext_moved * 1e6, m.bd * 1e6, m.position_after() * 1e6];
        let mut cols = Vec::with_capacity(3);
        for (j, &g) in got.iter().enumerate() {
            match CHECK_VALUES.get(i) {
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
