//! Co-Simulation (FMI 2.0 chapter 4, FMI 3.0 section 4): the communication step and the
//! status queries.

use std::ffi::c_void;

use super::call::with_instance;
use super::clocks::next_tick;
use super::time::same_time;
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

/// How a step ended, beyond its time: at a clock tick (`eventHandlingNeeded`), early at
/// one (`earlyReturn`), with the model failed (`terminateSimulation`).
#[derive(Clone, Copy, Default)]
struct Ending {
    event: bool,
    early: bool,
    terminate: bool,
}

impl StepOutputs {
    /// `lastSuccessfulTime` is the FMU time; `eventHandlingNeeded` and `earlyReturn` are
    /// true only for an instance with `eventModeUsed` at a tick; `terminateSimulation` only
    /// when the model failed (the instance is then in Error). A NULL one is skipped: the
    /// call has already been refused for it.
    unsafe fn report(&self, e: Ending, time: f64) {
        for (p, v) in [
            (self.event_handling_needed, e.event),
            (self.early_return, e.early),
            (self.terminate_simulation, e.terminate),
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
            o.report(Ending::default(), inst.time);
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
        // With event mode a step ends at the next clock tick at the latest: there, or early
        // at it when the importer allows, or it is refused.
        let tick = match inst.modes.event_mode {
            true => next_tick::<M>(inst.start_time, t),
            false => None,
        };
        let (end, ending) = match tick {
            Some(tick) if same_time(tick, t + h) => {
                (t + h, Ending { event: true, ..Ending::default() })
            }
            Some(tick) if tick < t + h && inst.modes.early_return => {
                (tick, Ending { event: true, early: true, terminate: false })
            }
            Some(tick) if tick < t + h => {
                let end = t + h;
                return inst.refuse(func, format_args!("the step to {end} s passes the clock tick at {tick} s: with eventModeUsed and without earlyReturnAllowed a step ends at the next tick at the latest (fmi3GetIntervalDecimal)"));
            }
            _ => (t + h, Ending::default()),
        };
        // The step before ended at a tick the importer stepped past without entering
        // event mode: the tick runs here, before the step, as it would have in the event.
        let mut status = OK;
        if inst.modes.event_mode && std::mem::take(&mut inst.tick_pending) {
            status = super::clocks::run_unhandled_ticks(inst, func);
            if status > WARNING {
                return status;
            }
            super::clocks::leave_event(inst);
        }
        let result = match inst.modes.event_mode {
            true => inst.with_step_log(|model, log| model.step_between_ticks(t, end - t, log)),
            false => inst.with_step_log(|model, log| model.do_step(t, h, log)),
        };
        match result {
            Ok(()) => {
                // The master's clock is the reference: following it keeps t and the FMU
                // time equal however the master accumulates it.
                inst.time = end;
                inst.tick_pending = ending.event;
                if let Some(o) = &outputs {
                    o.report(ending, inst.time);
                }
                let status = status.max(inst.report_step_log(func));
                inst.last_step_status = status;
                status
            }
            Err(why) => {
                inst.state = State::Error;
                inst.last_step_status = ERROR;
                if let Some(o) = &outputs {
                    o.report(Ending { terminate: true, ..Ending::default() }, inst.time);
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
    /// warned. Most steps report nothing: checked inline, the log drained in a cold
    /// function.
    #[inline(always)]
    pub(super) fn report_step_log(&mut self, func: &str) -> Status {
        match self.step_log.messages().is_empty() {
            true => OK,
            false => self.drain_step_log(func),
        }
    }

    #[cold]
    #[inline(never)]
    fn drain_step_log(&mut self, func: &str) -> Status {
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
