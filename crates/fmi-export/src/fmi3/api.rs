//! FMI 3.0: what the core needs from the standard beyond its facts ([`crate::Facts`]):
//! the logger call and the names of states and types ([`Fmi3`]); and its C functions,
//! each one line from its C signature to the generic body in [`crate::entry`].
//! [`crate::export_fmi3!`] exports them for one model; they are also callable here,
//! generic over the model, as `api::fmi3DoStep::<M>(…)`.
#![allow(
    non_snake_case,
    non_upper_case_globals,
    clippy::missing_safety_doc,
    clippy::too_many_arguments
)]

use std::os::raw::c_char;

use super::ffi::*;
use crate::entry::{
    self, Array, Booleans, EventSink, Integers, Reals, StepOutputs, GETTABLE, LIVE, SETTABLE,
};
use crate::instance::{Interface, Line, Modes, Scheduler, Standard, State};
use crate::{EventUpdate, Kind};

/// FMI 3.0 Co-Simulation without event mode, as the core sees it.
pub struct Fmi3;

impl Standard for Fmi3 {
    type Callbacks = (fmi3InstanceEnvironment, fmi3LogMessageCallback);

    fn state_name(s: State) -> &'static str {
        match s {
            State::StepComplete => "StepMode",
            other => other.name(),
        }
    }
    fn type_name(k: Kind) -> &'static str {
        type_name(k)
    }
    fn has_logger(cb: &Self::Callbacks) -> bool {
        cb.1.is_some()
    }
    /// The name is already in the message ([`crate::Facts::NAME_IN_MESSAGE`]).
    unsafe fn emit(cb: &Self::Callbacks, line: Line) {
        if let Some(logger) = cb.1 {
            logger(cb.0, line.status, line.category.as_ptr(), line.message.as_ptr());
        }
    }
}

/// FMI 3.0 type name of a table kind.
pub fn type_name(k: Kind) -> &'static str {
    match k {
        Kind::Real => "Float64",
        Kind::Integer => "Int32",
        Kind::Boolean => "Boolean",
        Kind::Clock => "Clock",
    }
}

pub fn fmi3GetVersion() -> *const c_char {
    fmi3Version.as_ptr() as *const c_char
}

/// What `fmi3InstantiateCoSimulation` refuses beyond the name, the token and event mode
/// ([`crate::entry::refusal`]).
fn cs_refusal(n_required: usize) -> Option<&'static str> {
    match n_required {
        0 => None,
        _ => Some(
            "requiredIntermediateVariables given, but this FMU provides no intermediate updates",
        ),
    }
}

/// A Co-Simulation instance's modes: with `eventModeUsed` its steps end at clock ticks;
/// with `earlyReturnAllowed` too, a step that would pass a tick returns early at it.
fn cs_modes(event_mode: bool, early_return: bool) -> Modes {
    Modes { event_mode, early_return, scheduler: None }
}

/// A Scheduled Execution instance's callbacks.
fn se_modes(
    env: fmi3InstanceEnvironment,
    clock_update: fmi3ClockUpdateCallback,
    lock: fmi3LockPreemptionCallback,
    unlock: fmi3UnlockPreemptionCallback,
) -> Modes {
    let scheduler = Scheduler { env, clock_update, lock, unlock };
    Modes { event_mode: false, early_return: false, scheduler: Some(scheduler) }
}

/// The six outputs of `fmi3UpdateDiscreteStates`.
pub struct EventOutputs {
    pub need_update: *mut fmi3Boolean,
    pub terminate: *mut fmi3Boolean,
    pub nominals_changed: *mut fmi3Boolean,
    pub values_changed: *mut fmi3Boolean,
    pub next_time_defined: *mut fmi3Boolean,
    pub next_time: *mut fmi3Float64,
}

impl EventSink for EventOutputs {
    fn any_null(&self) -> bool {
        [self.need_update, self.terminate, self.nominals_changed, self.values_changed]
            .into_iter()
            .chain([self.next_time_defined])
            .any(|p| p.is_null())
            || self.next_time.is_null()
    }
    unsafe fn write(&self, u: &EventUpdate, terminate: bool) {
        (*self.need_update, *self.terminate, *self.nominals_changed) = (false, terminate, false);
        *self.values_changed = u.states_changed;
        *self.next_time_defined = u.next_event_time.is_some();
        *self.next_time = u.next_event_time.unwrap_or(0.0);
    }
}

/// FMI 3.0's Booleans: written as C `bool`, read as bytes (a C bool the master filled with
/// another byte than 0 or 1 must not become an invalid Rust bool).
type Booleans3 = Booleans<fmi3Boolean, u8>;

const NO_DEPENDENCIES: &str = "providesPerElementDependencies is false (ModelStructure declares every output as depending on all inputs)";

/// Every FMI 3.0 function but `fmi3GetVersion`, for [`crate::__generic_entry_points!`]
/// and [`crate::__thunks!`].
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi3_entry_points { ($then:ident) => { $crate::$then! {
    fmi3SetDebugLogging(c: fmi3Instance, on: fmi3Boolean, n: usize, cats: *const fmi3String) -> fmi3Status = entry::set_debug_logging::<Fmi3, M>(c, F, on, n, cats);
    fmi3InstantiateModelExchange(name: fmi3String, token: fmi3String, res: fmi3String, visible: fmi3Boolean, logging: fmi3Boolean, env: fmi3InstanceEnvironment, log: fmi3LogMessageCallback) -> fmi3Instance = entry::instantiate::<Fmi3, M>(F, Some((env, log)), name, token, (Interface::ModelExchange, Modes::default(), None), logging);
    fmi3InstantiateCoSimulation(name: fmi3String, token: fmi3String, res: fmi3String, visible: fmi3Boolean, logging: fmi3Boolean, event_mode: fmi3Boolean, early: fmi3Boolean, req: *const fmi3ValueReference, nreq: usize, env: fmi3InstanceEnvironment, log: fmi3LogMessageCallback, update: fmi3IntermediateUpdateCallback) -> fmi3Instance = entry::instantiate::<Fmi3, M>(F, Some((env, log)), name, token, (Interface::CoSimulation, cs_modes(event_mode, early), cs_refusal(nreq)), logging);
    fmi3InstantiateScheduledExecution(name: fmi3String, token: fmi3String, res: fmi3String, visible: fmi3Boolean, logging: fmi3Boolean, env: fmi3InstanceEnvironment, log: fmi3LogMessageCallback, clock: fmi3ClockUpdateCallback, lock: fmi3LockPreemptionCallback, unlock: fmi3UnlockPreemptionCallback) -> fmi3Instance = entry::instantiate::<Fmi3, M>(F, Some((env, log)), name, token, (Interface::ScheduledExecution, se_modes(env, clock, lock, unlock), None), logging);
    fmi3FreeInstance(c: fmi3Instance) -> () = entry::free_instance::<Fmi3, M>(c, F);
    fmi3EnterInitializationMode(c: fmi3Instance, td: fmi3Boolean, tol: fmi3Float64, t0: fmi3Float64, sd: fmi3Boolean, t1: fmi3Float64) -> fmi3Status = entry::enter_initialization::<Fmi3, M>(c, F, Some((t0, sd.then_some(t1))));
    fmi3ExitInitializationMode(c: fmi3Instance) -> fmi3Status = entry::exit_initialization::<Fmi3, M>(c, F);
    fmi3EnterEventMode(c: fmi3Instance) -> fmi3Status = entry::enter_event_mode::<Fmi3, M>(c, F);
    fmi3Terminate(c: fmi3Instance) -> fmi3Status = entry::terminate::<Fmi3, M>(c, F);
    fmi3Reset(c: fmi3Instance) -> fmi3Status = entry::reset::<Fmi3, M>(c, F);
    fmi3GetFloat32(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3Float32, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, GETTABLE, "Float32", (vr, n), false);
    fmi3GetFloat64(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3Float64, nv: usize) -> fmi3Status = entry::get::<Fmi3, M, Reals>(c, F, (vr, n), (v, nv));
    fmi3GetInt8(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3Int8, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, GETTABLE, "Int8", (vr, n), false);
    fmi3GetUInt8(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3UInt8, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, GETTABLE, "UInt8", (vr, n), false);
    fmi3GetInt16(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3Int16, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, GETTABLE, "Int16", (vr, n), false);
    fmi3GetUInt16(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3UInt16, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, GETTABLE, "UInt16", (vr, n), false);
    fmi3GetInt32(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3Int32, nv: usize) -> fmi3Status = entry::get::<Fmi3, M, Integers>(c, F, (vr, n), (v, nv));
    fmi3GetUInt32(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3UInt32, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, GETTABLE, "UInt32", (vr, n), false);
    fmi3GetInt64(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3Int64, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, GETTABLE, "Int64", (vr, n), false);
    fmi3GetUInt64(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3UInt64, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, GETTABLE, "UInt64", (vr, n), false);
    fmi3GetBoolean(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3Boolean, nv: usize) -> fmi3Status = entry::get::<Fmi3, M, Booleans3>(c, F, (vr, n), (v, nv));
    fmi3GetString(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3String, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, GETTABLE, "String", (vr, n), false);
    fmi3GetBinary(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, sizes: *mut usize, v: *mut fmi3Binary, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, GETTABLE, "Binary", (vr, n), false);
    fmi3GetClock(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3Clock) -> fmi3Status = entry::get_clock::<Fmi3, M>(c, F, (vr, n), v);
    fmi3SetFloat32(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3Float32, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, SETTABLE, "Float32", (vr, n), false);
    fmi3SetFloat64(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3Float64, nv: usize) -> fmi3Status = entry::set::<Fmi3, M, Reals>(c, F, (vr, n), (v, nv));
    fmi3SetInt8(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3Int8, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, SETTABLE, "Int8", (vr, n), false);
    fmi3SetUInt8(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3UInt8, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, SETTABLE, "UInt8", (vr, n), false);
    fmi3SetInt16(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3Int16, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, SETTABLE, "Int16", (vr, n), false);
    fmi3SetUInt16(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3UInt16, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, SETTABLE, "UInt16", (vr, n), false);
    fmi3SetInt32(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3Int32, nv: usize) -> fmi3Status = entry::set::<Fmi3, M, Integers>(c, F, (vr, n), (v, nv));
    fmi3SetUInt32(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3UInt32, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, SETTABLE, "UInt32", (vr, n), false);
    fmi3SetInt64(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3Int64, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, SETTABLE, "Int64", (vr, n), false);
    fmi3SetUInt64(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3UInt64, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, SETTABLE, "UInt64", (vr, n), false);
    fmi3SetBoolean(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3Boolean, nv: usize) -> fmi3Status = entry::set::<Fmi3, M, Booleans3>(c, F, (vr, n), (v as *const u8, nv));
    fmi3SetString(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3String, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, SETTABLE, "String", (vr, n), false);
    fmi3SetBinary(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, sizes: *const usize, v: *const fmi3Binary, nv: usize) -> fmi3Status = entry::no_variables_of::<Fmi3, M>(c, F, SETTABLE, "Binary", (vr, n), false);
    fmi3SetClock(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3Clock) -> fmi3Status = entry::set_clock::<Fmi3, M>(c, F, (vr, n), v as *const u8);
    fmi3GetNumberOfVariableDependencies(c: fmi3Instance, vr: fmi3ValueReference, n: *mut usize) -> fmi3Status = entry::unsupported::<Fmi3, M>(c, F, LIVE, NO_DEPENDENCIES);
    fmi3GetVariableDependencies(c: fmi3Instance, dep: fmi3ValueReference, ed: *mut usize, ind: *mut fmi3ValueReference, ei: *mut usize, kinds: *mut fmi3DependencyKind, n: usize) -> fmi3Status = entry::unsupported::<Fmi3, M>(c, F, LIVE, NO_DEPENDENCIES);
    fmi3GetFMUState(c: fmi3Instance, s: *mut fmi3FMUState) -> fmi3Status = entry::get_fmu_state::<Fmi3, M>(c, F, s);
    fmi3SetFMUState(c: fmi3Instance, s: fmi3FMUState) -> fmi3Status = entry::set_fmu_state::<Fmi3, M>(c, F, s);
    fmi3FreeFMUState(c: fmi3Instance, s: *mut fmi3FMUState) -> fmi3Status = entry::free_fmu_state::<Fmi3, M>(c, F, s);
    fmi3SerializedFMUStateSize(c: fmi3Instance, s: fmi3FMUState, size: *mut usize) -> fmi3Status = entry::serialized_size::<Fmi3, M>(c, F, s, size);
    fmi3SerializeFMUState(c: fmi3Instance, s: fmi3FMUState, b: *mut fmi3Byte, size: usize) -> fmi3Status = entry::serialize::<Fmi3, M>(c, F, s, (b, size));
    fmi3DeserializeFMUState(c: fmi3Instance, b: *const fmi3Byte, size: usize, s: *mut fmi3FMUState) -> fmi3Status = entry::deserialize::<Fmi3, M>(c, F, (b, size), s);
    fmi3GetDirectionalDerivative(c: fmi3Instance, u: *const fmi3ValueReference, nu: usize, k: *const fmi3ValueReference, nk: usize, seed: *const fmi3Float64, ns: usize, sens: *mut fmi3Float64, nsens: usize) -> fmi3Status = entry::directional_derivative::<Fmi3, M>(c, F, (u, nu), (k, nk), (seed, ns), (sens, nsens));
    fmi3GetAdjointDerivative(c: fmi3Instance, u: *const fmi3ValueReference, nu: usize, k: *const fmi3ValueReference, nk: usize, seed: *const fmi3Float64, ns: usize, sens: *mut fmi3Float64, nsens: usize) -> fmi3Status = entry::unsupported::<Fmi3, M>(c, F, LIVE, "providesAdjointDerivatives is false");
    fmi3EnterConfigurationMode(c: fmi3Instance) -> fmi3Status = entry::unsupported::<Fmi3, M>(c, F, LIVE, "this FMU has no structural parameters");
    fmi3ExitConfigurationMode(c: fmi3Instance) -> fmi3Status = entry::unsupported::<Fmi3, M>(c, F, LIVE, "this FMU has no structural parameters, so it is never in configuration mode");
    fmi3GetIntervalDecimal(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, iv: *mut fmi3Float64, q: *mut fmi3IntervalQualifier) -> fmi3Status = entry::get_interval::<Fmi3, M>(c, F, (vr, n), (iv, q), fmi3IntervalUnchanged);
    fmi3GetIntervalFraction(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, cnt: *mut fmi3UInt64, res: *mut fmi3UInt64, q: *mut fmi3IntervalQualifier) -> fmi3Status = entry::constant_intervals::<Fmi3, M>(c, F);
    fmi3GetShiftDecimal(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, sh: *mut fmi3Float64) -> fmi3Status = entry::get_shift::<Fmi3, M>(c, F, (vr, n), sh);
    fmi3GetShiftFraction(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, cnt: *mut fmi3UInt64, res: *mut fmi3UInt64) -> fmi3Status = entry::constant_intervals::<Fmi3, M>(c, F);
    fmi3SetIntervalDecimal(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, iv: *const fmi3Float64) -> fmi3Status = entry::constant_intervals::<Fmi3, M>(c, F);
    fmi3SetIntervalFraction(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, cnt: *const fmi3UInt64, res: *const fmi3UInt64) -> fmi3Status = entry::constant_intervals::<Fmi3, M>(c, F);
    fmi3SetShiftDecimal(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, sh: *const fmi3Float64) -> fmi3Status = entry::constant_intervals::<Fmi3, M>(c, F);
    fmi3SetShiftFraction(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, cnt: *const fmi3UInt64, res: *const fmi3UInt64) -> fmi3Status = entry::constant_intervals::<Fmi3, M>(c, F);
    fmi3EvaluateDiscreteStates(c: fmi3Instance) -> fmi3Status = entry::unsupported::<Fmi3, M>(c, F, LIVE, "providesEvaluateDiscreteStates is false");
    fmi3UpdateDiscreteStates(c: fmi3Instance, a: *mut fmi3Boolean, b: *mut fmi3Boolean, d: *mut fmi3Boolean, e: *mut fmi3Boolean, f: *mut fmi3Boolean, t: *mut fmi3Float64) -> fmi3Status = entry::update_discrete_states::<Fmi3, M>(c, F, EventOutputs { need_update: a, terminate: b, nominals_changed: d, values_changed: e, next_time_defined: f, next_time: t });
    fmi3EnterContinuousTimeMode(c: fmi3Instance) -> fmi3Status = entry::enter_continuous_time_mode::<Fmi3, M>(c, F);
    fmi3CompletedIntegratorStep(c: fmi3Instance, no_prior: fmi3Boolean, ev: *mut fmi3Boolean, term: *mut fmi3Boolean) -> fmi3Status = entry::completed_integrator_step::<Fmi3, M, _>(c, F, (ev, term), false);
    fmi3SetTime(c: fmi3Instance, t: fmi3Float64) -> fmi3Status = entry::set_time::<Fmi3, M>(c, F, t);
    fmi3SetContinuousStates(c: fmi3Instance, x: *const fmi3Float64, n: usize) -> fmi3Status = entry::set_continuous_states::<Fmi3, M>(c, F, (x, n));
    fmi3GetContinuousStateDerivatives(c: fmi3Instance, dx: *mut fmi3Float64, n: usize) -> fmi3Status = entry::get_array::<Fmi3, M>(c, F, Array::Derivatives, (dx, n));
    fmi3GetEventIndicators(c: fmi3Instance, z: *mut fmi3Float64, n: usize) -> fmi3Status = entry::get_array::<Fmi3, M>(c, F, Array::EventIndicators, (z, n));
    fmi3GetContinuousStates(c: fmi3Instance, x: *mut fmi3Float64, n: usize) -> fmi3Status = entry::get_array::<Fmi3, M>(c, F, Array::States, (x, n));
    fmi3GetNominalsOfContinuousStates(c: fmi3Instance, x: *mut fmi3Float64, n: usize) -> fmi3Status = entry::get_array::<Fmi3, M>(c, F, Array::Nominals, (x, n));
    fmi3GetNumberOfEventIndicators(c: fmi3Instance, n: *mut usize) -> fmi3Status = entry::get_count::<Fmi3, M>(c, F, Array::EventIndicators, n);
    fmi3GetNumberOfContinuousStates(c: fmi3Instance, n: *mut usize) -> fmi3Status = entry::get_count::<Fmi3, M>(c, F, Array::States, n);
    fmi3EnterStepMode(c: fmi3Instance) -> fmi3Status = entry::enter_step_mode::<Fmi3, M>(c, F);
    fmi3GetOutputDerivatives(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, o: *const fmi3Int32, v: *mut fmi3Float64, nv: usize) -> fmi3Status = entry::unsupported::<Fmi3, M>(c, F, LIVE, "maxOutputDerivativeOrder is 0");
    fmi3DoStep(c: fmi3Instance, t: fmi3Float64, h: fmi3Float64, no_prior: fmi3Boolean, ev: *mut fmi3Boolean, term: *mut fmi3Boolean, early: *mut fmi3Boolean, last: *mut fmi3Float64) -> fmi3Status = entry::do_step::<Fmi3, M>(c, F, t, h, Some(StepOutputs { event_handling_needed: ev, terminate_simulation: term, early_return: early, last_successful_time: last }));
    fmi3ActivateModelPartition(c: fmi3Instance, clock: fmi3ValueReference, t: fmi3Float64) -> fmi3Status = entry::activate_model_partition::<Fmi3, M>(c, F, clock, t);
} } }

__fmi3_entry_points!(__generic_entry_points);
__fmi3_entry_points!(__every_entry_point);
