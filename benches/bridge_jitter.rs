//! `cargo bench -p inchworm --bench bridge_jitter`: the HIL bridge on loopback in real
//! time, 500 Hz, controller FMU on one side and the virtual board (plant FMU) on the other,
//! beside a bare `clock_nanosleep` loop measured in the same run; then the lock-step round
//! trip. `IW_BENCH_SECONDS` sets the length of each real-time part (default 60 s).
//!
//! Printed: wake-up lateness (period jitter) p50/p99/max and overruns of the bare loop, the
//! controller loop and the board loop, the ratios to the bare loop, and round-trip
//! latencies p50/p99.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use inchworm_bridge::board::{run_board, Board, BoardConfig};
use inchworm_bridge::controller::{run_controller, ControllerConfig};
use inchworm_bridge::realtime::{enter_real_time, percentiles, Pacer, Percentiles};
use inchworm_bridge::transport::UdpTransport;
use inchworm_scenarios::bridge::{FmuCompensator, FmuMechanism};

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
    let (plant, ctrl) = (dist.join("InchwormPlant.fmu"), dist.join("InchwormController.fmu"));
    assert!(
        plant.is_file() && ctrl.is_file(),
        "build the FMUs first: cargo run --release -p fmu-build"
    );
    let rt = enter_real_time(80);
    for w in &rt.warnings {
        println!("note: {w}");
    }
    println!("bridge jitter, {seconds} s at 500 Hz per part, loopback UDP, real-time set-up: FIFO {:?}, memory locked {}", rt.fifo_priority, rt.memory_locked);

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
            let mut board =
                Board::new(mech, BoardConfig { lockstep, ..BoardConfig::default() }, None).unwrap();
            let mut lateness = Vec::new();
            run_board(&mut board, &mut udp, &s, &mut lateness).unwrap();
            (lateness, board.counters.overruns, board.counters.steps)
        });
        (rx.recv().unwrap(), stop, handle)
    };
    let (addr, stop, handle) = board(false);
    let mut udp = UdpTransport::connect(addr).unwrap();
    let mut comp = FmuCompensator::load(&ctrl, &[]).unwrap();
    let cfg = ControllerConfig { ticks, ..ControllerConfig::default() };
    let report =
        run_controller(&mut comp, &mut udp, &|_| 100e-6, &cfg, None, &AtomicBool::new(false))
            .unwrap();
    stop.store(true, Ordering::Relaxed);
    let (board_lateness, board_overruns, board_steps) = handle.join().unwrap();
    assert!(report.fault.is_none(), "the real-time run faulted: {:?}", report.fault);
    let ctrl_p = percentiles(&report.lateness_us);
    let board_p = percentiles(&board_lateness);
    let rt_rtt = percentiles(&report.round_trip_us);

    // 3. Lock-step: the round trip alone (DAC frame → plant step → encoder frame).
    let (addr, stop, handle) = board(true);
    let mut udp = UdpTransport::connect(addr).unwrap();
    let mut comp = FmuCompensator::load(&ctrl, &[]).unwrap();
    let cfg = ControllerConfig { ticks: 10_000, lockstep: true, ..ControllerConfig::default() };
    let ls = run_controller(&mut comp, &mut udp, &|_| 100e-6, &cfg, None, &AtomicBool::new(false))
        .unwrap();
    stop.store(true, Ordering::Relaxed);
    handle.join().unwrap();
    let ls_rtt = percentiles(&ls.round_trip_us);

    println!("period jitter (wake-up lateness against the absolute deadline):");
    line("bare clock_nanosleep loop", bare_p, bare_overruns);
    line("bridge, controller side", ctrl_p, report.counters.overruns);
    line(&format!("bridge, virtual board ({board_steps} steps)"), board_p, board_overruns);
    let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { f64::NAN };
    println!(
        "  ratio to the bare loop: controller p99 {:.2}x, max {:.2}x; board p99 {:.2}x, max {:.2}x",
        ratio(ctrl_p.p99, bare_p.p99),
        ratio(ctrl_p.max, bare_p.max),
        ratio(board_p.p99, bare_p.p99),
        ratio(board_p.max, bare_p.max)
    );
    println!("round trip:");
    println!("  real time (DAC sent → the board's next encoder frame echoing it): p50 {:.1} µs, p99 {:.1} µs ({} samples)", rt_rtt.p50, rt_rtt.p99, rt_rtt.count);
    println!("  lock-step (DAC frame → plant FMU step → encoder frame):          p50 {:.1} µs, p99 {:.1} µs ({} samples)", ls_rtt.p50, ls_rtt.p99, ls_rtt.count);
    println!(
        "link: {} frames, {} malformed, {} gaps, {} duplicates, {} stale",
        report.counters.link.frames,
        report.counters.link.malformed,
        report.counters.link.gaps,
        report.counters.link.duplicates,
        report.counters.link.stale
    );
}
