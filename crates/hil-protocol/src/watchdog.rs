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

/// Counts periods without a valid DAC frame and latches the safe state at the limit.
/// Pure state machine with no clock: the firmware calls [`Watchdog::period_elapsed`]
/// from its periodic interrupt, which keeps it testable and deterministic.
#[derive(Clone, Copy, Debug)]
pub struct Watchdog {
    state: BoardState,
    limit: u32,
    missed: u32,
    got_frame: bool,
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
        }
    }

    /// Current state.
    pub fn state(&self) -> BoardState {
        self.state
    }

    /// Enters Armed from any state, clearing the missed count; the only way out of Safe.
    pub fn arm(&mut self) {
        self.state = BoardState::Armed;
        self.missed = 0;
        self.got_frame = false;
    }

    /// Enters Disarmed (safe codes, no watchdog counting), also from Safe.
    pub fn disarm(&mut self) {
        self.state = BoardState::Disarmed;
        self.missed = 0;
        self.got_frame = false;
    }

    /// Records that a valid DAC frame arrived in the current period. Only counts while
    /// Armed: frames arriving in Safe do not unlatch it.
    pub fn frame_received(&mut self) {
        if self.state == BoardState::Armed {
            self.got_frame = true;
            self.missed = 0;
        }
    }

    /// Ends a period. While Armed, a period without a frame increments the missed count;
    /// reaching the limit latches `Safe(Fault { Silence, detail: missed })`, which is
    /// returned once, on that transition (so the caller sends exactly one FAULT).
    pub fn period_elapsed(&mut self) -> Option<Fault> {
        if self.state != BoardState::Armed {
            self.got_frame = false;
            return None;
        }
        if core::mem::take(&mut self.got_frame) {
            self.missed = 0;
            return None;
        }
        self.missed = self.missed.saturating_add(1);
        if self.missed >= self.limit {
            let fault = Fault { reason: FaultReason::Silence, detail: self.missed };
            self.state = BoardState::Safe(fault);
            return Some(fault);
        }
        None
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

    /// Consecutive silent periods so far (while Armed), or at the trip.
    pub fn missed(&self) -> u32 {
        self.missed
    }

    /// Configured limit (after clamping).
    pub fn limit(&self) -> u32 {
        self.limit
    }
}

impl Default for Watchdog {
    fn default() -> Self {
        Watchdog::new(crate::DEFAULT_WATCHDOG_PERIODS)
    }
}
