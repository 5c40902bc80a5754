//! The board watchdog in C storage ([`IwWatchdog`]) and its entry points.

use core::mem::{align_of, size_of};

use inchworm_hil_protocol as iw;
use inchworm_hil_protocol::{BoardState, Fault, FaultReason, Watchdog};

use crate::constants::*;
use crate::guard;

/// Storage for a board watchdog. Treat as opaque: initialise with iw_watchdog_init and
/// use only through the iw_watchdog_* functions. Safe to copy after initialisation.
#[repr(C)]
pub struct IwWatchdog {
    /// Set by iw_watchdog_init; other functions refuse storage without it.
    pub init_tag: u32,
    /// Reserved, 0.
    pub reserved: u32,
    /// The Rust watchdog state.
    pub opaque: [u64; 4],
}

const WATCHDOG_TAG: u32 = u32::from_le_bytes(*b"IWDG");

const _: () = {
    assert!(size_of::<Watchdog>() <= size_of::<[u64; 4]>());
    assert!(align_of::<Watchdog>() <= align_of::<u64>());
};

unsafe fn watchdog<'a>(w: *const IwWatchdog) -> Option<&'a Watchdog> {
    let w = w.as_ref()?;
    if w.init_tag != WATCHDOG_TAG {
        return None;
    }
    Some(&*(w.opaque.as_ptr() as *const Watchdog))
}

unsafe fn watchdog_mut<'a>(w: *mut IwWatchdog) -> Option<&'a mut Watchdog> {
    let w = w.as_mut()?;
    if w.init_tag != WATCHDOG_TAG {
        return None;
    }
    Some(&mut *(w.opaque.as_mut_ptr() as *mut Watchdog))
}

/// Initialises `*w`: Disarmed, tripping after `limit` silent periods (0 counts as 1).
#[no_mangle]
pub unsafe extern "C" fn iw_watchdog_init(w: *mut IwWatchdog, limit: u32) {
    guard((), || {
        if w.is_null() {
            return;
        }
        let storage = IwWatchdog { init_tag: WATCHDOG_TAG, reserved: 0, opaque: [0; 4] };
        core::ptr::write(w, storage);
        core::ptr::write((*w).opaque.as_mut_ptr() as *mut Watchdog, Watchdog::new(limit));
    })
}

/// Initialises `*w` for a lock-step board: Disarmed; trips when `limit` DAC
/// transmissions in a row are lost (iw_watchdog_frames_lost), or with IW_FAULT_LINK_DEAD
/// after `dead_link_periods` wall-clock periods without a valid frame
/// (iw_watchdog_period_elapsed). Wall-clock silence below that bound is the controller
/// taking its time, not a missed period. 0 counts as 1 for both limits.
#[no_mangle]
pub unsafe extern "C" fn iw_watchdog_init_lockstep(
    w: *mut IwWatchdog,
    limit: u32,
    dead_link_periods: u32,
) {
    guard((), || {
        if w.is_null() {
            return;
        }
        let storage = IwWatchdog { init_tag: WATCHDOG_TAG, reserved: 0, opaque: [0; 4] };
        core::ptr::write(w, storage);
        core::ptr::write(
            (*w).opaque.as_mut_ptr() as *mut Watchdog,
            Watchdog::lockstep(limit, dead_link_periods),
        );
    })
}

/// Lock-step: call for a valid DAC frame that came after `missing` lost ones (its
/// sequence gap, 0 for none), before iw_watchdog_frame_received. Returns the fault
/// reason (IW_FAULT_SILENCE) if the safe state was latched by this call, else 0 (also
/// for a real-time watchdog, whose periods the wall clock counts, and for NULL).
#[no_mangle]
pub unsafe extern "C" fn iw_watchdog_frames_lost(w: *mut IwWatchdog, missing: u32) -> i32 {
    guard(0, || match watchdog_mut(w) {
        Some(w) => w.frames_lost(missing).map_or(0, |f| f.reason as i32),
        None => 0,
    })
}

/// Arms: leaves Disarmed or the latched safe state, clears the missed count.
#[no_mangle]
pub unsafe extern "C" fn iw_watchdog_arm(w: *mut IwWatchdog) {
    guard((), || {
        if let Some(w) = watchdog_mut(w) {
            w.arm()
        }
    })
}

/// Disarms: outputs safe codes and stops counting (also leaves the safe state).
#[no_mangle]
pub unsafe extern "C" fn iw_watchdog_disarm(w: *mut IwWatchdog) {
    guard((), || {
        if let Some(w) = watchdog_mut(w) {
            w.disarm()
        }
    })
}

/// Call when a valid DAC frame arrived in the current period.
#[no_mangle]
pub unsafe extern "C" fn iw_watchdog_frame_received(w: *mut IwWatchdog) {
    guard((), || {
        if let Some(w) = watchdog_mut(w) {
            w.frame_received()
        }
    })
}

/// Call at the end of every wall-clock period. Returns the fault reason if the safe
/// state was latched by this call (IW_FAULT_SILENCE in real time, IW_FAULT_LINK_DEAD at
/// a lock-step watchdog's dead-link bound), else 0 (also for NULL/uninitialised `w`).
#[no_mangle]
pub unsafe extern "C" fn iw_watchdog_period_elapsed(w: *mut IwWatchdog) -> i32 {
    guard(0, || match watchdog_mut(w) {
        Some(w) => w.period_elapsed().map_or(0, |f| f.reason as i32),
        None => 0,
    })
}

/// Latches the safe state with `reason` (IW_FAULT_*); the first fault is kept.
/// Returns IW_OK, IW_ERR_NULL or IW_ERR_INVALID_ARGUMENT.
#[no_mangle]
pub unsafe extern "C" fn iw_watchdog_fault(w: *mut IwWatchdog, reason: u8, detail: u32) -> i32 {
    guard(IW_ERR_PANIC, || {
        let Some(w) = watchdog_mut(w) else {
            return IW_ERR_NULL;
        };
        let Some(reason) = FaultReason::from_u8(reason) else {
            return IW_ERR_INVALID_ARGUMENT;
        };
        w.fault(Fault { reason, detail });
        IW_OK
    })
}

/// Writes the codes to output: `requested` while armed, else 0,0,0 (earth brake
/// closed, non-earth open, extension unpowered). With a NULL or uninitialised `w` or
/// NULL `requested`, `out` gets the safe codes.
#[no_mangle]
pub unsafe extern "C" fn iw_watchdog_output(
    w: *const IwWatchdog,
    requested: *const u16,
    out: *mut u16,
) {
    guard((), || {
        if out.is_null() {
            return;
        }
        let codes = match (watchdog(w), requested.is_null()) {
            (Some(w), false) => {
                let r = core::slice::from_raw_parts(requested, 3);
                w.output([r[0], r[1], r[2]])
            }
            _ => iw::SAFE_CODES,
        };
        core::ptr::copy_nonoverlapping(codes.as_ptr(), out, 3);
    })
}

/// IW_STATUS_ARMED / IW_STATUS_SAFE bits for the ENCODER frame (IW_STATUS_SAFE for a
/// NULL or uninitialised `w`, since it outputs safe codes).
#[no_mangle]
pub unsafe extern "C" fn iw_watchdog_status(w: *const IwWatchdog) -> u16 {
    guard(IW_STATUS_SAFE, || watchdog(w).map_or(IW_STATUS_SAFE, |w| w.status_bits()))
}

/// IW_STATE_DISARMED, IW_STATE_ARMED, IW_STATE_SAFE, or IW_ERR_NULL.
#[no_mangle]
pub unsafe extern "C" fn iw_watchdog_state(w: *const IwWatchdog) -> i32 {
    guard(IW_ERR_PANIC, || match watchdog(w).map(|w| w.state()) {
        Some(BoardState::Disarmed) => IW_STATE_DISARMED,
        Some(BoardState::Armed) => IW_STATE_ARMED,
        Some(BoardState::Safe(_)) => IW_STATE_SAFE,
        None => IW_ERR_NULL,
    })
}

/// The latched fault reason (IW_FAULT_*) and, if `detail` is not NULL, its detail;
/// 0 when not in the safe state.
#[no_mangle]
pub unsafe extern "C" fn iw_watchdog_fault_reason(w: *const IwWatchdog, detail: *mut u32) -> u8 {
    guard(0, || match watchdog(w).map(|w| w.state()) {
        Some(BoardState::Safe(f)) => {
            if !detail.is_null() {
                *detail = f.detail;
            }
            f.reason as u8
        }
        _ => 0,
    })
}

/// Consecutive missed periods counted so far (0 for NULL/uninitialised `w`).
#[no_mangle]
pub unsafe extern "C" fn iw_watchdog_missed(w: *const IwWatchdog) -> u32 {
    guard(0, || watchdog(w).map_or(0, |w| w.missed()))
}
