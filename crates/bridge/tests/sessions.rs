//! Bridge sessions (docs/hil-protocol.md, "Sessions"): which sender a board serves. Each
//! case here locked the real controller out, or passed a stranger silently, when the
//! board bound itself to the first address that sent it anything.

mod common;

use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Duration;

use common::*;
use inchworm_bridge::board::{run_board, Allow, Board, BoardConfig, SourceCounts};
use inchworm_bridge::controller::{run_controller, ControllerConfig};
use inchworm_bridge::protocol::{
    self, session_refused, BoardState, DacSample, Fault, FaultReason, Frame, Hello, Packet, Role,
    MAX_FRAME, VERSION,
};
use inchworm_bridge::transport::{Source, Transport, UdpTransport};

struct Rig {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    handle: std::thread::JoinHandle<Board<DirectPlant>>,
}

impl Rig {
    fn start(cfg: BoardConfig, allow: Vec<Allow>) -> Rig {
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, rx) = mpsc::channel();
        let s = Arc::clone(&stop);
        let handle = std::thread::spawn(move || {
            let mut udp = UdpTransport::bind("127.0.0.1:0").unwrap();
            tx.send(udp.local_addr().unwrap()).unwrap();
            let mut board = Board::new(DirectPlant::new(), cfg, None).unwrap();
            board.set_allow(allow);
            run_board(&mut board, &mut udp, &s, &mut Vec::new()).expect("board loop");
            board
        });
        Rig { addr: rx.recv().unwrap(), stop, handle }
    }

    fn finish(self) -> Board<DirectPlant> {
        self.stop.store(true, Ordering::Relaxed);
        self.handle.join().expect("board thread")
    }
}

fn lockstep_cfg() -> BoardConfig {
    BoardConfig { lockstep: true, watchdog_periods: 50, ..BoardConfig::default() }
}

fn lockstep(ticks: u64) -> ControllerConfig {
    ControllerConfig { lockstep: true, ticks, ..ControllerConfig::default() }
}

/// A whole lock-step controller run of `ticks` that must get the board and finish.
fn lockstep_run(
    udp: &mut UdpTransport,
    ticks: u64,
) -> inchworm_bridge::controller::ControllerReport {
    let r = run_controller(
        &mut DirectController::new(),
        udp,
        &reference,
        &lockstep(ticks),
        None,
        &AtomicBool::new(false),
    )
    .expect("the controller gets the board");
    assert!(r.fault.is_none(), "{:?}", r.fault);
    r
}

/// How the board sees a controller socket that was bound to 0.0.0.0.
fn seen_as(udp: &UdpTransport) -> Source {
    Source::Udp(SocketAddr::from(([127, 0, 0, 1], udp.local_addr().unwrap().port())))
}

fn seen_as_raw(s: &UdpSocket) -> Source {
    Source::Udp(s.local_addr().unwrap())
}

fn frame(seq: u16, frame: Frame) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME];
    let n = protocol::encode(&Packet { seq, frame }, &mut buf).unwrap();
    buf[..n].to_vec()
}

fn controller_hello(lockstep: bool) -> Frame {
    Frame::Hello(Hello {
        version: VERSION,
        role: Role::Controller,
        period_us: 2000,
        watchdog_periods: 3,
        lockstep,
    })
}

/// The next frame the board sends `s`, within 1 s.
fn answer(s: &UdpSocket) -> Packet {
    s.set_read_timeout(Some(Duration::from_secs(1))).unwrap();
    let mut buf = [0u8; 256];
    let n = s.recv(&mut buf).expect("an answer from the board within 1 s");
    protocol::decode(&buf[..n]).unwrap()
}

fn refused(detail: u32) -> Frame {
    Frame::Fault(Fault { reason: FaultReason::SessionRefused, detail })
}

#[test]
fn a_stray_datagram_first_does_not_lock_the_controller_out() {
    let _slot = real_time_slot();
    // Real time, with room in the watchdog for a machine busy with other builds.
    let rig = Rig::start(BoardConfig { watchdog_periods: 25, ..BoardConfig::default() }, vec![]);
    // Before any controller: junk, then a valid ARM that no HELLO opened.
    let stray = UdpSocket::bind("127.0.0.1:0").unwrap();
    stray.connect(rig.addr).unwrap();
    stray.send(b"\x00not a frame at all").unwrap();
    stray.send(&frame(1, Frame::Arm)).unwrap();
    assert_eq!(answer(&stray).frame, refused(session_refused::NO_SESSION));

    let mut udp = UdpTransport::connect(rig.addr).unwrap();
    let report = run_controller(
        &mut DirectController::new(),
        &mut udp,
        &reference,
        &ControllerConfig { ticks: 300, dead_after: 25, ..ControllerConfig::default() },
        None,
        &AtomicBool::new(false),
    )
    .expect("the controller gets its session");
    let board = rig.finish();
    assert!(report.fault.is_none(), "{:?}", report.fault);
    assert_eq!(report.ticks, 300);
    assert_eq!(board.sessions.len(), 1);
    assert_eq!(board.sessions[0].peer, seen_as(&udp));
    assert_eq!(board.sessions[0].arms, 1);
    assert_eq!(
        board.sources.get(&seen_as_raw(&stray)),
        Some(&SourceCounts { malformed: 1, foreign: 1, refused: 0, not_allowed: 0 })
    );
    // The stray's frames never reached the session's counters.
    assert_eq!(board.counters.link.malformed, 1);
    assert_eq!(board.state(), BoardState::Disarmed);
    let lines = board.summary_lines();
    assert_eq!(lines[0], "sessions: 1");
    assert!(
        lines.contains(&format!(
            "source {}: 1 malformed, 1 foreign, 0 HELLO refused, 0 not allowed",
            seen_as_raw(&stray)
        )),
        "{lines:?}"
    );
}

#[test]
fn controller_runs_in_a_row_each_get_a_session() {
    let _slot = real_time_slot();
    // A fresh plant per session: each run is the co-simulation from the start, exactly.
    let rig = Rig::start(BoardConfig { fresh_plant_per_session: true, ..lockstep_cfg() }, vec![]);
    let ticks = 400;
    let expected = cosimulation(ticks as usize);
    let mut first = UdpTransport::connect(rig.addr).unwrap();
    let mut second = UdpTransport::connect(rig.addr).unwrap();
    let mut traces = Vec::new();
    // Two sockets, then the second one again (the same address after its DISARM).
    for udp in [&mut first, &mut second] {
        let r = run_controller(
            &mut DirectController::new(),
            udp,
            &reference,
            &lockstep(ticks),
            None,
            &AtomicBool::new(false),
        )
        .expect("each run gets a session");
        assert!(r.fault.is_none(), "{:?}", r.fault);
        traces.push(r.encoder);
    }
    let r = run_controller(
        &mut DirectController::new(),
        &mut second,
        &reference,
        &lockstep(ticks),
        None,
        &AtomicBool::new(false),
    )
    .expect("the same address gets a new session after its DISARM");
    traces.push(r.encoder);
    let board = rig.finish();
    for (i, t) in traces.iter().enumerate() {
        assert_eq!(t, &expected, "run {i}");
    }
    let peers: Vec<_> = board.sessions.iter().map(|s| (s.id, s.peer, s.arms)).collect();
    assert_eq!(
        peers,
        vec![(1, seen_as(&first), 1), (2, seen_as(&second), 1), (3, seen_as(&second), 1)]
    );
    assert_eq!(board.sessions[0].end.as_deref(), Some("disarmed"));
    assert_eq!(board.sessions[1].end.as_deref(), Some("disarmed"));
    assert_eq!(board.sessions[2].end, None);
    assert_eq!(board.counters.steps, 3 * ticks);
    assert!(board.sources.is_empty(), "{:?}", board.sources);

    // Without the flag the mechanism keeps its state, as hardware does: the second run
    // starts from the count the first one left.
    let rig = Rig::start(lockstep_cfg(), vec![]);
    let mut ends = Vec::new();
    let mut starts = Vec::new();
    for _ in 0..2 {
        let mut udp = UdpTransport::connect(rig.addr).unwrap();
        let r = run_controller(
            &mut DirectController::new(),
            &mut udp,
            &reference,
            &lockstep(300),
            None,
            &AtomicBool::new(false),
        )
        .unwrap();
        starts.push(r.events[0].1.clone());
        ends.push(*r.encoder.last().unwrap());
    }
    let board = rig.finish();
    assert_eq!(board.sessions.len(), 2);
    assert!(starts[1].ends_with(&format!("encoder {}", ends[0])), "{starts:?} {ends:?}");
}

#[test]
fn a_hello_from_another_address_during_an_armed_session_is_refused_and_logged() {
    let _slot = real_time_slot();
    // Real time, so the session lasts (3 s) while the stranger knocks; a watchdog and a
    // dead-link limit with room for a machine busy with other builds.
    let rig = Rig::start(BoardConfig { watchdog_periods: 25, ..BoardConfig::default() }, vec![]);
    let realtime =
        |ticks| ControllerConfig { ticks, dead_after: 25, ..ControllerConfig::default() };
    let ticks = 1500;
    let addr = rig.addr;
    let (mut announcing, armed_rx) = Announcing::new(0);
    let owner = std::thread::spawn(move || {
        let mut udp = UdpTransport::connect(addr).unwrap();
        let r = run_controller(
            &mut announcing,
            &mut udp,
            &reference,
            &realtime(ticks),
            None,
            &AtomicBool::new(false),
        );
        (r, seen_as(&udp))
    });
    // The owner's first tick: it is armed (an event, not a guess at how long start-up takes).
    armed_rx.recv_timeout(Duration::from_secs(30)).expect("the owner armed");
    let rogue = UdpSocket::bind("127.0.0.1:0").unwrap();
    rogue.connect(addr).unwrap();
    rogue.send(&frame(1, controller_hello(false))).unwrap();
    assert_eq!(answer(&rogue).frame, refused(session_refused::BUSY));
    // Its DAC frames are not applied either.
    rogue.send(&frame(1, Frame::Dac(DacSample { tick: 0, codes: [65535; 3] }))).unwrap();
    assert_eq!(answer(&rogue).frame, refused(session_refused::NO_SESSION));
    // A whole controller side against the busy board: refused, with the reason, at its
    // handshake deadline.
    let mut late = UdpTransport::connect(addr).unwrap();
    let e = run_controller(
        &mut DirectController::new(),
        &mut late,
        &reference,
        &ControllerConfig { handshake_timeout: Duration::from_millis(300), ..realtime(10) },
        None,
        &AtomicBool::new(false),
    )
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "the board refused the session for 0.3 s: SessionRefused: the board is armed in a session with another controller"
    );
    let (report, owner_addr) = owner.join().unwrap();
    let report = report.unwrap();
    let board = rig.finish();
    assert!(report.fault.is_none(), "{:?}", report.fault);
    assert_eq!(report.ticks, ticks, "the session ran undisturbed");
    assert_eq!(board.sessions.len(), 1);
    assert_eq!(board.sessions[0].peer, owner_addr);
    assert_eq!(board.latches, vec![]);
    assert_eq!(
        board.sources.get(&seen_as_raw(&rogue)),
        Some(&SourceCounts { malformed: 0, foreign: 1, refused: 1, not_allowed: 0 })
    );
    assert!(board.sources.get(&seen_as(&late)).is_some_and(|c| c.refused >= 2));
    let logged =
        format!("HELLO from {} refused: session 1 with {owner_addr} is armed", seen_as_raw(&rogue));
    assert!(board.events.iter().any(|(_, e)| e.starts_with(&logged)), "{:?}", board.events);
}

#[test]
fn a_controller_that_went_silent_is_replaced_after_the_dead_link_time() {
    let _slot = real_time_slot();
    // A controller that HELLOs and ARMs and is then gone (crashed): the restarted one is
    // refused BUSY while the old session may still be alive, and gets in once the board
    // has latched LinkDead (500 ms) on its own.
    let rig = Rig::start(lockstep_cfg(), vec![]);
    let gone = UdpSocket::bind("127.0.0.1:0").unwrap();
    gone.connect(rig.addr).unwrap();
    gone.send(&frame(1, controller_hello(true))).unwrap();
    assert!(matches!(answer(&gone).frame, Frame::Hello(h) if h.role == Role::Board));
    gone.send(&frame(2, Frame::Arm)).unwrap();
    assert!(
        matches!(answer(&gone).frame, Frame::Encoder(e) if e.status & protocol::status::ARMED != 0)
    );
    let t0 = std::time::Instant::now();
    let mut udp = UdpTransport::connect(rig.addr).unwrap();
    let r = run_controller(
        &mut DirectController::new(),
        &mut udp,
        &reference,
        &lockstep(300),
        None,
        &AtomicBool::new(false),
    )
    .expect("the restarted controller gets the board");
    let waited = t0.elapsed();
    let board = rig.finish();
    assert!(r.fault.is_none(), "{:?}", r.fault);
    assert_eq!(r.ticks, 300);
    assert!(waited >= Duration::from_millis(400), "waited {waited:?}");
    assert_eq!(board.sessions.len(), 2);
    assert_eq!(
        board.sessions[0].end.as_deref(),
        Some("safe state latched: LinkDead: no answer from the peer for 250 periods")
    );
    assert_eq!(board.latches.len(), 1);
    assert!(
        board.sources.get(&seen_as(&udp)).is_some_and(|c| c.refused >= 1),
        "{:?}",
        board.sources
    );
}

#[test]
fn allow_keeps_other_addresses_out_with_the_reason() {
    let _slot = real_time_slot();
    // All of 127/8 is loopback: the stranger speaks from 127.0.0.2.
    let rig = Rig::start(lockstep_cfg(), vec![Allow::Host([127, 0, 0, 1].into())]);
    let other = UdpSocket::bind("127.0.0.2:0").unwrap();
    other.connect(rig.addr).unwrap();
    other.send(&frame(1, controller_hello(true))).unwrap();
    assert_eq!(answer(&other).frame, refused(session_refused::NOT_ALLOWED));
    other.send(b"junk").unwrap();
    let mut udp = UdpTransport::connect(rig.addr).unwrap();
    let r = run_controller(
        &mut DirectController::new(),
        &mut udp,
        &reference,
        &lockstep(200),
        None,
        &AtomicBool::new(false),
    )
    .expect("an allowed controller gets its session");
    let board = rig.finish();
    assert!(r.fault.is_none(), "{:?}", r.fault);
    assert_eq!(board.sessions.len(), 1);
    assert_eq!(board.sessions[0].peer, seen_as(&udp));
    assert_eq!(
        board.sources.get(&seen_as_raw(&other)),
        Some(&SourceCounts { malformed: 0, foreign: 0, refused: 0, not_allowed: 2 })
    );
    assert_eq!("127.0.0.1".parse::<Allow>().unwrap(), Allow::Host([127, 0, 0, 1].into()));
    assert_eq!(
        "127.0.0.1:40000".parse::<Allow>().unwrap(),
        Allow::Addr(SocketAddr::from(([127, 0, 0, 1], 40000)))
    );
    assert!("localhost:1".parse::<Allow>().unwrap_err().contains("--allow localhost:1"));
}

#[test]
fn a_hello_during_another_controllers_handshake_takes_nothing() {
    let _slot = real_time_slot();
    // A second sender's HELLO between a controller's HELLO and its ARM takes nothing: a
    // HELLO only answers; the session is bound by the ARM that completes a handshake, and
    // the first complete one holds it.
    let rig = Rig::start(lockstep_cfg(), vec![]);
    let (a, b) = (UdpSocket::bind("127.0.0.1:0").unwrap(), UdpSocket::bind("127.0.0.1:0").unwrap());
    for s in [&a, &b] {
        s.connect(rig.addr).unwrap();
        s.send(&frame(1, controller_hello(true))).unwrap();
        assert!(matches!(answer(s).frame, Frame::Hello(h) if h.role == Role::Board));
    }
    // A repeated HELLO is the same handshake.
    b.send(&frame(2, controller_hello(true))).unwrap();
    assert!(matches!(answer(&b).frame, Frame::Hello(_)));
    a.send(&frame(2, Frame::Arm)).unwrap();
    assert!(
        matches!(answer(&a).frame, Frame::Encoder(e) if e.status & protocol::status::ARMED != 0)
    );
    // b completes second: the board is armed with a, alive, so b is refused, with the reason.
    b.send(&frame(3, Frame::Arm)).unwrap();
    assert_eq!(answer(&b).frame, refused(session_refused::BUSY));
    b.send(&frame(4, controller_hello(true))).unwrap();
    assert_eq!(answer(&b).frame, refused(session_refused::BUSY));
    let board = rig.finish();
    let sessions: Vec<_> = board.sessions.iter().map(|s| (s.peer, s.arms, s.end.clone())).collect();
    assert_eq!(sessions, vec![(seen_as_raw(&a), 1, None)]);
    assert_eq!(
        board.sources.get(&seen_as_raw(&b)),
        Some(&SourceCounts { malformed: 0, foreign: 0, refused: 2, not_allowed: 0 })
    );
    assert_eq!(board.state(), BoardState::Armed);
    let logged = format!(
        "ARM from {} refused: session 1 with {} is armed",
        seen_as_raw(&b),
        seen_as_raw(&a)
    );
    assert!(board.events.iter().any(|(_, e)| e.starts_with(&logged)), "{:?}", board.events);
}

#[test]
fn a_hello_that_is_never_completed_holds_nothing_and_lapses() {
    let _slot = real_time_slot();
    // A 20 ms handshake window (the dead-link time), so the lapse is quick to see.
    let rig = Rig::start(BoardConfig { dead_link_periods: 10, ..lockstep_cfg() }, vec![]);
    let idle = UdpSocket::bind("127.0.0.1:0").unwrap();
    idle.connect(rig.addr).unwrap();
    idle.send(&frame(1, controller_hello(true))).unwrap();
    assert!(matches!(answer(&idle).frame, Frame::Hello(_)));
    // A whole controller gets the board at once: the unfinished handshake binds nothing.
    let mut udp = UdpTransport::connect(rig.addr).unwrap();
    assert_eq!(lockstep_run(&mut udp, 50).ticks, 50);
    // Past the window the old HELLO no longer counts: its ARM is a stranger's. (A sleep is
    // a lower bound here: a stalled test only waits longer, past the window all the same.)
    std::thread::sleep(Duration::from_millis(40));
    idle.send(&frame(2, Frame::Arm)).unwrap();
    assert_eq!(answer(&idle).frame, refused(session_refused::NO_SESSION));
    let board = rig.finish();
    assert_eq!(board.sessions.len(), 1);
    assert_eq!(board.sessions[0].peer, seen_as(&udp));
    assert_eq!(
        board.sources.get(&seen_as_raw(&idle)),
        Some(&SourceCounts { malformed: 0, foreign: 1, refused: 0, not_allowed: 0 })
    );
}

#[test]
fn a_flood_of_hellos_from_many_ports_grows_nothing_and_a_controller_still_gets_in() {
    let _slot = real_time_slot();
    let rig = Rig::start(lockstep_cfg(), vec![]);
    let flood: Vec<UdpSocket> = (0..300).map(|_| UdpSocket::bind("127.0.0.1:0").unwrap()).collect();
    let hello = frame(1, controller_hello(true));
    for round in 0..4 {
        for s in &flood {
            s.send_to(&hello, rig.addr).unwrap();
        }
        if round == 1 {
            // The real controller in the middle of the flood.
            let mut udp = UdpTransport::connect(rig.addr).unwrap();
            assert_eq!(lockstep_run(&mut udp, 100).ticks, 100);
        }
    }
    let board = rig.finish();
    // One session, and no per-sender state for the flood: its HELLOs were answered (or,
    // during the armed session, refused and counted within the bounded table).
    assert_eq!(board.summary_lines()[0], "sessions: 1");
    assert!(board.sources.len() <= inchworm_bridge::board::MAX_SOURCES);
    assert!(board.events.len() < 200, "{} events", board.events.len());
}

#[test]
fn session_records_are_bounded_and_the_summary_says_how_many_there_were() {
    let _slot = real_time_slot();
    let rig = Rig::start(lockstep_cfg(), vec![]);
    let n = inchworm_bridge::board::MAX_SESSION_RECORDS + 8;
    let peers: Vec<UdpSocket> = (0..n).map(|_| UdpSocket::bind("127.0.0.1:0").unwrap()).collect();
    for s in &peers {
        s.connect(rig.addr).unwrap();
        s.send(&frame(1, controller_hello(true))).unwrap();
        assert!(matches!(answer(s).frame, Frame::Hello(_)));
        s.send(&frame(2, Frame::Arm)).unwrap();
        assert!(matches!(answer(s).frame, Frame::Encoder(_)));
        s.send(&frame(3, Frame::Disarm)).unwrap();
    }
    // The last DISARM is taken before the stop (the board drains what arrived).
    let board = rig.finish();
    assert_eq!(board.sessions.len(), inchworm_bridge::board::MAX_SESSION_RECORDS);
    assert_eq!(board.sessions[0].id, 9);
    assert_eq!(board.sessions.last().unwrap().peer, seen_as_raw(&peers[n - 1]));
    let lines = board.summary_lines();
    assert_eq!(lines[0], format!("sessions: {n}"));
    assert!(lines[1].starts_with("sessions 1 to 8: not listed"), "{lines:?}");
    assert_eq!(lines.len(), 2 + inchworm_bridge::board::MAX_SESSION_RECORDS, "{lines:?}");
}

#[test]
fn a_flood_that_overfills_the_board_socket_loses_none_of_the_peer_s_datagrams() {
    // The board reads nothing while a flood from another port overfills its socket (a board
    // short of CPU): the kernel drops the flood's excess, and with one buffer for everyone
    // it dropped the peer's DAC frames too, 25 periods of which fire the board's watchdog.
    let mut board = UdpTransport::bind("127.0.0.1:0").unwrap();
    let addr = board.local_addr().unwrap();
    let peer = UdpSocket::bind("127.0.0.1:0").unwrap();
    let stranger = UdpSocket::bind("127.0.0.1:0").unwrap();
    let peer_addr = peer.local_addr().unwrap();
    board.set_peer(Source::Udp(peer_addr));
    // Far more than any socket buffer holds (some 200 KB by default; each datagram costs
    // its payload and about 1 KB of bookkeeping).
    let flood = [0x55u8; 64];
    for _ in 0..20_000 {
        stranger.send_to(&flood, addr).unwrap();
    }
    let frames: Vec<Vec<u8>> = (0u8..50).map(|i| vec![0xAA, i]).collect();
    for f in &frames {
        peer.send_to(f, addr).unwrap();
        stranger.send_to(&flood, addr).unwrap();
    }
    let mut buf = [0u8; 256];
    let (mut got, mut strangers) = (Vec::new(), 0usize);
    while let Some(n) = board.recv(&mut buf, Duration::ZERO).unwrap() {
        match board.source() {
            Source::Udp(a) if a == peer_addr => got.push(buf[..n].to_vec()),
            Source::Udp(a) => {
                assert_eq!(a, stranger.local_addr().unwrap());
                strangers += 1;
            }
            Source::Line => panic!("a UDP datagram from the line"),
        }
    }
    assert_eq!(got, frames, "the peer's datagrams, all and in order, before the flood's");
    assert!(strangers > 0 && strangers < 20_050, "the flood got in, in part: {strangers}");
    // Replies leave from the board's port, where the peer sends.
    board.send(&[1, 2, 3]).unwrap();
    peer.set_read_timeout(Some(Duration::from_secs(2))).unwrap();
    let (n, from) = peer.recv_from(&mut buf).unwrap();
    assert_eq!((&buf[..n], from), (&[1u8, 2, 3][..], addr));
}

#[test]
fn a_second_board_on_the_same_port_is_refused() {
    // The board's sockets share their port with each other (SO_REUSEPORT), not with another
    // board, which would take half the controllers' datagrams.
    let first = UdpTransport::bind("127.0.0.1:0").unwrap();
    let addr = first.local_addr().unwrap();
    let second = UdpTransport::bind(addr).err().expect("a second board on the same port");
    assert_eq!(second.kind(), std::io::ErrorKind::AddrInUse, "{second}");
    assert!(UdpSocket::bind(addr).is_err(), "a plain socket on the board's port");
}
