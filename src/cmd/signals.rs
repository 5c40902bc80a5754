//! Ctrl-C and `kill` for the binary: SIGINT and SIGTERM set the run's [`StopFlag`], so the
//! engine stops between two steps and returns through its destructors (the unpacked
//! archives are removed, the CSV written so far is flushed). A second signal ends the
//! process at once, by the default action.

use std::sync::atomic::{AtomicI32, Ordering};
use std::sync::OnceLock;

use inchworm_cosim::{Error, StopFlag};

/// The signal that asked the run to stop (0: none).
static SIGNAL: AtomicI32 = AtomicI32::new(0);
/// The flag the handler sets; made before the handler is installed.
static FLAG: OnceLock<StopFlag> = OnceLock::new();

#[cfg(unix)]
extern "C" fn on_signal(sig: libc::c_int) {
    if SIGNAL.swap(sig, Ordering::SeqCst) != 0 {
        // SAFETY: signal and raise are async-signal-safe.
        unsafe {
            libc::signal(sig, libc::SIG_DFL);
            libc::raise(sig);
        }
    }
    // An initialised OnceLock is read with an atomic load, and setting the flag is an
    // atomic store: nothing here locks or allocates.
    if let Some(flag) = FLAG.get() {
        flag.set();
    }
}

/// Installs the handler and returns the flag it sets. Only for a command that runs the
/// master and checks the flag: elsewhere the signals would be ignored.
pub fn stop_on_signals() -> StopFlag {
    let flag = FLAG.get_or_init(StopFlag::new).clone();
    #[cfg(unix)]
    // SAFETY: the handler only touches atomics and async-signal-safe calls.
    unsafe {
        let handler = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
        libc::signal(libc::SIGINT, handler);
        libc::signal(libc::SIGTERM, handler);
    }
    flag
}

/// The signal that stopped the run, if one did: for the exit status 128 + signal.
pub fn stop_signal() -> Option<i32> {
    Some(SIGNAL.load(Ordering::SeqCst)).filter(|&s| s != 0)
}

fn interrupted_text(sig: i32) -> String {
    let name = match sig {
        libc::SIGINT => "SIGINT",
        libc::SIGTERM => "SIGTERM",
        _ => "a signal",
    };
    format!("interrupted by {name}")
}

/// An error once a stop signal has come.
pub fn interrupted() -> Result<(), String> {
    stop_signal().map_or(Ok(()), |s| Err(interrupted_text(s)))
}

/// The engine's error as the binary says it: a run the flag stopped was interrupted by
/// the signal that set it.
pub fn describe(e: Error) -> String {
    match stop_signal() {
        Some(s) if e.is_stopped() => interrupted_text(s),
        _ => e.to_string(),
    }
}
