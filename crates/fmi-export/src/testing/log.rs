//! The logger the harness instantiates with: it captures every message an instance logs.

use std::ffi::{c_char, c_void, CStr};
use std::sync::Mutex;

use crate::ffi::*;

/// Messages logged, as "status|category|message".
pub struct Log(pub Mutex<Vec<String>>);

/// The distinct categories of logged "status|category|message" lines, sorted.
pub fn categories_of(lines: &[String]) -> Vec<String> {
    let mut cats: Vec<String> =
        lines.iter().filter_map(|l| l.split('|').nth(1)).map(str::to_string).collect();
    cats.sort();
    cats.dedup();
    cats
}

// Defined with the two arguments the layer passes ("%s" and the text): a Rust function
// cannot be variadic, and on the x86-64 and AArch64 Linux ABIs fixed pointer arguments
// arrive where a variadic callee reads them.
unsafe extern "C" fn logger(
    env: *mut c_void,
    _name: fmi2String,
    status: fmi2Status,
    category: fmi2String,
    fmt: fmi2String,
    arg: *const c_char,
) {
    let log = &*(env as *const Log);
    assert_eq!(
        CStr::from_ptr(fmt).to_str().unwrap(),
        "%s",
        "the message must be an argument, never the format"
    );
    let msg = CStr::from_ptr(arg).to_string_lossy();
    let cat = CStr::from_ptr(category).to_string_lossy();
    log.0.lock().unwrap().push(format!("{status}|{cat}|{msg}"));
}

/// FMI 2.0 callback functions whose logger appends to `log`.
pub fn callbacks(log: &Log) -> fmi2CallbackFunctions {
    fmi2CallbackFunctions {
        // SAFETY: see `logger`.
        logger: Some(unsafe {
            std::mem::transmute::<*const (), fmi2CallbackLogger>(logger as *const ())
        }),
        allocateMemory: None,
        freeMemory: None,
        stepFinished: None,
        componentEnvironment: log as *const Log as *mut c_void,
    }
}
