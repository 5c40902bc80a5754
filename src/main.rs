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
    /// The HIL bridge (docs/hil-protocol.md). `--role controller` runs the controller FMU
    /// against a driver board (real, or a virtual one); `--role board` is the virtual
    /// driver board: the plant FMU behind the protocol, for the controller bridge or a real
    /// controller board. Real time at 500 Hz, or lock-step with --lockstep.
    Bridge(BridgeArgs),
    /// Re-run the controller FMU on a controller-side bridge log and report any sample
    /// whose DAC codes differ from the logged ones.
    Replay(ReplayArgs),
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum RoleArg {
    Controller,
    Board,
}

#[derive(Args)]
struct BridgeArgs {
    #[arg(long, value_enum)]
    role: RoleArg,
    /// Board: the UDP address to listen on. Controller: the board's address.
    #[arg(long, default_value = "127.0.0.1:50500")]
    addr: String,
    /// Use a serial line (COBS frames) instead of UDP.
    #[arg(long)]
    serial: Option<PathBuf>,
    #[arg(long, default_value_t = 921_600)]
    baud: u32,
    /// The FMU to run (default: dist/InchwormController.fmu or dist/InchwormPlant.fmu).
    #[arg(long)]
    fmu: Option<PathBuf>,
    /// A start value or parameter of the FMU; repeatable.
    #[arg(long = "param", value_name = "NAME=VALUE")]
    params: Vec<String>,
    /// Lock-step: the controller drives each tick and the board answers at once; the
    /// encoder trace equals the co-simulation's.
    #[arg(long)]
    lockstep: bool,
    /// Controller: run this long (s). Board: stop after this long (default: until Ctrl-C).
    #[arg(long)]
    duration: Option<f64>,
    /// Controller: CSV `time,reference` (m), held piecewise constant; default 100 µm from t = 0.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Board: periods without a valid frame before the safe state latches.
    #[arg(long, default_value_t = 3)]
    watchdog: u32,
    /// Controller: the largest tolerated gap in the encoder stream's sequence.
    #[arg(long, default_value_t = 3)]
    max_gap: u16,
    /// Controller: real-time periods without an encoder frame before the link is dead.
    #[arg(long, default_value_t = 10)]
    dead_after: u32,
    /// What a missed deadline does: soft (count, log, continue) or hard (fault to the safe state).
    #[arg(long, default_value = "soft")]
    overrun: inchworm_bridge::OverrunPolicy,
    /// SCHED_FIFO priority to ask for (needs privileges; refused: a warning, and the run goes on).
    #[arg(long, default_value_t = 80)]
    rt_priority: i32,
    /// The run log (every sample and event; crash-proof; `inchworm replay` reads it).
    #[arg(long)]
    log: Option<PathBuf>,
    /// Controller: the encoder trace as CSV.
    #[arg(long)]
    out: Option<PathBuf>,
}

#[derive(Args)]
struct ReplayArgs {
    /// A controller-side log written by `inchworm bridge --role controller --log`.
    log: PathBuf,
    #[arg(long, default_value = "dist/InchwormController.fmu")]
    fmu: PathBuf,
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

/// Prints the FMU's logger messages (which the import layer, `inchworm-fmi-import`,
/// forwards as `log` records with the instance name as target) and the layer's own
/// warnings on stderr.
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
        Command::Bridge(_) => log::LevelFilter::Info,
        _ => log::LevelFilter::Warn,
    };
    // Only fails if a logger is already installed, which nothing in this binary does.
    let _ = log::set_logger(&LOGGER);
    log::set_max_level(level);
    let result = match cli.command {
        Command::Gait(args) => run_gait(&args),
        Command::Run(args) => run_file(&args),
        Command::Scenario(args) => run_scenario(&args),
        Command::Bridge(args) => run_bridge(&args),
        Command::Replay(args) => run_replay(&args),
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
    std::fs::create_dir_all(&args.out)
        .map_err(|e| format!("{}: cannot create the output directory: {e}", args.out.display()))?;
    let gammas = [0.0, 10.0];
    let runs = inchworm::scenario::open_loop_slew(&gammas, 200);
    println!("Fig. 11: open-loop slew of 200 full forward steps (plant crate, fia20)");
    let mut names = Vec::new();
    for (g, r) in gammas.iter().zip(&runs) {
        let per_step = |s: usize| {
            (r.encoder_counts[(s + 1) * 100 - 1]
                - if s == 0 { 0 } else { r.encoder_counts[s * 100 - 1] }) as f64
                * 1.2e-3
        };
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
        r.write_csv(&mut w)
            .and_then(|_| std::io::Write::flush(&mut w))
            .map_err(|e| format!("{}: {e}", path.display()))?;
        println!("wrote {}", path.display());
        names.push(format!("gamma = {g}"));
    }
    let png = args.out.join("stall.png");
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    plot::closed_loop_png(
        "Fig. 11: open-loop slews stall when the brake disturbance falls with the environment load",
        &names,
        &runs,
        &png,
    )
    .map_err(|e| format!("{}: cannot draw the plot: {e}", png.display()))?;
    println!("wrote {}", png.display());
    Ok(())
}

fn run_scenario(args: &ScenarioArgs) -> Result<(), String> {
    if args.name == "stall" {
        return run_stall(args);
    }
    let s = inchworm::scenario::by_name(&args.name).ok_or_else(|| {
        format!("unknown scenario `{}`; known: {}", args.name, inchworm::scenario::NAMES.join(", "))
    })?;
    plot::load_font(&args.font)?;
    std::fs::create_dir_all(&args.out)
        .map_err(|e| format!("{}: cannot create the output directory: {e}", args.out.display()))?;
    let wall = Instant::now();
    let runs = inchworm::scenario::run_scenario(&s, (!args.direct).then_some(args.dist.as_path()))?;
    let wall = wall.elapsed().as_secs_f64();
    let via = if args.direct {
        "plant and controller crates coupled directly"
    } else {
        "InchwormPlant.fmu + InchwormController.fmu, Jacobi 2 ms"
    };
    println!("{} ({via})", s.title);
    let mut written = Vec::new();
    for (v, r) in s.variants.iter().zip(&runs) {
        let settle = r.settle_time(1e-6).map_or("does not settle within 1 µm".into(), |t| {
            format!("settles within 1 µm at {t:.3} s")
        });
        let rms: Vec<String> =
            s.regulation.iter().map(|&(a, b)| format!("{:.3}", r.parked_rms(a, b) * 1e9)).collect();
        println!(
            "  {:<26} {settle}; parked RMS in regulation {} nm; final disturbance estimate {:.3} µm",
            v.name,
            rms.join(" / "),
            r.disturbance_estimate.last().copied().unwrap_or(0.0) * 1e6
        );
        let slug: String = v
            .name
            .split(|c: char| !c.is_alphanumeric())
            .filter(|w| !w.is_empty())
            .collect::<Vec<_>>()
            .join("_");
        let file = format!("{}_{slug}.csv", s.name);
        let path = args.out.join(file);
        let f = std::fs::File::create(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let mut w = std::io::BufWriter::new(f);
        r.write_csv(&mut w)
            .and_then(|_| std::io::Write::flush(&mut w))
            .map_err(|e| format!("{}: {e}", path.display()))?;
        written.push(path);
    }
    let png = args.out.join(format!("{}.png", s.name));
    let names: Vec<&str> = s.variants.iter().map(|v| v.name).collect();
    plot::closed_loop_png(s.title, &names, &runs, &png)
        .map_err(|e| format!("{}: cannot draw the plot: {e}", png.display()))?;
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
        Some(p) => Some(
            InputTable::parse(
                &std::fs::read_to_string(p).map_err(|e| format!("{}: {e}", p.display()))?,
            )
            .map_err(|e| format!("{}: {e}", p.display()))?,
        ),
        None => None,
    };
    let params = parse_params(&args.params)?;
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
    results
        .write_csv(&mut w)
        .and_then(|_| std::io::Write::flush(&mut w))
        .map_err(|e| format!("{}: {e}", args.out.display()))?;
    if let Some(png) = &args.plot {
        plot::load_font(&args.font)?;
        let title = format!("inchworm run {}", args.file.display());
        plot::results_png(&title, &results, png)
            .map_err(|e| format!("{}: cannot draw the plot: {e}", png.display()))?;
        println!("wrote {}", png.display());
    }
    let end = results.rows.last().map_or(0.0, |r| r.0);
    println!(
        "{end} s simulated in {wall:.3} s ({:.0}x real time); wrote {} ({} variables, {} rows)",
        end / wall,
        args.out.display(),
        results.names.len(),
        results.rows.len()
    );
    Ok(())
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
    let file =
        std::fs::File::create(&csv_path).map_err(|e| format!("{}: {e}", csv_path.display()))?;
    let mut w = std::io::BufWriter::new(file);
    run.write_csv(&mut w)
        .and_then(|_| std::io::Write::flush(&mut w))
        .map_err(|e| format!("{}: {e}", csv_path.display()))?;
    let png_path = args.out.join("gait.png");
    plot::gait_png(&run, &png_path)
        .map_err(|e| format!("{}: cannot draw the plot: {e}", png_path.display()))?;

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

/// Set by SIGINT/SIGTERM: the bridge stops at the next period, the board side in its safe
/// state, the logs flushed.
static STOP: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

extern "C" fn request_stop(_: libc::c_int) {
    STOP.store(true, std::sync::atomic::Ordering::Relaxed);
}

fn run_bridge(args: &BridgeArgs) -> Result<(), String> {
    use inchworm_bridge::board::{run_board, Board, BoardConfig};
    use inchworm_bridge::controller::{run_controller, ControllerConfig};
    use inchworm_bridge::realtime::{enter_real_time, percentiles};
    use inchworm_bridge::runlog::{LogWriter, Record};
    use inchworm_bridge::transport::{open_serial, CobsTransport, Transport, UdpTransport};
    use std::sync::atomic::Ordering;

    // SAFETY: the handler only stores to an atomic.
    unsafe {
        libc::signal(libc::SIGINT, request_stop as *const () as libc::sighandler_t);
        libc::signal(libc::SIGTERM, request_stop as *const () as libc::sighandler_t);
    }
    let params = parse_params(&args.params)?;
    let board_role = args.role == RoleArg::Board;
    let fmu = args.fmu.clone().unwrap_or_else(|| {
        PathBuf::from(if board_role {
            "dist/InchwormPlant.fmu"
        } else {
            "dist/InchwormController.fmu"
        })
    });
    let mut transport: Box<dyn Transport> = match &args.serial {
        Some(path) => {
            let f = open_serial(path, args.baud).map_err(|e| format!("{}: {e}", path.display()))?;
            Box::new(CobsTransport::new(f))
        }
        None if board_role => Box::new(
            UdpTransport::bind(&args.addr)
                .map_err(|e| format!("cannot listen on {}: {e}", args.addr))?,
        ),
        None => Box::new(
            UdpTransport::connect(&args.addr)
                .map_err(|e| format!("board address {}: {e}", args.addr))?,
        ),
    };
    let mut log = match &args.log {
        Some(p) => {
            if let Some(dir) = p.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
            }
            Some(LogWriter::create(p).map_err(|e| format!("run log: {e}"))?)
        }
        None => None,
    };
    if !args.lockstep {
        let rt = enter_real_time(args.rt_priority);
        for w in &rt.warnings {
            eprintln!("warning: {w}");
        }
    }
    let mode = if args.lockstep { "lock-step" } else { "real time, 500 Hz" };

    if board_role {
        let mechanism = inchworm::bridge::FmuMechanism::load(&fmu, &params)?;
        let cfg = BoardConfig {
            lockstep: args.lockstep,
            watchdog_periods: args.watchdog.max(1),
            overrun: args.overrun,
            ..BoardConfig::default()
        };
        let mut board = Board::new(mechanism, cfg, log.take())?;
        let where_ = args.serial.as_ref().map_or(args.addr.clone(), |p| p.display().to_string());
        println!(
            "virtual board: {} on {where_} ({mode}, watchdog {} periods); Ctrl-C stops",
            fmu.display(),
            cfg.watchdog_periods
        );
        if let Some(d) = args.duration {
            std::thread::spawn(move || {
                std::thread::sleep(std::time::Duration::from_secs_f64(d.max(0.0)));
                STOP.store(true, Ordering::Relaxed);
            });
        }
        let mut lateness = Vec::new();
        let result = run_board(&mut board, &mut transport, &STOP, &mut lateness);
        let c = &board.counters;
        println!(
            "board: {} steps; frames {} valid, {} malformed, {} duplicate, {} stale, {} gaps ({} missing), {} while unarmed, {} overruns; final state {:?}",
            c.steps, c.link.frames, c.link.malformed, c.link.duplicates, c.link.stale, c.link.gaps, c.link.missing, c.unarmed, c.overruns, board.state()
        );
        for l in &board.latches {
            println!(
                "safe state at tick {} ({} periods after the last valid frame): {}",
                l.tick,
                l.tick.wrapping_sub(l.last_valid_tick),
                inchworm_bridge::describe_fault(&l.fault)
            );
        }
        if !lateness.is_empty() {
            let p = percentiles(&lateness);
            println!(
                "wake-up lateness: p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs",
                p.p50, p.p99, p.max
            );
        }
        return result.map_err(|e| format!("board: {e}"));
    }

    let duration = args.duration.unwrap_or(10.0);
    if !(duration > 0.0 && duration.is_finite()) {
        return Err(format!("--duration {duration}: must be a positive number of seconds"));
    }
    let table = match &args.reference {
        Some(p) => {
            let t = inchworm::master::InputTable::parse(
                &std::fs::read_to_string(p).map_err(|e| format!("{}: {e}", p.display()))?,
            )
            .map_err(|e| format!("{}: {e}", p.display()))?;
            let col = t
                .names
                .iter()
                .position(|n| n == "reference")
                .ok_or_else(|| format!("{}: no `reference` column", p.display()))?;
            Some((t, col))
        }
        None => None,
    };
    let reference = |t: f64| table.as_ref().map_or(100e-6, |(tab, col)| tab.value(*col, t));
    let mut comp = inchworm::bridge::FmuCompensator::load(&fmu, &params)?;
    if let Some(l) = log.as_mut() {
        let mut meta = format!(
            "role=controller\nfmu={}\nlockstep={}\nduration={duration}\n",
            fmu.display(),
            args.lockstep
        );
        for (n, v) in &params {
            meta.push_str(&format!("param={n}={v}\n"));
        }
        l.write(&Record::Meta(meta)).map_err(|e| format!("run log: {e}"))?;
    }
    let cfg = ControllerConfig {
        lockstep: args.lockstep,
        ticks: (duration / inchworm_bridge::PERIOD.as_secs_f64()).round() as u64,
        max_gap: args.max_gap,
        dead_after: args.dead_after,
        overrun: args.overrun,
        ..ControllerConfig::default()
    };
    println!(
        "controller bridge: {} → board at {} ({mode}), {duration} s",
        fmu.display(),
        args.serial.as_ref().map_or(args.addr.clone(), |p| p.display().to_string())
    );
    let wall = Instant::now();
    let report = run_controller(&mut comp, &mut transport, &reference, &cfg, log.as_mut(), &STOP)?;
    let wall = wall.elapsed().as_secs_f64();
    let c = &report.counters;
    println!(
        "{} ticks in {wall:.2} s; frames {} valid, {} malformed, {} duplicate, {} stale, {} gaps ({} missing), {} retransmits, {} overruns",
        report.ticks, c.link.frames, c.link.malformed, c.link.duplicates, c.link.stale, c.link.gaps, c.link.missing, c.retransmits, c.overruns
    );
    if let Some(&last) = report.encoder.last() {
        let t = report.ticks as f64 * inchworm_bridge::PERIOD.as_secs_f64();
        println!(
            "final encoder {last} counts ({:.3} µm; reference {:.3} µm)",
            f64::from(last) * 1.2e-3,
            reference(t) * 1e6
        );
    }
    if !report.lateness_us.is_empty() {
        let p = percentiles(&report.lateness_us);
        println!("wake-up lateness: p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs", p.p50, p.p99, p.max);
    }
    if !report.round_trip_us.is_empty() {
        let p = percentiles(&report.round_trip_us);
        println!(
            "round trip (DAC frame → encoder frame echoing it): p50 {:.1} µs, p99 {:.1} µs",
            p.p50, p.p99
        );
    }
    if let Some(path) = &args.out {
        let mut csv = String::from("time,encoder_counts\n");
        for (k, c) in report.encoder.iter().enumerate() {
            csv.push_str(&format!(
                "{},{c}\n",
                (k + 1) as f64 * inchworm_bridge::PERIOD.as_secs_f64()
            ));
        }
        std::fs::write(path, csv).map_err(|e| format!("{}: {e}", path.display()))?;
        println!("wrote {}", path.display());
    }
    if let Some((_, text)) = &report.fault {
        return Err(format!("the run ended in a fault after {} ticks: {text}", report.ticks));
    }
    Ok(())
}

fn parse_params(params: &[String]) -> Result<Vec<(String, String)>, String> {
    params
        .iter()
        .map(|p| {
            p.split_once('=')
                .map(|(a, b)| (a.to_string(), b.to_string()))
                .ok_or_else(|| format!("--param {p}: expected NAME=VALUE"))
        })
        .collect()
}

fn run_replay(args: &ReplayArgs) -> Result<(), String> {
    use inchworm_bridge::replay::{controller_samples, replay};
    use inchworm_bridge::runlog::{read_log, Record};
    let log = read_log(&args.log)?;
    if let Some(at) = log.truncated_at {
        eprintln!("warning: {}: the log ends inside a record at byte {at} (the writer stopped mid-write); replaying what is whole", args.log.display());
    }
    let meta = log
        .records
        .iter()
        .find_map(|r| if let Record::Meta(m) = r { Some(m.clone()) } else { None })
        .unwrap_or_default();
    if !meta.contains("role=controller") {
        return Err(format!(
            "{}: not a controller-side log (its meta says: {})",
            args.log.display(),
            meta.lines().next().unwrap_or("nothing")
        ));
    }
    let samples = controller_samples(&log.records);
    if samples.is_empty() {
        return Err(format!("{}: no controller samples", args.log.display()));
    }
    let params = inchworm::bridge::params_from_meta(&meta);
    let mut comp = inchworm::bridge::FmuCompensator::load(&args.fmu, &params)?;
    let r = replay(&mut comp, &samples)?;
    let events = log.records.iter().filter(|r| matches!(r, Record::Event { .. })).count();
    println!(
        "replayed {} samples ({} events, {} discontinuities) with {}",
        r.samples,
        events,
        r.discontinuities,
        args.fmu.display()
    );
    match r.first {
        None => {
            println!("no divergence: every tick's DAC codes are the logged ones");
            Ok(())
        }
        Some((tick, logged, replayed)) => Err(format!(
            "{} of {} samples diverge; first at tick {tick}: logged codes {logged:?}, replayed {replayed:?}",
            r.divergent, r.samples
        )),
    }
}
