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

/// Senders whose HELLO was answered and whose ARM is awaited, at most. A controller ARMs
/// one round trip after its HELLO is answered, so a flood would need this many HELLOs in
/// that round trip to push its entry out (and then it HELLOs again).
pub const MAX_HANDSHAKES: usize = 256;

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

    /// Adds one to the count `field` picks for `from`; the new count and whom it counts
    /// ("it", or the senders beyond the first [`MAX_SOURCES`] together), for the log line.
    pub(super) fn count(
        &mut self,
        from: Source,
        field: impl FnOnce(&mut SourceCounts) -> &mut u64,
    ) -> (u64, String) {
        let shared = self.sources.len() >= MAX_SOURCES && !self.sources.contains_key(&from);
        let c = field(self.counts_of(from));
        *c += 1;
        let who = if shared {
            format!("the senders beyond the first {MAX_SOURCES}")
        } else {
            "it".to_string()
        };
        (*c, who)
    }

    pub(super) fn dead_link_ns(&self) -> u64 {
        u64::from(self.cfg.dead_link_periods.max(1)) * self.cfg.period.as_nanos() as u64
    }

    /// Bytes that are not a frame, from `from`: counted, and reported at 1, 2, 4, … per
    /// sender so a flood cannot flood the log.
    pub fn refuse_malformed(&mut self, from: Source, why: &str) {
        self.counters.link.malformed += 1;
        let (n, who) = self.count(from, |c| &mut c.malformed);
        if n.is_power_of_two() {
            self.refusal(format!(
                "malformed datagram from {from} refused ({why}); {n} from {who} so far"
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
            // The session's own controller is not counted as foreign traffic; anyone else
            // is logged at its 1st, 2nd, 4th, … refusal.
            let (n, who) = if self.peer == Some(from) {
                (1, "it".to_string())
            } else {
                self.count(from, |c| &mut c.refused)
            };
            if n.is_power_of_two() {
                self.refusal(format!(
                    "HELLO from {from} refused: {why}; {n} refused from {who} so far"
                ));
            }
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
        if self.peer == Some(from) && armed {
            // The armed controller repeating HELLO (it lost the board's): the same session.
            return self.send_frame(Frame::Hello(reply), Some(from), tx);
        }
        if let Some(busy) = self.held_from(from) {
            return self.refuse_busy(from, "HELLO", busy, tx);
        }
        // Answered, and remembered for its ARM; nothing is bound yet, so a HELLO can never
        // take the board from a controller whose own handshake is under way.
        self.remember_handshake(from);
        self.send_frame(Frame::Hello(reply), Some(from), tx)
    }

    /// The armed session of another controller that keeps `from` out, if there is one:
    /// its peer and how long ago it was heard (ns). The watchdog alone decides when an
    /// armed session is gone (it latches after its silent periods in real time, and after
    /// the dead-link time in lock-step), so a takeover never races the latch.
    fn held_from(&self, from: Source) -> Option<(Source, u64)> {
        let peer = self.peer.filter(|&p| p != from)?;
        let silent_ns = now_ns().saturating_sub(self.peer_heard_ns);
        (self.wd.state() == BoardState::Armed).then_some((peer, silent_ns))
    }

    /// BUSY to `from`, counted per sender and logged at its 1st, 2nd, 4th, … refusal.
    fn refuse_busy(
        &mut self,
        from: Source,
        what: &str,
        (peer, silent_ns): (Source, u64),
        tx: &mut dyn Transport,
    ) -> io::Result<()> {
        let (n, who) = self.count(from, |c| &mut c.refused);
        if n.is_power_of_two() {
            let id = self.sessions_opened;
            self.refusal(format!(
                "{what} from {from} refused: session {id} with {peer} is armed (heard {:.1} ms ago); {n} refused from {who} so far",
                silent_ns as f64 / 1e6
            ));
        }
        self.refuse(from, session_refused::BUSY, tx)
    }

    /// Notes that `from`'s HELLO was answered. The table holds [`MAX_HANDSHAKES`] senders;
    /// a newer HELLO displaces the oldest entry, never a session.
    fn remember_handshake(&mut self, from: Source) {
        let now = now_ns();
        let window = self.dead_link_ns();
        self.handshakes.retain(|&(s, at)| s != from && now.saturating_sub(at) < window);
        if self.handshakes.len() >= MAX_HANDSHAKES {
            self.handshakes.remove(0);
        }
        self.handshakes.push((from, now));
    }

    /// Whether `from` had its HELLO answered within the handshake window (the dead-link
    /// time): its ARM completes the handshake.
    pub(super) fn in_handshake(&self, from: Source) -> bool {
        let now = now_ns();
        self.handshakes
            .iter()
            .any(|&(s, at)| s == from && now.saturating_sub(at) < self.dead_link_ns())
    }

    /// The ARM that completes `from`'s handshake: the session is bound to it here, unless
    /// another controller completed its own first and is armed and alive.
    pub(super) fn complete_handshake(
        &mut self,
        from: Source,
        tx: &mut dyn Transport,
    ) -> io::Result<()> {
        self.handshakes.retain(|&(s, _)| s != from);
        if let Some(busy) = self.held_from(from) {
            return self.refuse_busy(from, "ARM", busy, tx);
        }
        self.open_session(from, tx)?;
        self.event(format!(
            "session {}: a controller at {from} completed its handshake (protocol {VERSION}, {} µs, lock-step {})",
            self.sessions_opened,
            self.cfg.period.as_micros(),
            self.cfg.lockstep
        ));
        self.arm(tx)
    }
}
