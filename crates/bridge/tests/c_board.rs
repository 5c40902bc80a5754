//! The Rust controller side against a board written in C on the project's C library
//! (`libinchworm_hil.a`, its codec and watchdog): what a board firmware links. The C board
//! (tests/c/board.c) runs lock-step with a stand-in mechanism whose integer arithmetic the
//! test repeats, so every count must match. Its watchdog counts in the lock-step sense
//! (docs/hil-protocol.md, "Lock-step: what a missed period is"): it must ride out a slow
//! controller, latch and say so when DAC transmissions are lost in a row, and latch
//! LinkDead when the controller is gone.

mod common;
#[path = "../../hil-protocol/tests/ffi_build/mod.rs"]
mod ffi_build;

use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use common::real_time_slot;
use inchworm_bridge::controller::{run_controller, ControllerConfig};
use inchworm_bridge::faults::{FaultPlan, FaultyTransport};
use inchworm_bridge::protocol::FaultReason;
use inchworm_bridge::transport::UdpTransport;
use inchworm_bridge::{Compensator, ModelError};

/// Commands a fixed, varied code sequence; ignores the counts.
struct Sequence(u32);

impl Sequence {
    fn codes(k: u32) -> [u16; 3] {
        [
            (k.wrapping_mul(97) % 65536) as u16,
            (k.wrapping_mul(31) % 65536) as u16,
            (k.wrapping_mul(1237) % 65536) as u16,
        ]
    }
}

impl Compensator for Sequence {
    fn codes(&mut self) -> Result<[u16; 3], ModelError> {
        Ok(Sequence::codes(self.0))
    }
    fn step(&mut self, _counts: i32, _reference: f64) -> Result<(), ModelError> {
        self.0 += 1;
        Ok(())
    }
}

/// The C board's mechanism, repeated: counts += extension / 16 − earth / 64.
fn expected(ticks: u32) -> Vec<i32> {
    let mut counts = 0i32;
    (0..ticks)
        .map(|k| {
            let c = Sequence::codes(k);
            counts += i32::from(c[2] / 16) - i32::from(c[0] / 64);
            counts
        })
        .collect()
}

fn board() -> PathBuf {
    let source = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/c/board.c");
    ffi_build::compile(&source, "board")
}

fn start(exe: &PathBuf) -> (Child, String) {
    let port = std::net::UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let child = Command::new(exe)
        .arg(port.to_string())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    (child, format!("127.0.0.1:{port}"))
}

fn summary(child: Child) -> String {
    let out = child.wait_with_output().unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{text}");
    text
}

#[test]
fn the_rust_controller_drives_a_c_board_in_lock_step() {
    let _slot = real_time_slot();
    let exe = board();
    let (child, addr) = start(&exe);
    let mut udp = UdpTransport::connect(&addr).unwrap();
    let cfg = ControllerConfig { lockstep: true, ticks: 3000, ..ControllerConfig::default() };
    let report =
        run_controller(&mut Sequence(0), &mut udp, &|_| 0.0, &cfg, None, &AtomicBool::new(false))
            .unwrap();
    assert!(report.fault.is_none(), "{:?}", report.fault);
    assert_eq!(report.encoder, expected(3000));
    let text = summary(child);
    let last = expected(3000)[2999];
    assert_eq!(
        text.trim(),
        format!("c board: 3000 steps, 0 malformed, counts {last}, state 0, fault 0")
    );
}

/// [`Sequence`], stalling `stall` before the codes of every `every`-th tick.
struct Slow {
    seq: Sequence,
    every: u32,
    stall: Duration,
}

impl Compensator for Slow {
    fn codes(&mut self) -> Result<[u16; 3], ModelError> {
        if self.seq.0 % self.every == self.every - 1 {
            std::thread::sleep(self.stall);
        }
        self.seq.codes()
    }
    fn step(&mut self, counts: i32, reference: f64) -> Result<(), ModelError> {
        self.seq.step(counts, reference)
    }
}

#[test]
fn a_slow_lock_step_controller_does_not_trip_the_c_boards_watchdog() {
    let _slot = real_time_slot();
    let exe = board();
    let (child, addr) = start(&exe);
    let mut udp = UdpTransport::connect(&addr).unwrap();
    // 20 ms between an answer and the next DAC frame is 10 wall-clock periods, far past
    // the watchdog's 3: the controller is slow, and nothing is missed in lock-step.
    let mut slow = Slow { seq: Sequence(0), every: 50, stall: Duration::from_millis(20) };
    let cfg = ControllerConfig { lockstep: true, ticks: 400, ..ControllerConfig::default() };
    let started = Instant::now();
    let report =
        run_controller(&mut slow, &mut udp, &|_| 0.0, &cfg, None, &AtomicBool::new(false)).unwrap();
    assert!(started.elapsed() >= Duration::from_millis(8 * 20), "the stalls happened");
    assert!(report.fault.is_none(), "{:?}", report.fault);
    assert_eq!(report.encoder, expected(400));
    assert_eq!(
        summary(child).trim(),
        format!("c board: 400 steps, 0 malformed, counts {}, state 0, fault 0", expected(400)[399])
    );
}

#[test]
fn the_c_boards_watchdog_latches_and_the_rust_side_reports_it() {
    let _slot = real_time_slot();
    let exe = board();
    let (child, addr) = start(&exe);
    let udp = UdpTransport::connect(&addr).unwrap();
    // DAC transmissions 200, 201 and 202 are lost: the first of a tick and its first two
    // repeats. The third repeat arrives with a sequence gap of 3, the watchdog's limit.
    let mut link = FaultyTransport::new(
        udp,
        FaultPlan { silence: Some((200, 3)), only_type: Some(0x10), ..FaultPlan::default() },
    );
    let cfg = ControllerConfig { lockstep: true, ticks: 3000, ..ControllerConfig::default() };
    let report =
        run_controller(&mut Sequence(0), &mut link, &|_| 0.0, &cfg, None, &AtomicBool::new(false))
            .unwrap();
    let (fault, text) = report.fault.expect("the C board's FAULT");
    assert_eq!((fault.reason, fault.detail), (FaultReason::Silence, 3), "{text}");
    // Transmission 200 is tick 200's first, unless an answer late by more than 2 ms on a
    // busy machine made the controller repeat an earlier tick: each such repeat moves the
    // lost window one tick earlier.
    let ticks = report.ticks;
    assert!(ticks <= 200 && ticks + report.counters.retransmits >= 203, "{ticks} ticks");
    assert_eq!(report.encoder, expected(ticks as u32));
    // The C board ends by its idle timeout: latched (state 2), Silence (1), nothing stepped
    // after the last valid frame.
    let last = expected(ticks as u32)[ticks as usize - 1];
    assert_eq!(
        summary(child).trim(),
        format!("c board: {ticks} steps, 0 malformed, counts {last}, state 2, fault 1")
    );
}

#[test]
fn the_c_board_latches_link_dead_when_the_controller_is_gone() {
    let _slot = real_time_slot();
    let exe = board();
    let (child, addr) = start(&exe);
    let udp = UdpTransport::connect(&addr).unwrap();
    // Everything the controller sends from its 202nd frame on (HELLO and ARM are the
    // first two) is lost, its own FAULT too: the board hears nothing more.
    let mut link = FaultyTransport::new(
        udp,
        FaultPlan { silence: Some((202, u64::MAX / 2)), ..FaultPlan::default() },
    );
    let cfg = ControllerConfig { lockstep: true, ticks: 3000, ..ControllerConfig::default() };
    let report =
        run_controller(&mut Sequence(0), &mut link, &|_| 0.0, &cfg, None, &AtomicBool::new(false))
            .unwrap();
    let (fault, text) = report.fault.expect("the controller's own dead-link fault");
    assert_eq!((fault.reason, fault.detail), (FaultReason::LinkDead, 26), "{text}");
    let ticks = report.ticks;
    assert!(ticks <= 200, "{ticks} ticks");
    assert_eq!(report.encoder, expected(ticks as u32));
    // The board latched by its dead-link bound, 250 silent periods, before its 1 s idle
    // exit: state 2, LinkDead (3).
    let last = expected(ticks as u32)[ticks as usize - 1];
    assert_eq!(
        summary(child).trim(),
        format!("c board: {ticks} steps, 0 malformed, counts {last}, state 2, fault 3")
    );
}
