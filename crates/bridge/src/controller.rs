//! The controller side: handshake, arming, then one DAC frame per tick.
//!
//! A tick uses the encoder count that holds at its start and sends the codes for the
//! interval that starts there, as a Jacobi co-simulation master couples the two FMUs. In
//! lock-step the count at the end of the interval comes back in the answer to the DAC
//! frame, so the loop is the co-simulation exactly; in real time it is the newest count
//! the board has sent.
//!
//! The run ends in a fault, reported with its reason, when the encoder stream skips more
//! than `max_gap` frames, when nothing valid arrives for `dead_after` periods (real time)
//! or after `max_retransmits` unanswered repeats (lock-step), when the board reports its
//! safe state, and on an overrun under the hard policy. The board is told (FAULT) so it
//! latches its safe state at once instead of waiting for its watchdog.

use std::io;
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use inchworm_hil_protocol::{
    decode, encode, session_refused, status, DacSample, EncoderSample, Fault, FaultReason, Frame,
    Hello, Packet, Role, SeqTracker, SeqVerdict, MAX_FRAME, VERSION,
};

use crate::realtime::{now_ns, Pacer};
use crate::runlog::{ControllerSample, LogWriter, Record};
use crate::transport::Transport;
use crate::{describe_fault, Compensator, Error, LinkCounters, OverrunPolicy};

#[derive(Clone, Copy, Debug)]
pub struct ControllerConfig {
    pub period: Duration,
    pub lockstep: bool,
    /// Ticks to run.
    pub ticks: u64,
    /// The largest sequence gap on the encoder stream that is still tolerated.
    pub max_gap: u16,
    /// Real time: periods without a valid encoder frame before the link counts as dead.
    pub dead_after: u32,
    /// Lock-step: wait this long for an answer before repeating the DAC frame.
    pub retransmit_after: Duration,
    /// Lock-step: unanswered repeats before the link counts as dead.
    pub max_retransmits: u32,
    pub overrun: OverrunPolicy,
    /// How long to wait for the board's HELLO and ARM answers.
    pub handshake_timeout: Duration,
}

impl Default for ControllerConfig {
    fn default() -> Self {
        ControllerConfig {
            period: crate::PERIOD,
            lockstep: false,
            ticks: 0,
            max_gap: 3,
            dead_after: 10,
            retransmit_after: Duration::from_millis(2),
            max_retransmits: 25,
            overrun: OverrunPolicy::Soft,
            handshake_timeout: Duration::from_secs(5),
        }
    }
}

#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ControllerCounters {
    /// The encoder and control frames received.
    pub link: LinkCounters,
    pub retransmits: u64,
    pub overruns: u64,
}

#[derive(Clone, Debug, Default)]
pub struct ControllerReport {
    /// Ticks completed.
    pub ticks: u64,
    /// The board's tick when the run started.
    pub first_tick: u32,
    /// The encoder count at the end of each completed tick's interval (lock-step: exactly
    /// the co-simulation's trace; real time: the newest count at the next tick).
    pub encoder: Vec<i32>,
    /// Why the run ended early, if it did.
    pub fault: Option<(Fault, String)>,
    pub counters: ControllerCounters,
    /// Wake-up lateness per real-time period (µs).
    pub lateness_us: Vec<f64>,
    /// DAC frame sent → encoder frame echoing it received (µs).
    pub round_trip_us: Vec<f64>,
    pub events: Vec<(u64, String)>,
    /// Ticks at which an output clock of the compensator ticked
    /// ([`Compensator::ticked_clock`]), each also an event of the run log.
    pub clock_ticks: u64,
}

struct Link<'a> {
    tx: &'a mut dyn Transport,
    dac_seq: u16,
    ctl_seq: u16,
    enc: SeqTracker,
    buf: [u8; 256],
    sent_at: Vec<u64>,
    counters: ControllerCounters,
}

enum Incoming {
    Encoder(EncoderSample),
    Fault(Fault),
    Hello(Hello),
    Nothing,
}

impl Link<'_> {
    fn send(&mut self, frame: Frame) -> io::Result<u16> {
        let seq = if matches!(frame, Frame::Dac(_)) {
            self.dac_seq = self.dac_seq.wrapping_add(1);
            self.sent_at[usize::from(self.dac_seq)] = now_ns();
            self.dac_seq
        } else {
            self.ctl_seq = self.ctl_seq.wrapping_add(1);
            self.ctl_seq
        };
        let mut out = [0u8; MAX_FRAME];
        let n = encode(&Packet { seq, frame }, &mut out)
            .map_err(|e| io::Error::other(e.to_string()))?;
        self.tx.send(&out[..n])?;
        Ok(seq)
    }

    /// One frame or nothing within `timeout`; sequence bookkeeping on the encoder stream.
    /// A gap larger than `max_gap` comes back as a fault.
    fn recv(&mut self, timeout: Duration, max_gap: u16) -> io::Result<Incoming> {
        let n = match self.tx.recv(&mut self.buf, timeout) {
            Ok(Some(n)) => n,
            Ok(None) => return Ok(Incoming::Nothing),
            Err(e) if e.kind() == io::ErrorKind::InvalidData => {
                self.counters.link.malformed += 1;
                return self.recv(Duration::ZERO, max_gap);
            }
            Err(e) => return Err(e),
        };
        let packet = match decode(&self.buf[..n]) {
            Ok(p) => p,
            Err(_) => {
                self.counters.link.malformed += 1;
                return self.recv(Duration::ZERO, max_gap);
            }
        };
        self.counters.link.frames += 1;
        Ok(match packet.frame {
            Frame::Encoder(e) => {
                let verdict = self.enc.accept(packet.seq);
                if !self.counters.link.sequence(verdict) {
                    return self.recv(Duration::ZERO, max_gap);
                }
                match verdict {
                    SeqVerdict::Gap { missing } if missing > max_gap => Incoming::Fault(Fault {
                        reason: FaultReason::SequenceGap,
                        detail: u32::from(missing),
                    }),
                    _ => Incoming::Encoder(e),
                }
            }
            Frame::Fault(f) => Incoming::Fault(f),
            Frame::Hello(h) => Incoming::Hello(h),
            _ => {
                self.counters.link.malformed += 1;
                Incoming::Nothing
            }
        })
    }
}

fn log_record(log: &mut Option<&mut LogWriter>, r: Record) -> Result<(), Error> {
    match log {
        Some(l) => l.write(&r).map_err(Error::RunLog),
        None => Ok(()),
    }
}

/// HELLO until the board answers in kind, or `deadline` (ns, [`now_ns`]).
fn handshake(
    link: &mut Link,
    cfg: &ControllerConfig,
    stop: &AtomicBool,
    deadline: u64,
) -> Result<(), Error> {
    let hello = Hello {
        version: VERSION,
        role: Role::Controller,
        period_us: cfg.period.as_micros() as u32,
        watchdog_periods: inchworm_hil_protocol::DEFAULT_WATCHDOG_PERIODS as u8,
        lockstep: cfg.lockstep,
    };
    // A board busy with another controller frees itself when that one disarms, latches
    // safe or goes silent (a restarted controller racing its own old session), so BUSY is
    // retried until the deadline and reported only then.
    let mut busy = None;
    loop {
        link.send(Frame::Hello(hello)).map_err(Error::Link)?;
        let retry = now_ns() + 100_000_000;
        while now_ns() < retry {
            match link.recv(Duration::from_millis(20), cfg.max_gap).map_err(Error::Link)? {
                Incoming::Hello(h) if h.role == Role::Board && h.version == VERSION => {
                    return Ok(());
                }
                Incoming::Fault(f)
                    if f.reason == FaultReason::SessionRefused
                        && f.detail == session_refused::BUSY =>
                {
                    busy = Some(f);
                }
                Incoming::Fault(f)
                    if f.reason == FaultReason::ProtocolMismatch
                        || (f.reason == FaultReason::SessionRefused
                            && f.detail != session_refused::NO_SESSION) =>
                {
                    return Err(Error::Refused(f));
                }
                _ => {}
            }
        }
        if now_ns() > deadline || stop.load(Ordering::Relaxed) {
            if let Some(f) = busy {
                return Err(Error::Busy { fault: f, seconds: cfg.handshake_timeout.as_secs_f64() });
            }
            return Err(Error::NoAnswer { seconds: cfg.handshake_timeout.as_secs_f64() });
        }
    }
}

/// One ARM, and up to 100 ms for the encoder frame that says armed: it carries the tick
/// and count to start from. `Ok(Err(_))`: not armed, so the handshake starts over (HELLO
/// again, then ARM): the board refused this ARM (the fault: another controller completed
/// its handshake first, or this one's HELLO is no longer remembered), or said nothing.
fn arm(link: &mut Link) -> Result<Result<EncoderSample, Option<Fault>>, Error> {
    link.enc.reset();
    link.send(Frame::Arm).map_err(Error::Link)?;
    let retry = now_ns() + 100_000_000;
    while now_ns() < retry {
        match link.recv(Duration::from_millis(20), u16::MAX).map_err(Error::Link)? {
            Incoming::Encoder(e) if e.status & status::ARMED != 0 => return Ok(Ok(e)),
            Incoming::Fault(f) if f.reason == FaultReason::SessionRefused => {
                return Ok(Err(Some(f)));
            }
            _ => {}
        }
    }
    Ok(Err(None))
}

/// What paces the ticks.
enum Pacing {
    /// Each tick waits for the board's answer to its DAC frame.
    LockStep,
    /// Each tick waits for its absolute deadline; `last_heard` is the last tick that had a
    /// valid encoder frame, for the dead-link limit.
    RealTime { pacer: Pacer, last_heard: u64 },
}

/// The armed session: the link, the newest count and status, and the report so far.
struct Session<'a, 'c> {
    link: Link<'a>,
    cfg: &'c ControllerConfig,
    pacing: Pacing,
    start_tick: u32,
    counts: i32,
    board_status: u16,
    report: ControllerReport,
}

impl Session<'_, '_> {
    /// One tick in either pacing: wait for it, send the codes, step the controller, log.
    /// `Break` ends the run with a link or board fault.
    fn tick<C: Compensator>(
        &mut self,
        k: u64,
        comp: &mut C,
        reference: &dyn Fn(f64) -> f64,
        log: &mut Option<&mut LogWriter>,
    ) -> Result<ControlFlow<Fault>, Error> {
        if let ControlFlow::Break(f) = self.wait_for_tick(k)? {
            return Ok(ControlFlow::Break(f));
        }
        let tick = self.start_tick.wrapping_add(k as u32);
        let t = k as f64 * self.cfg.period.as_secs_f64();
        let r = reference(t);
        let sent = crate::tick(comp, self.counts, r, |codes| {
            let first_seq =
                self.link.send(Frame::Dac(DacSample { tick, codes })).map_err(Error::Link)?;
            Ok::<_, Error>(match self.pacing {
                Pacing::LockStep => match self.await_answer(tick, codes, first_seq)? {
                    ControlFlow::Continue((answer, seq)) => {
                        ControlFlow::Continue((Some(answer), seq))
                    }
                    ControlFlow::Break(f) => ControlFlow::Break(f),
                },
                Pacing::RealTime { .. } => ControlFlow::Continue((None, first_seq)),
            })
        })?;
        let ((answer, seq), codes) = match sent {
            ControlFlow::Continue(sent) => sent,
            ControlFlow::Break(f) => return Ok(ControlFlow::Break(f)),
        };
        if let Some(clock) = comp.ticked_clock()? {
            self.report.clock_ticks += 1;
            let text = format!("output clock {clock} ticked");
            log_record(log, Record::Event { tick, text })?;
        }
        log_record(
            log,
            Record::Controller(ControllerSample {
                tick,
                time: t,
                reference: r,
                counts: self.counts,
                codes,
                status: self.board_status,
                seq,
            }),
        )?;
        // Lock-step: the answer is the count at the end of this tick's interval, which the
        // next tick uses; in real time the newest count was taken before the codes.
        if let Some(answer) = answer {
            self.counts = answer.counts;
            self.board_status = answer.status;
        }
        self.report.encoder.push(self.counts);
        self.report.ticks += 1;
        Ok(ControlFlow::Continue(()))
    }

    /// Real time: sleeps to tick `k`'s deadline (the overrun policy applies), takes the
    /// encoder frames that arrived, keeping the newest, and checks for a dead link.
    /// Lock-step: nothing to wait for, the previous answer started this tick.
    fn wait_for_tick(&mut self, k: u64) -> Result<ControlFlow<Fault>, Error> {
        let Pacing::RealTime { pacer, last_heard } = &mut self.pacing else {
            return Ok(ControlFlow::Continue(()));
        };
        let wake = pacer.wait();
        self.report.lateness_us.push(wake.lateness_ns as f64 / 1e3);
        if wake.overrun {
            self.link.counters.overruns += 1;
            let late_us =
                (wake.lateness_ns + wake.skipped * self.cfg.period.as_nanos() as u64) / 1000;
            self.report
                .events
                .push((k, format!("deadline missed ({} periods skipped)", wake.skipped)));
            if self.cfg.overrun == OverrunPolicy::Hard {
                return Ok(ControlFlow::Break(Fault {
                    reason: FaultReason::Overrun,
                    detail: late_us as u32,
                }));
            }
        }
        loop {
            match self.link.recv(Duration::ZERO, self.cfg.max_gap).map_err(Error::Link)? {
                Incoming::Encoder(e) => {
                    if e.status & status::SAFE != 0 {
                        return Ok(ControlFlow::Break(Fault {
                            reason: FaultReason::Silence,
                            detail: 0,
                        }));
                    }
                    if e.echo_seq != 0 {
                        let sent = self.link.sent_at[usize::from(e.echo_seq)];
                        if sent != 0 {
                            self.report.round_trip_us.push((now_ns() - sent) as f64 / 1e3);
                            self.link.sent_at[usize::from(e.echo_seq)] = 0;
                        }
                    }
                    self.counts = e.counts;
                    self.board_status = e.status;
                    *last_heard = k;
                }
                Incoming::Fault(f) => return Ok(ControlFlow::Break(f)),
                Incoming::Hello(_) => {}
                Incoming::Nothing => break,
            }
        }
        if k - *last_heard > u64::from(self.cfg.dead_after) {
            return Ok(ControlFlow::Break(Fault {
                reason: FaultReason::LinkDead,
                detail: (k - *last_heard) as u32,
            }));
        }
        Ok(ControlFlow::Continue(()))
    }

    /// Lock-step: waits for the board's answer to tick `tick`, whose DAC frame went out as
    /// `first_seq`, repeating the frame after each `retransmit_after` without one. Gives
    /// the answer and the seq of the last transmission.
    fn await_answer(
        &mut self,
        tick: u32,
        codes: [u16; 3],
        first_seq: u16,
    ) -> Result<ControlFlow<Fault, (EncoderSample, u16)>, Error> {
        let mut seq = first_seq;
        let mut tries = 0;
        let mut wait_until = now_ns() + self.cfg.retransmit_after.as_nanos() as u64;
        loop {
            let now = now_ns();
            let timeout = Duration::from_nanos(wait_until.saturating_sub(now));
            match self.link.recv(timeout, self.cfg.max_gap).map_err(Error::Link)? {
                Incoming::Encoder(e) if e.status & status::SAFE != 0 => {
                    return Ok(ControlFlow::Break(Fault {
                        reason: FaultReason::Silence,
                        detail: 0,
                    }));
                }
                Incoming::Encoder(e) if e.tick == tick.wrapping_add(1) => {
                    let sent = self.link.sent_at[usize::from(e.echo_seq)];
                    if e.echo_seq == seq || e.echo_seq == first_seq {
                        self.report.round_trip_us.push((now_ns() - sent) as f64 / 1e3);
                    }
                    return Ok(ControlFlow::Continue((e, seq)));
                }
                Incoming::Encoder(_) => self.link.counters.link.stale += 1,
                Incoming::Fault(f) => return Ok(ControlFlow::Break(f)),
                Incoming::Hello(_) => {}
                Incoming::Nothing => {
                    if now_ns() >= wait_until {
                        tries += 1;
                        if tries > self.cfg.max_retransmits {
                            return Ok(ControlFlow::Break(Fault {
                                reason: FaultReason::LinkDead,
                                detail: tries,
                            }));
                        }
                        self.link.counters.retransmits += 1;
                        seq = self
                            .link
                            .send(Frame::Dac(DacSample { tick, codes }))
                            .map_err(Error::Link)?;
                        wait_until = now_ns() + self.cfg.retransmit_after.as_nanos() as u64;
                    }
                }
            }
        }
    }

    /// Ends the session: FAULT to the board after a fault, else DISARM; the report.
    fn finish(
        mut self,
        fault: Option<Fault>,
        log: &mut Option<&mut LogWriter>,
    ) -> Result<ControllerReport, Error> {
        let tick = self.start_tick.wrapping_add(self.report.ticks as u32);
        match fault {
            Some(f) => {
                let text = describe_fault(&f);
                // Tell the board, so it latches the safe state now rather than by its
                // watchdog; unless the board itself said this controller has no session.
                if f.reason != FaultReason::SessionRefused {
                    let _ = self.link.send(Frame::Fault(f));
                }
                log_record(log, Record::Event { tick, text: format!("fault: {text}") })?;
                let end = format!("fault after {} ticks: {text}", self.report.ticks);
                log_record(log, Record::End { tick, text: end })?;
                self.report.fault = Some((f, text));
            }
            None => {
                // Twice: a lost DISARM would leave the board to its watchdog, which also ends safe.
                let _ = self.link.send(Frame::Disarm);
                let _ = self.link.send(Frame::Disarm);
                log_record(log, Record::Event { tick, text: "disarmed: end of run".into() })?;
                let end = format!("completed: {} ticks, disarmed", self.report.ticks);
                log_record(log, Record::End { tick, text: end })?;
            }
        }
        if let Some(l) = log.as_mut() {
            let _ = l.sync();
        }
        self.report.counters = self.link.counters;
        Ok(self.report)
    }
}

/// Runs the controller side for `cfg.ticks` ticks (or until `stop`). `Err` is for what
/// stops the bridge itself (a socket or model error); link and board faults end the run
/// with `report.fault` set.
pub fn run_controller<C: Compensator>(
    comp: &mut C,
    tx: &mut dyn Transport,
    reference: &dyn Fn(f64) -> f64,
    cfg: &ControllerConfig,
    mut log: Option<&mut LogWriter>,
    stop: &AtomicBool,
) -> Result<ControllerReport, Error> {
    let mut link = Link {
        tx,
        dac_seq: 0,
        ctl_seq: 0,
        enc: SeqTracker::new(),
        buf: [0; 256],
        sent_at: vec![0; 1 << 16],
        counters: ControllerCounters::default(),
    };
    let deadline = now_ns() + cfg.handshake_timeout.as_nanos() as u64;
    // HELLO and ARM share one deadline.
    let start = loop {
        handshake(&mut link, cfg, stop, deadline)?;
        match arm(&mut link)? {
            Ok(start) => break start,
            Err(_) if now_ns() <= deadline && !stop.load(Ordering::Relaxed) => {}
            Err(Some(f)) => {
                return Err(Error::Refused(f));
            }
            Err(None) => {
                return Err(Error::NotArmed { seconds: cfg.handshake_timeout.as_secs_f64() });
            }
        }
    };
    let mut report = ControllerReport { first_tick: start.tick, ..ControllerReport::default() };
    report
        .events
        .push((0, format!("armed at board tick {}, encoder {}", start.tick, start.counts)));
    let pacing = if cfg.lockstep {
        Pacing::LockStep
    } else {
        Pacing::RealTime { pacer: Pacer::new(cfg.period), last_heard: 0 }
    };
    let mut session = Session {
        link,
        cfg,
        pacing,
        start_tick: start.tick,
        counts: start.counts,
        board_status: start.status,
        report,
    };
    let mut fault = None;
    for k in 0..cfg.ticks {
        if stop.load(Ordering::Relaxed) {
            fault = Some(Fault { reason: FaultReason::Operator, detail: 0 });
            break;
        }
        if let ControlFlow::Break(f) = session.tick(k, comp, reference, &mut log)? {
            fault = Some(f);
            break;
        }
    }
    session.finish(fault, &mut log)
}
