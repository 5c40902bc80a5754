//! Model Exchange (FMI 2.0 chapter 3, FMI 3.0 chapter 3): time, continuous states,
//! derivatives, event indicators, event mode and directional derivatives.

use std::ffi::c_void;

use super::call::{slice, slice_mut, with_instance};
use super::clocks::{has_event_mode, leave_event, next_tick, no_event_mode, run_activated};
use super::time::same_time;
use super::values::read_row;
use crate::instance::*;
use crate::state::*;
use crate::table::Kind;
use crate::{EventUpdate, Model};

/// The model's Model Exchange declaration. Only reached through an instance of that
/// interface, which [`instantiate`] creates only for a model that has one.
fn me<M: Model>() -> &'static crate::ModelExchange {
    const NONE: crate::ModelExchange =
        crate::ModelExchange { states: &[], event_indicators: &[], directional_derivatives: false };
    M::model_exchange().unwrap_or(&NONE)
}

/// Runs `body` on a Model Exchange instance in one of the `allowed` states.
unsafe fn with_me<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    allowed: u16,
    body: impl FnOnce(&mut Instance<S, M>) -> Status,
) -> Status {
    with_instance::<S, M>(c, func, LIVE, |inst| {
        if inst.interface != Interface::ModelExchange {
            let why = "a Co-Simulation instance has no event mode (hasEventMode is false) and no continuous states";
            return inst.refuse(func, format_args!("not supported: {why}"));
        }
        if inst.state as u16 & allowed == 0 {
            let state = S::state_name(inst.state);
            let why = format_args!("illegal call sequence: not allowed in state {state}");
            return inst.refuse(func, why);
        }
        body(inst)
    })
}

/// The four arrays of Model Exchange, each in the order of its declaration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Array {
    States,
    Derivatives,
    EventIndicators,
    Nominals,
}

impl Array {
    fn len<M: Model>(self) -> usize {
        match self {
            Array::EventIndicators => me::<M>().event_indicators.len(),
            _ => me::<M>().states.len(),
        }
    }
    fn allowed(self) -> u16 {
        match self {
            Array::Nominals => NOMINALS,
            _ => ME_READABLE,
        }
    }
    fn what(self) -> &'static str {
        match self {
            Array::States => "continuous states",
            Array::Derivatives => "state derivatives",
            Array::EventIndicators => "event indicators",
            Array::Nominals => "nominals of continuous states",
        }
    }
}

/// Refuses an array whose length is not the model's count.
fn check_len<S: Standard, M: Model>(
    inst: &Instance<S, M>,
    func: &str,
    array: Array,
    n: usize,
) -> Result<(), Status> {
    let want = array.len::<M>();
    if n == want {
        return Ok(());
    }
    let what = array.what();
    Err(inst.refuse(func, format_args!("{n} {what} asked for, this FMU has {want}")))
}

/// `Get*` of one Model Exchange array.
pub unsafe fn get_array<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    array: Array,
    (out, n): (*mut f64, usize),
) -> Status {
    with_me::<S, M>(c, func, array.allowed(), |inst| {
        if let Err(s) = check_len(inst, func, array, n) {
            return s;
        }
        let Some(out) = slice_mut(out, n) else {
            return inst.refuse(func, format_args!("the array of {} is NULL", array.what()));
        };
        // The array in one evaluation if the model computes it whole; a value that is not
        // finite is refused below, through its row, by name.
        if inst.model.me_array(array, out) && out.iter().all(|v| v.is_finite()) {
            return OK;
        }
        let decl = me::<M>();
        for (i, out) in out.iter_mut().enumerate() {
            let vr = match array {
                Array::States => decl.states[i].value,
                Array::Derivatives => decl.states[i].derivative,
                Array::EventIndicators => decl.event_indicators[i],
                Array::Nominals => {
                    *out = decl.states[i].nominal;
                    continue;
                }
            };
            let value = match inst.indexed(vr) {
                Some(entry) => inst.rows_of(entry).first().map(|row| read_row(row, &inst.model)),
                None => None,
            };
            match value {
                Some(Ok(v)) => *out = v.real(),
                Some(Err(why)) => return inst.refuse(func, format_args!("{why}")),
                None => return inst.refuse(func, format_args!("value reference {vr} of the Model Exchange declaration is not in the table")),
            }
        }
        OK
    })
}

/// FMI 3.0's `fmi3GetNumberOf*`.
pub unsafe fn get_count<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    array: Array,
    out: *mut usize,
) -> Status {
    with_me::<S, M>(c, func, LIVE, |inst| {
        if out.is_null() {
            return inst.refuse(func, format_args!("the count's pointer is NULL"));
        }
        *out = array.len::<M>();
        OK
    })
}

pub unsafe fn set_time<S: Standard, M: Model>(c: *mut c_void, func: &str, t: f64) -> Status {
    with_me::<S, M>(c, func, TIMED, |inst| {
        if !t.is_finite() {
            return inst.refuse(func, format_args!("time {t} is not finite"));
        }
        // A time past the stop time is taken: integrators evaluate their last step past the
        // end and interpolate back (FMPy's CVode does). The event update refuses it.
        if let Err(why) = inst.model.check_time(t) {
            return inst.refuse(func, format_args!("{why}"));
        }
        inst.time = t;
        inst.model.set_time(t);
        OK
    })
}

/// The integrator's states: all finite or none taken, so a diverging integrator leaves
/// the model at its last consistent states (the rule of NaN inputs).
pub unsafe fn set_continuous_states<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    (x, n): (*const f64, usize),
) -> Status {
    with_me::<S, M>(c, func, CONTINUOUS_TIME, |inst| {
        if let Err(s) = check_len(inst, func, Array::States, n) {
            return s;
        }
        let Some(x) = slice(x, n) else {
            return inst.refuse(func, format_args!("the array of continuous states is NULL"));
        };
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            let name = inst.variable(me::<M>().states[i].value).map_or("?", |v| v.0.name);
            let why = format_args!(
                "state {i} ({name}) = {} refused: continuous states must be finite; keeping all",
                x[i]
            );
            return inst.refuse(func, why);
        }
        match inst.model.set_continuous_states(x) {
            Ok(()) => OK,
            Err(why) => inst.refuse(func, format_args!("{why}")),
        }
    })
}

/// Runs `body` on an instance with event mode (Model Exchange, or Co-Simulation with
/// `eventModeUsed`) in one of the states `allowed` for its interface.
unsafe fn with_events<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    (me, cs): (u16, u16),
    body: impl FnOnce(&mut Instance<S, M>) -> Status,
) -> Status {
    with_instance::<S, M>(c, func, LIVE, |inst| {
        if !has_event_mode(inst) {
            let why = no_event_mode::<M>(inst.interface);
            return inst.refuse(func, format_args!("not supported: {why}"));
        }
        let allowed = if inst.interface == Interface::ModelExchange { me } else { cs };
        if inst.state as u16 & allowed == 0 {
            let state = S::state_name(inst.state);
            let why = format_args!("illegal call sequence: not allowed in state {state}");
            return inst.refuse(func, why);
        }
        body(inst)
    })
}

/// Model Exchange enters event mode from continuous-time mode, Co-Simulation with event
/// mode from step mode (after a step that ended at a tick, or on the importer's own
/// account); both are allowed in event mode too.
pub unsafe fn enter_event_mode<S: Standard, M: Model>(c: *mut c_void, func: &str) -> Status {
    with_events::<S, M>(c, func, (TIMED, STEPPING | EVENT_MODE), |inst| {
        inst.tick_pending = false;
        inst.state = State::EventMode;
        OK
    })
}

pub unsafe fn enter_continuous_time_mode<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
) -> Status {
    with_me::<S, M>(c, func, EVENT_MODE, |inst| {
        leave_event(inst);
        inst.state = State::ContinuousTimeMode;
        OK
    })
}

/// The model has no step events and never ends the simulation: both flags false.
pub unsafe fn completed_integrator_step<S: Standard, M: Model, B: Copy>(
    c: *mut c_void,
    func: &str,
    (enter_event_mode, terminate): (*mut B, *mut B),
    no: B,
) -> Status {
    with_me::<S, M>(c, func, CONTINUOUS_TIME, |inst| {
        if enter_event_mode.is_null() || terminate.is_null() {
            let why = "enterEventMode or terminateSimulation is NULL";
            return inst.refuse(func, format_args!("{why}"));
        }
        (*enter_event_mode, *terminate) = (no, no);
        OK
    })
}

/// Where a standard wants the outcome of one event-mode update: FMI 2.0's
/// `fmi2EventInfo`, FMI 3.0's six pointers.
pub trait EventSink {
    fn any_null(&self) -> bool;
    /// Writes the update; `terminate` is true only when the model failed.
    ///
    /// # Safety
    /// [`EventSink::any_null`] is false.
    unsafe fn write(&self, u: &EventUpdate, terminate: bool);
}

/// One pass of the event iteration at the instance's time: the partitions of the input
/// clocks activated since the last pass (once per activation), then Model Exchange's
/// update. The model reaches its fixed point in one update, so the master is never asked
/// for another. A Co-Simulation instance's next event is its clocks' next tick.
pub unsafe fn update_discrete_states<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    out: impl EventSink,
) -> Status {
    with_events::<S, M>(c, func, (EVENT_MODE, EVENT_MODE), |inst| {
        if out.any_null() {
            return inst.refuse(func, format_args!("an argument for the event's outcome is NULL"));
        }
        let t = inst.time;
        // The stop time holds in Model Exchange as in a step (FMI 2.0 section 2.1.6, FMI
        // 3.0 section 2.3.2 allow an error for computing past a defined stop time): the
        // update is the computation whose results a master keeps.
        if let Some(stop) = inst.stop_time.filter(|&s| t > s && !same_time(t, s)) {
            let at = S::EXPERIMENT_FN;
            return inst.refuse(
                func,
                format_args!("an event update at {t} s is past the stop time {stop} set in {at}"),
            );
        }
        let (me, next) =
            (inst.interface == Interface::ModelExchange, next_tick::<M>(inst.start_time, t));
        let updated = run_activated(inst, |model, log, active| {
            for &clock in active {
                model.activate_clock(clock, t, log)?;
            }
            match me {
                true => model.update_discrete_states(t, log),
                false => Ok(EventUpdate { states_changed: false, next_event_time: next }),
            }
        });
        match updated {
            Ok(update) => {
                out.write(&update, false);
                inst.report_step_log(func)
            }
            Err(why) => {
                inst.state = State::Error;
                out.write(&EventUpdate::default(), true);
                inst.refuse(func, format_args!("{why}"))
            }
        }
    })
}

/// `GetDirectionalDerivative(s)`: `sensitivity = J seed` over the given unknowns and
/// knowns, from the model's exact partial derivatives.
pub unsafe fn directional_derivative<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    (unknowns, nu): (*const u32, usize),
    (knowns, nk): (*const u32, usize),
    (seed, ns): (*const f64, usize),
    (out, no): (*mut f64, usize),
) -> Status {
    with_instance::<S, M>(c, func, GETTABLE, |inst| {
        if !M::model_exchange().is_some_and(|me| me.directional_derivatives) {
            let why = format_args!("not supported: {}", S::NO_DIRECTIONAL_DERIVATIVES);
            return inst.refuse(func, why);
        }
        if ns != nk || no != nu {
            let why = format_args!("{ns} seeds for {nk} knowns, {no} sensitivities for {nu} unknowns (every variable of this FMU is a scalar)");
            return inst.refuse(func, why);
        }
        let (Some(u), Some(k), Some(seed), Some(out)) =
            (slice(unknowns, nu), slice(knowns, nk), slice(seed, ns), slice_mut(out, no))
        else {
            return inst.refuse(func, format_args!("an array argument is NULL"));
        };
        for &vr in u.iter().chain(k) {
            if let Err(why) = inst.variable_of(vr, Kind::Real) {
                return inst.refuse(func, format_args!("{why}"));
            }
        }
        if let Some(s) = seed.iter().find(|s| !s.is_finite()) {
            return inst.refuse(func, format_args!("seed {s} is not finite"));
        }
        match inst.model.directional_derivative(u, k, seed, out) {
            Ok(()) => OK,
            Err(why) => inst.refuse(func, format_args!("{why}")),
        }
    })
}
