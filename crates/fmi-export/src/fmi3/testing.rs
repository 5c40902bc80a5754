//! For tests of FMI 3.0 FMUs: a logger callback that records what an instance logs.

use std::ffi::{c_void, CStr};

use super::ffi::*;
pub use crate::testing::Log;

unsafe extern "C" fn logger(
    env: fmi3InstanceEnvironment,
    status: fmi3Status,
    category: fmi3String,
    message: fmi3String,
) {
    let log = &*(env as *const Log);
    let msg = CStr::from_ptr(message).to_string_lossy();
    let cat = CStr::from_ptr(category).to_string_lossy();
    if let Ok(mut lines) = log.0.lock() {
        lines.push(format!("{status}|{cat}|{msg}"));
    }
}

/// The logger and its environment for `fmi3InstantiateCoSimulation`, appending
/// "status|category|message" lines to `log`.
pub fn log_callback(log: &Log) -> (fmi3InstanceEnvironment, fmi3LogMessageCallback) {
    (log as *const Log as *mut c_void, Some(logger))
}
