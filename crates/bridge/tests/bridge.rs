//! The bridge end to end on loopback: a controller side and a virtual board in one process,
//! with the plain-Rust plant and controller behind them, and seeded link faults.

mod common;

use std::sync::atomic::AtomicBool;
use std::time::Duration;

use common::*;
use inchworm_bridge::board::{run_board, Board, BoardConfig};
use inchworm_bridge::controller::{run_controller, ControllerConfig};
use inchworm_bridge::faults::{FaultPlan, FaultyTransport};
use inchworm_bridge::protocol::{self, BoardState, FaultReason, Frame, Packet, MAX_FRAME};
use inchworm_bridge::replay::{controller_samples, replay};
use inchworm_bridge::runlog::{read_log, LogWriter, Record};
use inchworm_bridge::transport::{CobsTransport, Transport, UdpTransport};
use inchworm_bridge::{Compensator, Mechanism, ModelError, OverrunPolicy};

fn lockstep(ticks: u64) -> ControllerConfig {
    ControllerConfig { lockstep: true, ticks, ..ControllerConfig::default() }
}

fn realtime(ticks: u64) -> ControllerConfig {
    ControllerConfig { lockstep: false, ticks, ..ControllerConfig::default() }
}

/// Lock-step boards get a 100 ms watchdog: those tests are about exactness, and a test
/// machine busy with other tests can stall a thread for longer than 3 periods. The
/// real-time ones keep the default 3 periods under test.
fn board_cfg(lockstep: bool) -> BoardConfig {
    BoardConfig {
        lockstep,
        watchdog_periods: if lockstep { 50 } else { 3 },
        ..BoardConfig::default()
    }
}

#[test]
fn lockstep_reproduces_the_cosimulation_exactly() {
    let _slot = real_time_slot();
    let ticks = 1000;
    let board = spawn_board(board_cfg(true), None);
    let mut udp = UdpTransport::connect(board.addr).unwrap();
    let mut ctrl = DirectController::new();
    let report = run_controller(
        &mut ctrl,
        &mut udp,
        &reference,
        &lockstep(ticks),
        None,
        &AtomicBool::new(false),
    )
    .unwrap();
    let (board, _) = board.finish();
    assert!(report.fault.is_none(), "{:?}", report.fault);
    let expected = cosimulation(ticks as usize);
    assert_eq!(report.encoder, expected, "the lock-step encoder trace is the co-simulation's");
    assert!(
        expected.iter().any(|&c| c > 20_000),
        "the run moved the runner: {:?}",
        expected.last()
    );
    assert_eq!(board.counters.steps, ticks);
    assert_eq!(board.state(), BoardState::Disarmed, "DISARM at the end of the run");
    // A loaded machine may delay an answer past the 2 ms repeat; nothing may be lost or bad.
    assert_eq!(
        (board.counters.link.malformed, board.counters.link.gaps, report.counters.link.malformed),
        (0, 0, 0)
    );
}

#[test]
fn lockstep_rides_through_injected_faults_and_stays_exact() {
    let _slot = real_time_slot();
    let ticks = 1500;
    let plan = |seed| FaultPlan {
        seed,
        drop: 0.03,
        duplicate: 0.03,
        reorder: 0.03,
        delay: 0.02,
        delay_frames: 3,
        corrupt: 0.03,
        ..FaultPlan::default()
    };
    // Faults on both directions: DAC frames and the board's answers.
    let board = spawn_board(board_cfg(true), Some(plan(11)));
    let udp = UdpTransport::connect(board.addr).unwrap();
    let mut link = FaultyTransport::new(udp, plan(7));
    let injected = link.counts();
    let mut ctrl = DirectController::new();
    let report = run_controller(
        &mut ctrl,
        &mut link,
        &reference,
        &lockstep(ticks),
        None,
        &AtomicBool::new(false),
    )
    .unwrap();
    let (board, _) = board.finish();
    assert!(report.fault.is_none(), "{:?}", report.fault);
    assert_eq!(
        report.encoder,
        cosimulation(ticks as usize),
        "faults recovered without changing a count"
    );
    let injected = injected.lock().unwrap().clone();
    assert!(
        injected.dropped > 10
            && injected.corrupted > 10
            && injected.duplicated > 10
            && injected.reordered > 10,
        "{injected:?}"
    );
    // Every corrupted frame was refused: a one-bit error never passes the CRC.
    assert!(
        board.counters.link.malformed >= injected.corrupted,
        "{:?} vs {injected:?}",
        board.counters
    );
    assert!(
        board.counters.link.duplicates > 0
            && board.counters.link.stale > 0
            && board.counters.repeats > 0,
        "{:?}",
        board.counters
    );
    assert!(
        report.counters.retransmits > 0 && report.counters.link.malformed > 0,
        "{:?}",
        report.counters
    );
    assert_eq!(board.counters.steps, ticks, "a repeated tick never steps the plant twice");
}

/// [`DirectController`], stalling 20 ms (10 periods) before the codes of every 50th tick.
struct SlowController(DirectController, u32);

impl Compensator for SlowController {
    fn codes(&mut self) -> Result<[u16; 3], ModelError> {
        if self.1 % 50 == 49 {
            std::thread::sleep(Duration::from_millis(20));
        }
        self.0.codes()
    }
    fn step(&mut self, counts: i32, reference: f64) -> Result<(), ModelError> {
        self.1 += 1;
        self.0.step(counts, reference)
    }
}

#[test]
fn the_lock_step_watchdog_counts_lost_transmissions_not_a_slow_controller() {
    let _slot = real_time_slot();
    // The default watchdog of 3 periods, in lock-step.
    let cfg = BoardConfig { lockstep: true, ..BoardConfig::default() };
    let board = spawn_board(cfg, None);
    let mut udp = UdpTransport::connect(board.addr).unwrap();
    let mut slow = SlowController(DirectController::new(), 0);
    let report = run_controller(
        &mut slow,
        &mut udp,
        &reference,
        &lockstep(300),
        None,
        &AtomicBool::new(false),
    )
    .unwrap();
    let (board, _) = board.finish();
    assert!(report.fault.is_none(), "{:?}", report.fault);
    assert_eq!(report.encoder, cosimulation(300));
    assert!(board.latches.is_empty(), "{:?}", board.events);
    assert_eq!(board.counters.steps, 300);

    // Transmissions 150 to 152 lost: the next one shows a gap of 3, the limit.
    let board = spawn_board(cfg, None);
    let udp = UdpTransport::connect(board.addr).unwrap();
    let mut link = FaultyTransport::new(
        udp,
        FaultPlan { silence: Some((150, 3)), only_type: Some(0x10), ..FaultPlan::default() },
    );
    let mut ctrl = DirectController::new();
    let report = run_controller(
        &mut ctrl,
        &mut link,
        &reference,
        &lockstep(1000),
        None,
        &AtomicBool::new(false),
    )
    .unwrap();
    let (board, _) = board.finish();
    let (fault, text) = report.fault.expect("the board's FAULT");
    assert_eq!((fault.reason, fault.detail), (FaultReason::Silence, 3), "{text}");
    // A repeat of an earlier tick (an answer late on a busy machine) moves the window back.
    let ticks = report.ticks;
    assert!(ticks <= 150 && ticks + report.counters.retransmits >= 153, "{ticks} ticks");
    assert_eq!(report.encoder, cosimulation(ticks as usize));
    assert_eq!(board.latches.len(), 1, "{:?}", board.events);
    assert_eq!(board.latches[0].fault, fault);
    assert_eq!(board.counters.steps, ticks);
}

#[test]
fn the_lock_step_board_latches_link_dead_when_the_controller_is_gone() {
    let _slot = real_time_slot();
    let board = spawn_board(BoardConfig { lockstep: true, ..BoardConfig::default() }, None);
    let udp = UdpTransport::connect(board.addr).unwrap();
    // Nothing the controller sends arrives from its 102nd frame on (after HELLO, ARM and
    // 100 DAC frames), its FAULT included.
    let mut link = FaultyTransport::new(
        udp,
        FaultPlan { silence: Some((102, u64::MAX / 2)), ..FaultPlan::default() },
    );
    let mut ctrl = DirectController::new();
    let report = run_controller(
        &mut ctrl,
        &mut link,
        &reference,
        &lockstep(1000),
        None,
        &AtomicBool::new(false),
    )
    .unwrap();
    let (fault, text) = report.fault.expect("the controller's own dead-link fault");
    assert_eq!((fault.reason, fault.detail), (FaultReason::LinkDead, 26), "{text}");
    // The board's bound is 250 wall-clock periods, 500 ms; its latch sends a FAULT, which
    // still arrives (only what the controller sends is lost): that is the event to wait for.
    let mut rx = [0u8; 256];
    let t0 = std::time::Instant::now();
    loop {
        assert!(t0.elapsed() < Duration::from_secs(30), "no LinkDead latch within 30 s");
        let Some(n) = link.recv(&mut rx, Duration::from_millis(100)).unwrap() else { continue };
        if let Ok(Frame::Fault(f)) = protocol::decode(&rx[..n]).map(|p| p.frame) {
            if f.reason == FaultReason::LinkDead {
                break;
            }
        }
    }
    let (board, _) = board.finish();
    let dead = protocol::Fault {
        reason: FaultReason::LinkDead,
        detail: protocol::LOCKSTEP_DEAD_LINK_PERIODS,
    };
    assert_eq!(
        board.latches.iter().map(|l| l.fault).collect::<Vec<_>>(),
        [dead],
        "{:?}",
        board.events
    );
    assert_eq!(board.counters.steps, report.ticks);
}

#[test]
fn sequence_numbers_wrap_without_false_gaps() {
    let _slot = real_time_slot();
    // 70 000 frames each way: both 16-bit sequences wrap once.
    let ticks = 70_000;
    let board = spawn_board(board_cfg(true), None);
    let mut udp = UdpTransport::connect(board.addr).unwrap();
    let mut ctrl = DirectController::new();
    let report = run_controller(
        &mut ctrl,
        &mut udp,
        &|_| 5e-6,
        &lockstep(ticks),
        None,
        &AtomicBool::new(false),
    )
    .unwrap();
    let (board, _) = board.finish();
    assert!(report.fault.is_none(), "{:?}", report.fault);
    assert_eq!(report.ticks, ticks);
    let c = &board.counters.link;
    assert_eq!((c.gaps, c.duplicates, c.malformed), (0, 0, 0), "{c:?}");
    let r = &report.counters;
    assert_eq!((r.link.gaps, r.link.stale, r.link.malformed), (0, 0, 0), "{r:?}");
    // A late answer and the answer to its repeat are the same frame: a duplicate, not a gap.
    assert!(r.link.duplicates <= r.retransmits, "{r:?}");
    assert_eq!(board.tick() as u64, ticks);
}

#[test]
fn silence_latches_the_safe_state_within_n_periods_and_needs_a_rearm() {
    let _slot = real_time_slot();
    // Real time. The controller's DAC frames stop after 300 frames; its encoder feed stays.
    let board = spawn_board(board_cfg(false), None);
    let udp = UdpTransport::connect(board.addr).unwrap();
    let dac_type = 0x10;
    let mut link = FaultyTransport::new(
        udp,
        FaultPlan {
            silence: Some((300, u64::MAX / 2)),
            only_type: Some(dac_type),
            ..FaultPlan::default()
        },
    );
    let mut ctrl = DirectController::new();
    // What is under test is the board's latch after 3 silent periods and its FAULT reaching
    // the controller; the controller's own dead-link limit (10 periods by default) must not
    // pre-empt it when a busy test machine stalls the board's thread for 20 ms.
    let cfg = ControllerConfig { dead_after: 100, ..realtime(600) };
    let report =
        run_controller(&mut ctrl, &mut link, &reference, &cfg, None, &AtomicBool::new(false))
            .unwrap();

    let (fault, text) = report.fault.clone().expect("the controller must see the board's fault");
    assert_eq!(fault.reason, FaultReason::Silence, "{text}");
    assert_eq!(fault.detail, 3, "{text}");
    assert!(text.contains("no valid DAC frame for 3 periods"), "{text}");
    // The silence starts at DAC frame 300, or earlier if the machine stalled the
    // controller for 3 periods: either way the board latches within 3 periods of the last
    // valid frame (checked on its latch below), and the controller stops soon after.
    assert!(
        report.ticks < 330,
        "the controller stopped soon after the board latched: {}",
        report.ticks
    );

    // Frames alone do not unlatch it. Send DAC frames straight to the board, from the same
    // socket (the board answers only the peer it armed with).
    let mut raw = link.into_inner();
    let mut buf = [0u8; MAX_FRAME];
    let dac = |seq: u16, buf: &mut [u8; MAX_FRAME]| {
        protocol::encode(
            &Packet {
                seq,
                frame: Frame::Dac(protocol::DacSample { tick: 0, codes: [40000, 40000, 40000] }),
            },
            buf,
        )
        .unwrap()
    };
    for seq in 1000..1005 {
        let n = dac(seq, &mut buf);
        raw.send(&buf[..n]).unwrap();
    }
    let n = protocol::encode(&Packet { seq: 1, frame: Frame::Arm }, &mut buf).unwrap();
    raw.send(&buf[..n]).unwrap();
    // The board takes the frames in order: the DAC frames while latched, the ARM, and,
    // with no DAC frame after it, the second latch, whose FAULT is the event waited for.
    let mut rx = [0u8; 256];
    let t0 = std::time::Instant::now();
    let mut armed = false;
    loop {
        assert!(t0.elapsed() < Duration::from_secs(30), "no second latch within 30 s");
        let Some(n) = raw.recv(&mut rx, Duration::from_millis(100)).unwrap() else { continue };
        match protocol::decode(&rx[..n]).map(|p| p.frame) {
            Ok(Frame::Encoder(e)) if e.status & protocol::status::ARMED != 0 => armed = true,
            Ok(Frame::Fault(f)) if armed => {
                assert_eq!(f.reason, FaultReason::Silence);
                break;
            }
            _ => {}
        }
    }
    let (mut board, _) = board.finish();
    let latch = board.latches[0];
    assert_eq!(latch.fault.reason, FaultReason::Silence);
    assert!(
        latch.tick - latch.last_valid_tick <= 3,
        "safe codes applied {} periods after the last valid frame",
        latch.tick - latch.last_valid_tick
    );
    assert!(
        board.counters.unarmed >= 5,
        "DAC frames while latched were refused: {:?}",
        board.counters
    );
    assert!(board.events.iter().any(|(_, e)| e.contains("armed (was Safe")), "{:?}", board.events);
    // Re-armed, and with no DAC frame after the ARM the watchdog latched again 3 periods on.
    assert_eq!(board.latches.len(), 2, "{:?}", board.events);
    let again = board.latches[1];
    let armed_at = board.events.iter().find(|(_, e)| e.contains("armed (was Safe")).unwrap().0;
    assert_eq!((again.last_valid_tick, again.tick - armed_at), (armed_at, 3), "{:?}", board.events);
    // The 40000 codes sent while latched were never applied.
    assert_eq!(board.applied(), [0, 0, 0]);
    assert!(board.mechanism().counts().is_ok());
}

#[test]
fn a_corrupt_frame_stream_ends_in_the_safe_state() {
    let _slot = real_time_slot();
    let board = spawn_board(board_cfg(false), None);
    let udp = UdpTransport::connect(board.addr).unwrap();
    let mut link = FaultyTransport::new(
        udp,
        FaultPlan { seed: 3, corrupt: 1.0, only_type: Some(0x10), ..FaultPlan::default() },
    );
    let mut ctrl = DirectController::new();
    let report = run_controller(
        &mut ctrl,
        &mut link,
        &reference,
        &realtime(200),
        None,
        &AtomicBool::new(false),
    )
    .unwrap();
    let (board, _) = board.finish();
    let (fault, text) = report.fault.expect("fault");
    assert_eq!(fault.reason, FaultReason::Silence, "{text}");
    assert!(board.counters.link.malformed >= 1, "{:?}", board.counters);
    assert_eq!(board.latches.len(), 1);
    assert!(board.latches[0].tick - board.latches[0].last_valid_tick <= 3);
}

#[test]
fn the_controller_faults_on_a_sequence_gap_larger_than_k() {
    let _slot = real_time_slot();
    // The board's encoder frames 100..104 are lost: a gap of 5 > K = 3.
    // The board's watchdog gets 10 periods: the subject is the controller's gap policy.
    let board = spawn_board(
        BoardConfig { watchdog_periods: 10, ..board_cfg(false) },
        Some(FaultPlan { silence: Some((100, 5)), only_type: Some(0x11), ..FaultPlan::default() }),
    );
    let mut udp = UdpTransport::connect(board.addr).unwrap();
    let mut ctrl = DirectController::new();
    let report = run_controller(
        &mut ctrl,
        &mut udp,
        &reference,
        &realtime(400),
        None,
        &AtomicBool::new(false),
    )
    .unwrap();
    std::thread::sleep(Duration::from_millis(10));
    let (board, _) = board.finish();
    let (fault, text) = report.fault.expect("fault");
    assert_eq!((fault.reason, fault.detail), (FaultReason::SequenceGap, 5), "{text}");
    assert!(text.contains("5 frames missing in a row"), "{text}");
    // The controller told the board, which latched at once rather than by its watchdog.
    assert_eq!(board.latches.len(), 1, "{:?}", board.events);
    assert_eq!(board.latches[0].fault.reason, FaultReason::SequenceGap);
    assert!(matches!(board.state(), BoardState::Safe(_)));
}

#[test]
fn the_controller_faults_on_a_dead_link() {
    let _slot = real_time_slot();
    // The board's watchdog gets 10 periods: the subject is the controller's dead-link policy.
    let board = spawn_board(BoardConfig { watchdog_periods: 10, ..board_cfg(false) }, None);
    let addr = board.addr;
    let mut udp = UdpTransport::connect(addr).unwrap();
    // The board stops once the controller is 100 ticks into its run.
    let (mut ctrl, ticking) = Announcing::new(100);
    let stopper = std::thread::spawn(move || {
        ticking.recv_timeout(Duration::from_secs(30)).expect("100 ticks");
        board.finish()
    });
    let cfg = ControllerConfig { dead_after: 10, ..realtime(2000) };
    let report =
        run_controller(&mut ctrl, &mut udp, &reference, &cfg, None, &AtomicBool::new(false))
            .unwrap();
    stopper.join().unwrap();
    let (fault, text) = report.fault.expect("fault");
    assert_eq!(fault.reason, FaultReason::LinkDead, "{text}");
    assert_eq!(fault.detail, 11);
    assert!(report.ticks < 250, "{}", report.ticks);

    // Lock-step: the board gone, retransmissions run out.
    let board = spawn_board(board_cfg(true), None);
    let mut udp = UdpTransport::connect(board.addr).unwrap();
    let stop = board.stop.clone();
    let (mut ctrl, ticking) = Announcing::new(100);
    let stopper = std::thread::spawn(move || {
        ticking.recv_timeout(Duration::from_secs(30)).expect("100 ticks");
        stop.store(true, std::sync::atomic::Ordering::Relaxed);
        board.handle.join().unwrap()
    });
    let report = run_controller(
        &mut ctrl,
        &mut udp,
        &reference,
        &lockstep(1_000_000),
        None,
        &AtomicBool::new(false),
    )
    .unwrap();
    stopper.join().unwrap();
    let (fault, text) = report.fault.expect("fault");
    assert_eq!((fault.reason, fault.detail), (FaultReason::LinkDead, 26), "{text}");
}

#[test]
fn the_hard_overrun_policy_faults_to_the_safe_state() {
    let _slot = real_time_slot();
    struct Slow(DirectController, u32);
    impl Compensator for Slow {
        fn codes(&mut self) -> Result<[u16; 3], ModelError> {
            self.0.codes()
        }
        fn step(&mut self, counts: i32, reference: f64) -> Result<(), ModelError> {
            self.1 += 1;
            if self.1 == 50 {
                std::thread::sleep(Duration::from_millis(7));
            }
            self.0.step(counts, reference)
        }
    }
    // The 7 ms stall is 3.5 periods: the board's watchdog gets 10, so what ends the run is
    // the controller's policy, not the board's silence detection.
    let board = spawn_board(BoardConfig { watchdog_periods: 10, ..board_cfg(false) }, None);
    let mut udp = UdpTransport::connect(board.addr).unwrap();
    let mut soft = Slow(DirectController::new(), 0);
    let report = run_controller(
        &mut soft,
        &mut udp,
        &reference,
        &realtime(100),
        None,
        &AtomicBool::new(false),
    )
    .unwrap();
    assert!(report.fault.is_none(), "soft: log and continue: {:?}", report.fault);
    assert!(report.counters.overruns >= 1);

    let mut hard = Slow(DirectController::new(), 0);
    let cfg = ControllerConfig { overrun: OverrunPolicy::Hard, ..realtime(100) };
    let report =
        run_controller(&mut hard, &mut udp, &reference, &cfg, None, &AtomicBool::new(false))
            .unwrap();
    std::thread::sleep(Duration::from_millis(10));
    let (board, _) = board.finish();
    let (fault, text) = report.fault.expect("hard policy");
    assert_eq!(fault.reason, FaultReason::Overrun, "{text}");
    // The 7 ms stall at tick 50 overruns for sure; a busy machine may overrun earlier, by less.
    assert!(
        fault.detail > 0 && report.ticks <= 50,
        "late by {} µs after {} ticks",
        fault.detail,
        report.ticks
    );
    assert!(
        matches!(board.state(), BoardState::Safe(f) if f.reason == FaultReason::Overrun),
        "{:?}",
        board.events
    );
}

#[test]
fn malformed_frames_of_every_kind_are_refused_without_harm() {
    let _slot = real_time_slot();
    let board = spawn_board(board_cfg(true), None);
    let mut raw = UdpTransport::connect(board.addr).unwrap();
    let mut good = [0u8; MAX_FRAME];
    let n = protocol::encode(
        &Packet { seq: 9, frame: Frame::Dac(protocol::DacSample { tick: 0, codes: [1, 2, 3] }) },
        &mut good,
    )
    .unwrap();
    let mut junk: Vec<Vec<u8>> = vec![
        vec![],
        vec![0x49],
        b"IW".to_vec(),
        vec![0; 26],
        vec![0xff; 200],
        good[..n - 1].to_vec(),
        [&good[..n], &[0u8][..]].concat(),
    ];
    for bit in 0..n * 8 {
        let mut f = good[..n].to_vec();
        f[bit / 8] ^= 1 << (bit % 8);
        junk.push(f);
    }
    for f in &junk {
        raw.send(f).unwrap();
    }
    std::thread::sleep(Duration::from_millis(50));
    let (board, _) = board.finish();
    assert_eq!(board.counters.link.malformed, junk.len() as u64, "{:?}", board.counters);
    assert_eq!((board.counters.link.frames, board.counters.steps), (0, 0));
    assert_eq!(board.state(), BoardState::Disarmed);
}

#[test]
fn cobs_over_a_byte_stream_gives_the_same_trace() {
    let _slot = real_time_slot();
    let (a, b) = std::os::unix::net::UnixStream::pair().unwrap();
    a.set_nonblocking(true).unwrap();
    b.set_nonblocking(true).unwrap();
    let stop = std::sync::Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    let handle = std::thread::spawn(move || {
        let mut t = CobsTransport::new(b);
        let mut board = Board::new(DirectPlant::new(), board_cfg(true), None).unwrap();
        run_board(&mut board, &mut t, &s, &mut Vec::new()).unwrap();
        board
    });
    // Line noise before the first frame: the receiver resynchronises at the delimiter.
    std::io::Write::write_all(&mut &a, &[1, 2, 3, 0x55]).unwrap();
    let mut t = CobsTransport::new(a);
    let mut ctrl = DirectController::new();
    let report = run_controller(
        &mut ctrl,
        &mut t,
        &reference,
        &lockstep(500),
        None,
        &AtomicBool::new(false),
    )
    .unwrap();
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let board = handle.join().unwrap();
    assert!(report.fault.is_none());
    assert_eq!(report.encoder, cosimulation(500));
    assert_eq!(board.counters.link.malformed, 1, "the noise, and nothing else");
}

#[test]
fn the_log_replays_without_divergence_and_a_changed_sample_is_found() {
    let _slot = real_time_slot();
    let dir = std::env::temp_dir().join(format!("iw-bridge-log-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("controller.log");
    let board = spawn_board(board_cfg(true), None);
    let mut udp = UdpTransport::connect(board.addr).unwrap();
    let mut log = LogWriter::create(&path).unwrap();
    log.write(&Record::Meta("role=controller".into())).unwrap();
    let mut ctrl = DirectController::new();
    let report = run_controller(
        &mut ctrl,
        &mut udp,
        &reference,
        &lockstep(800),
        Some(&mut log),
        &AtomicBool::new(false),
    )
    .unwrap();
    board.finish();
    assert!(report.fault.is_none());
    drop(log);

    let contents = read_log(&path).unwrap();
    assert_eq!(contents.truncated_at, None);
    let samples = controller_samples(&contents.records);
    assert_eq!(samples.len(), 800);
    assert!(contents
        .records
        .iter()
        .any(|r| matches!(r, Record::Event { text, .. } if text.contains("disarmed"))));
    let r = replay(&mut DirectController::new(), &samples).unwrap();
    assert_eq!((r.samples, r.divergent, r.discontinuities), (800, 0, 0), "{r:?}");

    // One encoder count changed by one: the controller's later codes differ.
    let mut changed = samples.clone();
    for s in &mut changed[300..400] {
        s.counts += 100;
    }
    let r = replay(&mut DirectController::new(), &changed).unwrap();
    assert!(r.divergent > 0, "{r:?}");
    assert!(r.first.unwrap().0 > 300, "{r:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_controller_that_writes_at_its_tick_gives_the_same_trace_and_logs_its_clock() {
    // Scheduled Execution's order (step, then send) against the co-simulation's (send,
    // then step): the same samples reach the board, so the same trace comes back, and the
    // output clock lands in the run log at each tick whose write ended a gait step.
    let _slot = real_time_slot();
    let dir = std::env::temp_dir().join(format!("iw-bridge-at-tick-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("controller.log");
    let ticks = 1000;
    let board = spawn_board(board_cfg(true), None);
    let mut udp = UdpTransport::connect(board.addr).unwrap();
    let mut log = LogWriter::create(&path).unwrap();
    log.write(&Record::Meta("role=controller".into())).unwrap();
    let mut ctrl = ScheduledController::new();
    let report = run_controller(
        &mut ctrl,
        &mut udp,
        &reference,
        &lockstep(ticks),
        Some(&mut log),
        &AtomicBool::new(false),
    )
    .unwrap();
    board.finish();
    drop(log);
    assert!(report.fault.is_none(), "{:?}", report.fault);
    assert_eq!(report.encoder, cosimulation(ticks as usize));

    // The gait steps of the co-simulation's controller: its tick k writes the sample for
    // tick k + 1, which the scheduled controller writes at tick k + 1.
    let mut direct = DirectController::new();
    let mut counts = 0;
    let mut expected = Vec::new();
    for (k, &next) in report.encoder.iter().enumerate() {
        direct.step(counts, reference(k as f64 * H)).unwrap();
        if direct.ctrl.estimated() {
            expected.push(k as u32 + 1);
        }
        counts = next;
    }
    expected.retain(|&k| k < ticks as u32);
    assert!(expected.len() >= 5, "the gait ran: {expected:?}");
    assert_eq!(report.clock_ticks, expected.len() as u64);
    let contents = read_log(&path).unwrap();
    let clocks: Vec<u32> = contents
        .records
        .iter()
        .filter_map(|r| match r {
            Record::Event { tick, text } if text == "output clock gait_step ticked" => Some(*tick),
            _ => None,
        })
        .collect();
    let first = report.first_tick;
    assert_eq!(clocks, expected.iter().map(|k| first.wrapping_add(*k)).collect::<Vec<_>>());

    // The log replays through either order without a divergence.
    let samples = controller_samples(&contents.records);
    for r in [
        replay(&mut ScheduledController::new(), &samples).unwrap(),
        replay(&mut DirectController::new(), &samples).unwrap(),
    ] {
        assert_eq!((r.samples, r.divergent, r.discontinuities), (ticks, 0, 0), "{r:?}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn hello_with_another_mode_is_refused_with_the_reason() {
    let _slot = real_time_slot();
    // A real-time controller against a lock-step board.
    let board = spawn_board(board_cfg(true), None);
    let mut udp = UdpTransport::connect(board.addr).unwrap();
    let mut ctrl = DirectController::new();
    let e = run_controller(
        &mut ctrl,
        &mut udp,
        &reference,
        &realtime(10),
        None,
        &AtomicBool::new(false),
    )
    .unwrap_err()
    .to_string();
    let (board, _) = board.finish();
    assert!(e.contains("ProtocolMismatch"), "{e}");
    assert!(
        board.events.iter().any(|(_, t)| t.contains(" refused: lock-step false (board: true)")),
        "{:?}",
        board.events
    );
}
