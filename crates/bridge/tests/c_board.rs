//! The Rust controller side against a board written in C on the project's C library
//! (`libinchworm_hil.a`, its codec and watchdog): what a board firmware links. The C board
//! (tests/c/board.c) runs lock-step with a stand-in mechanism whose integer arithmetic the
//! test repeats, so every count must match; and its watchdog must latch the safe state
//! and say so when the DAC frames stop.

mod common;
#[path = "../../hil-protocol/tests/ffi_build/mod.rs"]
mod ffi_build;

use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::AtomicBool;

use common::real_time_slot;
use inchworm_bridge::controller::{run_controller, ControllerConfig};
use inchworm_bridge::faults::{FaultPlan, FaultyTransport};
use inchworm_bridge::protocol::FaultReason;
use inchworm_bridge::transport::UdpTransport;
use inchworm_bridge::Compensator;

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
    fn codes(&mut self) -> Result<[u16; 3], String> {
        Ok(Sequence::codes(self.0))
    }
    fn step(&mut self, _counts: i32, _reference: f64) -> Result<(), String> {
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

#[test]
fn the_c_boards_watchdog_latches_and_the_rust_side_reports_it() {
    let _slot = real_time_slot();
    let exe = board();
    let (child, addr) = start(&exe);
    let udp = UdpTransport::connect(&addr).unwrap();
    // DAC frames from the 200th on are lost; the repeats too.
    let mut link = FaultyTransport::new(
        udp,
        FaultPlan {
            silence: Some((200, u64::MAX / 2)),
            only_type: Some(0x10),
            ..FaultPlan::default()
        },
    );
    let cfg = ControllerConfig { lockstep: true, ticks: 3000, ..ControllerConfig::default() };
    let report =
        run_controller(&mut Sequence(0), &mut link, &|_| 0.0, &cfg, None, &AtomicBool::new(false))
            .unwrap();
    let (fault, text) = report.fault.expect("the C board's FAULT");
    assert_eq!((fault.reason, fault.detail), (FaultReason::Silence, 3), "{text}");
    assert_eq!(report.ticks, 200);
    assert_eq!(report.encoder, expected(200));
    // The C board ends by its idle timeout: latched (state 2), Silence (1), nothing stepped
    // after the last valid frame.
    let text = summary(child);
    assert_eq!(
        text.trim(),
        format!("c board: 200 steps, 0 malformed, counts {}, state 2, fault 1", expected(200)[199])
    );
}
