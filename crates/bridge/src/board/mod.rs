//! The board side: what the driver board's firmware does, with a [`Mechanism`] in place of
//! the DACs, amplifiers, PZTs and encoder.
//!
//! Real time: at every period boundary the board takes the frames that arrived during the
//! period, closes the period in the watchdog, holds the codes the watchdog lets through for
//! the next period (one mechanism step) and sends the encoder count at its end.
//!
//! Lock-step: the controller drives. A DAC frame for the board's current tick is applied
//! at once (one step) and answered with the count at the end of the interval; a repeat of
//! the previous tick (the controller lost the answer) gets the stored answer again without
//! stepping, so retransmissions never step the plant twice. The controller owns time here,
//! so the watchdog counts missed periods in the lock-step sense: N DAC transmissions lost
//! in a row (the sequence gap of the next one) latch the safe state, while wall-clock
//! silence only counts towards the dead-link bound (`dead_link_periods`), which catches a
//! controller that is gone but not one that is slow (docs/hil-protocol.md, "Lock-step:
//! what a missed period is").
//!
//! Sessions: the board takes a controller only on a valid HELLO, and only when no other
//! controller holds an armed, live session; everything else from other senders is counted
//! per source and dropped, so no stray datagram can lock the real controller out
//! (docs/hil-protocol.md, "Sessions").

mod admission;
mod config;
mod run;
mod sessions;

use std::collections::BTreeMap;
use std::io;

use inchworm_hil_protocol::{
    decode, encode, session_refused, status, BoardState, DacSample, EncoderSample, Fault,
    FaultReason, Frame, Packet, SeqTracker, SeqVerdict, Watchdog, MAX_FRAME, SAFE_CODES, VERSION,
};

pub use admission::{SourceCounts, MAX_HANDSHAKES, MAX_SOURCES};
pub use config::{Allow, BoardConfig};
pub use run::run_board;
pub use sessions::{SessionInfo, MAX_SESSION_RECORDS};

/// Events kept in memory (see [`Board::events`]).
pub const MAX_EVENTS: usize = 1024;

/// The log lines for refused datagrams a board writes at once, before the rate applies.
pub const REFUSAL_BURST: f64 = 32.0;
/// The log lines for refused datagrams a board writes per second after its burst.
pub const REFUSALS_PER_S: f64 = 8.0;

use crate::realtime::now_ns;
use crate::runlog::{BoardSample, LogWriter, Record};
use crate::transport::{Source, Transport};
use crate::{describe_fault, LinkCounters, Mechanism, ModelError, OverrunPolicy};

/// Frames received and what became of them, and the board's own counts.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BoardCounters {
    /// The DAC and control frames received.
    pub link: LinkCounters,
    /// DAC frames that arrived while the board was not armed (output stayed safe).
    pub unarmed: u64,
    /// Lock-step repeats of the previous tick, answered from the stored reply.
    pub repeats: u64,
    pub overruns: u64,
    pub steps: u64,
}

/// One latch of the safe state, in board ticks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SafeLatch {
    pub fault: Fault,
    /// The tick at which the last valid DAC frame was taken.
    pub last_valid_tick: u32,
    /// The tick from which the safe codes were applied.
    pub tick: u32,
}

pub struct Board<M> {
    cfg: BoardConfig,
    mech: M,
    wd: Watchdog,
    dac_seq: SeqTracker,
    enc_seq: u16,
    ctl_seq: u16,
    requested: [u16; 3],
    applied: [u16; 3],
    last_dac_seq: u16,
    tick: u32,
    counts: i32,
    reply: ([u8; MAX_FRAME], usize),
    last_valid_tick: u32,
    overrun_flag: bool,
    /// The controller whose HELLO opened the current session: the only sender whose frames
    /// are applied, and the one encoder frames go to. `None` until the first valid HELLO.
    peer: Option<Source>,
    /// When the peer's last valid frame arrived (`now_ns`), for the takeover rule.
    peer_heard_ns: u64,
    /// Senders whose HELLO was answered, with when (`now_ns`): an ARM from one of them
    /// completes its handshake (at most [`MAX_HANDSHAKES`], oldest first).
    handshakes: Vec<(Source, u64)>,
    /// Sessions opened so far; [`Board::sessions`] keeps the last [`MAX_SESSION_RECORDS`].
    sessions_opened: u32,
    /// Refusal log lines the budget allows now, and when it was last topped up (`now_ns`).
    refusal_budget: (f64, u64),
    /// Refusal log lines held back by the budget.
    refusals_unlogged: u64,
    allow: Vec<Allow>,
    /// The last [`MAX_SESSION_RECORDS`] sessions, oldest first.
    pub sessions: Vec<SessionInfo>,
    /// Traffic not taken as session traffic, per sender (the first [`MAX_SOURCES`]).
    pub sources: BTreeMap<Source, SourceCounts>,
    /// The same for every sender beyond the first [`MAX_SOURCES`], together.
    pub other_sources: SourceCounts,
    pub counters: BoardCounters,
    pub latches: Vec<SafeLatch>,
    /// (tick, text) of everything notable, in order: the last [`MAX_EVENTS`] to
    /// 2 × [`MAX_EVENTS`] of them (the log has them all, each rate-limited at its source).
    pub events: Vec<(u32, String)>,
    log: Option<LogWriter>,
}

impl<M: Mechanism> Board<M> {
    pub fn new(
        mut mech: M,
        cfg: BoardConfig,
        log: Option<LogWriter>,
    ) -> Result<Board<M>, ModelError> {
        let counts = mech.counts()?;
        let mut board = Board {
            cfg,
            mech,
            wd: if cfg.lockstep {
                Watchdog::lockstep(cfg.watchdog_periods, cfg.dead_link_periods)
            } else {
                Watchdog::new(cfg.watchdog_periods)
            },
            dac_seq: SeqTracker::new(),
            enc_seq: 0,
            ctl_seq: 0,
            requested: SAFE_CODES,
            applied: SAFE_CODES,
            last_dac_seq: 0,
            tick: 0,
            counts,
            reply: ([0; MAX_FRAME], 0),
            last_valid_tick: 0,
            overrun_flag: false,
            peer: None,
            peer_heard_ns: 0,
            handshakes: Vec::new(),
            sessions_opened: 0,
            refusal_budget: (REFUSAL_BURST, 0),
            refusals_unlogged: 0,
            allow: Vec::new(),
            sessions: Vec::new(),
            sources: BTreeMap::new(),
            other_sources: SourceCounts::default(),
            counters: BoardCounters::default(),
            latches: Vec::new(),
            events: Vec::new(),
            log,
        };
        board.write_log(Record::Meta(format!(
            "role=board\nprotocol={VERSION}\nperiod_us={}\nwatchdog_periods={}\nlockstep={}\ndead_link_periods={}\noverrun={:?}\nfresh_plant_per_session={}",
            cfg.period.as_micros(),
            cfg.watchdog_periods,
            cfg.lockstep,
            cfg.dead_link_periods,
            cfg.overrun,
            cfg.fresh_plant_per_session
        )));
        Ok(board)
    }

    pub fn state(&self) -> BoardState {
        self.wd.state()
    }

    /// Only these senders are heard (`--allow`); empty: anyone.
    pub fn set_allow(&mut self, allow: Vec<Allow>) {
        self.write_log(Record::Meta(format!(
            "allow={}",
            allow.iter().map(|a| format!("{a:?}")).collect::<Vec<_>>().join(",")
        )));
        self.allow = allow;
    }

    /// The current session's controller.
    pub fn peer(&self) -> Option<Source> {
        self.peer
    }

    pub fn tick(&self) -> u32 {
        self.tick
    }

    /// The codes held during the last interval stepped (after the watchdog).
    pub fn applied(&self) -> [u16; 3] {
        self.applied
    }

    pub fn mechanism(&mut self) -> &mut M {
        &mut self.mech
    }

    fn write_log(&mut self, record: Record) {
        if let Some(log) = &mut self.log {
            if let Err(e) = log.write(&record) {
                // The run goes on; losing the log is reported once and the writer dropped.
                self.events.push((self.tick, format!("log write failed, logging stopped: {e}")));
                self.log = None;
            }
        }
    }

    /// A refused datagram's log line, under the board-wide budget: a burst of
    /// [`REFUSAL_BURST`] lines, then [`REFUSALS_PER_S`] a second; the rest are counted
    /// and the count is in the summary. Session events are never held back.
    fn refusal(&mut self, text: String) {
        let now = now_ns();
        let refill = now.saturating_sub(self.refusal_budget.1) as f64 * 1e-9 * REFUSALS_PER_S;
        self.refusal_budget = ((self.refusal_budget.0 + refill).min(REFUSAL_BURST), now);
        if self.refusal_budget.0 >= 1.0 {
            self.refusal_budget.0 -= 1.0;
            self.event(text);
        } else {
            self.refusals_unlogged += 1;
        }
    }

    fn event(&mut self, text: String) {
        log::info!(target: "board", "tick {}: {text}", self.tick);
        self.write_log(Record::Event { tick: self.tick, text: text.clone() });
        if self.events.len() >= 2 * MAX_EVENTS {
            self.events.drain(..MAX_EVENTS);
        }
        self.events.push((self.tick, text));
    }

    /// `frame` to the session's peer, or to `to`.
    fn send_frame(
        &mut self,
        frame: Frame,
        to: Option<Source>,
        tx: &mut dyn Transport,
    ) -> io::Result<()> {
        self.ctl_seq = self.ctl_seq.wrapping_add(1);
        let mut buf = [0u8; MAX_FRAME];
        let n = encode(&Packet { seq: self.ctl_seq, frame }, &mut buf)
            .map_err(|e| io::Error::other(e.to_string()))?;
        match to {
            Some(to) => tx.send_to(&buf[..n], to),
            None => tx.send(&buf[..n]),
        }
    }

    fn send(&mut self, frame: Frame, tx: &mut dyn Transport) -> io::Result<()> {
        if self.peer.is_none() {
            // Nobody has opened a session: there is no one to tell.
            return Ok(());
        }
        let seq = match frame {
            Frame::Encoder(_) => {
                self.enc_seq = self.enc_seq.wrapping_add(1);
                self.enc_seq
            }
            _ => {
                self.ctl_seq = self.ctl_seq.wrapping_add(1);
                self.ctl_seq
            }
        };
        let mut buf = [0u8; MAX_FRAME];
        let n = encode(&Packet { seq, frame }, &mut buf)
            .map_err(|e| io::Error::other(e.to_string()))?;
        if matches!(frame, Frame::Encoder(_)) {
            self.reply = (buf, n);
        }
        tx.send(&buf[..n])
    }

    fn status(&self) -> u16 {
        let mut s = self.wd.status_bits();
        if self.cfg.lockstep {
            s |= status::LOCKSTEP;
        }
        if self.overrun_flag {
            s |= status::OVERRUN;
        }
        s
    }

    fn send_encoder(&mut self, tx: &mut dyn Transport) -> io::Result<()> {
        let e = EncoderSample {
            tick: self.tick,
            counts: self.counts,
            status: self.status(),
            echo_seq: self.last_dac_seq,
        };
        self.overrun_flag = false;
        self.send(Frame::Encoder(e), tx)
    }

    fn latch(&mut self, fault: Fault, tx: &mut dyn Transport) -> io::Result<()> {
        self.latches.push(SafeLatch {
            fault,
            last_valid_tick: self.last_valid_tick,
            tick: self.tick,
        });
        self.event(format!("safe state latched: {}; re-arm required", describe_fault(&fault)));
        // Tell the controller why, so its report names the cause and not only the symptom.
        self.send(Frame::Fault(fault), tx)
    }

    /// One interval with the codes the watchdog lets through.
    fn step(&mut self) -> io::Result<()> {
        self.applied = self.wd.output(self.requested);
        self.counts = self.mech.step(self.applied).map_err(|e| {
            io::Error::other(format!("the mechanism failed at tick {}: {e}", self.tick))
        })?;
        self.tick = self.tick.wrapping_add(1);
        self.counters.steps += 1;
        let s = BoardSample {
            tick: self.tick,
            codes: self.applied,
            counts: self.counts,
            status: self.status(),
            dac_seq: self.last_dac_seq,
        };
        self.write_log(Record::Board(s));
        Ok(())
    }

    /// Handles one received frame; replies go out through `tx`.
    pub fn handle(&mut self, bytes: &[u8], tx: &mut dyn Transport) -> io::Result<()> {
        let from = tx.source();
        if !self.allowed(from) {
            let (n, who) = self.count(from, |c| &mut c.not_allowed);
            if n.is_power_of_two() {
                self.refusal(format!(
                    "datagram from {from} ignored: not an allowed peer (--allow); {n} from {who} so far"
                ));
                // A controller that is kept out learns why instead of timing out.
                if matches!(decode(bytes), Ok(Packet { frame: Frame::Hello(_), .. })) {
                    self.refuse(from, session_refused::NOT_ALLOWED, tx)?;
                }
            }
            return Ok(());
        }
        let packet = match decode(bytes) {
            Ok(p) => p,
            Err(e) => {
                self.refuse_malformed(from, &e.to_string());
                return Ok(());
            }
        };
        let from_peer = self.peer == Some(from);
        // An ARM after an answered HELLO completes a handshake (a new session, or the
        // peer's next run after its DISARM); any other ARM from the peer re-arms.
        let completes_handshake = matches!(packet.frame, Frame::Arm) && self.in_handshake(from);
        if !from_peer && !completes_handshake && !matches!(packet.frame, Frame::Hello(_)) {
            let (n, who) = self.count(from, |c| &mut c.foreign);
            if n.is_power_of_two() {
                let holder = self.peer.map_or_else(|| "nobody".to_string(), |p| p.to_string());
                self.refusal(format!(
                    "{} frame from {from} dropped: it holds no session (the session is {holder}'s); {n} from {who} so far",
                    frame_name(&packet.frame)
                ));
                self.refuse(from, session_refused::NO_SESSION, tx)?;
            }
            return Ok(());
        }
        if from_peer {
            self.counters.link.frames += 1;
            self.peer_heard_ns = now_ns();
        }
        match packet.frame {
            Frame::Hello(h) => self.hello(from, h, tx),
            Frame::Arm if completes_handshake => self.complete_handshake(from, tx),
            Frame::Arm => self.arm(tx),
            Frame::Disarm if self.wd.state() == BoardState::Disarmed => Ok(()),
            Frame::Disarm => {
                self.wd.disarm();
                self.event("disarmed by the controller: safe codes".into());
                Ok(())
            }
            Frame::Fault(f) => {
                let first = !matches!(self.wd.state(), BoardState::Safe(_));
                self.wd.fault(f);
                if first {
                    self.latches.push(SafeLatch {
                        fault: f,
                        last_valid_tick: self.last_valid_tick,
                        tick: self.tick,
                    });
                }
                self.event(format!(
                    "the controller reported a fault, safe state: {}",
                    describe_fault(&f)
                ));
                Ok(())
            }
            Frame::Dac(d) => self.dac(packet.seq, d, tx),
            Frame::Encoder(_) => {
                self.counters.link.malformed += 1;
                self.event("an encoder frame came in; only the board sends those".into());
                Ok(())
            }
        }
    }

    /// ARM from the session's controller.
    fn arm(&mut self, tx: &mut dyn Transport) -> io::Result<()> {
        let was = self.wd.state();
        self.wd.arm();
        // The ARM is the first valid frame of the session: silence counts from it.
        self.wd.frame_received();
        self.requested = SAFE_CODES;
        self.dac_seq.reset();
        self.last_valid_tick = self.tick;
        if let Some(s) = self.sessions.last_mut() {
            s.arms += 1;
        }
        self.event(format!("armed (was {was:?})"));
        // The controller learns the tick and count it starts from.
        self.send_encoder(tx)
    }

    fn dac(&mut self, seq: u16, d: DacSample, tx: &mut dyn Transport) -> io::Result<()> {
        let verdict = self.dac_seq.accept(seq);
        if !self.counters.link.sequence(verdict) {
            return Ok(());
        }
        if let SeqVerdict::Gap { missing } = verdict {
            // Lock-step: the lost transmissions are the missed periods (a no-op in real
            // time, where the wall clock counted them).
            if let Some(f) = self.wd.frames_lost(u32::from(missing)) {
                self.latch(f, tx)?;
            }
        }
        if self.wd.state() != BoardState::Armed {
            // Frames never unlatch the safe state; only ARM does.
            self.counters.unarmed += 1;
            if self.counters.unarmed.is_power_of_two() {
                let state = self.wd.state();
                self.event(format!(
                    "DAC frame while {state:?}: output stays safe until ARM ({} such frames)",
                    self.counters.unarmed
                ));
            }
            return if self.cfg.lockstep { self.send_encoder(tx) } else { Ok(()) };
        }
        if !self.cfg.lockstep {
            self.requested = d.codes;
            self.last_dac_seq = seq;
            self.last_valid_tick = self.tick;
            self.wd.frame_received();
            return Ok(());
        }
        if d.tick == self.tick {
            self.requested = d.codes;
            self.last_dac_seq = seq;
            self.last_valid_tick = self.tick;
            self.wd.frame_received();
            self.step()?;
            self.send_encoder(tx)
        } else if d.tick.wrapping_add(1) == self.tick {
            self.counters.repeats += 1;
            self.wd.frame_received();
            let (buf, n) = self.reply;
            tx.send(&buf[..n])
        } else {
            self.counters.link.stale += 1;
            Ok(())
        }
    }

    /// The end of a real-time period: watchdog, one step, the encoder frame.
    pub fn period(&mut self, overrun_us: Option<u64>, tx: &mut dyn Transport) -> io::Result<()> {
        if let Some(late) = overrun_us {
            self.counters.overruns += 1;
            self.overrun_flag = true;
            if self.cfg.overrun == OverrunPolicy::Hard && self.wd.state() == BoardState::Armed {
                let f = Fault {
                    reason: FaultReason::Overrun,
                    detail: late.min(u64::from(u32::MAX)) as u32,
                };
                self.wd.fault(f);
                self.latch(f, tx)?;
            }
        }
        if let Some(f) = self.wd.period_elapsed() {
            self.latch(f, tx)?;
        }
        self.step()?;
        // The mechanism runs from power-on; the encoder stream starts with a session.
        if self.peer.is_some() {
            self.send_encoder(tx)?;
        }
        Ok(())
    }

    /// A lock-step period of the wall clock without a valid frame: counts towards the
    /// dead-link bound only, since a lock-step controller may be slow without being gone.
    pub fn silent_period(&mut self, tx: &mut dyn Transport) -> io::Result<()> {
        if let Some(f) = self.wd.period_elapsed() {
            self.latch(f, tx)?;
        }
        Ok(())
    }

    /// Forces the log to disk (end of run, or after a fault).
    pub fn sync_log(&mut self) {
        if let Some(log) = &mut self.log {
            let _ = log.sync();
        }
    }
}

fn frame_name(f: &Frame) -> &'static str {
    match f {
        Frame::Hello(_) => "HELLO",
        Frame::Arm => "ARM",
        Frame::Disarm => "DISARM",
        Frame::Fault(_) => "FAULT",
        Frame::Dac(_) => "DAC",
        Frame::Encoder(_) => "ENCODER",
    }
}
