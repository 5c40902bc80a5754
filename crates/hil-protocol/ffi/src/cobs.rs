//! COBS framing for serial links: encode and decode one frame.

use inchworm_hil_protocol as iw;

use crate::constants::*;
use crate::{guard, slice, slice_mut};

/// COBS-encodes `len` bytes of `src` into `dst` (capacity `cap`; IW_MAX_COBS_FRAME
/// suffices for a frame), without the trailing 0x00 delimiter, which the caller sends.
/// Returns the encoded length (always at least 1), or 0 on NULL pointers or small `cap`.
#[no_mangle]
pub unsafe extern "C" fn iw_cobs_encode(
    src: *const u8,
    len: usize,
    dst: *mut u8,
    cap: usize,
) -> usize {
    guard(0, || {
        let (Some(src), Some(dst)) = (slice(src, len), slice_mut(dst, cap)) else {
            return 0;
        };
        iw::cobs::encode(src, dst).unwrap_or(0)
    })
}

/// Decodes one COBS frame (the bytes between two 0x00 delimiters) from `src` into
/// `dst` (capacity `cap`). Returns the decoded length (>= 0), or IW_ERR_NULL,
/// IW_ERR_BUFFER_TOO_SMALL, IW_ERR_COBS (malformed), IW_ERR_INVALID_ARGUMENT (`len`
/// larger than INT32_MAX).
#[no_mangle]
pub unsafe extern "C" fn iw_cobs_decode(
    src: *const u8,
    len: usize,
    dst: *mut u8,
    cap: usize,
) -> i32 {
    guard(IW_ERR_PANIC, || {
        let (Some(src), Some(dst)) = (slice(src, len), slice_mut(dst, cap)) else {
            return IW_ERR_NULL;
        };
        if len > i32::MAX as usize {
            return IW_ERR_INVALID_ARGUMENT;
        }
        match iw::cobs::decode(src, dst) {
            Ok(n) => n as i32,
            Err(iw::cobs::CobsError::OutputTooSmall { .. }) => IW_ERR_BUFFER_TOO_SMALL,
            Err(_) => IW_ERR_COBS,
        }
    })
}
