//! The HIL bridge: the controller FMU in front of a driver board, or the plant FMU behind
//! the board's protocol (the virtual board, also the plant-in-the-loop bridge for a real
//! controller board), over the wire protocol of `inchworm-hil-protocol`.
//!
//! * [`board`]: the board side. Applies DAC codes through the watchdog, steps the
//!   mechanism once per period (real time) or once per DAC frame (lock-step), answers with
//!   the encoder count and status.
//! * [`controller`]: the controller side. Handshake, arming, one DAC frame per tick, the
//!   sequence-gap and dead-link faults.
//! * [`realtime`]: absolute-deadline pacing, SCHED_FIFO and locked memory when permitted.
//! * [`transport`]: UDP datagrams, or COBS frames on a serial line.
//! * [`faults`]: seeded fault injection for the tests.
//! * [`runlog`]: the crash-proof run log; [`replay`] re-runs a controller on it.
//!
//! The two sides see the models only through [`Mechanism`] and [`Compensator`], so the
//! same loops drive the FMUs (in the `inchworm` CLI) and the plain-Rust crates (in tests).

pub mod board;
pub mod controller;
mod error;
pub mod faults;
pub mod realtime;
pub mod replay;
pub mod runlog;
pub mod transport;

use std::ops::ControlFlow;
use std::time::Duration;

pub use error::{Error, ModelError};
pub use inchworm_hil_protocol as protocol;

/// The communication period of docs/model.md §5: 500 Hz.
pub const PERIOD: Duration = Duration::from_millis(2);

/// The plant side as the board sees it: DAC codes held for one period in, encoder count out.
pub trait Mechanism {
    /// The encoder count now (before any step).
    fn counts(&mut self) -> Result<i32, ModelError>;
    /// Holds `codes` for one period; returns the encoder count at its end.
    fn step(&mut self, codes: [u16; 3]) -> Result<i32, ModelError>;
    /// Back to the state it started in. Hardware cannot do this (the runner stays where
    /// it is), so only test rigs ask for it (`--fresh-plant-per-session`).
    fn reinitialise(&mut self) -> Result<(), ModelError> {
        Err("this mechanism cannot be re-initialised".into())
    }
}

/// The controller as the bridge drives it.
pub trait Compensator {
    /// When a tick's codes are computed; [`Schedule::Ahead`] unless the compensator says
    /// otherwise.
    fn schedule(&self) -> Schedule {
        Schedule::Ahead
    }
    /// The DAC codes for the interval that starts now.
    fn codes(&mut self) -> Result<[u16; 3], ModelError>;
    /// One tick: the encoder count that holds now and the reference. Afterwards
    /// [`codes`](Compensator::codes) gives the next interval's codes
    /// ([`Schedule::Ahead`]) or this one's ([`Schedule::AtTick`]).
    fn step(&mut self, counts: i32, reference: f64) -> Result<(), ModelError>;
    /// The name of an output clock that ticked in the last [`step`](Compensator::step)
    /// (the controller FMU's `gait_step`, signalled through Scheduled Execution's
    /// clockUpdate), if one did; the run log records it. None by default.
    fn ticked_clock(&mut self) -> Result<Option<&str>, ModelError> {
        Ok(None)
    }
}

/// When a [`Compensator`] computes the codes of the interval that starts at a tick. The
/// samples are the same either way (the codes of the interval that starts at tick k come
/// from the count that held at tick k − 1); what differs is whether the tick's own call
/// writes them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Schedule {
    /// The previous tick's step wrote them (Co-Simulation: the step from t to t + h
    /// writes the sample for [t + h, t + 2h)): the bridge sends them, then steps with the
    /// count that holds now.
    Ahead,
    /// The tick's step writes them (Scheduled Execution: activating the sample partition
    /// at t writes the sample for [t, t + h) and latches the count that holds at t): the
    /// bridge steps with the count that holds now, then sends.
    AtTick,
}

/// One tick of `comp` as the bridge and the replay run it: `send` gets the codes for the
/// interval that starts now, and the step with `counts` and `reference` comes before it or
/// after it as the compensator's [`Schedule`] says (after it only if `send` went on).
/// Gives what `send` gave and the codes.
pub fn tick<C, B, T, E>(
    comp: &mut C,
    counts: i32,
    reference: f64,
    send: impl FnOnce([u16; 3]) -> Result<ControlFlow<B, T>, E>,
) -> Result<ControlFlow<B, (T, [u16; 3])>, E>
where
    C: Compensator + ?Sized,
    E: From<ModelError>,
{
    let ahead = comp.schedule() == Schedule::Ahead;
    if !ahead {
        comp.step(counts, reference)?;
    }
    let codes = comp.codes()?;
    let sent = match send(codes)? {
        ControlFlow::Continue(sent) => sent,
        ControlFlow::Break(b) => return Ok(ControlFlow::Break(b)),
    };
    if ahead {
        comp.step(counts, reference)?;
    }
    Ok(ControlFlow::Continue((sent, codes)))
}

/// What became of the frames one side received, the same on both sides.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LinkCounters {
    /// Valid frames of any type.
    pub frames: u64,
    /// Refused by the transport or the decoder: COBS, CRC, length, magic, version, type, stream.
    pub malformed: u64,
    pub duplicates: u64,
    /// Out-of-date frames: behind in sequence, or (lock-step) for a tick already past.
    pub stale: u64,
    /// Sequence gaps seen on the data stream, and the frames missing in them.
    pub gaps: u64,
    pub missing: u64,
}

impl LinkCounters {
    /// Books a data frame's sequence verdict; true when the frame is to be taken (First,
    /// Next or Gap), false when it is dropped (Duplicate, Stale).
    pub fn sequence(&mut self, verdict: protocol::SeqVerdict) -> bool {
        use protocol::SeqVerdict::*;
        match verdict {
            Duplicate => self.duplicates += 1,
            Stale { .. } => self.stale += 1,
            Gap { missing } => {
                self.gaps += 1;
                self.missing += u64::from(missing);
                return true;
            }
            First | Next => return true,
        }
        false
    }
}

/// What a missed deadline does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OverrunPolicy {
    /// Count it, log it, go on.
    Soft,
    /// Fault to the safe state.
    Hard,
}

/// An overrun policy that is neither `soft` nor `hard` (the text as given).
#[derive(Debug, thiserror::Error)]
#[error(
    "overrun policy `{}`: use soft (log and continue) or hard (fault to the safe state)",
    quoted(.0)
)]
pub struct UnknownPolicy(pub String);

impl std::str::FromStr for OverrunPolicy {
    type Err = UnknownPolicy;
    fn from_str(s: &str) -> Result<Self, UnknownPolicy> {
        match s {
            "soft" => Ok(OverrunPolicy::Soft),
            "hard" => Ok(OverrunPolicy::Hard),
            other => Err(UnknownPolicy(other.to_owned())),
        }
    }
}

/// The longest piece of outside text (a token from the command line, a name from a peer or
/// a log) that goes into a message whole, in characters.
pub const MAX_QUOTED: usize = 64;

/// `text` for a message: whole if short, else its first [`MAX_QUOTED`] characters and its
/// length, so a hostile or mistaken megabyte does not become a megabyte of log.
pub fn quoted(text: &str) -> String {
    match text.char_indices().nth(MAX_QUOTED) {
        None => text.to_string(),
        Some((at, _)) => format!("{}… ({} bytes in all)", &text[..at], text.len()),
    }
}

/// A fault as people read it.
pub fn describe_fault(f: &protocol::Fault) -> String {
    use protocol::FaultReason::*;
    let what = match f.reason {
        Silence if f.detail == 0 => "the board reports its latched safe state".to_string(),
        Silence => format!("no valid DAC frame for {} periods (watchdog)", f.detail),
        SequenceGap => format!("{} frames missing in a row", f.detail),
        LinkDead => format!("no answer from the peer for {} periods", f.detail),
        Corrupt => format!("{} malformed frames", f.detail),
        Overrun => format!("deadline missed by {} µs under the hard real-time policy", f.detail),
        Operator => "stopped by the operator".to_string(),
        ProtocolMismatch => format!("protocol mismatch (detail {})", f.detail),
        SessionRefused => match f.detail {
            protocol::session_refused::BUSY => {
                "the board is armed in a session with another controller".to_string()
            }
            protocol::session_refused::NOT_ALLOWED => {
                "this address is not among the board's allowed peers (--allow)".to_string()
            }
            protocol::session_refused::NO_SESSION => {
                "this controller holds no session with the board (HELLO first; another controller may have taken it over)".to_string()
            }
            other => format!("refused (detail {other})"),
        },
    };
    format!("{:?}: {what}", f.reason)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outside_text_is_cut_in_messages() {
        assert_eq!(quoted("soft-ish"), "soft-ish");
        let long = "é".repeat(100_000);
        let q = quoted(&long);
        assert_eq!(q, format!("{}… (200000 bytes in all)", "é".repeat(MAX_QUOTED)));
        let e = "x".repeat(1 << 20).parse::<OverrunPolicy>().unwrap_err().to_string();
        assert!(e.len() < 200 && e.contains("(1048576 bytes in all)"), "{e}");
    }
}
