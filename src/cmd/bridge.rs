//! `inchworm bridge`: either end of the HIL bridge (docs/hil-protocol.md) with the FMUs
//! behind it.

use super::Text;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use clap::Args;

use inchworm_bridge::board::{run_board, Allow, Board, BoardConfig};
use inchworm_bridge::controller::{run_controller, ControllerConfig};
use inchworm_bridge::realtime::{enter_real_time, percentiles};
use inchworm_bridge::runlog::{LogWriter, Record};
use inchworm_bridge::transport::{open_serial, CobsTransport, Transport, UdpTransport};
use inchworm_plant::PlantParams;
use inchworm_scenarios::bridge::{FmuController, Interface};
use inchworm_scenarios::closed_loop::REFERENCE;

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RoleArg {
    Controller,
    Board,
}

/// How the controller side drives the controller FMU (`--interface`).
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum InterfaceArg {
    /// Scheduled Execution if the FMU offers it (FMI 3.0 `<ScheduledExecution>`), else
    /// Co-Simulation.
    Auto,
    /// Scheduled Execution: each tick activates the FMU's `sample_clock` at its time.
    Se,
    /// Co-Simulation: each tick is a 2 ms step.
    Cs,
}

impl From<InterfaceArg> for Interface {
    fn from(a: InterfaceArg) -> Interface {
        match a {
            InterfaceArg::Auto => Interface::Auto,
            InterfaceArg::Se => Interface::ScheduledExecution,
            InterfaceArg::Cs => Interface::CoSimulation,
        }
    }
}

#[derive(Args)]
pub struct BridgeArgs {
    #[arg(long, value_enum)]
    pub role: RoleArg,
    /// Board: the UDP address to listen on. Controller: the board's address.
    #[arg(long, default_value = "127.0.0.1:50500")]
    pub addr: String,
    /// Use a serial line (COBS frames) instead of UDP.
    #[arg(long)]
    pub serial: Option<PathBuf>,
    #[arg(long, default_value_t = 921_600)]
    pub baud: u32,
    /// The FMU to run (default: dist/InchwormPlant.fmu for the board; for the controller
    /// dist/InchwormController.fmu, or dist/fmi3/InchwormController.fmu with --interface se).
    #[arg(long)]
    pub fmu: Option<PathBuf>,
    /// Controller: how the controller FMU is driven: auto (Scheduled Execution when the
    /// FMU offers it, else Co-Simulation; the default), se or cs. The codes are the same.
    #[arg(long, value_enum)]
    pub interface: Option<InterfaceArg>,
    /// A start value or parameter of the FMU; repeatable.
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// Lock-step: the controller drives each tick and the board answers at once; the
    /// encoder trace equals the co-simulation's.
    #[arg(long)]
    pub lockstep: bool,
    /// Controller: run this long (s). Board: stop after this long (default: until Ctrl-C).
    /// A finite number of seconds, 0 < D ≤ 1e9.
    #[arg(long, value_parser = parse_duration, allow_hyphen_values = true)]
    pub duration: Option<f64>,
    /// Board: hear only this peer (IP, any port; or IP:PORT); repeatable. Default: anyone.
    #[arg(long = "allow", value_name = "ADDR")]
    pub allow: Vec<Allow>,
    /// Board: re-initialise the plant FMU at every new session (test rigs; a real
    /// mechanism keeps its state from one controller to the next).
    #[arg(long)]
    pub fresh_plant_per_session: bool,
    /// Controller: CSV `time,reference` (m), held piecewise constant; default 100 µm from t = 0.
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Board: periods without a valid frame before the safe state latches.
    #[arg(long, default_value_t = 3)]
    pub watchdog: u32,
    /// Controller: the largest tolerated gap in the encoder stream's sequence.
    #[arg(long, default_value_t = 3)]
    pub max_gap: u16,
    /// Controller: real-time periods without an encoder frame before the link is dead.
    #[arg(long, default_value_t = 10)]
    pub dead_after: u32,
    /// What a missed deadline does: soft (count, log, continue) or hard (fault to the safe state).
    #[arg(long, default_value = "soft")]
    pub overrun: inchworm_bridge::OverrunPolicy,
    /// SCHED_FIFO priority to ask for (needs privileges; refused: a warning, and the run goes on).
    #[arg(long, default_value_t = 80)]
    pub rt_priority: i32,
    /// The run log (every sample and event; crash-proof; `inchworm replay` reads it).
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// Controller: the encoder trace as CSV.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// The longest `--duration`: far beyond any run, and small enough that every derived
/// count (ticks, a sleep) is exact.
const MAX_DURATION_S: f64 = 1e9;

/// `--duration`: refused before anything starts unless it is a usable length of time.
fn parse_duration(s: &str) -> Result<f64, String> {
    let d: f64 = s.trim().parse().map_err(|_| {
        format!(
            "not a number; --duration takes a finite number of seconds, 0 < D ≤ {MAX_DURATION_S:e}"
        )
    })?;
    if d.is_finite() && d > 0.0 && d <= MAX_DURATION_S {
        Ok(d)
    } else {
        Err(format!(
            "{d} is out of range; --duration takes a finite number of seconds, 0 < D ≤ {MAX_DURATION_S:e}"
        ))
    }
}

/// Set by SIGINT/SIGTERM: the bridge stops at the next period, the board side in its safe
/// state, the logs flushed.
static STOP: AtomicBool = AtomicBool::new(false);

extern "C" fn request_stop(_: libc::c_int) {
    STOP.store(true, Ordering::Relaxed);
}

/// The bridge with its run log (`--log`) and CSV (`--out`) under the output discipline:
/// checked before any work (distinct, and not the FMU, the reference table or the serial
/// device). The log streams record by record, readable while the run goes and after a
/// kill: a new log at its own name (nothing there to destroy), a log over an earlier one
/// into a temporary beside it, renamed over the earlier log only when the run completes
/// (a failed run leaves the earlier log as it was).
pub fn run(args: &BridgeArgs) -> Result<(), String> {
    let inputs: Vec<&std::path::Path> = [&args.fmu, &args.reference, &args.serial]
        .into_iter()
        .flatten()
        .map(|p| p.as_path())
        .collect();
    let outputs: Vec<(&str, &std::path::Path)> = [("--log", &args.log), ("--out", &args.out)]
        .into_iter()
        .filter_map(|(role, p)| p.as_deref().map(|p| (role, p)))
        .collect();
    inchworm_cosim::output::check(&outputs, &inputs).map_err(|e| e.to_string())?;
    let Some(path) = &args.log else { return session(args, None) };
    let over_earlier = path.exists().then(|| super::create_file(path)).transpose()?;
    let at = over_earlier.as_ref().map_or(path.as_path(), |p| p.path());
    let log = LogWriter::create(at).map_err(|e| format!("run log: {e}"))?;
    let result = session(args, Some(log));
    if let (Some(pending), Ok(())) = (over_earlier, &result) {
        super::commit(pending)?;
    }
    result
}

fn session(args: &BridgeArgs, mut log: Option<LogWriter>) -> Result<(), String> {
    // SAFETY: the handler only stores to an atomic.
    unsafe {
        libc::signal(libc::SIGINT, request_stop as *const () as libc::sighandler_t);
        libc::signal(libc::SIGTERM, request_stop as *const () as libc::sighandler_t);
    }
    let params = super::parse_params(&args.params)?;
    let board_role = args.role == RoleArg::Board;
    if !board_role && (!args.allow.is_empty() || args.fresh_plant_per_session) {
        return Err("--allow and --fresh-plant-per-session are board options (--role board)".into());
    }
    if board_role && args.interface.is_some() {
        return Err("--interface is a controller option (--role controller)".into());
    }
    let interface = args.interface.unwrap_or(InterfaceArg::Auto);
    let fmu = args.fmu.clone().unwrap_or_else(|| {
        PathBuf::from(match (board_role, interface) {
            (true, _) => "dist/InchwormPlant.fmu",
            (false, InterfaceArg::Se) => "dist/fmi3/InchwormController.fmu",
            (false, _) => "dist/InchwormController.fmu",
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
    if !args.lockstep {
        let rt = enter_real_time(args.rt_priority);
        for w in &rt.warnings {
            eprintln!("warning: {w}");
        }
    }
    let mode = if args.lockstep { "lock-step" } else { "real time, 500 Hz" };

    if board_role {
        let mechanism = inchworm_scenarios::bridge::FmuMechanism::load(&fmu, &params).text()?;
        let cfg = BoardConfig {
            lockstep: args.lockstep,
            watchdog_periods: args.watchdog.max(1),
            overrun: args.overrun,
            fresh_plant_per_session: args.fresh_plant_per_session,
            ..BoardConfig::default()
        };
        let mut board = Board::new(mechanism, cfg, log.take()).text()?;
        if !args.allow.is_empty() {
            board.set_allow(args.allow.clone());
        }
        let where_ = args.serial.as_ref().map_or(args.addr.clone(), |p| p.display().to_string());
        println!(
            "virtual board: {} on {where_} ({mode}, watchdog {} periods); Ctrl-C stops",
            fmu.display(),
            cfg.watchdog_periods
        );
        if let Some(d) = args.duration {
            // parse_duration bounds it, so the conversion cannot fail.
            let d = std::time::Duration::try_from_secs_f64(d)
                .map_err(|e| format!("--duration {d}: {e}"))?;
            std::thread::spawn(move || {
                std::thread::sleep(d);
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
        for line in board.summary_lines() {
            println!("{line}");
        }
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
    let table = match &args.reference {
        Some(p) => {
            let t = super::read_input(p)?;
            let col = t
                .names
                .iter()
                .position(|n| n == REFERENCE)
                .ok_or_else(|| format!("{}: no `{REFERENCE}` column", p.display()))?;
            Some((t, col))
        }
        None => None,
    };
    let reference = |t: f64| table.as_ref().map_or(100e-6, |(tab, col)| tab.value(*col, t));
    let mut comp = FmuController::load(&fmu, &params, interface.into()).text()?;
    if let Some(l) = log.as_mut() {
        let mut meta = format!(
            "role=controller\nfmu={}\ninterface={}\nlockstep={}\nduration={duration}\n",
            fmu.display(),
            comp.interface(),
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
        "controller bridge: {} ({}) → board at {} ({mode}), {duration} s",
        fmu.display(),
        match comp {
            FmuController::Se(_) => "Scheduled Execution, sample_clock every tick",
            FmuController::Cs(_) => "Co-Simulation, a 2 ms step every tick",
        },
        args.serial.as_ref().map_or(args.addr.clone(), |p| p.display().to_string())
    );
    let wall = Instant::now();
    let report =
        run_controller(&mut comp, &mut transport, &reference, &cfg, log.as_mut(), &STOP).text()?;
    let wall = wall.elapsed().as_secs_f64();
    let c = &report.counters;
    println!(
        "{} ticks in {wall:.2} s; frames {} valid, {} malformed, {} duplicate, {} stale, {} gaps ({} missing), {} retransmits, {} overruns",
        report.ticks, c.link.frames, c.link.malformed, c.link.duplicates, c.link.stale, c.link.gaps, c.link.missing, c.retransmits, c.overruns
    );
    if report.clock_ticks > 0 {
        println!("output clock ticks: {} (each an event of the run log)", report.clock_ticks);
    }
    if let Some(&last) = report.encoder.last() {
        let t = report.ticks as f64 * inchworm_bridge::PERIOD.as_secs_f64();
        println!(
            "final encoder {last} counts ({:.3} µm; reference {:.3} µm)",
            f64::from(last) * PlantParams::default().q_enc * 1e6,
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
        let period = inchworm_bridge::PERIOD.as_secs_f64();
        super::write_file(path, |w| {
            writeln!(w, "time,encoder_counts")?;
            for (k, c) in report.encoder.iter().enumerate() {
                writeln!(w, "{},{c}", (k + 1) as f64 * period)?;
            }
            Ok(())
        })?;
    }
    if let Some((_, text)) = &report.fault {
        return Err(format!("the run ended in a fault after {} ticks: {text}", report.ticks));
    }
    Ok(())
}
