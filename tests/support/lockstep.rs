//! The bridge in lock-step on loopback: a virtual board with a plant FMU on a thread of
//! its own, the controller side here with its run log.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use inchworm::bridge::FmuMechanism;
use inchworm_bridge::board::{run_board, Board, BoardConfig, BoardCounters};
use inchworm_bridge::controller::{run_controller, ControllerConfig, ControllerReport};
use inchworm_bridge::runlog::{LogWriter, Record};
use inchworm_bridge::transport::UdpTransport;
use inchworm_bridge::Compensator;

/// `ticks` lock-step ticks of `comp` against the plant FMU `plant` in a virtual board,
/// following `reference`, its run log written to `log`: the controller's report (no fault)
/// and the board's counters.
pub fn lockstep<C: Compensator>(
    plant: &Path,
    comp: &mut C,
    reference: &dyn Fn(f64) -> f64,
    ticks: u64,
    log: &Path,
) -> (ControllerReport, BoardCounters) {
    let stop = Arc::new(AtomicBool::new(false));
    let (tx, rx) = std::sync::mpsc::channel();
    let s = Arc::clone(&stop);
    let plant = plant.to_path_buf();
    let board = std::thread::spawn(move || {
        let mut udp = UdpTransport::bind("127.0.0.1:0").unwrap();
        tx.send(udp.local_addr().unwrap()).unwrap();
        let mech = FmuMechanism::load(&plant, &[]).unwrap();
        // A generous watchdog: the tests are about exactness on a machine busy with others.
        let cfg = BoardConfig { lockstep: true, watchdog_periods: 50, ..BoardConfig::default() };
        let mut board = Board::new(mech, cfg, None).unwrap();
        run_board(&mut board, &mut udp, &s, &mut Vec::new()).unwrap();
        board.counters.clone()
    });
    let mut udp = UdpTransport::connect(rx.recv().unwrap()).unwrap();
    let mut log = LogWriter::create(log).unwrap();
    log.write(&Record::Meta("role=controller\n".into())).unwrap();
    let cfg = ControllerConfig { lockstep: true, ticks, ..ControllerConfig::default() };
    let report =
        run_controller(comp, &mut udp, reference, &cfg, Some(&mut log), &AtomicBool::new(false))
            .unwrap();
    stop.store(true, Ordering::Relaxed);
    let counters = board.join().unwrap();
    assert!(report.fault.is_none(), "{:?}", report.fault);
    assert_eq!(counters.steps, ticks, "one plant step per tick");
    (report, counters)
}
