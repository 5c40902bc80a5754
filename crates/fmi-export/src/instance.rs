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

/// The log categories of `modelDescription.xml`, in the order declared there. Names
/// follow the standard's recommendations (FMI 2.0 section 2.2.4); `logAll` is the one
/// that selects every message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LogCategory {
    Events,
    StatusWarning,
    StatusError,
    All,
}

impl LogCategory {
    pub const ALL: [LogCategory; 4] = [
        LogCategory::Events,
        LogCategory::StatusWarning,
        LogCategory::StatusError,
        LogCategory::All,
    ];

    pub fn name(self) -> &'static str {
        match self {
            LogCategory::Events => "logEvents",
            LogCategory::StatusWarning => "logStatusWarning",
            LogCategory::StatusError => "logStatusError",
            LogCategory::All => "logAll",
        }
    }

    pub fn from_name(name: &str) -> Option<LogCategory> {
        LogCategory::ALL.into_iter().find(|c| c.name() == name)
    }

    /// The description in `modelDescription.xml`: what counts as an event is the model's
    /// to say; the other categories are the layer's own.
    pub fn description<M: Model>(self) -> &'static str {
        match self {
            LogCategory::Events => M::info().log_events,
            LogCategory::StatusWarning => "Calls that returned fmi2Warning",
            LogCategory::StatusError => "Calls that returned fmi2Error or fmi2Fatal",
            LogCategory::All => "Everything, including each call",
        }
    }

    fn bit(self) -> u8 {
        1 << self as u8
    }
}

/// The set of enabled categories, one bit per [`LogCategory`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Categories(u8);

impl Categories {
    pub const NONE: Categories = Categories(0);
    pub const ALL: Categories = Categories((1 << LogCategory::ALL.len()) - 1);

    pub fn of(cats: &[LogCategory]) -> Categories {
        Categories(cats.iter().fold(0, |b, c| b | c.bit()))
    }
    pub fn without(self, other: Categories) -> Categories {
        Categories(self.0 & !other.0)
    }
    pub fn contains(self, c: LogCategory) -> bool {
        self.0 & c.bit() != 0
    }
}

/// Guards against a master passing a pointer that is not one of our instances (or a
/// freed one): checked before anything else is read.
pub const INSTANCE_MAGIC: u64 = 0x4957_464d_4932_0001;

pub struct Instance<M: Model> {
    pub magic: u64,
    pub name: CString,
    pub callbacks: fmi2CallbackFunctions,
    /// Categories whose debug messages (status fmi2OK) reach the logger.
    pub categories: Categories,
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
            categories: if logging_on { Categories::ALL } else { Categories::NONE },
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
    /// master needs them to understand a status, and FMI 2.0 section 2.1.5 has the FMU
    /// report why a call failed); debug messages only in an enabled category, or with
    /// `logAll` enabled.
    pub fn log(&self, status: fmi2Status, category: LogCategory, message: &str) {
        let Some(logger) = self.callbacks.logger else { return };
        let wanted = status >= fmi2Warning
            || self.categories.contains(category)
            || self.categories.contains(LogCategory::All);
        if !wanted {
            return;
        }
        let cat = CString::new(category.name()).unwrap_or_default();
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

/// What a caught panic says, for the log line that ends the instance.
pub(crate) fn panic_text(panic: &(dyn std::any::Any + Send)) -> String {
    panic
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}
