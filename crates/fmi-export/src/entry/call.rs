//! What every entry point does first: find its instance (refusing any pointer that is not
//! a live instance of its model and standard) and check the call against the instance's
//! state; and the pointer and string helpers of the C arguments.

use std::ffi::{c_void, CStr};
use std::os::raw::c_char;
use std::panic::{catch_unwind, AssertUnwindSafe};

use crate::instance::*;
use crate::state::*;
use crate::{registry, Model};

/// Runs `body` on the instance behind `c` if the call is allowed in its state. A pointer
/// that is not a live instance of this model and standard (NULL, freed, another FMU's,
/// junk) is refused without being read: there is no logger to tell but the instance's.
pub unsafe fn with_instance<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    allowed: u16,
    body: impl FnOnce(&mut Instance<S, M>) -> Status,
) -> Status {
    let c = c as *mut Instance<S, M>;
    let Some(guard) = (!c.is_null()).then(|| registry::guard_of(c)).flatten() else {
        return ERROR;
    };
    // One call at a time: a call from another thread while this one runs is refused
    // (Scheduled Execution's tasks may run on several threads), counted, and logged by
    // the running call.
    if !guard.enter() {
        return ERROR;
    }
    let status = run::<S, M>(&mut *c, func, allowed, body, guard);
    guard.leave();
    status
}

/// [`with_instance`] once the call holds the instance. What almost every call finds
/// (`logAll` off, no call refused meanwhile) is checked inline; the messages otherwise are
/// built in cold functions.
#[inline(always)]
fn run<S: Standard, M: Model>(
    inst: &mut Instance<S, M>,
    func: &str,
    allowed: u16,
    body: impl FnOnce(&mut Instance<S, M>) -> Status,
    guard: &registry::Guard,
) -> Status {
    let status = if inst.state as u16 & allowed == 0 {
        refuse_state(inst, func)
    } else {
        if inst.wants(LogCategory::All) {
            log_call(inst, func);
        }
        match catch_unwind(AssertUnwindSafe(|| body(&mut *inst))) {
            Ok(status) => status,
            Err(panic) => contain(inst, func, panic),
        }
    };
    let n = guard.take_refused();
    if n > 0 {
        report_refused(inst, func, n);
    }
    status
}

#[cold]
#[inline(never)]
fn refuse_state<S: Standard, M: Model>(inst: &Instance<S, M>, func: &str) -> Status {
    let state = S::state_name(inst.state);
    inst.refuse(func, format_args!("illegal call sequence: not allowed in state {state}"))
}

/// `logAll`'s line of each call.
#[cold]
#[inline(never)]
fn log_call<S: Standard, M: Model>(inst: &Instance<S, M>, func: &str) {
    inst.log(OK, LogCategory::All, format_args!("{func}"));
}

/// A panic of the call's body: the instance ends in Fatal.
#[cold]
#[inline(never)]
fn contain<S: Standard, M: Model>(
    inst: &mut Instance<S, M>,
    func: &str,
    panic: Box<dyn std::any::Any + Send>,
) -> Status {
    inst.state = State::Fatal;
    let what = panic_text(panic.as_ref());
    let why = format_args!("{func}: internal error, instance unusable: {what}");
    inst.log(FATAL, LogCategory::StatusError, why);
    FATAL
}

/// The calls another thread made while this one ran, refused.
#[cold]
#[inline(never)]
fn report_refused<S: Standard, M: Model>(inst: &Instance<S, M>, func: &str, n: u32) {
    let why = format_args!("{n} call(s) from another thread refused (fmi3Error) while this instance ran {func}: an instance takes one call at a time");
    inst.log(ERROR, LogCategory::StatusError, why);
}

pub(super) unsafe fn slice<'a, T>(ptr: *const T, n: usize) -> Option<&'a [T]> {
    match (n, ptr.is_null()) {
        (0, _) => Some(&[]),
        (_, true) => None,
        _ => Some(std::slice::from_raw_parts(ptr, n)),
    }
}

pub(super) unsafe fn slice_mut<'a, T>(ptr: *mut T, n: usize) -> Option<&'a mut [T]> {
    match (n, ptr.is_null()) {
        (0, _) => Some(&mut []),
        (_, true) => None,
        _ => Some(std::slice::from_raw_parts_mut(ptr, n)),
    }
}

pub(super) fn text(p: *const c_char) -> String {
    // SAFETY: callers pass a non-NULL C string of the master's.
    unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
}

/// An entry point this FMU does not support: logged with the reason, Error.
pub unsafe fn unsupported<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    allowed: u16,
    why: &str,
) -> Status {
    with_instance::<S, M>(c, func, allowed, |inst| {
        inst.refuse(func, format_args!("not supported: {why}"))
    })
}
