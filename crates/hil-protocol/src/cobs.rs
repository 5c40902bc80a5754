//! Consistent Overhead Byte Stuffing (Cheshire & Baker, 1999) for the serial
//! transport: removes every 0x00 from a frame so 0x00 can delimit frames on the wire,
//! and a receiver that starts mid-stream resynchronises at the next 0x00.
//!
//! [`encode`] writes no delimiter; the sender appends one 0x00 after each frame (and
//! may send one before the first). [`decode`] takes the bytes between two delimiters.
//! The decoder is strict: it accepts exactly the outputs of [`encode`], so that every
//! byte string has at most one meaning.

use crate::EncodeError;
use core::fmt;

/// Why [`decode`] refused its input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CobsError {
    /// Nothing between two delimiters (the encoding of an empty frame is `[0x01]`);
    /// harmless on the wire, e.g. two delimiters in a row.
    Empty,
    /// A 0x00 inside the encoded data: the delimiter must be stripped first.
    ZeroByte {
        /// Offset of the zero.
        at: usize,
    },
    /// A code byte announces more bytes than follow: the frame was cut short.
    Truncated {
        /// Offset of the code byte.
        at: usize,
    },
    /// A final empty group after a full 254-byte group: decodable, but never produced
    /// by [`encode`], so refused to keep the encoding unique.
    NonCanonical,
    /// The decoded data does not fit `dst`.
    OutputTooSmall {
        /// Bytes of decoded data.
        needed: usize,
    },
}

impl fmt::Display for CobsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            CobsError::Empty => write!(f, "empty COBS frame"),
            CobsError::ZeroByte { at } => write!(f, "0x00 inside a COBS frame at offset {at}"),
            CobsError::Truncated { at } => {
                write!(f, "COBS frame cut short: the code byte at offset {at} runs past the end")
            }
            CobsError::NonCanonical => write!(f, "non-canonical COBS encoding"),
            CobsError::OutputTooSmall { needed } => {
                write!(f, "output buffer too small: the decoded frame needs {needed} bytes")
            }
        }
    }
}

/// Worst-case encoded size of `n` bytes (one code byte per started 254-byte run plus
/// one), for sizing buffers at compile time: `max_encoded_len(MAX_FRAME)` is 27.
pub const fn max_encoded_len(n: usize) -> usize {
    n + n / 254 + 1
}

/// Exact encoded size of `src`.
fn encoded_len(src: &[u8]) -> usize {
    let mut len = 1;
    let mut run = 0;
    for (i, &b) in src.iter().enumerate() {
        if b == 0 {
            len += 1;
            run = 0;
        } else {
            len += 1;
            run += 1;
            if run == 254 && i + 1 < src.len() {
                len += 1;
                run = 0;
            }
        }
    }
    len
}

/// COBS-encodes `src` into `dst` without a trailing delimiter; returns the length
/// written. The output contains no 0x00. Nothing is written on error.
pub fn encode(src: &[u8], dst: &mut [u8]) -> Result<usize, EncodeError> {
    let needed = encoded_len(src);
    if dst.len() < needed {
        return Err(EncodeError::BufferTooSmall { needed });
    }
    let mut code_at = 0;
    let mut out = 1;
    let mut code: u8 = 1;
    for (i, &b) in src.iter().enumerate() {
        if b == 0 {
            dst[code_at] = code;
            code_at = out;
            out += 1;
            code = 1;
        } else {
            dst[out] = b;
            out += 1;
            code += 1;
            if code == 0xFF && i + 1 < src.len() {
                dst[code_at] = code;
                code_at = out;
                out += 1;
                code = 1;
            }
        }
    }
    dst[code_at] = code;
    debug_assert_eq!(out, needed);
    Ok(out)
}

/// Decodes one COBS frame (delimiter already stripped) into `dst`; returns the decoded
/// length. Refuses anything [`encode`] could not have produced.
pub fn decode(src: &[u8], dst: &mut [u8]) -> Result<usize, CobsError> {
    if src.is_empty() {
        return Err(CobsError::Empty);
    }
    if let Some(at) = src.iter().position(|&b| b == 0) {
        return Err(CobsError::ZeroByte { at });
    }
    // First pass validates and sizes, so nothing is written on error.
    let mut i = 0;
    let mut needed = 0;
    let mut prev_full = false;
    while i < src.len() {
        let code = src[i] as usize;
        let end = i + code;
        if end > src.len() {
            return Err(CobsError::Truncated { at: i });
        }
        if code == 1 && end == src.len() && prev_full {
            return Err(CobsError::NonCanonical);
        }
        needed += code - 1;
        if code != 0xFF && end < src.len() {
            needed += 1;
        }
        prev_full = code == 0xFF;
        i = end;
    }
    if dst.len() < needed {
        return Err(CobsError::OutputTooSmall { needed });
    }
    let mut i = 0;
    let mut out = 0;
    while i < src.len() {
        let code = src[i] as usize;
        let end = i + code;
        dst[out..out + code - 1].copy_from_slice(&src[i + 1..end]);
        out += code - 1;
        if code != 0xFF && end < src.len() {
            dst[out] = 0;
            out += 1;
        }
        i = end;
    }
    Ok(out)
}
