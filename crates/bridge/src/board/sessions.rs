//! Sessions: the one controller the board serves at a time, the record of every session
//! and the summary the board prints and logs at its stop.

use std::io;

use inchworm_hil_protocol::BoardState;

use super::{Board, SourceCounts, MAX_SOURCES};

/// Session records kept: the summary lists the last this many and counts the rest, so a
/// long rig day (or a peer that opens session after session) cannot grow it without bound.
pub const MAX_SESSION_RECORDS: usize = 32;
use crate::realtime::now_ns;
use crate::runlog::Record;
use crate::transport::{Source, Transport};
use crate::{describe_fault, Mechanism};

/// One session: from the ARM that completed its controller's handshake to the one that
/// completed the next controller's, or the stop.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SessionInfo {
    /// 1, 2, … in order.
    pub id: u32,
    pub peer: Source,
    pub start_tick: u32,
    /// ARMs received in it.
    pub arms: u32,
    /// How it ended; `None` while it is the current one.
    pub end: Option<String>,
}

impl<M: Mechanism> Board<M> {
    /// The sessions and the foreign traffic, as the summary and the log give them.
    pub fn summary_lines(&self) -> Vec<String> {
        let mut out = vec![format!("sessions: {}", self.sessions_opened)];
        let dropped = self.sessions_opened as usize - self.sessions.len();
        if dropped > 0 {
            out.push(format!(
                "sessions 1 to {dropped}: not listed (the board keeps the last {MAX_SESSION_RECORDS} session records; the log has every session's events)"
            ));
        }
        for s in &self.sessions {
            out.push(format!(
                "session {}: controller {} from tick {}, {} ARM; {}",
                s.id,
                s.peer,
                s.start_tick,
                s.arms,
                s.end.as_deref().map_or_else(
                    || format!("open at the board's stop ({})", state_name(self.wd.state())),
                    |e| format!("ended: {e}")
                )
            ));
        }
        for (src, c) in &self.sources {
            out.push(format!("source {src}: {c}"));
        }
        if self.other_sources != SourceCounts::default() {
            out.push(format!("sources beyond the first {MAX_SOURCES}: {}", self.other_sources));
        }
        if self.refusals_unlogged > 0 {
            out.push(format!(
                "refusal log lines held back by the rate limit ({} at once, then {}/s): {}",
                super::REFUSAL_BURST,
                super::REFUSALS_PER_S,
                self.refusals_unlogged
            ));
        }
        out
    }

    /// The end of the board's run: the summary into the log, closed by an end record.
    pub(super) fn close_log(&mut self, outcome: &str) {
        for line in self.summary_lines() {
            self.write_log(Record::Event { tick: self.tick, text: line });
        }
        let text = format!("board stopped: {outcome}");
        self.write_log(Record::End { tick: self.tick, text });
    }

    /// Closes the current session, if any, and opens one with `from`. The mechanism keeps
    /// its state (as hardware does) unless the rig asks for a fresh one.
    pub(super) fn open_session(&mut self, from: Source, tx: &mut dyn Transport) -> io::Result<()> {
        let now = now_ns();
        if let Some(prev) = self.peer {
            let why = match self.wd.state() {
                BoardState::Armed => {
                    // Not reached while the admission rules hold (an armed session is
                    // taken over only once latched); if it were, the new controller must
                    // still ARM for itself.
                    self.wd.disarm();
                    format!(
                        "armed but silent for {:.0} ms, disarmed (safe codes)",
                        now.saturating_sub(self.peer_heard_ns) as f64 / 1e6
                    )
                }
                other => state_name(other),
            };
            let id = self.sessions_opened;
            if let Some(s) = self.sessions.last_mut() {
                s.end = Some(why.clone());
            }
            self.event(format!("session {id} with {prev} ends ({why}): {from} opens a new one"));
        }
        if self.cfg.fresh_plant_per_session && self.sessions_opened > 0 {
            self.mech.reinitialise().map_err(|e| {
                io::Error::other(format!(
                    "--fresh-plant-per-session: the mechanism could not be re-initialised: {e}"
                ))
            })?;
            self.counts = self.mech.counts().map_err(io::Error::other)?;
            self.event("mechanism re-initialised for the new session".into());
        }
        if self.peer != Some(from) {
            self.counters.link.frames += 1;
        }
        self.peer = Some(from);
        tx.set_peer(from);
        self.peer_heard_ns = now;
        self.sessions_opened += 1;
        if self.sessions.len() >= MAX_SESSION_RECORDS {
            self.sessions.remove(0);
        }
        self.sessions.push(SessionInfo {
            id: self.sessions_opened,
            peer: from,
            start_tick: self.tick,
            arms: 0,
            end: None,
        });
        Ok(())
    }
}

pub(super) fn state_name(s: BoardState) -> String {
    match s {
        BoardState::Disarmed => "disarmed".into(),
        BoardState::Armed => "armed".into(),
        BoardState::Safe(f) => format!("safe state latched: {}", describe_fault(&f)),
    }
}
