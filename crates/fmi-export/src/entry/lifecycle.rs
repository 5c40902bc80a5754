//! Creating, initializing, terminating, resetting and freeing an instance, and its debug
//! logging (FMI 2.0 sections 2.1.5-2.1.6, FMI 3.0 sections 2.3.1-2.3.4).

use std::ffi::{c_void, CStr};
use std::fmt;
use std::os::raw::c_char;
use std::panic::{catch_unwind, AssertUnwindSafe};

use super::call::{slice, text, with_instance};
use crate::instance::*;
use crate::state::*;
use crate::{model_description, registry, Model};

/// Logs through the master's callback before an instance exists.
fn log_early<S: Standard>(cb: &S::Callbacks, name: *const c_char, func: &str, why: fmt::Arguments) {
    // SAFETY: a non-NULL name is the master's C string.
    let name = (!name.is_null()).then(|| unsafe { CStr::from_ptr(name) });
    emit::<S>(cb, name, ERROR, LogCategory::StatusError, format_args!("{func}: {why}"));
}

/// Creates an instance of `interface` after checking its name, the interface-specific
/// `refusal` the standard's glue found, that the model has the interface, and the token,
/// which must be this build's GUID.
pub unsafe fn instantiate<S: Standard, M: Model>(
    func: &str,
    callbacks: Option<S::Callbacks>,
    name: *const c_char,
    token: *const c_char,
    (interface, modes, refusal): (Interface, Modes, Option<&str>),
    logging_on: bool,
) -> *mut c_void {
    let result = catch_unwind(AssertUnwindSafe(|| {
        let Some(cb) = callbacks else { return std::ptr::null_mut() };
        let fail = |why: fmt::Arguments| {
            log_early::<S>(&cb, name, func, why);
            std::ptr::null_mut()
        };
        if name.is_null() || *name == 0 {
            return fail(format_args!("instanceName is NULL or empty"));
        }
        if let Some(why) = refusal {
            return fail(format_args!("{why}"));
        }
        if interface == Interface::ModelExchange && M::model_exchange().is_none() {
            return fail(format_args!("not supported: this FMU implements Co-Simulation only"));
        }
        if let Some(why) = super::clocks::refusal::<M>(interface, &modes) {
            return fail(format_args!("{why}"));
        }
        let (arg, guid) = (S::TOKEN_ARG, model_description::guid::<M>());
        if token.is_null() {
            return fail(format_args!("{arg} is NULL"));
        }
        let given = text(token);
        if given != guid {
            let given = Clip(&given);
            return fail(format_args!("{arg} \"{given}\" does not match this FMU's \"{guid}\" (modelDescription.xml from another build?)"));
        }
        let name = CStr::from_ptr(name).to_owned();
        let inst = Box::into_raw(Box::new(Instance::<S, M>::new(
            name,
            cb,
            (interface, modes),
            logging_on,
        )));
        registry::register(inst);
        inst as *mut c_void
    }));
    result.unwrap_or(std::ptr::null_mut())
}

/// Frees the instance, after the totals of its inputs' clamps if no Terminate or Reset
/// logged them (the master's logger is valid until this call returns).
pub unsafe fn free_instance<S: Standard, M: Model>(c: *mut c_void, func: &str) {
    let c = c as *mut Instance<S, M>;
    // Out of the registry first: a second free, or a call racing this one's end, finds
    // nothing to read.
    if c.is_null() || !registry::unregister(c) {
        return;
    }
    // Dropping a model only frees memory; a panic there must still not unwind into C.
    let _ = catch_unwind(AssertUnwindSafe(|| {
        let mut inst = Box::from_raw(c);
        inst.summarize_clamps(func);
    }));
}

/// FMI 2.0 section 2.1.5, kept by FMI 3.0 section 2.3.1: on with no categories enables
/// all of them; on with categories enables exactly those; off with categories disables
/// those; off with none disables all. A NULL or unknown name refuses the whole call and
/// changes nothing, so a master's typo cannot leave half of its request applied.
pub unsafe fn set_debug_logging<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    on: bool,
    n: usize,
    categories: *const *const c_char,
) -> Status {
    with_instance::<S, M>(c, func, LIVE, |inst| {
        let Some(names) = slice(categories, n) else {
            return inst.refuse(func, format_args!("categories is NULL"));
        };
        let mut named = Categories::NONE;
        for &p in names {
            if p.is_null() {
                let why = format_args!("a category name is NULL; logging left unchanged");
                return inst.refuse(func, why);
            }
            match LogCategory::from_name(CStr::from_ptr(p).to_bytes()) {
                Some(cat) => named = named.with(cat),
                None => {
                    let (name, known) = (text(p), KnownCategories);
                    let name = Clip(&name);
                    return inst.refuse(func, format_args!("unknown log category \"{name}\" (this FMU has {known}); logging left unchanged"));
                }
            }
        }
        inst.categories = match (on, names.is_empty()) {
            (true, true) => Categories::ALL,
            (true, false) => named,
            (false, true) => Categories::NONE,
            (false, false) => inst.categories.without(named),
        };
        OK
    })
}

struct KnownCategories;

impl fmt::Display for KnownCategories {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, c) in LogCategory::ALL.iter().enumerate() {
            write!(f, "{}{}", if i == 0 { "" } else { ", " }, c.name())?;
        }
        Ok(())
    }
}

/// The experiment: a finite start, and a stop time, if any, not before it.
fn experiment<S: Standard, M: Model>(
    inst: &mut Instance<S, M>,
    func: &str,
    start: f64,
    stop: Option<f64>,
) -> Status {
    if !start.is_finite() {
        return inst.refuse(func, format_args!("startTime {start} is not finite"));
    }
    if let Some(stop) = stop.filter(|&s| !s.is_finite() || s < start) {
        let why = format_args!("stopTime {stop} is not finite or before startTime {start}");
        return inst.refuse(func, why);
    }
    (inst.start_time, inst.time, inst.stop_time) = (start, start, stop);
    OK
}

pub unsafe fn setup_experiment<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    start: f64,
    stop: Option<f64>,
) -> Status {
    with_instance::<S, M>(c, func, INSTANTIATED, |inst| experiment(inst, func, start, stop))
}

/// Enters initialization mode, with the experiment if the standard passes it here.
pub unsafe fn enter_initialization<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    exp: Option<(f64, Option<f64>)>,
) -> Status {
    with_instance::<S, M>(c, func, INSTANTIATED, |inst| {
        if let Some((start, stop)) = exp {
            if experiment(inst, func, start, stop) != OK {
                return ERROR;
            }
        }
        inst.state = State::InitializationMode;
        OK
    })
}

/// Without event mode, FMI 3.0 Co-Simulation goes straight to Step Mode, which is the
/// core's StepComplete; with it (`eventModeUsed`), and Model Exchange of both standards, to
/// EventMode (the start time is a tick of every periodic clock); Scheduled Execution to
/// ClockActivationMode.
pub unsafe fn exit_initialization<S: Standard, M: Model>(c: *mut c_void, func: &str) -> Status {
    with_instance::<S, M>(c, func, INITIALIZATION, |inst| {
        let me = inst.interface == Interface::ModelExchange;
        let exit = inst.model.exit_initialization(inst.start_time);
        match exit.and_then(|()| if me { inst.model.enter_model_exchange() } else { Ok(()) }) {
            Ok(()) => {
                inst.state = match inst.interface {
                    Interface::CoSimulation if inst.modes.event_mode => State::EventMode,
                    Interface::CoSimulation => State::StepComplete,
                    Interface::ModelExchange => State::EventMode,
                    Interface::ScheduledExecution => State::ClockActivationMode,
                };
                OK
            }
            Err(why) => {
                inst.state = State::Error;
                inst.refuse(func, format_args!("{why}"))
            }
        }
    })
}

/// Terminates, with the totals of the inputs' clamps that were only counted.
pub unsafe fn terminate<S: Standard, M: Model>(c: *mut c_void, func: &str) -> Status {
    with_instance::<S, M>(c, func, TERMINABLE, |inst| {
        inst.state = State::Terminated;
        inst.summarize_clamps(func)
    })
}

/// Back to Instantiated; the clamps of the run that ends are summed up if Terminate did
/// not, and counted anew.
pub unsafe fn reset<S: Standard, M: Model>(c: *mut c_void, func: &str) -> Status {
    with_instance::<S, M>(c, func, LIVE, |inst| {
        let status = inst.summarize_clamps(func);
        inst.model = M::new();
        inst.state = State::Instantiated;
        (inst.time, inst.start_time, inst.stop_time) = (0.0, 0.0, None);
        inst.last_step_status = OK;
        inst.active_clocks.clear();
        inst.ran_clocks.clear();
        inst.last_activation = None;
        (inst.tick_pending, inst.unhandled_ticks) = (false, 0);
        for c in inst.clamps.iter_mut() {
            (c.count, c.logged, c.summarized) = (0, 0, 0);
        }
        status
    })
}
