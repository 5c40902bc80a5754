//! Per-stream sequence numbers compared with wrap-around (serial number arithmetic in
//! the style of RFC 1982), so 65535 → 0 is an ordinary step and not a jump back.

/// Signed distance from `from` to `to` on the 16-bit circle: positive when `to` is
/// newer. Distances of 32768 and more in either direction are ambiguous; they come out
/// negative (−32768), i.e. such a frame is treated as stale rather than as a huge gap.
pub fn seq_distance(from: u16, to: u16) -> i16 {
    to.wrapping_sub(from) as i16
}

/// What a received sequence number means relative to the last accepted one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SeqVerdict {
    /// Nothing accepted yet (or after [`SeqTracker::reset`]): accept and start here.
    First,
    /// Exactly the successor: accept.
    Next,
    /// Newer, with `missing` frames lost in between: accept, and count the loss.
    Gap {
        /// Number of sequence numbers skipped.
        missing: u16,
    },
    /// Same as the last accepted: drop (a retransmission or a duplicated datagram).
    Duplicate,
    /// Older than the last accepted (reordered or delayed): drop, it is out of date.
    Stale {
        /// How far behind the last accepted seq it is.
        behind: u16,
    },
}

/// Receiver-side state of one stream: the last accepted sequence number.
#[derive(Clone, Copy, Debug, Default)]
pub struct SeqTracker {
    last: Option<u16>,
}

impl SeqTracker {
    /// A tracker that has accepted nothing; `const` so firmware can put it in a static.
    pub const fn new() -> Self {
        SeqTracker { last: None }
    }

    /// Classifies `seq`. First, Next and Gap advance the tracker to `seq`; Duplicate and
    /// Stale leave it unchanged, so one late frame cannot pull the stream backwards.
    pub fn accept(&mut self, seq: u16) -> SeqVerdict {
        let Some(last) = self.last else {
            self.last = Some(seq);
            return SeqVerdict::First;
        };
        let d = seq_distance(last, seq);
        if d == 0 {
            SeqVerdict::Duplicate
        } else if d < 0 {
            SeqVerdict::Stale { behind: last.wrapping_sub(seq) }
        } else {
            self.last = Some(seq);
            if d == 1 {
                SeqVerdict::Next
            } else {
                SeqVerdict::Gap { missing: (d - 1) as u16 }
            }
        }
    }

    /// Last accepted sequence number, `None` before the first.
    pub fn last(&self) -> Option<u16> {
        self.last
    }

    /// Forgets the stream, e.g. at a new session (HELLO) where the peer restarts at any seq.
    pub fn reset(&mut self) {
        self.last = None;
    }
}
