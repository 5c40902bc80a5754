//! One FMI 3.0 instance: the model, its FMI 3.0 state, its time and the master's logger.

use std::ffi::CString;

use super::ffi::*;
use crate::instance::{Categories, LogCategory, State};
use crate::Model;

/// The states of FMI 3.0 Co-Simulation without event mode (section 4.2), one bit each
/// so that every entry point names the states it is allowed in as a mask.
/// Configuration, event, intermediate-update and reconfiguration modes are never entered:
/// the FMU has no structural parameters, `hasEventMode` is false and it provides no
/// intermediate updates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u16)]
pub enum State3 {
    Instantiated = 1 << 0,
    InitializationMode = 1 << 1,
    StepMode = 1 << 2,
    Terminated = 1 << 3,
    Error = 1 << 4,
    Fatal = 1 << 5,
}

impl State3 {
    pub fn name(self) -> &'static str {
        match self {
            State3::Instantiated => "Instantiated",
            State3::InitializationMode => "InitializationMode",
            State3::StepMode => "StepMode",
            State3::Terminated => "Terminated",
            State3::Error => "Error",
            State3::Fatal => "Fatal",
        }
    }

    /// The state recorded in the shared serialized-state frame (whose codes are FMI 2.0's):
    /// step mode is FMI 2.0's stepComplete. Error and Fatal are never saved.
    pub(crate) fn to_blob(self) -> Option<State> {
        match self {
            State3::Instantiated => Some(State::Instantiated),
            State3::InitializationMode => Some(State::InitializationMode),
            State3::StepMode => Some(State::StepComplete),
            State3::Terminated => Some(State::Terminated),
            State3::Error | State3::Fatal => None,
        }
    }

    pub(crate) fn from_blob(s: State) -> Result<State3, String> {
        match s {
            State::Instantiated => Ok(State3::Instantiated),
            State::InitializationMode => Ok(State3::InitializationMode),
            State::StepComplete => Ok(State3::StepMode),
            State::Terminated => Ok(State3::Terminated),
            other => Err(format!(
                "serialized state was saved in FMI 2.0 state {}, which FMI 3.0 has not",
                other.name()
            )),
        }
    }
}

/// Guards against a pointer that is not one of our FMI 3.0 instances (or a freed one).
pub const INSTANCE3_MAGIC: u64 = 0x4957_464d_4933_0001;

pub struct Instance3<M: Model> {
    pub magic: u64,
    pub name: CString,
    pub environment: fmi3InstanceEnvironment,
    pub logger: fmi3LogMessageCallback,
    pub categories: Categories,
    pub state: State3,
    pub model: M,
    pub time: f64,
    pub start_time: f64,
    pub stop_time: Option<f64>,
    /// Snapshots handed out by `fmi3GetFMUState`, so that a foreign pointer is refused.
    pub snapshots: Vec<*mut Snapshot3<M>>,
}

#[derive(Clone)]
pub struct Snapshot3<M> {
    pub model: M,
    pub state: State3,
    pub time: f64,
    pub start_time: f64,
    pub stop_time: Option<f64>,
}

impl<M: Model> Instance3<M> {
    pub fn new(
        name: CString,
        environment: fmi3InstanceEnvironment,
        logger: fmi3LogMessageCallback,
        logging_on: bool,
    ) -> Self {
        Instance3 {
            magic: INSTANCE3_MAGIC,
            name,
            environment,
            logger,
            categories: if logging_on { Categories::ALL } else { Categories::NONE },
            state: State3::Instantiated,
            model: M::new(),
            time: 0.0,
            start_time: 0.0,
            stop_time: None,
            snapshots: Vec::new(),
        }
    }

    /// As the FMI 2.0 instance logs: errors and warnings always, debug messages in an
    /// enabled category or with `logAll`. FMI 3.0's logger takes the message itself (no
    /// format), and the instance name is not an argument, so it leads the message.
    pub fn log(&self, status: fmi3Status, category: LogCategory, message: &str) {
        let Some(logger) = self.logger else { return };
        let wanted = status >= fmi3Warning
            || self.categories.contains(category)
            || self.categories.contains(LogCategory::All);
        if !wanted {
            return;
        }
        let cat = CString::new(category.name()).unwrap_or_default();
        let text = format!("{}: {message}", self.name.to_string_lossy());
        let msg = CString::new(text.replace('\0', " ")).unwrap_or_default();
        // SAFETY: the master promised a logger with the fmi3LogMessageCallback signature.
        unsafe { logger(self.environment, status, cat.as_ptr(), msg.as_ptr()) };
    }

    pub fn snapshot(&self) -> Snapshot3<M> {
        Snapshot3 {
            model: self.model.clone(),
            state: self.state,
            time: self.time,
            start_time: self.start_time,
            stop_time: self.stop_time,
        }
    }

    pub fn restore(&mut self, s: &Snapshot3<M>) {
        self.model = s.model.clone();
        self.state = s.state;
        self.time = s.time;
        self.start_time = s.start_time;
        self.stop_time = s.stop_time;
    }
}

impl<M: Model> Drop for Instance3<M> {
    fn drop(&mut self) {
        self.magic = 0;
        for s in self.snapshots.drain(..) {
            // SAFETY: every pointer in the list came from Box::into_raw and is freed once.
            drop(unsafe { Box::from_raw(s) });
        }
    }
}
