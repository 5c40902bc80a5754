//! Frames in flat C form ([`IwPacket`]) and the codec's entry points: encode, decode,
//! error names, CRC-32 and sequence distance.

use inchworm_hil_protocol as iw;
use inchworm_hil_protocol::{
    DacSample, EncoderSample, Fault, FaultReason, Frame, Hello, Packet, Role,
};

use crate::constants::*;
use crate::{guard, slice, slice_mut};

/// One frame in flat form. `frame_type` selects which payload fields are meaningful;
/// the others are ignored by iw_encode and set to 0 by iw_decode. `stream` is filled in
/// by iw_decode and ignored by iw_encode (the type determines it).
#[repr(C)]
#[derive(Clone, Copy, Default)]
pub struct IwPacket {
    /// IW_TYPE_*.
    pub frame_type: u8,
    /// Sender's per-stream sequence number.
    pub seq: u16,
    /// IW_STREAM_* (output of iw_decode only).
    pub stream: u16,
    /// HELLO: sender's protocol version.
    pub hello_version: u8,
    /// HELLO: IW_ROLE_CONTROLLER or IW_ROLE_BOARD.
    pub hello_role: u8,
    /// HELLO: sample period in microseconds.
    pub hello_period_us: u32,
    /// HELLO: watchdog limit in periods.
    pub hello_watchdog_periods: u8,
    /// HELLO: 1 = lock-step, 0 = free-running (anything non-zero counts as 1).
    pub hello_lockstep: u8,
    /// FAULT: IW_FAULT_*.
    pub fault_reason: u8,
    /// FAULT: reason-specific detail.
    pub fault_detail: u32,
    /// DAC and ENCODER: sample index.
    pub tick: u32,
    /// DAC: codes for earth brake, non-earth brake, extension (volts = code*10/65535).
    pub codes: [u16; 3],
    /// ENCODER: position in counts of 1.2 nm.
    pub counts: i32,
    /// ENCODER: IW_STATUS_* bits.
    pub status: u16,
    /// ENCODER: seq of the last DAC frame applied.
    pub echo_seq: u16,
}

fn to_packet(p: &IwPacket) -> Option<Packet> {
    let frame = match p.frame_type {
        IW_TYPE_HELLO => Frame::Hello(Hello {
            version: p.hello_version,
            role: Role::from_u8(p.hello_role)?,
            period_us: p.hello_period_us,
            watchdog_periods: p.hello_watchdog_periods,
            lockstep: p.hello_lockstep != 0,
        }),
        IW_TYPE_ARM => Frame::Arm,
        IW_TYPE_DISARM => Frame::Disarm,
        IW_TYPE_FAULT => Frame::Fault(Fault {
            reason: FaultReason::from_u8(p.fault_reason)?,
            detail: p.fault_detail,
        }),
        IW_TYPE_DAC => Frame::Dac(DacSample { tick: p.tick, codes: p.codes }),
        IW_TYPE_ENCODER => {
            if p.status & !iw::status::ALL != 0 {
                return None;
            }
            Frame::Encoder(EncoderSample {
                tick: p.tick,
                counts: p.counts,
                status: p.status,
                echo_seq: p.echo_seq,
            })
        }
        _ => return None,
    };
    Some(Packet { seq: p.seq, frame })
}

fn from_packet(packet: &Packet) -> IwPacket {
    let mut p = IwPacket {
        frame_type: packet.frame.frame_type(),
        seq: packet.seq,
        stream: packet.frame.stream(),
        ..IwPacket::default()
    };
    match packet.frame {
        Frame::Hello(h) => {
            p.hello_version = h.version;
            p.hello_role = h.role as u8;
            p.hello_period_us = h.period_us;
            p.hello_watchdog_periods = h.watchdog_periods;
            p.hello_lockstep = h.lockstep as u8;
        }
        Frame::Arm | Frame::Disarm => {}
        Frame::Fault(f) => {
            p.fault_reason = f.reason as u8;
            p.fault_detail = f.detail;
        }
        Frame::Dac(d) => {
            p.tick = d.tick;
            p.codes = d.codes;
        }
        Frame::Encoder(e) => {
            p.tick = e.tick;
            p.counts = e.counts;
            p.status = e.status;
            p.echo_seq = e.echo_seq;
        }
    }
    p
}

fn decode_error_code(e: iw::DecodeError) -> i32 {
    use iw::DecodeError::*;
    match e {
        TooShort { .. } => IW_ERR_TOO_SHORT,
        BadMagic => IW_ERR_BAD_MAGIC,
        UnsupportedVersion(_) => IW_ERR_VERSION,
        Truncated { .. } => IW_ERR_TRUNCATED,
        TrailingBytes { .. } => IW_ERR_TRAILING_BYTES,
        BadCrc { .. } => IW_ERR_CRC,
        UnknownType(_) => IW_ERR_UNKNOWN_TYPE,
        WrongStream { .. } => IW_ERR_WRONG_STREAM,
        BadLength { .. } => IW_ERR_BAD_LENGTH,
        BadPayload(_) => IW_ERR_BAD_PAYLOAD,
    }
}

/// Encodes `packet` into `buf` (capacity `cap`; IW_MAX_FRAME always suffices).
/// Returns the frame length, or 0 if a pointer is NULL, `cap` is too small, or a field
/// is invalid (unknown type, role or reason, undefined status bits). Nothing is
/// written on error.
#[no_mangle]
pub unsafe extern "C" fn iw_encode(packet: *const IwPacket, buf: *mut u8, cap: usize) -> usize {
    guard(0, || {
        let (Some(p), Some(out)) = (packet.as_ref(), slice_mut(buf, cap)) else {
            return 0;
        };
        let Some(packet) = to_packet(p) else { return 0 };
        iw::encode(&packet, out).unwrap_or(0)
    })
}

/// Decodes exactly one frame of `len` bytes into `*out`. Returns IW_OK, or a negative
/// IW_ERR_* code (IW_ERR_CRC for a damaged frame); `*out` is untouched on error.
#[no_mangle]
pub unsafe extern "C" fn iw_decode(buf: *const u8, len: usize, out: *mut IwPacket) -> i32 {
    guard(IW_ERR_PANIC, || {
        let (Some(bytes), Some(out)) = (slice(buf, len), out.as_mut()) else {
            return IW_ERR_NULL;
        };
        match iw::decode(bytes) {
            Ok(packet) => {
                *out = from_packet(&packet);
                IW_OK
            }
            Err(e) => decode_error_code(e),
        }
    })
}

/// Returns a human-readable, static, NUL-terminated description of an IW_* code.
#[no_mangle]
pub extern "C" fn iw_error_name(code: i32) -> *const core::ffi::c_char {
    let s: &'static core::ffi::CStr = match code {
        IW_OK => c"ok",
        IW_ERR_NULL => c"NULL pointer or uninitialised watchdog",
        IW_ERR_TOO_SHORT => c"frame too short",
        IW_ERR_BAD_MAGIC => c"bad magic",
        IW_ERR_VERSION => c"unsupported protocol version",
        IW_ERR_TRUNCATED => c"truncated frame",
        IW_ERR_TRAILING_BYTES => c"trailing bytes after the frame",
        IW_ERR_CRC => c"CRC mismatch",
        IW_ERR_UNKNOWN_TYPE => c"unknown frame type",
        IW_ERR_WRONG_STREAM => c"wrong stream for the frame type",
        IW_ERR_BAD_LENGTH => c"bad payload length",
        IW_ERR_BAD_PAYLOAD => c"invalid payload value",
        IW_ERR_BUFFER_TOO_SMALL => c"buffer too small",
        IW_ERR_COBS => c"malformed COBS data",
        IW_ERR_INVALID_ARGUMENT => c"invalid argument",
        IW_ERR_PANIC => c"internal error (caught panic)",
        _ => c"unknown error code",
    };
    s.as_ptr()
}

/// CRC-32 (zlib) of `len` bytes; 0 if `data` is NULL with a non-zero length.
#[no_mangle]
pub unsafe extern "C" fn iw_crc32(data: *const u8, len: usize) -> u32 {
    guard(0, || slice(data, len).map_or(0, iw::crc32))
}

/// Wrap-around distance from sequence number `from` to `to`: positive if `to` is newer.
#[no_mangle]
pub extern "C" fn iw_seq_distance(from: u16, to: u16) -> i16 {
    iw::seq_distance(from, to)
}
