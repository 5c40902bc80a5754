//! The board's loop: real time paced by absolute deadlines, lock-step paced by the
//! controller's DAC frames, and the drain of what arrived before a stop.

use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use super::Board;
use crate::realtime::{now_ns, Pacer};
use crate::transport::Transport;
use crate::Mechanism;

/// Runs the board until `stop` is set. Real time: one step per period. Lock-step: one step
/// per DAC frame, wall-clock periods of silence counting towards the dead-link bound.
/// `lateness_us` receives the wake-up lateness of every real-time period.
pub fn run_board<M: Mechanism>(
    board: &mut Board<M>,
    tx: &mut dyn Transport,
    stop: &AtomicBool,
    lateness_us: &mut Vec<f64>,
) -> io::Result<()> {
    // Room for the largest UDP datagram, so an oversized one is refused for its real size
    // and not for whatever part of it fitted.
    let mut buf = vec![0u8; 65536];
    let period_ns = board.cfg.period.as_nanos() as u64;
    // What has arrived, until none is left or the clock reads `until_ns`: a flood that
    // never lets the socket empty cannot hold back a period's step, or a stop (on which
    // what has already arrived, a DISARM, a FAULT, is still taken).
    let drain = |board: &mut Board<M>,
                 tx: &mut dyn Transport,
                 buf: &mut [u8],
                 until_ns: u64|
     -> io::Result<()> {
        while now_ns() < until_ns {
            match tx.recv(buf, Duration::ZERO) {
                Ok(Some(n)) => board.handle(&buf[..n], tx)?,
                Ok(None) => return Ok(()),
                Err(e) if e.kind() == io::ErrorKind::InvalidData => {
                    board.refuse_malformed(tx.source(), &e.to_string())
                }
                Err(e) => return Err(e),
            }
        }
        Ok(())
    };
    let result = if board.cfg.lockstep {
        let mut boundary = now_ns() + period_ns;
        loop {
            if stop.load(Ordering::Relaxed) {
                break drain(board, tx, &mut buf, now_ns() + period_ns);
            }
            let now = now_ns();
            if now >= boundary {
                board.silent_period(tx)?;
                boundary += period_ns;
                continue;
            }
            match tx.recv(&mut buf, Duration::from_nanos(boundary - now)) {
                Ok(Some(n)) => {
                    let before = board.counters.steps + board.counters.repeats;
                    board.handle(&buf[..n], tx)?;
                    if board.counters.steps + board.counters.repeats != before {
                        boundary = now_ns() + period_ns;
                    }
                }
                Ok(None) => {}
                Err(e) if e.kind() == io::ErrorKind::InvalidData => {
                    board.refuse_malformed(tx.source(), &e.to_string())
                }
                Err(e) => break Err(e),
            }
        }
    } else {
        let mut pacer = Pacer::new(board.cfg.period);
        loop {
            if stop.load(Ordering::Relaxed) {
                break drain(board, tx, &mut buf, now_ns() + period_ns);
            }
            let wake = pacer.wait();
            lateness_us.push(wake.lateness_ns as f64 / 1e3);
            // Half the period for what arrived, the rest for the step and its frame.
            drain(board, tx, &mut buf, now_ns() + period_ns / 2)?;
            let overrun =
                wake.overrun.then(|| (wake.lateness_ns + wake.skipped * period_ns) / 1000);
            board.period(overrun, tx)?;
        }
    };
    match &result {
        Ok(()) => board.close_log("stopped on request"),
        Err(e) => board.close_log(&format!("error: {e}")),
    }
    board.sync_log();
    result
}
