//! `cargo bench -p inchworm --bench bridge_jitter`: the HIL bridge on loopback in real
//! time, 500 Hz, controller FMU on one side and the virtual board (plant FMU) on the other,
//! beside a bare `clock_nanosleep` loop measured in the same run; then the lock-step round
//! trip. The FMI 3.0 controller runs twice over, through Co-Simulation (a 2 ms step per
//! tick) and through Scheduled Execution (`sample_clock` activated at each tick), in
//! alternating rounds of at most 10 s so both see the same machine. `IW_BENCH_SECONDS`
//! sets the length of the bare loop and of each interface's real-time part (default 60 s).
//!
//! Printed: wake-up lateness (period jitter) p50/p99/max and overruns of the bare loop, the
//! controller loop through each interface and the board loop, the ratios to the bare loop
//! and p99(SE)/p99(CS), and round-trip latencies p50/p99 for each interface.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use inchworm_bridge::board::{run_board, Board, BoardConfig};
use inchworm_bridge::controller::{run_controller, ControllerConfig};
use inchworm_bridge::realtime::{enter_real_time, percentiles, Pacer, Percentiles};
use inchworm_bridge::transport::UdpTransport;
use inchworm_scenarios::bridge::{FmuController, FmuMechanism, Interface};

fn line(name: &str, p: Percentiles, overruns: u64) {
    println!(
        "  {name:<34} p50 {:>7.1} µs   p99 {:>7.1} µs   max {:>8.1} µs   overruns {overruns}",
        p.p50, p.p99, p.max
    );
}

fn main() {
    let seconds: f64 =
        std::env::var("IW_BENCH_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(60.0);
    let ticks = (seconds / 0.002).round() as u64;
    let dist = Path::new(env!("CARGO_MANIFEST_DIR")).join("dist");
    let (plant, ctrl) = (dist.join("InchwormPlant.fmu"), dist.join("fmi3/InchwormController.fmu"));
    assert!(
        plant.is_file() && ctrl.is_file(),
        "build the FMUs first: cargo run --release -p fmu-build"
    );
    let rt = enter_real_time(80);
    for w in &rt.warnings {
        println!("note: {w}");
    }
    println!("bridge jitter, {seconds} s at 500 Hz per part (CS and SE in alternating rounds of at most 10 s), loopback UDP, real-time set-up: FIFO {:?}, memory locked {}", rt.fifo_priority, rt.memory_locked);

    // 1. The bare loop: absolute-deadline sleeps and nothing else.
    let mut pacer = Pacer::new(Duration::from_millis(2));
    let mut bare = Vec::with_capacity(ticks as usize);
    let mut bare_overruns = 0;
    for _ in 0..ticks {
        let w = pacer.wait();
        bare.push(w.lateness_ns as f64 / 1e3);
        bare_overruns += u64::from(w.overrun);
    }
    let bare_p = percentiles(&bare);

    // 2. The bridge in real time: the board in a thread, the controller here.
    let board = |lockstep: bool| {
        let stop = Arc::new(AtomicBool::new(false));
        let s = Arc::clone(&stop);
        let (tx, rx) = std::sync::mpsc::channel();
        let plant = plant.clone();
        let handle = std::thread::spawn(move || {
            let rt = enter_real_time(80);
            let _ = rt;
            let mut udp = UdpTransport::bind("127.0.0.1:0").unwrap();
            tx.send(udp.local_addr().unwrap()).unwrap();
            let mech = FmuMechanism::load(&plant, &[]).unwrap();
            // A 25-period watchdog, as the tests take on a loaded machine: a stall of a few
            // periods is counted in the jitter, not made a fault that ends the round.
            let cfg = BoardConfig { lockstep, watchdog_periods: 25, ..BoardConfig::default() };
            let mut board = Board::new(mech, cfg, None).unwrap();
            let mut lateness = Vec::new();
            run_board(&mut board, &mut udp, &s, &mut lateness).unwrap();
            (lateness, board.counters.overruns, board.counters.steps)
        });
        (rx.recv().unwrap(), stop, handle)
    };
    // One real-time run of `ticks` through `interface`, into `part`.
    let run = |interface: Interface, ticks: u64, part: &mut Part| {
        let (addr, stop, handle) = board(false);
        let mut udp = UdpTransport::connect(addr).unwrap();
        let mut comp = FmuController::load(&ctrl, &[], interface).unwrap();
        let cfg = ControllerConfig { ticks, dead_after: 25, ..ControllerConfig::default() };
        let report =
            run_controller(&mut comp, &mut udp, &|_| 100e-6, &cfg, None, &AtomicBool::new(false))
                .unwrap();
        stop.store(true, Ordering::Relaxed);
        let (board_lateness, board_overruns, board_steps) = handle.join().unwrap();
        assert!(report.fault.is_none(), "the real-time run faulted: {:?}", report.fault);
        part.lateness.extend(&report.lateness_us);
        part.round_trip.extend(&report.round_trip_us);
        part.overruns += report.counters.overruns;
        part.board_lateness.extend(board_lateness);
        part.board_overruns += board_overruns;
        part.board_steps += board_steps;
        part.clock_ticks += report.clock_ticks;
        part.malformed += report.counters.link.malformed;
        part.gaps += report.counters.link.gaps;
    };
    let (mut cs, mut se) = (Part::default(), Part::default());
    let round = 5_000u64.min(ticks.max(1));
    // Each round runs both, the one that goes first swapped from round to round.
    let (mut done, mut swap) = (0, false);
    while done < ticks {
        let n = round.min(ticks - done);
        if swap {
            run(Interface::ScheduledExecution, n, &mut se);
            run(Interface::CoSimulation, n, &mut cs);
        } else {
            run(Interface::CoSimulation, n, &mut cs);
            run(Interface::ScheduledExecution, n, &mut se);
        }
        done += n;
        swap = !swap;
    }

    // 3. Lock-step: the round trip alone (DAC frame → plant step → encoder frame).
    let lockstep = |interface: Interface| {
        let (addr, stop, handle) = board(true);
        let mut udp = UdpTransport::connect(addr).unwrap();
        let mut comp = FmuController::load(&ctrl, &[], interface).unwrap();
        let cfg = ControllerConfig { ticks: 10_000, lockstep: true, ..ControllerConfig::default() };
        let ls =
            run_controller(&mut comp, &mut udp, &|_| 100e-6, &cfg, None, &AtomicBool::new(false))
                .unwrap();
        stop.store(true, Ordering::Relaxed);
        handle.join().unwrap();
        assert!(ls.fault.is_none(), "the lock-step run faulted: {:?}", ls.fault);
        (percentiles(&ls.round_trip_us), ls.encoder)
    };
    let (ls_cs, enc_cs) = lockstep(Interface::CoSimulation);
    let (ls_se, enc_se) = lockstep(Interface::ScheduledExecution);
    assert_eq!(enc_cs, enc_se, "lock-step: the same encoder trace through either interface");

    let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { f64::NAN };
    println!("period jitter (wake-up lateness against the absolute deadline):");
    line("bare clock_nanosleep loop", bare_p, bare_overruns);
    let (cs_p, se_p) = (percentiles(&cs.lateness), percentiles(&se.lateness));
    for (name, part, p) in [("CS", &cs, cs_p), ("SE", &se, se_p)] {
        line(&format!("controller side, {name}"), p, part.overruns);
        line(
            &format!("virtual board, {name} run ({} steps)", part.board_steps),
            percentiles(&part.board_lateness),
            part.board_overruns,
        );
    }
    println!(
        "  ratio to the bare loop: controller CS p99 {:.2}x, max {:.2}x; SE p99 {:.2}x, max {:.2}x",
        ratio(cs_p.p99, bare_p.p99),
        ratio(cs_p.max, bare_p.max),
        ratio(se_p.p99, bare_p.p99),
        ratio(se_p.max, bare_p.max)
    );
    println!(
        "  Scheduled Execution against Co-Simulation: p50 {:.2}x, p99 {:.2}x, max {:.2}x",
        ratio(se_p.p50, cs_p.p50),
        ratio(se_p.p99, cs_p.p99),
        ratio(se_p.max, cs_p.max)
    );
    println!("round trip:");
    for (name, part, ls) in [("CS", &cs, ls_cs), ("SE", &se, ls_se)] {
        let rt = percentiles(&part.round_trip);
        println!("  {name} real time (DAC sent → the board's next encoder frame echoing it): p50 {:.1} µs, p99 {:.1} µs ({} samples)", rt.p50, rt.p99, rt.count);
        println!("  {name} lock-step (DAC frame → plant FMU step → encoder frame):          p50 {:.1} µs, p99 {:.1} µs ({} samples)", ls.p50, ls.p99, ls.count);
    }
    println!(
        "link: CS {} malformed, {} gaps; SE {} malformed, {} gaps; gait_step ticks (SE, clockUpdate): {}",
        cs.malformed, cs.gaps, se.malformed, se.gaps, se.clock_ticks
    );
}

/// What the real-time rounds of one interface gathered.
#[derive(Default)]
struct Part {
    lateness: Vec<f64>,
    round_trip: Vec<f64>,
    overruns: u64,
    board_lateness: Vec<f64>,
    board_overruns: u64,
    board_steps: u64,
    clock_ticks: u64,
    malformed: u64,
    gaps: u64,
}
