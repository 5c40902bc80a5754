//! Board-side watchdog and safe state. The board must stop driving the actuator when
//! the controller goes quiet, and must not resume on its own when frames come back:
//! a human (or the controller, deliberately) re-arms it.

use crate::{status, Fault, FaultReason, SAFE_CODES};

/// What the board is doing with the DAC codes it receives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoardState {
    /// Not started (or stopped on purpose): outputs [`SAFE_CODES`].
    Disarmed,
    /// Applies the received codes.
    Armed,
    /// A fault latched the safe state: outputs [`SAFE_CODES`] until the next arm.
    Safe(Fault),
}

/// Counts missed periods and latches the safe state at the limit.
/// Pure state machine with no clock: the firmware calls [`Watchdog::period_elapsed`]
/// from its periodic interrupt, which keeps it testable and deterministic.
///
/// What a missed period is depends on who owns time (docs/hil-protocol.md, "Lock-step:
/// what a missed period is"). Real time ([`Watchdog::new`]): a wall-clock period without
/// a valid DAC frame. Lock-step ([`Watchdog::lockstep`]): the controller's frames are the clock and
/// it may take as long as it likes over a step, so wall-clock silence is not a missed
/// period; a missed period is a DAC transmission that never arrived, which the sequence
/// gap of the next one shows ([`Watchdog::frames_lost`]). Wall-clock silence then only
/// counts towards a much longer dead-link bound.
#[derive(Clone, Copy, Debug)]
pub struct Watchdog {
    state: BoardState,
    limit: u32,
    missed: u32,
    got_frame: bool,
    /// Lock-step only (0 in real time): wall-clock periods without a valid frame at
    /// which the link counts as dead.
    dead_link: u32,
    /// Lock-step: consecutive wall-clock periods without a valid frame.
    silent: u32,
}

impl Watchdog {
    /// A disarmed watchdog that trips after `limit_periods` silent periods. A limit of 0
    /// would trip before any frame could arrive, so it is clamped to 1.
    pub const fn new(limit_periods: u32) -> Self {
        Watchdog {
            state: BoardState::Disarmed,
            limit: if limit_periods == 0 { 1 } else { limit_periods },
            missed: 0,
            got_frame: false,
            dead_link: 0,
            silent: 0,
        }
    }

    /// A disarmed lock-step watchdog: trips when `limit_periods` DAC transmissions in a
    /// row are lost ([`Watchdog::frames_lost`]), or with LinkDead after
    /// `dead_link_periods` wall-clock periods without any valid frame
    /// ([`Watchdog::period_elapsed`]). Both limits are clamped to at least 1.
    pub const fn lockstep(limit_periods: u32, dead_link_periods: u32) -> Self {
        let mut w = Watchdog::new(limit_periods);
        w.dead_link = if dead_link_periods == 0 { 1 } else { dead_link_periods };
        w
    }

    /// Whether this watchdog counts in the lock-step sense.
    pub fn is_lockstep(&self) -> bool {
        self.dead_link != 0
    }

    /// Current state.
    pub fn state(&self) -> BoardState {
        self.state
    }

    /// Enters Armed from any state, clearing the missed count; the only way out of Safe.
    pub fn arm(&mut self) {
        self.state = BoardState::Armed;
        self.missed = 0;
        self.silent = 0;
        self.got_frame = false;
    }

    /// Enters Disarmed (safe codes, no watchdog counting), also from Safe.
    pub fn disarm(&mut self) {
        self.state = BoardState::Disarmed;
        self.missed = 0;
        self.silent = 0;
        self.got_frame = false;
    }

    /// Records that a valid DAC frame arrived in the current period. Only counts while
    /// Armed: frames arriving in Safe do not unlatch it.
    pub fn frame_received(&mut self) {
        if self.state == BoardState::Armed {
            self.got_frame = true;
            self.missed = 0;
            self.silent = 0;
        }
    }

    /// Lock-step: the valid DAC frame about to be passed to [`Watchdog::frame_received`]
    /// came after `missing` lost transmissions (its [`SeqVerdict::Gap`](crate::SeqVerdict)).
    /// The controller repeats an unanswered frame once per period, so each lost
    /// transmission is a period in which it waited for the board in vain: `missing` at or
    /// above the limit latches `Safe(Fault { Silence, detail: missing })`, returned once.
    /// In real time the wall clock already counted those periods, so this does nothing.
    pub fn frames_lost(&mut self, missing: u32) -> Option<Fault> {
        if !self.is_lockstep() || self.state != BoardState::Armed {
            return None;
        }
        self.missed = missing;
        if missing >= self.limit {
            return Some(self.trip(FaultReason::Silence, missing));
        }
        None
    }

    /// Ends a wall-clock period. While Armed, a period without a frame is counted:
    /// in real time as a missed period, latching `Safe(Fault { Silence, detail: missed })`
    /// at the limit; in lock-step towards the dead-link bound, latching
    /// `Safe(Fault { LinkDead, detail: silent periods })` there. The fault is returned
    /// once, on that transition (so the caller sends exactly one FAULT).
    pub fn period_elapsed(&mut self) -> Option<Fault> {
        if self.state != BoardState::Armed {
            self.got_frame = false;
            return None;
        }
        if core::mem::take(&mut self.got_frame) {
            self.missed = 0;
            self.silent = 0;
            return None;
        }
        if self.is_lockstep() {
            self.silent = self.silent.saturating_add(1);
            if self.silent >= self.dead_link {
                return Some(self.trip(FaultReason::LinkDead, self.silent));
            }
            return None;
        }
        self.missed = self.missed.saturating_add(1);
        if self.missed >= self.limit {
            return Some(self.trip(FaultReason::Silence, self.missed));
        }
        None
    }

    fn trip(&mut self, reason: FaultReason, detail: u32) -> Fault {
        let fault = Fault { reason, detail };
        self.state = BoardState::Safe(fault);
        fault
    }

    /// Latches Safe with `fault` (overrun, operator, corrupt link, ...). If Safe is
    /// already latched the first fault is kept: it is the cause, later ones are effects.
    pub fn fault(&mut self, fault: Fault) {
        if !matches!(self.state, BoardState::Safe(_)) {
            self.state = BoardState::Safe(fault);
        }
        self.got_frame = false;
    }

    /// The codes to put on the DACs: `requested` only while Armed, else [`SAFE_CODES`].
    pub fn output(&self, requested: [u16; 3]) -> [u16; 3] {
        match self.state {
            BoardState::Armed => requested,
            _ => SAFE_CODES,
        }
    }

    /// [`status::ARMED`] / [`status::SAFE`] bits for the ENCODER frame.
    pub fn status_bits(&self) -> u16 {
        match self.state {
            BoardState::Disarmed => 0,
            BoardState::Armed => status::ARMED,
            BoardState::Safe(_) => status::SAFE,
        }
    }

    /// Consecutive missed periods so far (while Armed), or at the trip.
    pub fn missed(&self) -> u32 {
        self.missed
    }

    /// Lock-step: consecutive wall-clock periods without a valid frame (0 in real time).
    pub fn silent(&self) -> u32 {
        self.silent
    }

    /// Configured limit (after clamping).
    pub fn limit(&self) -> u32 {
        self.limit
    }

    /// Lock-step dead-link bound in wall-clock periods (after clamping); 0 in real time.
    pub fn dead_link_limit(&self) -> u32 {
        self.dead_link
    }
}

impl Default for Watchdog {
    fn default() -> Self {
        Watchdog::new(crate::DEFAULT_WATCHDOG_PERIODS)
    }
}
