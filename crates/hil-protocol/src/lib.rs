//! Wire protocol of the inchworm hardware-in-the-loop bridge.
//!
//! The controller and the driver board exchange one small frame per 2 ms period:
//! DAC codes one way, the encoder count and status bits the other. This crate is the
//! single definition of those frames, shared by the host bridge and the board
//! firmware, so it is `no_std`, allocation-free and dependency-free: firmware links
//! nothing but this code. The protocol itself is specified in `docs/hil-protocol.md`.
//!
//! Contents: the frame codec ([`encode`], [`decode`], [`crc32`]), sequence-number
//! tracking ([`SeqTracker`]), the board-side watchdog and safe state ([`Watchdog`]) and
//! COBS framing for serial links ([`cobs`]). The C API lives in the separate
//! `inchworm-hil-ffi` crate (`crates/hil-protocol/ffi`), so this crate stays a plain
//! `no_std` rlib that a bare-metal Rust firmware can depend on.
#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

use core::fmt;

pub mod cobs;
mod crc;
mod seq;
mod watchdog;

pub use crc::crc32;
pub use seq::{seq_distance, SeqTracker, SeqVerdict};
pub use watchdog::{BoardState, Watchdog};

/// Protocol version carried in every frame header; a receiver refuses any other, since
/// a different layout cannot be decoded safely.
pub const VERSION: u8 = 1;
/// The two magic bytes `"IW"` that open every frame, so a stray datagram or a
/// misaligned serial read is refused before anything else is looked at.
pub const MAGIC: [u8; 2] = *b"IW";
/// Bytes before the payload: magic, version, type, seq, stream, length.
pub const HEADER_LEN: usize = 10;
/// Bytes of the CRC-32 trailer.
pub const CRC_LEN: usize = 4;
/// Shortest possible frame (empty payload), below which nothing can be parsed.
pub const MIN_FRAME: usize = HEADER_LEN + CRC_LEN;
/// Longest frame (the 12-byte ENCODER payload); fixed-size buffers of this length
/// always suffice for [`encode`].
pub const MAX_FRAME: usize = HEADER_LEN + 12 + CRC_LEN;
/// DAC codes the board outputs whenever it is not armed: earth brake closed (holds the
/// load), non-earth brake open, extension PZT unpowered. Safe with power present.
pub const SAFE_CODES: [u16; 3] = [0, 0, 0];
/// Silent periods the board tolerates before latching the safe state: one late frame
/// is jitter, three in a row (6 ms at 500 Hz) is a dead link.
pub const DEFAULT_WATCHDOG_PERIODS: u32 = 3;

/// Lock-step board: wall-clock periods without any valid frame before the link counts as
/// dead (500 ms at 2 ms). In lock-step the controller owns time and may take long over a
/// step, so silence is not a missed period; this bound only catches a controller or link
/// that is gone, and it is far above the controller's own 25 unanswered repeats (about
/// 50 ms), so on a live link the controller decides first and tells the board.
pub const LOCKSTEP_DEAD_LINK_PERIODS: u32 = 250;

/// Frame type ids (header byte 3). Control frames are below 0x10, data frames from 0x10.
pub mod frame_type {
    /// Session start: version, role and timing of the sender.
    pub const HELLO: u8 = 0x01;
    /// The controller asks the board to leave Disarmed/Safe and apply DAC codes.
    pub const ARM: u8 = 0x02;
    /// The controller asks the board to output safe codes and stop.
    pub const DISARM: u8 = 0x03;
    /// Either side reports why it gave up.
    pub const FAULT: u8 = 0x04;
    /// Controller → board DAC codes for one period.
    pub const DAC: u8 = 0x10;
    /// Board → controller encoder count and status for one period.
    pub const ENCODER: u8 = 0x11;
}

/// Stream ids (header bytes 6..8). Sequence numbers are counted per stream, so a lost
/// control frame never looks like a lost data frame.
pub mod stream {
    /// HELLO, ARM, DISARM, FAULT.
    pub const CONTROL: u16 = 0;
    /// DAC frames, controller → board.
    pub const DAC: u16 = 1;
    /// ENCODER frames, board → controller.
    pub const ENCODER: u16 = 2;
}

/// Fixed payload length of a frame type, or `None` for an unknown type. Lengths are
/// fixed so a receiver can reject a frame from its header alone.
pub const fn payload_len(frame_type: u8) -> Option<usize> {
    match frame_type {
        frame_type::HELLO => Some(8),
        frame_type::ARM | frame_type::DISARM => Some(0),
        frame_type::FAULT => Some(8),
        frame_type::DAC => Some(10),
        frame_type::ENCODER => Some(12),
        _ => None,
    }
}

/// Which end of the link a HELLO comes from; a session needs one of each.
#[repr(u8)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// The host running the controller (sends DAC frames).
    Controller = 1,
    /// The driver board (sends ENCODER frames).
    Board = 2,
}

impl Role {
    /// Wire value to role; `None` for values the protocol does not define.
    pub const fn from_u8(v: u8) -> Option<Role> {
        match v {
            1 => Some(Role::Controller),
            2 => Some(Role::Board),
            _ => None,
        }
    }
}

/// HELLO payload: lets both ends check they agree on version and timing before arming.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Hello {
    /// The sender's protocol version (must equal the receiver's, else ProtocolMismatch).
    pub version: u8,
    /// Which end sent it.
    pub role: Role,
    /// Sample period in microseconds (2000 at 500 Hz).
    pub period_us: u32,
    /// Silent periods before the board latches the safe state.
    pub watchdog_periods: u8,
    /// Lock-step mode: the board advances one period per DAC frame instead of its clock.
    pub lockstep: bool,
}

/// HELLO flag bit 0: lock-step. Other flag bits are undefined and refused.
pub const HELLO_FLAG_LOCKSTEP: u8 = 1;

/// Why a side gave up; carried by FAULT frames and latched by the [`Watchdog`].
#[repr(u8)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaultReason {
    /// Watchdog: no valid frame for N periods (detail = missed periods).
    Silence = 1,
    /// Frames were lost (detail = gap size).
    SequenceGap = 2,
    /// The transport itself failed (socket/serial error).
    LinkDead = 3,
    /// Too many frames failed to decode (detail = count).
    Corrupt = 4,
    /// A hard real-time deadline was missed (detail = overrun count or µs).
    Overrun = 5,
    /// A person stopped the run.
    Operator = 6,
    /// HELLO versions or parameters disagree.
    ProtocolMismatch = 7,
    /// The board refused a controller's frame because the sender holds no session with
    /// it (detail: [`session_refused`] codes). Added within version 1: the frame layout
    /// is unchanged, and a receiver that predates it refuses the frame as BadPayload.
    SessionRefused = 8,
}

/// The detail of a FAULT SessionRefused: why the board will not talk to the sender.
pub mod session_refused {
    /// Another controller holds an armed, live session.
    pub const BUSY: u32 = 1;
    /// The sender's address is not among the board's allowed peers.
    pub const NOT_ALLOWED: u32 = 2;
    /// A frame other than HELLO from an address without a session: HELLO first.
    pub const NO_SESSION: u32 = 3;
}

impl FaultReason {
    /// Wire value to reason; `None` for values the protocol does not define.
    pub const fn from_u8(v: u8) -> Option<FaultReason> {
        match v {
            1 => Some(FaultReason::Silence),
            2 => Some(FaultReason::SequenceGap),
            3 => Some(FaultReason::LinkDead),
            4 => Some(FaultReason::Corrupt),
            5 => Some(FaultReason::Overrun),
            6 => Some(FaultReason::Operator),
            7 => Some(FaultReason::ProtocolMismatch),
            8 => Some(FaultReason::SessionRefused),
            _ => None,
        }
    }
}

/// FAULT payload: the reason plus one number that makes the log actionable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fault {
    /// Why.
    pub reason: FaultReason,
    /// Reason-specific number (missed periods, gap size, bad-frame count, ...).
    pub detail: u32,
}

/// DAC payload: the three codes the controller wants applied for one period.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DacSample {
    /// The controller's sample index, so the board can log which sample it applied.
    pub tick: u32,
    /// Codes for earth brake, non-earth brake, extension PZT (volts = code·10/65535).
    pub codes: [u16; 3],
}

/// Bits of [`EncoderSample::status`]. Bits not defined here must be 0; a frame with any
/// other bit set is refused, so the bits can be given meaning in a later version.
pub mod status {
    /// The board is armed and applying DAC codes.
    pub const ARMED: u16 = 1;
    /// The safe state is latched; only ARM leaves it.
    pub const SAFE: u16 = 2;
    /// The board missed a deadline since its previous ENCODER frame.
    pub const OVERRUN: u16 = 4;
    /// The board runs in lock-step mode.
    pub const LOCKSTEP: u16 = 8;
    /// All defined bits.
    pub const ALL: u16 = ARMED | SAFE | OVERRUN | LOCKSTEP;
}

/// ENCODER payload: the measurement the controller closes its loop on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EncoderSample {
    /// The board's sample index the count belongs to.
    pub tick: u32,
    /// Encoder position, 1.2 nm per count.
    pub counts: i32,
    /// [`status`] bits.
    pub status: u16,
    /// Seq of the last DAC frame the board applied, for round-trip time measurement.
    pub echo_seq: u16,
}

/// One decoded frame body; the variant fixes type id, stream and payload length.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Frame {
    /// Session start.
    Hello(Hello),
    /// Enter Armed.
    Arm,
    /// Enter Disarmed.
    Disarm,
    /// Give up, with a reason.
    Fault(Fault),
    /// Controller → board data.
    Dac(DacSample),
    /// Board → controller data.
    Encoder(EncoderSample),
}

impl Frame {
    /// Wire type id of this frame (see [`frame_type`]).
    pub fn frame_type(&self) -> u8 {
        match self {
            Frame::Hello(_) => frame_type::HELLO,
            Frame::Arm => frame_type::ARM,
            Frame::Disarm => frame_type::DISARM,
            Frame::Fault(_) => frame_type::FAULT,
            Frame::Dac(_) => frame_type::DAC,
            Frame::Encoder(_) => frame_type::ENCODER,
        }
    }

    /// Stream the frame travels on (see [`stream`]); each stream has its own seq.
    pub fn stream(&self) -> u16 {
        match self {
            Frame::Hello(_) | Frame::Arm | Frame::Disarm | Frame::Fault(_) => stream::CONTROL,
            Frame::Dac(_) => stream::DAC,
            Frame::Encoder(_) => stream::ENCODER,
        }
    }

    /// Total encoded size of this frame in bytes.
    pub fn encoded_len(&self) -> usize {
        match payload_len(self.frame_type()) {
            Some(n) => MIN_FRAME + n,
            None => MAX_FRAME, // unreachable: every variant has a known type
        }
    }
}

/// A frame plus the sender's per-stream sequence number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Packet {
    /// Sender's sequence number on this frame's stream, +1 per frame, wrapping.
    pub seq: u16,
    /// The frame.
    pub frame: Frame,
}

/// Why [`encode`] (or [`cobs::encode`]) wrote nothing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EncodeError {
    /// The output buffer is shorter than the encoded frame.
    BufferTooSmall {
        /// Bytes the output needs.
        needed: usize,
    },
}

impl fmt::Display for EncodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EncodeError::BufferTooSmall { needed } => {
                write!(f, "output buffer too small: the frame needs {needed} bytes")
            }
        }
    }
}

/// Why [`decode`] refused a frame. Every variant means "drop it and count it"; they are
/// distinct so logs tell a noisy link (BadCrc) from a peer speaking something else.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecodeError {
    /// Fewer bytes than the smallest frame (header + CRC).
    TooShort {
        /// Bytes given.
        len: usize,
    },
    /// The first two bytes are not `"IW"`.
    BadMagic,
    /// The header's protocol version is not [`VERSION`].
    UnsupportedVersion(u8),
    /// The length field announces more bytes than were given.
    Truncated {
        /// Bytes given.
        len: usize,
        /// Bytes the header announces.
        needed: usize,
    },
    /// More bytes than the header announces (a frame must be decoded alone).
    TrailingBytes {
        /// Bytes beyond the frame.
        extra: usize,
    },
    /// The CRC trailer does not match the bytes: the frame was damaged in transit.
    BadCrc {
        /// CRC carried by the frame.
        expected: u32,
        /// CRC computed over the bytes received.
        found: u32,
    },
    /// Intact frame with a type id this version does not define.
    UnknownType(u8),
    /// Intact frame whose stream id is not the one its type travels on.
    WrongStream {
        /// Type id.
        frame_type: u8,
        /// Stream id found.
        stream: u16,
    },
    /// Intact frame whose length field is not its type's fixed payload length.
    BadLength {
        /// Type id.
        frame_type: u8,
        /// Length field found.
        len: u16,
    },
    /// Intact frame with a payload value the protocol does not define.
    BadPayload(&'static str),
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            DecodeError::TooShort { len } => {
                write!(f, "frame too short: {len} bytes, the smallest frame is {MIN_FRAME} bytes")
            }
            DecodeError::BadMagic => write!(f, "bad magic: frame does not start with \"IW\""),
            DecodeError::UnsupportedVersion(v) => {
                write!(f, "unsupported protocol version {v} (this side speaks version {VERSION})")
            }
            DecodeError::Truncated { len, needed } => {
                write!(f, "truncated frame: {len} bytes, the header announces {needed}")
            }
            DecodeError::TrailingBytes { extra } => {
                write!(f, "{extra} trailing bytes after the frame")
            }
            DecodeError::BadCrc { expected, found } => {
                write!(f, "CRC mismatch: frame says {expected:#010x}, bytes give {found:#010x}")
            }
            DecodeError::UnknownType(t) => write!(f, "unknown frame type {t:#04x}"),
            DecodeError::WrongStream { frame_type, stream } => {
                write!(f, "frame type {frame_type:#04x} does not travel on stream {stream}")
            }
            DecodeError::BadLength { frame_type, len } => write!(
                f,
                "frame type {frame_type:#04x} has a fixed payload length, not {len} bytes"
            ),
            DecodeError::BadPayload(what) => write!(f, "invalid payload: {what}"),
        }
    }
}

/// Encodes one packet into `buf`, returning the number of bytes written
/// ([`Frame::encoded_len`], at most [`MAX_FRAME`]). Nothing is written on error.
///
/// The encoder trusts its input: status bits outside [`status::ALL`] are sent as given,
/// and the receiver refuses the frame, which surfaces the sender's bug.
pub fn encode(packet: &Packet, buf: &mut [u8]) -> Result<usize, EncodeError> {
    let frame = &packet.frame;
    let total = frame.encoded_len();
    if buf.len() < total {
        return Err(EncodeError::BufferTooSmall { needed: total });
    }
    let n = total - MIN_FRAME;
    let out = &mut buf[..total];
    out[0..2].copy_from_slice(&MAGIC);
    out[2] = VERSION;
    out[3] = frame.frame_type();
    out[4..6].copy_from_slice(&packet.seq.to_le_bytes());
    out[6..8].copy_from_slice(&frame.stream().to_le_bytes());
    out[8..10].copy_from_slice(&(n as u16).to_le_bytes());
    let p = &mut out[HEADER_LEN..HEADER_LEN + n];
    match *frame {
        Frame::Hello(h) => {
            p[0] = h.version;
            p[1] = h.role as u8;
            p[2..6].copy_from_slice(&h.period_us.to_le_bytes());
            p[6] = h.watchdog_periods;
            p[7] = if h.lockstep { HELLO_FLAG_LOCKSTEP } else { 0 };
        }
        Frame::Arm | Frame::Disarm => {}
        Frame::Fault(fault) => {
            p[0] = fault.reason as u8;
            p[1..4].fill(0);
            p[4..8].copy_from_slice(&fault.detail.to_le_bytes());
        }
        Frame::Dac(d) => {
            p[0..4].copy_from_slice(&d.tick.to_le_bytes());
            for (i, code) in d.codes.iter().enumerate() {
                p[4 + 2 * i..6 + 2 * i].copy_from_slice(&code.to_le_bytes());
            }
        }
        Frame::Encoder(e) => {
            p[0..4].copy_from_slice(&e.tick.to_le_bytes());
            p[4..8].copy_from_slice(&e.counts.to_le_bytes());
            p[8..10].copy_from_slice(&e.status.to_le_bytes());
            p[10..12].copy_from_slice(&e.echo_seq.to_le_bytes());
        }
    }
    let crc = crc32(&out[..HEADER_LEN + n]);
    out[HEADER_LEN + n..].copy_from_slice(&crc.to_le_bytes());
    Ok(total)
}

fn u16_at(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([b[at], b[at + 1]])
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

/// Decodes exactly one frame (a whole UDP datagram, or one COBS-decoded serial frame).
///
/// Checks run in this order: size, magic, version, length field against the bytes
/// given, CRC, then type/stream/length/payload. Framing is checked first because the
/// CRC's position depends on it; the CRC comes before the semantic checks so that
/// damage in transit is always reported as [`DecodeError::BadCrc`], and the semantic
/// errors only ever describe intact frames (a peer bug, not line noise).
///
/// The 3 reserved bytes of FAULT are ignored (not required to be 0), so a later version
/// may use them; everything else that the encoder would not produce is refused.
pub fn decode(bytes: &[u8]) -> Result<Packet, DecodeError> {
    let len = bytes.len();
    if len < MIN_FRAME {
        return Err(DecodeError::TooShort { len });
    }
    if bytes[0..2] != MAGIC {
        return Err(DecodeError::BadMagic);
    }
    if bytes[2] != VERSION {
        return Err(DecodeError::UnsupportedVersion(bytes[2]));
    }
    let n = u16_at(bytes, 8);
    let needed = MIN_FRAME + n as usize;
    if len < needed {
        return Err(DecodeError::Truncated { len, needed });
    }
    if len > needed {
        return Err(DecodeError::TrailingBytes { extra: len - needed });
    }
    let body = HEADER_LEN + n as usize;
    let expected = u32_at(bytes, body);
    let found = crc32(&bytes[..body]);
    if expected != found {
        return Err(DecodeError::BadCrc { expected, found });
    }
    let ty = bytes[3];
    let seq = u16_at(bytes, 4);
    let stream_id = u16_at(bytes, 6);
    let fixed = payload_len(ty).ok_or(DecodeError::UnknownType(ty))?;
    let want_stream = match ty {
        frame_type::DAC => stream::DAC,
        frame_type::ENCODER => stream::ENCODER,
        _ => stream::CONTROL,
    };
    if stream_id != want_stream {
        return Err(DecodeError::WrongStream { frame_type: ty, stream: stream_id });
    }
    if n as usize != fixed {
        return Err(DecodeError::BadLength { frame_type: ty, len: n });
    }
    let p = &bytes[HEADER_LEN..body];
    let frame = match ty {
        frame_type::HELLO => {
            let role =
                Role::from_u8(p[1]).ok_or(DecodeError::BadPayload("HELLO role is not 1 or 2"))?;
            if p[7] & !HELLO_FLAG_LOCKSTEP != 0 {
                return Err(DecodeError::BadPayload("HELLO has undefined flag bits set"));
            }
            Frame::Hello(Hello {
                version: p[0],
                role,
                period_us: u32_at(p, 2),
                watchdog_periods: p[6],
                lockstep: p[7] & HELLO_FLAG_LOCKSTEP != 0,
            })
        }
        frame_type::ARM => Frame::Arm,
        frame_type::DISARM => Frame::Disarm,
        frame_type::FAULT => {
            let reason = FaultReason::from_u8(p[0])
                .ok_or(DecodeError::BadPayload("FAULT reason is not 1..=8"))?;
            Frame::Fault(Fault { reason, detail: u32_at(p, 4) })
        }
        frame_type::DAC => Frame::Dac(DacSample {
            tick: u32_at(p, 0),
            codes: [u16_at(p, 4), u16_at(p, 6), u16_at(p, 8)],
        }),
        frame_type::ENCODER => {
            let status = u16_at(p, 8);
            if status & !status::ALL != 0 {
                return Err(DecodeError::BadPayload("ENCODER status has undefined bits set"));
            }
            Frame::Encoder(EncoderSample {
                tick: u32_at(p, 0),
                counts: u32_at(p, 4) as i32,
                status,
                echo_seq: u16_at(p, 10),
            })
        }
        _ => return Err(DecodeError::UnknownType(ty)),
    };
    Ok(Packet { seq, frame })
}
