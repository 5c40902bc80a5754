//! A master in miniature for tests: drives one instance of any [`Model`] through the
//! generic entry points of [`crate::api`] (the code every exported `fmi2*` symbol calls)
//! and records what the instance logs.
// The FMU-state handles passed back in are the ones this harness got from the layer.
#![allow(clippy::not_unsafe_ptr_arg_deref)]

use std::ffi::{c_char, c_void, CStr, CString};
use std::marker::PhantomData;
use std::sync::Mutex;

use crate::api;
use crate::ffi::*;
use crate::model_description::guid;
use crate::{state_blob, Model};

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

/// Callback functions whose logger appends to `log`.
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

/// The model's payload inside a serialized FMU state of `M`.
pub fn payload_of<M: Model>(blob: &[u8]) -> Vec<u8> {
    state_blob::decode(guid::<M>(), blob).expect("a blob of M").1.to_vec()
}

/// `blob` with its payload replaced and its CRC made right again, to test how a model
/// payload that passes the frame's checks is read.
pub fn with_payload<M: Model>(blob: &[u8], payload: &[u8]) -> Vec<u8> {
    let (header, _) = state_blob::decode(guid::<M>(), blob).expect("a blob of M");
    state_blob::encode(guid::<M>(), &header, payload)
}

pub struct Harness<M: Model> {
    pub c: fmi2Component,
    log: Box<Log>,
    _functions: Box<fmi2CallbackFunctions>,
    _model: PhantomData<M>,
}

// The layer promises independent instances usable from any thread.
unsafe impl<M: Model> Send for Harness<M> {}

impl<M: Model> Harness<M> {
    /// An instance in state Instantiated.
    pub fn new(name: &str) -> Self {
        Self::with_logging(name, false)
    }

    /// An instance in state Instantiated, with `loggingOn` as given.
    pub fn with_logging(name: &str, logging_on: bool) -> Self {
        let log = Box::new(Log(Mutex::new(Vec::new())));
        let functions = Box::new(callbacks(&log));
        let name = CString::new(name).unwrap();
        let guid = CString::new(guid::<M>()).unwrap();
        let c = unsafe {
            api::fmi2Instantiate::<M>(
                name.as_ptr(),
                fmi2CoSimulation,
                guid.as_ptr(),
                std::ptr::null(),
                &*functions,
                fmi2False,
                if logging_on { fmi2True } else { fmi2False },
            )
        };
        assert!(!c.is_null(), "fmi2Instantiate failed: {:?}", log.0.lock().unwrap());
        Harness { c, log, _functions: functions, _model: PhantomData }
    }

    /// An instance in state StepComplete at t = 0.
    pub fn init(name: &str) -> Self {
        let h = Self::new(name);
        assert_eq!(h.setup(), fmi2OK);
        assert_eq!(h.enter(), fmi2OK);
        assert_eq!(h.exit(), fmi2OK, "{:?}", h.logged());
        h
    }

    pub fn setup(&self) -> fmi2Status {
        unsafe { api::fmi2SetupExperiment::<M>(self.c, fmi2False, 0.0, 0.0, fmi2False, 0.0) }
    }
    pub fn enter(&self) -> fmi2Status {
        unsafe { api::fmi2EnterInitializationMode::<M>(self.c) }
    }
    pub fn exit(&self) -> fmi2Status {
        unsafe { api::fmi2ExitInitializationMode::<M>(self.c) }
    }
    pub fn reset(&self) -> fmi2Status {
        unsafe { api::fmi2Reset::<M>(self.c) }
    }
    pub fn set_real(&self, vr: u32, v: f64) -> fmi2Status {
        unsafe { api::fmi2SetReal::<M>(self.c, &vr, 1, &v) }
    }
    pub fn set_integer(&self, vr: u32, v: i32) -> fmi2Status {
        unsafe { api::fmi2SetInteger::<M>(self.c, &vr, 1, &v) }
    }
    pub fn set_boolean(&self, vr: u32, v: bool) -> fmi2Status {
        let v = if v { fmi2True } else { fmi2False };
        unsafe { api::fmi2SetBoolean::<M>(self.c, &vr, 1, &v) }
    }
    pub fn real(&self, vr: u32) -> (fmi2Status, f64) {
        let mut v = f64::NAN;
        let s = unsafe { api::fmi2GetReal::<M>(self.c, &vr, 1, &mut v) };
        (s, v)
    }
    pub fn integer(&self, vr: u32) -> (fmi2Status, i32) {
        let mut v = i32::MIN;
        let s = unsafe { api::fmi2GetInteger::<M>(self.c, &vr, 1, &mut v) };
        (s, v)
    }
    pub fn boolean(&self, vr: u32) -> (fmi2Status, bool) {
        let mut v = -1;
        let s = unsafe { api::fmi2GetBoolean::<M>(self.c, &vr, 1, &mut v) };
        (s, v != fmi2False)
    }
    pub fn step(&self, t: f64, h: f64) -> fmi2Status {
        unsafe { api::fmi2DoStep::<M>(self.c, t, h, fmi2True) }
    }

    pub fn logged(&self) -> Vec<String> {
        self.log.0.lock().unwrap().clone()
    }

    /// The messages logged so far, removed from the log.
    pub fn take_logged(&self) -> Vec<String> {
        std::mem::take(&mut *self.log.0.lock().unwrap())
    }

    /// `fmi2SetDebugLogging` with these category names.
    pub fn set_debug_logging(&self, on: bool, categories: &[&str]) -> fmi2Status {
        let names: Vec<CString> = categories.iter().map(|c| CString::new(*c).unwrap()).collect();
        let ptrs: Vec<fmi2String> = names.iter().map(|c| c.as_ptr()).collect();
        let on = if on { fmi2True } else { fmi2False };
        unsafe { api::fmi2SetDebugLogging::<M>(self.c, on, ptrs.len(), ptrs.as_ptr()) }
    }

    /// Whether a message with this status containing every part was logged.
    pub fn saw(&self, status: fmi2Status, parts: &[&str]) -> bool {
        self.logged()
            .iter()
            .any(|m| m.starts_with(&format!("{status}|")) && parts.iter().all(|p| m.contains(p)))
    }

    /// `fmi2GetFMUstate`; the caller frees it with [`Harness::free_state`].
    pub fn get_state(&self) -> fmi2FMUstate {
        let mut s: fmi2FMUstate = std::ptr::null_mut();
        assert_eq!(unsafe { api::fmi2GetFMUstate::<M>(self.c, &mut s) }, fmi2OK);
        s
    }
    pub fn set_state(&self, s: fmi2FMUstate) -> fmi2Status {
        unsafe { api::fmi2SetFMUstate::<M>(self.c, s) }
    }
    pub fn free_state(&self, mut s: fmi2FMUstate) -> fmi2Status {
        unsafe { api::fmi2FreeFMUstate::<M>(self.c, &mut s) }
    }

    /// The current state, serialized.
    pub fn serialize(&self) -> Vec<u8> {
        let s = self.get_state();
        let mut size = 0usize;
        assert_eq!(unsafe { api::fmi2SerializedFMUstateSize::<M>(self.c, s, &mut size) }, fmi2OK);
        let mut bytes = vec![0u8; size];
        assert_eq!(
            unsafe {
                api::fmi2SerializeFMUstate::<M>(
                    self.c,
                    s,
                    bytes.as_mut_ptr() as *mut fmi2Byte,
                    size,
                )
            },
            fmi2OK
        );
        assert_eq!(self.free_state(s), fmi2OK);
        bytes
    }

    /// Deserializes `bytes` and sets the instance to it.
    pub fn deserialize(&self, bytes: &[u8]) -> fmi2Status {
        let mut s: fmi2FMUstate = std::ptr::null_mut();
        let st = unsafe {
            api::fmi2DeSerializeFMUstate::<M>(
                self.c,
                bytes.as_ptr() as *const fmi2Byte,
                bytes.len(),
                &mut s,
            )
        };
        if st != fmi2OK {
            return st;
        }
        let st = self.set_state(s);
        self.free_state(s);
        st
    }
}

impl<M: Model> Drop for Harness<M> {
    fn drop(&mut self) {
        unsafe { api::fmi2FreeInstance::<M>(self.c) };
    }
}
