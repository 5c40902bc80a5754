//! Co-Simulation (FMI 2.0 chapter 4, FMI 3.0 section 4): the communication step and the
//! status queries.

use std::ffi::c_void;

use super::call::with_instance;
use crate::instance::*;
use crate::state::*;
use crate::{Message, Model, StepLog};

/// A status query: `read` answers it from the instance or says why it cannot.
pub unsafe fn status_query<S: Standard, M: Model, T>(
    c: *mut c_void,
    func: &str,
    value: *mut T,
    read: impl FnOnce(&Instance<S, M>) -> Result<T, String>,
) -> Status {
    with_instance::<S, M>(c, func, STATUS_CALLS, |inst| {
        if value.is_null() {
            return inst.refuse(func, format_args!("value is NULL"));
        }
        match read(inst) {
            Ok(v) => {
                *value = v;
                OK
            }
            Err(why) => inst.refuse(func, format_args!("{why}")),
        }
    })
}

/// Where FMI 3.0's `fmi3DoStep` reports; FMI 2.0 has no such arguments.
pub struct StepOutputs {
    pub event_handling_needed: *mut bool,
    pub terminate_simulation: *mut bool,
    pub early_return: *mut bool,
    pub last_successful_time: *mut f64,
}

impl StepOutputs {
    /// The FMU has no event mode and never returns early, so those two are always false;
    /// `lastSuccessfulTime` is the FMU time; `terminateSimulation` is true only when the
    /// model failed (the instance is then in Error). A NULL one is skipped: the call has
    /// already been refused for it.
    unsafe fn report(&self, terminate: bool, time: f64) {
        for (p, v) in [
            (self.event_handling_needed, false),
            (self.early_return, false),
            (self.terminate_simulation, terminate),
        ] {
            if !p.is_null() {
                *p = v;
            }
        }
        if !self.last_successful_time.is_null() {
            *self.last_successful_time = time;
        }
    }

    fn any_null(&self) -> bool {
        self.event_handling_needed.is_null()
            || self.terminate_simulation.is_null()
            || self.early_return.is_null()
            || self.last_successful_time.is_null()
    }
}

/// One communication step from `t` of length `h`.
pub unsafe fn do_step<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    t: f64,
    h: f64,
    outputs: Option<StepOutputs>,
) -> Status {
    with_instance::<S, M>(c, func, STEPPING, |inst| {
        if let Some(o) = &outputs {
            o.report(false, inst.time);
            if o.any_null() {
                return inst.refuse(func, format_args!("eventHandlingNeeded, terminateSimulation, earlyReturn or lastSuccessfulTime is NULL"));
            }
        }
        if !(h.is_finite() && h > 0.0) {
            return inst
                .refuse(func, format_args!("communicationStepSize {h} must be finite and > 0"));
        }
        if !t.is_finite() || !same_time(t, inst.time) {
            let now = inst.time;
            return inst.refuse(func, format_args!("currentCommunicationPoint {t} does not match the FMU time {now} (a step must start where the last one ended)"));
        }
        if let Some(stop) = inst.stop_time.filter(|&s| t + h > s && !same_time(t + h, s)) {
            let (end, at) = (t + h, S::EXPERIMENT_FN);
            return inst.refuse(
                func,
                format_args!("step to {end} passes the stop time {stop} set in {at}"),
            );
        }
        if let Err(why) = inst.model.check_step(t, h) {
            return inst.refuse(func, format_args!("{why}"));
        }
        let result = inst.with_step_log(|model, log| model.do_step(t, h, log));
        match result {
            Ok(()) => {
                // The master's clock is the reference: following it keeps t and the FMU
                // time equal however the master accumulates it.
                inst.time = t + h;
                if let Some(o) = &outputs {
                    o.report(false, inst.time);
                }
                let status = inst.report_step_log(func);
                inst.last_step_status = status;
                status
            }
            Err(why) => {
                inst.state = State::Error;
                inst.last_step_status = ERROR;
                if let Some(o) = &outputs {
                    o.report(true, inst.time);
                }
                inst.refuse(func, format_args!("{why}"))
            }
        }
    })
}

impl<S: Standard, M: Model> Instance<S, M> {
    /// Runs `f` with the instance's reusable [`StepLog`], reset to what is wanted now.
    pub(super) fn with_step_log<T>(&mut self, f: impl FnOnce(&mut M, &mut StepLog) -> T) -> T {
        let events = self.wants(LogCategory::Events);
        self.step_log.reset(events);
        f(&mut self.model, &mut self.step_log)
    }

    /// Logs what the model reported in its last step or update: OK, or Warning if it
    /// warned.
    pub(super) fn report_step_log(&mut self, func: &str) -> Status {
        // Most steps report nothing: done without moving the log out and back.
        if self.step_log.messages().is_empty() {
            return OK;
        }
        let mut log = std::mem::take(&mut self.step_log);
        let mut status = OK;
        for m in log.drain() {
            match m {
                Message::Event(text) => self.log(OK, LogCategory::Events, format_args!("{text}")),
                Message::Warning(text) => {
                    let why = format_args!("{func}: {text}");
                    self.log(WARNING, LogCategory::StatusWarning, why);
                    status = WARNING;
                }
            }
        }
        self.step_log = log;
        status
    }
}

/// Communication points from `t += h` and from `k · h` differ by rounding; they are the
/// same point when within 1e-9 of the time (and within a few ulps at t = 0). The rule of
/// every `DoStep`'s time, and of a model whose own instants must meet it (the controller's
/// sample clock).
pub fn same_time(a: f64, b: f64) -> bool {
    let scale = a.abs().max(b.abs());
    (a - b).abs() <= (1e-9 * scale).max(4.0 * f64::EPSILON * scale).max(f64::MIN_POSITIVE)
}
