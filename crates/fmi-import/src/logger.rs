//! The FMU's logger callback. `logger.c` formats the C-variadic message; this side turns
//! it into a `log` record whose target is the instance name and whose level follows the
//! status (OK → info, Warning → warn, Discard/Error/Fatal → error), the text prefixed by
//! the FMU's log category. Nothing here may unwind into the FMU: all of it runs inside
//! `catch_unwind`, NULL pointers are tolerated and text is decoded lossily.

use std::borrow::Cow;
use std::ffi::CStr;
use std::os::raw::{c_char, c_int, c_void};
use std::panic::{catch_unwind, AssertUnwindSafe};

use crate::ffi::{fmi2ComponentEnvironment, fmi2Status, fmi2String};

/// What `componentEnvironment` (FMI 3.0 `instanceEnvironment`) points to: owned by the
/// backend, alive until after the instance is freed. It also counts the FMI 3.0
/// `clockUpdate` calls of a Scheduled Execution instance (`backend::clocks`).
pub(crate) struct LogEnv {
    pub instance: String,
    pub clock_updates: std::sync::atomic::AtomicU64,
}

impl LogEnv {
    pub fn new(instance: &str) -> LogEnv {
        LogEnv { instance: instance.to_owned(), clock_updates: Default::default() }
    }
}

extern "C" {
    /// Defined in `logger.c`; has the `fmi2CallbackLogger` signature.
    pub(crate) fn inchworm_fmi_import_logger(
        environment: fmi2ComponentEnvironment,
        instance_name: fmi2String,
        status: fmi2Status,
        category: fmi2String,
        message: fmi2String,
        ...
    );
}

fn text<'a>(p: *const c_char) -> Option<Cow<'a, str>> {
    if p.is_null() {
        None
    } else {
        // SAFETY: a non-NULL string from the FMU (or logger.c) is NUL-terminated and
        // lives for the duration of the callback.
        Some(unsafe { CStr::from_ptr(p) }.to_string_lossy())
    }
}

/// The level a message of this status is logged at.
pub(crate) fn level(status: c_int) -> log::Level {
    match status {
        0 | 5 => log::Level::Info,
        2..=4 => log::Level::Error,
        _ => log::Level::Warn,
    }
}

/// Called by `logger.c` with the formatted message.
#[no_mangle]
pub extern "C" fn inchworm_fmi_import_log(
    environment: *mut c_void,
    instance_name: *const c_char,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    let _ = catch_unwind(AssertUnwindSafe(|| {
        let level = level(status);
        if level > log::max_level() {
            return;
        }
        let env_name = if environment.is_null() {
            None
        } else {
            // SAFETY: the environment is the `LogEnv` this crate passed to fmi2Instantiate
            // (FMUs hand it back unchanged), alive until after fmi2FreeInstance.
            Some(unsafe { &*(environment as *const LogEnv) }.instance.as_str())
        };
        let fmu_name = text(instance_name).filter(|s| !s.is_empty());
        let target: &str = match (&fmu_name, env_name) {
            (Some(n), _) => n,
            (None, Some(n)) => n,
            (None, None) => "fmu",
        };
        let message = text(message).unwrap_or(Cow::Borrowed(""));
        let message = message.trim_end_matches(['\n', '\r']);
        match text(category).filter(|c| !c.is_empty()) {
            Some(c) => emit(level, target, format_args!("{c}: {message}")),
            None => emit(level, target, format_args!("{message}")),
        }
    }));
}

pub(crate) fn emit(level: log::Level, target: &str, args: std::fmt::Arguments<'_>) {
    log::logger().log(
        &log::Record::builder()
            .level(level)
            .target(target)
            .module_path_static(Some(module_path!()))
            .args(args)
            .build(),
    );
}
