//! FMI 3.0 clocks (section 2.2.8): input clocks the importer activates (`fmi3SetClock` in
//! event mode, `fmi3ActivateModelPartition` in Scheduled Execution), output clocks the
//! model ticks (`fmi3GetClock`, and Scheduled Execution's `clockUpdate` callback), their
//! intervals, and where a Co-Simulation step with `eventModeUsed` ends. A model has clocks
//! when its table has [`Kind::Clock`] rows; FMI 2.0 instances never reach this file.

use std::ffi::c_void;

use super::call::{slice, slice_mut, with_instance};
use super::time::same_time;
use crate::instance::*;
use crate::state::*;
use crate::table::{Causality, ClockKind, Kind, Variable};
use crate::{Access, Model};

/// The model's clock rows.
fn clocks<M: Model>() -> impl Iterator<Item = &'static crate::Row<M>> {
    M::table().iter().filter(|r| r.var.kind == Kind::Clock)
}

/// Whether the model declares clocks: then its FMI 3.0 description has `hasEventMode` and
/// `<ScheduledExecution>`, and its instances may use either.
pub fn has_clocks<M: Model>() -> bool {
    clocks::<M>().next().is_some()
}

/// The clock row behind `vr`, or why there is none.
fn clock_row<M: Model>(vr: u32) -> Result<&'static crate::Row<M>, String> {
    clocks::<M>()
        .find(|r| r.var.vr == vr)
        .ok_or_else(|| format!("value reference {vr} is not a clock of this FMU"))
}

/// The interval of an input clock (`None` for an output clock).
fn interval(v: &Variable) -> Option<f64> {
    match v.clock {
        Some(ClockKind::Periodic { interval }) => Some(interval),
        _ => None,
    }
}

/// An input clock's row behind `vr` (the one kind an importer activates), or why not.
fn input_clock<M: Model>(vr: u32) -> Result<(&'static Variable, f64), String> {
    let row = clock_row::<M>(vr)?;
    let v = &row.var;
    match (v.causality, interval(v)) {
        (Causality::Input, Some(dt)) => Ok((v, dt)),
        _ => Err(format!(
            "{} (value reference {vr}) is an output clock: the FMU ticks it and fmi3GetClock reads it; only an input clock is activated",
            v.name
        )),
    }
}

/// Whether `t` is a tick `start + n × dt` (n = 0, 1, …, counted as the models count
/// their instants) up to the layer's rounding.
fn is_tick(start: f64, dt: f64, t: f64) -> bool {
    let n = ((t - start) / dt).round();
    n >= 0.0 && same_time(start + n * dt, t)
}

/// Refuses an activation of `v` at `t` that is not one of its ticks.
fn check_tick(v: &Variable, dt: f64, start: f64, t: f64) -> Result<(), String> {
    match is_tick(start, dt, t) {
        true => Ok(()),
        false => Err(format!(
            "{} ticks at {start} s + n × {dt} s; {t} s is not one of its ticks",
            v.name
        )),
    }
}

/// The first tick of any input clock after `t` (not `t` itself, up to rounding).
pub(crate) fn next_tick<M: Model>(start: f64, t: f64) -> Option<f64> {
    clocks::<M>()
        .filter_map(|r| interval(&r.var))
        .filter_map(|dt| {
            let n = ((t - start) / dt).floor().max(0.0);
            (0..3)
                .map(|k| start + (n + f64::from(k)) * dt)
                .find(|&tick| tick > t && !same_time(tick, t))
        })
        .min_by(f64::total_cmp)
}

/// Whether an output clock of the model ticked.
fn any_output_ticked<M: Model>(model: &M) -> bool {
    clocks::<M>().any(|r| matches!(r.access, Access::Clock { ticked: Some(f) } if f(model)))
}

/// What an instantiation of a model without clocks refuses: event mode and Scheduled
/// Execution need them.
pub fn refusal<M: Model>(interface: Interface, modes: &Modes) -> Option<&'static str> {
    if has_clocks::<M>() {
        return None;
    }
    match interface {
        Interface::ScheduledExecution => {
            Some("not supported: this FMU has no Scheduled Execution interface")
        }
        Interface::CoSimulation if modes.event_mode => {
            Some("eventModeUsed requested, but this FMU has no event mode (hasEventMode=\"false\")")
        }
        _ => None,
    }
}

/// Whether the instance has an event mode: Model Exchange, and Co-Simulation instantiated
/// with `eventModeUsed`.
pub(crate) fn has_event_mode<S: Standard, M: Model>(inst: &Instance<S, M>) -> bool {
    match inst.interface {
        Interface::ModelExchange => true,
        Interface::CoSimulation => inst.modes.event_mode,
        Interface::ScheduledExecution => false,
    }
}

/// Why an instance without event mode refuses an event-mode call.
pub(crate) fn no_event_mode<M: Model>(interface: Interface) -> &'static str {
    match (interface, has_clocks::<M>()) {
        (Interface::ScheduledExecution, _) => "a Scheduled Execution instance has no event mode: its importer activates model partitions (fmi3ActivateModelPartition)",
        (_, true) => "this Co-Simulation instance was instantiated without eventModeUsed, so it has no event mode",
        (_, false) => "a Co-Simulation instance has no event mode (hasEventMode is false) and no continuous states",
    }
}

/// `fmi3SetClock`: activates (or deactivates) input clocks in event mode, at one of their
/// ticks. Every reference and value is checked before any clock is activated.
pub unsafe fn set_clock<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    (vr, n): (*const u32, usize),
    values: *const u8,
) -> Status {
    if !has_clocks::<M>() {
        return super::values::no_variables_of::<S, M>(c, func, LIVE, "Clock", (vr, n), false);
    }
    with_instance::<S, M>(c, func, LIVE, |inst| {
        if !has_event_mode(inst) {
            let why = no_event_mode::<M>(inst.interface);
            return inst.refuse(func, format_args!("not supported: {why}"));
        }
        if inst.state != State::EventMode {
            let state = S::state_name(inst.state);
            let why = format_args!("illegal call sequence: not allowed in state {state}");
            return inst.refuse(func, why);
        }
        let (Some(vrs), Some(values)) = (slice(vr, n), slice(values, n)) else {
            return inst.refuse(func, format_args!("valueReferences or values is NULL"));
        };
        for (&r, &on) in vrs.iter().zip(values) {
            let checked = input_clock::<M>(r).and_then(|(v, dt)| match on {
                0 => Ok(()),
                1 => check_tick(v, dt, inst.start_time, inst.time),
                b => {
                    Err(format!("{} = {b} refused: a clock is 0 (inactive) or 1 (active)", v.name))
                }
            });
            if let Err(why) = checked {
                return inst.refuse(func, format_args!("{why}"));
            }
        }
        for (&r, &on) in vrs.iter().zip(values) {
            inst.active_clocks.retain(|&a| a != r);
            if on == 1 {
                inst.active_clocks.push(r);
            }
        }
        OK
    })
}

/// `fmi3GetClock`: an input clock reads whether it is active in this event; an output
/// clock whether the model ticked it. In Scheduled Execution the importer reads output
/// clocks after `clockUpdate`, and reading them deactivates them.
pub unsafe fn get_clock<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    (vr, n): (*const u32, usize),
    values: *mut bool,
) -> Status {
    if !has_clocks::<M>() {
        return super::values::no_variables_of::<S, M>(c, func, LIVE, "Clock", (vr, n), false);
    }
    with_instance::<S, M>(c, func, LIVE, |inst| {
        if inst.state as u16 & CLOCK_READABLE == 0 {
            let state = S::state_name(inst.state);
            let why = format_args!("illegal call sequence: not allowed in state {state}");
            return inst.refuse(func, why);
        }
        let (Some(vrs), Some(out)) = (slice(vr, n), slice_mut(values, n)) else {
            return inst.refuse(func, format_args!("valueReferences or values is NULL"));
        };
        let mut read_output = false;
        for (&r, out) in vrs.iter().zip(out.iter_mut()) {
            match clock_row::<M>(r) {
                Ok(row) => match row.access {
                    Access::Clock { ticked: Some(f) } => {
                        *out = f(&inst.model);
                        read_output = true;
                    }
                    _ => *out = inst.active_clocks.contains(&r),
                },
                Err(why) => return inst.refuse(func, format_args!("{why}")),
            }
        }
        if read_output && inst.interface == Interface::ScheduledExecution {
            inst.model.clear_output_clocks();
        }
        OK
    })
}

/// `fmi3GetIntervalDecimal`: an input clock's interval (a constant of the description,
/// `intervalVariability="constant"`), with the qualifier `unchanged`: FMI 3.0 allows no
/// other for a constant clock (its table of clock types and qualifiers: the importer knows
/// the interval from the description, and neither side can change it; `fmi3IntervalChanged`
/// with a constant clock is listed as not allowed). An output clock has no interval.
pub unsafe fn get_interval<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    (vr, n): (*const u32, usize),
    (intervals, qualifiers): (*mut f64, *mut i32),
    unchanged: i32,
) -> Status {
    with_instance::<S, M>(c, func, INTERVALS, |inst| {
        let (Some(vrs), Some(iv), Some(q)) =
            (slice(vr, n), slice_mut(intervals, n), slice_mut(qualifiers, n))
        else {
            return inst
                .refuse(func, format_args!("valueReferences, intervals or qualifiers is NULL"));
        };
        for (i, &r) in vrs.iter().enumerate() {
            match input_clock::<M>(r) {
                Ok((_, dt)) => (iv[i], q[i]) = (dt, unchanged),
                Err(why) => return inst.refuse(func, format_args!("{why}")),
            }
        }
        OK
    })
}

/// `fmi3GetShiftDecimal`: an input clock's first tick is the start time (shift 0).
pub unsafe fn get_shift<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    (vr, n): (*const u32, usize),
    shifts: *mut f64,
) -> Status {
    with_instance::<S, M>(c, func, INTERVALS, |inst| {
        let (Some(vrs), Some(out)) = (slice(vr, n), slice_mut(shifts, n)) else {
            return inst.refuse(func, format_args!("valueReferences or shifts is NULL"));
        };
        for (&r, out) in vrs.iter().zip(out.iter_mut()) {
            match input_clock::<M>(r) {
                Ok(_) => *out = 0.0,
                Err(why) => return inst.refuse(func, format_args!("{why}")),
            }
        }
        OK
    })
}

/// `fmi3SetInterval*`, `fmi3SetShift*`, `fmi3GetIntervalFraction`, `fmi3GetShiftFraction`:
/// refused with the reason.
pub unsafe fn constant_intervals<S: Standard, M: Model>(c: *mut c_void, func: &str) -> Status {
    let why = match has_clocks::<M>() {
        true => "the clocks' intervals and shifts are constants of the model description (intervalVariability=\"constant\"), read with fmi3GetIntervalDecimal and fmi3GetShiftDecimal",
        false => "this FMU has no clocks",
    };
    super::call::unsupported::<S, M>(c, func, LIVE, why)
}

/// `fmi3EnterStepMode`: a Co-Simulation instance with event mode leaves it once every
/// input clock ticking now has run its partition; the clocks of the event are deactivated.
pub unsafe fn enter_step_mode<S: Standard, M: Model>(c: *mut c_void, func: &str) -> Status {
    with_instance::<S, M>(c, func, LIVE, |inst| {
        if inst.interface != Interface::CoSimulation || !inst.modes.event_mode {
            let why = match inst.interface {
                Interface::CoSimulation if !has_clocks::<M>() => "hasEventMode is false, so the FMU is never in event mode (fmi3ExitInitializationMode enters step mode)",
                _ => "fmi3EnterStepMode is for a Co-Simulation instance with eventModeUsed",
            };
            return inst.refuse(func, format_args!("not supported: {why}"));
        }
        if inst.state != State::EventMode {
            let state = S::state_name(inst.state);
            let why = format_args!("illegal call sequence: not allowed in state {state}");
            return inst.refuse(func, why);
        }
        let status = run_unhandled_ticks(inst, func);
        if status > WARNING {
            return status;
        }
        leave_event(inst);
        inst.state = State::StepComplete;
        status
    })
}

/// Runs the partitions of the input clocks that tick at the instance's time and have not
/// run in this event, and returns the status of the call that found them: OK, or what
/// the partitions reported. A time-based clock is the importer's to activate at each of
/// its ticks (FMI 3.0 section 2.2.8.2: `fmi3SetClock`, then `fmi3UpdateDiscreteStates`),
/// and with `eventModeUsed` the model computes its clocked variables only then
/// (`step_between_ticks`). An importer that does not (one that leaves the event without
/// activating, or steps on past `eventHandlingNeeded` without entering event mode) would
/// otherwise hold them silently; so the FMU runs the tick itself, with the inputs it has,
/// as a Co-Simulation instance without `eventModeUsed` runs it inside `fmi3DoStep`. The
/// first such tick of an instance is logged with fmi3Warning, with its time and what the
/// importer skipped; the call still returns OK, since the FMU did compute the tick (an
/// importer that stops at a Warning, as fmusim does, would otherwise not run at all).
pub(crate) fn run_unhandled_ticks<S: Standard, M: Model>(
    inst: &mut Instance<S, M>,
    func: &str,
) -> Status {
    let (start, t) = (inst.start_time, inst.time);
    let inputs = clocks::<M>()
        .filter(|r| r.var.causality == Causality::Input)
        .filter_map(|r| interval(&r.var).map(|dt| (&r.var, dt)));
    let mut status = OK;
    for (v, dt) in inputs {
        if !is_tick(start, dt, t) || inst.ran_clocks.contains(&v.vr) {
            continue;
        }
        if inst.unhandled_ticks == 0 {
            let why = format_args!(
                "{func}: {name} ticks at {t} s and the importer did not activate it (fmi3SetClock, then fmi3UpdateDiscreteStates, before leaving the event: FMI 3.0 section 2.2.8.2); the FMU runs the tick itself, with the inputs it has, as a Co-Simulation instance without eventModeUsed does in fmi3DoStep. Logged for the first such tick of this instance only",
                name = v.name
            );
            inst.log(WARNING, LogCategory::StatusWarning, why);
        }
        inst.unhandled_ticks += 1;
        inst.model.clear_output_clocks();
        match inst.with_step_log(|model, log| model.activate_clock(v.vr, t, log)) {
            Ok(()) => {
                inst.ran_clocks.push(v.vr);
                status = status.max(inst.report_step_log(func));
            }
            Err(why) => {
                inst.state = State::Error;
                return inst.refuse(func, format_args!("{why}"));
            }
        }
    }
    status
}

/// Deactivates the event's clocks, input and output.
pub(crate) fn leave_event<S: Standard, M: Model>(inst: &mut Instance<S, M>) {
    inst.active_clocks.clear();
    inst.ran_clocks.clear();
    inst.model.clear_output_clocks();
}

/// `f` with the model, the step log and the input clocks activated since the last event
/// update, which it runs (once per activation: the list is empty afterwards) and which
/// count as run in this event.
pub(crate) fn run_activated<S: Standard, M: Model, T>(
    inst: &mut Instance<S, M>,
    f: impl FnOnce(&mut M, &mut crate::StepLog, &[u32]) -> T,
) -> T {
    let mut active = std::mem::take(&mut inst.active_clocks);
    let result = inst.with_step_log(|model, log| f(model, log, &active));
    for &clock in &active {
        if !inst.ran_clocks.contains(&clock) {
            inst.ran_clocks.push(clock);
        }
    }
    // The list's capacity is kept, so an activation allocates nothing.
    active.clear();
    inst.active_clocks = active;
    result
}

/// `fmi3ActivateModelPartition`: one tick of an input clock's partition in Scheduled
/// Execution. The time must be a tick of the clock and not precede the last activation.
/// The partition runs with preemption locked (the scheduler's `lockPreemption` before,
/// `unlockPreemption` after); when it ticks an output clock, the FMU calls `clockUpdate`
/// after the partition, outside its own call's lock on the instance, so that the importer
/// may call back into it from there.
pub unsafe fn activate_model_partition<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    clock: u32,
    t: f64,
) -> Status {
    let mut update = None;
    let status = with_instance::<S, M>(c, func, LIVE, |inst| {
        if inst.interface != Interface::ScheduledExecution {
            let why = "fmi3ActivateModelPartition is for an instance of Scheduled Execution (fmi3InstantiateScheduledExecution)";
            return inst.refuse(func, format_args!("not supported: {why}"));
        }
        if inst.state != State::ClockActivationMode {
            let state = S::state_name(inst.state);
            let why = format_args!("illegal call sequence: not allowed in state {state}");
            return inst.refuse(func, why);
        }
        let (v, dt) = match input_clock::<M>(clock) {
            Ok(found) => found,
            Err(why) => return inst.refuse(func, format_args!("{why}")),
        };
        if !t.is_finite() {
            return inst.refuse(func, format_args!("activationTime {t} is not finite"));
        }
        if let Some(last) = inst.last_activation.filter(|&l| t < l && !same_time(t, l)) {
            return inst.refuse(func, format_args!("activationTime {t} s precedes the last activation at {last} s (time does not run backwards)"));
        }
        if let Some(stop) = inst.stop_time.filter(|&s| t > s && !same_time(t, s)) {
            let at = S::EXPERIMENT_FN;
            return inst.refuse(
                func,
                format_args!("an activation at {t} s is past the stop time {stop} set in {at}"),
            );
        }
        let checked = check_tick(v, dt, inst.start_time, t).and_then(|()| inst.model.check_time(t));
        if let Err(why) = checked {
            return inst.refuse(func, format_args!("{why}"));
        }
        let scheduler = inst.modes.scheduler;
        let lock = scheduler.and_then(|s| s.lock);
        let unlock = scheduler.and_then(|s| s.unlock);
        if let Some(lock) = lock {
            lock();
        }
        inst.model.clear_output_clocks();
        let result = inst.with_step_log(|model, log| model.activate_clock(clock, t, log));
        if let Some(unlock) = unlock {
            unlock();
        }
        match result {
            Ok(()) => {
                (inst.time, inst.last_activation) = (t, Some(t));
                if any_output_ticked(&inst.model) {
                    update = scheduler.and_then(|s| s.clock_update.map(|f| (f, s.env)));
                }
                inst.report_step_log(func)
            }
            Err(why) => {
                inst.state = State::Error;
                inst.refuse(func, format_args!("{why}"))
            }
        }
    });
    if let Some((clock_update, env)) = update {
        clock_update(env);
    }
    status
}
