//! Seeded fault injection on the sending side of a transport: the link faults a real
//! network or serial line produces (loss, duplication, reordering, delay, bit errors,
//! silence), reproducible from a seed so a failing run can be rerun exactly.

use std::collections::VecDeque;
use std::io;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use crate::transport::{Source, Transport};

/// Per-frame probabilities and windows, counted in frames sent through the wrapper.
#[derive(Clone, Debug, Default)]
pub struct FaultPlan {
    pub seed: u64,
    pub drop: f64,
    pub duplicate: f64,
    /// The frame is held back and sent after the next one.
    pub reorder: f64,
    /// The frame is held back for `delay_frames` further sends.
    pub delay: f64,
    pub delay_frames: u64,
    /// One random bit of the frame is flipped.
    pub corrupt: f64,
    /// Frames `[start, start + len)` (0-based send index) are not sent at all.
    pub silence: Option<(u64, u64)>,
    /// Only frames whose first byte pattern matches (`frame[3]`, the frame type) are
    /// subject to faults; `None`: every frame.
    pub only_type: Option<u8>,
}

/// What the wrapper did, for tests to compare with what the receiver reports.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct FaultCounts {
    pub offered: u64,
    pub dropped: u64,
    pub duplicated: u64,
    pub reordered: u64,
    pub delayed: u64,
    pub corrupted: u64,
    pub silenced: u64,
}

pub struct FaultyTransport<T> {
    inner: T,
    plan: FaultPlan,
    rng: u64,
    sent: u64,
    held: Option<Vec<u8>>,
    delayed: VecDeque<(u64, Vec<u8>)>,
    counts: Arc<Mutex<FaultCounts>>,
}

impl<T: Transport> FaultyTransport<T> {
    pub fn new(inner: T, plan: FaultPlan) -> FaultyTransport<T> {
        // xorshift must not start at 0.
        let rng = plan.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        FaultyTransport {
            inner,
            plan,
            rng,
            sent: 0,
            held: None,
            delayed: VecDeque::new(),
            counts: Arc::default(),
        }
    }

    /// The transport without the faults (frames still held back are lost, as on a link).
    pub fn into_inner(self) -> T {
        self.inner
    }

    pub fn counts(&self) -> Arc<Mutex<FaultCounts>> {
        Arc::clone(&self.counts)
    }

    fn uniform(&mut self) -> f64 {
        self.rng ^= self.rng << 13;
        self.rng ^= self.rng >> 7;
        self.rng ^= self.rng << 17;
        (self.rng >> 11) as f64 / (1u64 << 53) as f64
    }

    fn roll(&mut self, p: f64) -> bool {
        // Always draw, so one fault's probability does not shift the others' sequence.
        let u = self.uniform();
        u < p
    }
}

impl<T: Transport> Transport for FaultyTransport<T> {
    fn send(&mut self, frame: &[u8]) -> io::Result<()> {
        let index = self.sent;
        self.sent += 1;
        while self.delayed.front().is_some_and(|(due, _)| *due <= index) {
            let (_, f) = self.delayed.pop_front().unwrap();
            self.inner.send(&f)?;
        }
        let subject = self.plan.only_type.is_none_or(|t| frame.get(3) == Some(&t));
        if !subject {
            return self.inner.send(frame);
        }
        let mut counts = self.counts.lock().unwrap().clone();
        counts.offered += 1;
        let (drop, dup, reorder, delay, corrupt) = (
            self.roll(self.plan.drop),
            self.roll(self.plan.duplicate),
            self.roll(self.plan.reorder),
            self.roll(self.plan.delay),
            self.roll(self.plan.corrupt),
        );
        let bit = self.uniform();
        let result = if self
            .plan
            .silence
            .is_some_and(|(start, len)| (start..start + len).contains(&(counts.offered - 1)))
        {
            counts.silenced += 1;
            Ok(())
        } else if drop {
            counts.dropped += 1;
            Ok(())
        } else {
            let mut f = frame.to_vec();
            if corrupt {
                let b = ((bit * (f.len() * 8) as f64) as usize).min(f.len() * 8 - 1);
                f[b / 8] ^= 1 << (b % 8);
                counts.corrupted += 1;
            }
            if delay && self.plan.delay_frames > 0 {
                counts.delayed += 1;
                self.delayed.push_back((index + self.plan.delay_frames, f));
                Ok(())
            } else if reorder && self.held.is_none() {
                counts.reordered += 1;
                self.held = Some(f);
                Ok(())
            } else {
                let r = self.inner.send(&f);
                if dup {
                    counts.duplicated += 1;
                    self.inner.send(&f)?;
                }
                if let Some(h) = self.held.take() {
                    self.inner.send(&h)?;
                }
                r
            }
        };
        *self.counts.lock().unwrap() = counts;
        result
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<Option<usize>> {
        self.inner.recv(buf, timeout)
    }

    fn source(&self) -> Source {
        self.inner.source()
    }

    fn set_peer(&mut self, peer: Source) {
        self.inner.set_peer(peer)
    }

    // Refusals to strangers bypass the plan: the faults model the session's link.
    fn send_to(&mut self, frame: &[u8], to: Source) -> io::Result<()> {
        self.inner.send_to(frame, to)
    }
}
