//! One FMU instance: the model, its FMI state, its time and its link to the master.

use std::ffi::CString;
use std::os::raw::c_char;

use crate::ffi::*;
use crate::Model;

/// The states of FMI 2.0 Co-Simulation (section 4.2.4), one bit each so that every
/// entry point can name the states it is allowed in as a mask.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u16)]
pub enum State {
    Instantiated = 1 << 0,
    InitializationMode = 1 << 1,
    StepComplete = 1 << 2,
    StepInProgress = 1 << 3,
    StepFailed = 1 << 4,
    StepCanceled = 1 << 5,
    Terminated = 1 << 6,
    Error = 1 << 7,
    Fatal = 1 << 8,
}

impl State {
    pub fn name(self) -> &'static str {
        match self {
            State::Instantiated => "Instantiated",
            State::InitializationMode => "InitializationMode",
            State::StepComplete => "StepComplete",
            State::StepInProgress => "StepInProgress",
            State::StepFailed => "StepFailed",
            State::StepCanceled => "StepCanceled",
            State::Terminated => "Terminated",
            State::Error => "Error",
            State::Fatal => "Fatal",
        }
    }
}

/// Log categories declared in `modelDescription.xml`, in this order.
pub const LOG_CATEGORIES: [(&str, &str); 4] = [
    ("logEvents", "Model events: brake switches, mode changes, slips"),
    ("logStatusWarning", "Calls that returned fmi2Warning"),
    ("logStatusError", "Calls that returned fmi2Error or fmi2Fatal"),
    ("logAll", "Everything, including each call"),
];

/// Guards against a master passing a pointer that is not one of our instances (or a
/// freed one): checked before anything else is read.
pub const INSTANCE_MAGIC: u64 = 0x4957_464d_4932_0001;

pub struct Instance<M: Model> {
    pub magic: u64,
    pub name: CString,
    pub callbacks: fmi2CallbackFunctions,
    pub logging_on: bool,
    pub categories: [bool; LOG_CATEGORIES.len()],
    pub state: State,
    pub model: M,
    pub time: f64,
    pub start_time: f64,
    pub stop_time: Option<f64>,
    pub last_step_status: fmi2Status,
    /// Snapshots handed out by `fmi2GetFMUstate`, so `fmi2SetFMUstate` can refuse a
    /// pointer that is not one of them instead of dereferencing it.
    pub snapshots: Vec<*mut Snapshot<M>>,
}

/// What `fmi2GetFMUstate` saves.
#[derive(Clone)]
pub struct Snapshot<M> {
    pub model: M,
    pub state: State,
    pub time: f64,
    pub start_time: f64,
    pub stop_time: Option<f64>,
}

impl<M: Model> Instance<M> {
    pub fn new(name: CString, callbacks: fmi2CallbackFunctions, logging_on: bool) -> Self {
        Instance {
            magic: INSTANCE_MAGIC,
            name,
            callbacks,
            logging_on,
            categories: [true; LOG_CATEGORIES.len()],
            state: State::Instantiated,
            model: M::new(),
            time: 0.0,
            start_time: 0.0,
            stop_time: None,
            last_step_status: fmi2OK,
            snapshots: Vec::new(),
        }
    }

    /// Sends a message to the master's logger. Errors and warnings always go out (the
    /// master needs them to understand a status); other categories only with debug
    /// logging on and the category enabled.
    pub fn log(&self, status: fmi2Status, category: usize, message: &str) {
        let Some(logger) = self.callbacks.logger else { return };
        let wanted = status >= fmi2Warning
            || (self.logging_on && (self.categories[category] || self.categories[3]));
        if !wanted {
            return;
        }
        let cat = CString::new(LOG_CATEGORIES[category].0).unwrap_or_default();
        // Interior NULs would truncate the message; replace them rather than drop it.
        let msg = CString::new(message.replace('\0', " ")).unwrap_or_default();
        let fmt = b"%s\0";
        // SAFETY: the master promised a logger with the fmi2CallbackLogger signature; the
        // message is passed as an argument of "%s", never as the format.
        unsafe {
            logger(
                self.callbacks.componentEnvironment,
                self.name.as_ptr(),
                status,
                cat.as_ptr(),
                fmt.as_ptr() as *const c_char,
                msg.as_ptr(),
            );
        }
    }

    pub fn snapshot(&self) -> Snapshot<M> {
        Snapshot {
            model: self.model.clone(),
            state: self.state,
            time: self.time,
            start_time: self.start_time,
            stop_time: self.stop_time,
        }
    }

    pub fn restore(&mut self, s: &Snapshot<M>) {
        self.model = s.model.clone();
        self.state = s.state;
        self.time = s.time;
        self.start_time = s.start_time;
        self.stop_time = s.stop_time;
    }
}

impl<M: Model> Drop for Instance<M> {
    fn drop(&mut self) {
        self.magic = 0;
        for s in self.snapshots.drain(..) {
            // SAFETY: every pointer in the list came from Box::into_raw and is freed once.
            drop(unsafe { Box::from_raw(s) });
        }
    }
}
