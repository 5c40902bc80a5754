//! `inchworm`: command-line co-simulation master of the inchworm actuator FMUs.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cmd;

use cmd::bridge::BridgeArgs;
use cmd::delay_line::DelayLineArgs;
use cmd::gait::GaitArgs;
use cmd::replay::ReplayArgs;
use cmd::run::RunArgs;
use cmd::scenario::ScenarioArgs;
use cmd::sweep::SweepArgs;

#[derive(Parser)]
#[command(
    name = "inchworm",
    version,
    about = "Co-simulation of JPL's inchworm actuator: runs its FMI 2.0 and 3.0 FMUs, writes CSV and plots"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Drive the plant FMU open loop with the docs/model.md §2.9 gait sequence (steps of amplitude
    /// +1, +1, −1, +0.3, −0.3, 100 samples of 2 ms each), write <out>/gait.csv and
    /// <out>/gait.png, and print the docs/model.md §3.3 raw measurements beside the docs/model.md §2.9 check
    /// values.
    ///
    /// gait.csv has one row per 2 ms communication point from t = 0: the DAC volts held
    /// from that time over the next sample, and the plant outputs at that time, in SI
    /// units (s, V, m; mode 1 HOLD, 2 LOCKED, 3 DRIVE, 4 FREE).
    Gait(GaitArgs),
    /// Run a named scenario (fig5, staircase, calibration, fia6: the paper's closed loops
    /// through the master on dist/InchwormSystem.ssp, or the crates with --direct; slew,
    /// stall: open-loop slews of the plant crate; mirror: the three-actuator mount;
    /// analog, fastgait, combined, bdmap: the controller's options beyond the paper), write
    /// its CSVs and <out>/<name>.png, and print settle times, RMS and estimates.
    Scenario(ScenarioArgs),
    /// Run an SSP system (.ssp) or a single FMI 2.0 or 3.0 Co-Simulation FMU (.fmu) with a fixed
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
    /// Sweep parameters of a system over a grid and/or Monte Carlo draws, each run reduced
    /// to metrics (settle time, parked RMS, estimates, any output's final/min/max), on
    /// --jobs worker threads; write <out>/plan.csv, <out>/results.csv (one row per run)
    /// and summary plots. --plan-only writes the plan; --plan PLAN --row K runs one row
    /// and prints its metrics as one JSON line.
    Sweep(SweepArgs),
    /// An interferometer's delay line on the inchworm (docs/delay-line.md): the sidereal
    /// path of a baseline on the ground (on a cart) or a drifting path in space, a fringe
    /// tracker and a fine stage in the loop; write <out>/delay-line.csv and .png and print
    /// the residual, visibility and null depth. --survey runs the designer's table and the
    /// largest rate each gait follows.
    DelayLine(DelayLineArgs),
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
    // A bug must still end in one clear line, not a backtrace: the run's own errors are
    // all `Err`s, so a panic is the binary's fault, said as such (exit status 101).
    std::panic::set_hook(Box::new(|info| {
        let what = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown".into());
        let at =
            info.location().map(|l| format!(" at {}:{}", l.file(), l.line())).unwrap_or_default();
        eprintln!("error: internal error (a bug in inchworm, please report it): {what}{at}");
    }));
    let cli = Cli::parse();
    // Every run of this process takes its FMUs' unpacked files from the cache of unpacked
    // FMUs (docs/ssp.md, Temporary folders and the FMU cache).
    inchworm_cosim::fmu::archive::cache::set_root(
        inchworm_cosim::fmu::archive::cache::default_root(),
    );
    let level = match &cli.command {
        Command::Gait(args) if args.fmi_logging => log::LevelFilter::Info,
        Command::Bridge(_) => log::LevelFilter::Info,
        _ => log::LevelFilter::Warn,
    };
    // Only fails if a logger is already installed, which nothing in this binary does.
    let _ = log::set_logger(&LOGGER);
    log::set_max_level(level);
    let result = match cli.command {
        Command::Gait(args) => cmd::gait::run(&args),
        Command::Run(args) => cmd::run::run(&args),
        Command::Scenario(args) => cmd::scenario::run(&args),
        Command::Bridge(args) => cmd::bridge::run(&args),
        Command::Replay(args) => cmd::replay::run(&args),
        Command::Sweep(args) => cmd::sweep::run(&args),
        Command::DelayLine(args) => cmd::delay_line::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            // The shell's convention for a run a signal stopped: 128 + the signal.
            match cmd::signals::stop_signal() {
                Some(s) => ExitCode::from((128 + s).clamp(0, 255) as u8),
                None => ExitCode::FAILURE,
            }
        }
    }
}
