//! Who gets heard: the allow list, the per-sender counts of what was not session
//! traffic, and the HELLO rules that decide whether a sender may open a session.

use std::io;

use inchworm_hil_protocol::{
    session_refused, BoardState, Fault, FaultReason, Frame, Hello, Role, VERSION,
};

use super::Board;
use crate::realtime::now_ns;
use crate::transport::{Source, Transport};
use crate::Mechanism;

/// Distinct senders counted one by one; beyond this many they share one count, so a flood
/// from many addresses cannot grow the board's memory without bound.
pub const MAX_SOURCES: usize = 64;

/// What one sender sent that the board did not take as session traffic.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SourceCounts {
    /// Datagrams that failed to decode (from any sender, the session's own included).
    pub malformed: u64,
    /// Valid frames other than HELLO from a sender that holds no session.
    pub foreign: u64,
    /// HELLOs refused: another controller's session was armed, or the parameters differ.
    pub refused: u64,
    /// Datagrams from an address outside the allow list, whatever they held.
    pub not_allowed: u64,
}

impl std::fmt::Display for SourceCounts {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} malformed, {} foreign, {} HELLO refused, {} not allowed",
            self.malformed, self.foreign, self.refused, self.not_allowed
        )
    }
}

impl<M: Mechanism> Board<M> {
    pub(super) fn allowed(&self, from: Source) -> bool {
        match from {
            Source::Line => true,
            Source::Udp(a) => self.allow.is_empty() || self.allow.iter().any(|r| r.admits(&a)),
        }
    }

    pub(super) fn counts_of(&mut self, from: Source) -> &mut SourceCounts {
        if self.sources.len() >= MAX_SOURCES && !self.sources.contains_key(&from) {
            return &mut self.other_sources;
        }
        self.sources.entry(from).or_default()
    }

    pub(super) fn dead_link_ns(&self) -> u64 {
        u64::from(self.cfg.dead_link_periods.max(1)) * self.cfg.period.as_nanos() as u64
    }

    /// Bytes that are not a frame, from `from`: counted, and reported at 1, 2, 4, … per
    /// sender so a flood cannot flood the log.
    pub fn refuse_malformed(&mut self, from: Source, why: &str) {
        self.counters.link.malformed += 1;
        let c = self.counts_of(from);
        c.malformed += 1;
        let n = c.malformed;
        if n.is_power_of_two() {
            self.event(format!(
                "malformed datagram from {from} refused ({why}); {n} from it so far"
            ));
        }
    }

    pub(super) fn refuse(
        &mut self,
        to: Source,
        detail: u32,
        tx: &mut dyn Transport,
    ) -> io::Result<()> {
        let f = Fault { reason: FaultReason::SessionRefused, detail };
        self.send_frame(Frame::Fault(f), Some(to), tx)
    }

    pub(super) fn hello(
        &mut self,
        from: Source,
        h: Hello,
        tx: &mut dyn Transport,
    ) -> io::Result<()> {
        let period_us = self.cfg.period.as_micros() as u32;
        let mismatch = if h.version != VERSION {
            Some((
                format!("protocol version {} (board speaks {VERSION})", h.version),
                u32::from(h.version),
            ))
        } else if h.role != Role::Controller {
            Some(("the peer says it is a board".to_string(), h.role as u32))
        } else if h.lockstep != self.cfg.lockstep {
            Some((
                format!("lock-step {} (board: {})", h.lockstep, self.cfg.lockstep),
                u32::from(h.lockstep),
            ))
        } else if h.period_us != period_us {
            Some((format!("period {} µs (board: {period_us} µs)", h.period_us), h.period_us))
        } else {
            None
        };
        if let Some((why, detail)) = mismatch {
            if self.peer != Some(from) {
                self.counts_of(from).refused += 1;
            }
            self.event(format!("HELLO from {from} refused: {why}"));
            let f = Fault { reason: FaultReason::ProtocolMismatch, detail };
            return self.send_frame(Frame::Fault(f), Some(from), tx);
        }
        let reply = Hello {
            version: VERSION,
            role: Role::Board,
            period_us,
            watchdog_periods: self.cfg.watchdog_periods.min(255) as u8,
            lockstep: self.cfg.lockstep,
        };
        let armed = self.wd.state() == BoardState::Armed;
        if self.peer == Some(from) && (armed || !self.session_armed) {
            // The controller repeats HELLO until it hears the board's: the same session.
            return self.send_frame(Frame::Hello(reply), Some(from), tx);
        }
        if let Some(peer) = self.peer.filter(|&p| p != from) {
            let silent_ns = now_ns().saturating_sub(self.peer_heard_ns);
            if armed && silent_ns < self.dead_link_ns() {
                let c = self.counts_of(from);
                c.refused += 1;
                let n = c.refused;
                if n.is_power_of_two() {
                    let id = self.sessions.len();
                    self.event(format!(
                        "HELLO from {from} refused: session {id} with {peer} is armed (heard {:.1} ms ago); {n} refused from it so far",
                        silent_ns as f64 / 1e6
                    ));
                }
                return self.refuse(from, session_refused::BUSY, tx);
            }
        }
        self.open_session(from, tx)?;
        self.event(format!(
            "session {}: HELLO from a controller at {from} (protocol {VERSION}, {period_us} µs, lock-step {})",
            self.sessions.len(),
            h.lockstep
        ));
        self.send_frame(Frame::Hello(reply), Some(from), tx)
    }
}
