//! FMI 2.0 Co-Simulation: what the core needs from the standard beyond its facts
//! ([`crate::Facts`]): the logger call and the names of states and types ([`Fmi2`]); and
//! its C functions, each one line from its C signature to the generic body in
//! [`crate::entry`].
//! [`crate::export_fmi2!`] exports them for one model; the functions are also callable
//! here, generic over the model, as `api::fmi2DoStep::<M>(…)`.
#![allow(
    non_snake_case,
    non_upper_case_globals,
    clippy::missing_safety_doc,
    clippy::too_many_arguments
)]

use std::os::raw::c_char;

use crate::entry::{
    self, Array, Booleans, EventSink, Integers, Reals, AFTER_STEP, GETTABLE, LIVE, SETTABLE,
};
use crate::ffi::*;
use crate::instance::{Interface, Line, Modes, Standard, State};
use crate::{EventUpdate, Kind};

/// `fmi2EventInfo`, which only Model Exchange uses: the ABI crate's, which the importer shares.
pub use crate::ffi::fmi2EventInfo;

impl EventSink for *mut fmi2EventInfo {
    fn any_null(&self) -> bool {
        self.is_null()
    }
    unsafe fn write(&self, u: &EventUpdate, terminate: bool) {
        **self = fmi2EventInfo {
            newDiscreteStatesNeeded: fmi2False,
            terminateSimulation: fmi2Boolean::from(terminate),
            nominalsOfContinuousStatesChanged: fmi2False,
            valuesOfContinuousStatesChanged: fmi2Boolean::from(u.states_changed),
            nextEventTimeDefined: fmi2Boolean::from(u.next_event_time.is_some()),
            nextEventTime: u.next_event_time.unwrap_or(0.0),
        };
    }
}

/// The interface `fmuType` asks for; FMI 2.0 has no event mode or scheduler.
fn interface(ty: fmi2Type) -> (Interface, Modes, Option<&'static str>) {
    let none = Modes::default();
    match ty {
        fmi2CoSimulation => (Interface::CoSimulation, none, None),
        fmi2ModelExchange => (Interface::ModelExchange, none, None),
        _ => (Interface::CoSimulation, none, Some(BAD_TYPE)),
    }
}

/// FMI 2.0 as the core sees it.
pub struct Fmi2;

impl Standard for Fmi2 {
    type Callbacks = fmi2CallbackFunctions;

    fn state_name(s: State) -> &'static str {
        s.name()
    }
    fn type_name(k: Kind) -> &'static str {
        match k {
            Kind::Real => "Real",
            Kind::Integer => "Integer",
            Kind::Boolean => "Boolean",
            Kind::Clock => "Clock",
        }
    }
    fn has_logger(cb: &Self::Callbacks) -> bool {
        cb.logger.is_some()
    }
    unsafe fn emit(cb: &Self::Callbacks, line: Line) {
        if let Some(logger) = cb.logger {
            let name = line.name.unwrap_or(c"?").as_ptr();
            let (env, cat) = (cb.componentEnvironment, line.category.as_ptr());
            // The message is passed as the argument of "%s", never as the format.
            logger(env, name, line.status, cat, c"%s".as_ptr(), line.message.as_ptr());
        }
    }
}

pub fn fmi2GetTypesPlatform() -> *const c_char {
    fmi2TypesPlatform.as_ptr() as *const c_char
}

pub fn fmi2GetVersion() -> *const c_char {
    fmi2Version.as_ptr() as *const c_char
}

const BAD_TYPE: &str = "fmuType is neither fmi2ModelExchange (0) nor fmi2CoSimulation (1)";
const NO_INTERPOLATION: &str =
    "canInterpolateInputs is false (inputs are held constant over each communication step)";
const SYNCHRONOUS: &str =
    "fmi2DoStep always completes synchronously, so there is no step in progress to cancel";

/// Every FMI 2.0 function but the two without an instance, for
/// [`crate::__generic_entry_points!`] and [`crate::__thunks!`].
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi2_entry_points { ($then:ident) => { $crate::$then! {
    fmi2SetDebugLogging(c: fmi2Component, on: fmi2Boolean, n: usize, cats: *const fmi2String) -> fmi2Status = entry::set_debug_logging::<Fmi2, M>(c, F, on != fmi2False, n, cats);
    fmi2Instantiate(name: fmi2String, ty: fmi2Type, guid: fmi2String, res: fmi2String, functions: *const fmi2CallbackFunctions, visible: fmi2Boolean, logging: fmi2Boolean) -> fmi2Component = entry::instantiate::<Fmi2, M>(F, functions.as_ref().copied(), name, guid, interface(ty), logging != fmi2False);
    fmi2FreeInstance(c: fmi2Component) -> () = entry::free_instance::<Fmi2, M>(c, F);
    fmi2SetupExperiment(c: fmi2Component, td: fmi2Boolean, tol: fmi2Real, t0: fmi2Real, sd: fmi2Boolean, t1: fmi2Real) -> fmi2Status = entry::setup_experiment::<Fmi2, M>(c, F, t0, (sd != fmi2False).then_some(t1));
    fmi2EnterInitializationMode(c: fmi2Component) -> fmi2Status = entry::enter_initialization::<Fmi2, M>(c, F, None);
    fmi2ExitInitializationMode(c: fmi2Component) -> fmi2Status = entry::exit_initialization::<Fmi2, M>(c, F);
    fmi2Terminate(c: fmi2Component) -> fmi2Status = entry::terminate::<Fmi2, M>(c, F);
    fmi2EnterEventMode(c: fmi2Component) -> fmi2Status = entry::enter_event_mode::<Fmi2, M>(c, F);
    fmi2NewDiscreteStates(c: fmi2Component, info: *mut fmi2EventInfo) -> fmi2Status = entry::update_discrete_states::<Fmi2, M>(c, F, info);
    fmi2EnterContinuousTimeMode(c: fmi2Component) -> fmi2Status = entry::enter_continuous_time_mode::<Fmi2, M>(c, F);
    fmi2CompletedIntegratorStep(c: fmi2Component, no_prior: fmi2Boolean, ev: *mut fmi2Boolean, term: *mut fmi2Boolean) -> fmi2Status = entry::completed_integrator_step::<Fmi2, M, _>(c, F, (ev, term), fmi2False);
    fmi2SetTime(c: fmi2Component, t: fmi2Real) -> fmi2Status = entry::set_time::<Fmi2, M>(c, F, t);
    fmi2SetContinuousStates(c: fmi2Component, x: *const fmi2Real, n: usize) -> fmi2Status = entry::set_continuous_states::<Fmi2, M>(c, F, (x, n));
    fmi2GetDerivatives(c: fmi2Component, dx: *mut fmi2Real, n: usize) -> fmi2Status = entry::get_array::<Fmi2, M>(c, F, Array::Derivatives, (dx, n));
    fmi2GetEventIndicators(c: fmi2Component, z: *mut fmi2Real, n: usize) -> fmi2Status = entry::get_array::<Fmi2, M>(c, F, Array::EventIndicators, (z, n));
    fmi2GetContinuousStates(c: fmi2Component, x: *mut fmi2Real, n: usize) -> fmi2Status = entry::get_array::<Fmi2, M>(c, F, Array::States, (x, n));
    fmi2GetNominalsOfContinuousStates(c: fmi2Component, x: *mut fmi2Real, n: usize) -> fmi2Status = entry::get_array::<Fmi2, M>(c, F, Array::Nominals, (x, n));
    fmi2Reset(c: fmi2Component) -> fmi2Status = entry::reset::<Fmi2, M>(c, F);
    fmi2GetReal(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, v: *mut fmi2Real) -> fmi2Status = entry::get::<Fmi2, M, Reals>(c, F, (vr, n), (v, n));
    fmi2GetInteger(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, v: *mut fmi2Integer) -> fmi2Status = entry::get::<Fmi2, M, Integers>(c, F, (vr, n), (v, n));
    fmi2GetBoolean(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, v: *mut fmi2Boolean) -> fmi2Status = entry::get::<Fmi2, M, Booleans<fmi2Boolean, fmi2Boolean>>(c, F, (vr, n), (v, n));
    fmi2GetString(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, v: *mut fmi2String) -> fmi2Status = entry::no_variables_of::<Fmi2, M>(c, F, GETTABLE, "String", (vr, n), v.is_null());
    fmi2SetReal(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, v: *const fmi2Real) -> fmi2Status = entry::set::<Fmi2, M, Reals>(c, F, (vr, n), (v, n));
    fmi2SetInteger(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, v: *const fmi2Integer) -> fmi2Status = entry::set::<Fmi2, M, Integers>(c, F, (vr, n), (v, n));
    fmi2SetBoolean(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, v: *const fmi2Boolean) -> fmi2Status = entry::set::<Fmi2, M, Booleans<fmi2Boolean, fmi2Boolean>>(c, F, (vr, n), (v, n));
    fmi2SetString(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, v: *const fmi2String) -> fmi2Status = entry::no_variables_of::<Fmi2, M>(c, F, SETTABLE, "String", (vr, n), v.is_null());
    fmi2GetFMUstate(c: fmi2Component, s: *mut fmi2FMUstate) -> fmi2Status = entry::get_fmu_state::<Fmi2, M>(c, F, s);
    fmi2SetFMUstate(c: fmi2Component, s: fmi2FMUstate) -> fmi2Status = entry::set_fmu_state::<Fmi2, M>(c, F, s);
    fmi2FreeFMUstate(c: fmi2Component, s: *mut fmi2FMUstate) -> fmi2Status = entry::free_fmu_state::<Fmi2, M>(c, F, s);
    fmi2SerializedFMUstateSize(c: fmi2Component, s: fmi2FMUstate, size: *mut usize) -> fmi2Status = entry::serialized_size::<Fmi2, M>(c, F, s, size);
    fmi2SerializeFMUstate(c: fmi2Component, s: fmi2FMUstate, b: *mut fmi2Byte, size: usize) -> fmi2Status = entry::serialize::<Fmi2, M>(c, F, s, (b as *mut u8, size));
    fmi2DeSerializeFMUstate(c: fmi2Component, b: *const fmi2Byte, size: usize, s: *mut fmi2FMUstate) -> fmi2Status = entry::deserialize::<Fmi2, M>(c, F, (b as *const u8, size), s);
    fmi2GetDirectionalDerivative(c: fmi2Component, u: *const fmi2ValueReference, nu: usize, k: *const fmi2ValueReference, nk: usize, dk: *const fmi2Real, du: *mut fmi2Real) -> fmi2Status = entry::directional_derivative::<Fmi2, M>(c, F, (u, nu), (k, nk), (dk, nk), (du, nu));
    fmi2SetRealInputDerivatives(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, o: *const fmi2Integer, v: *const fmi2Real) -> fmi2Status = entry::unsupported::<Fmi2, M>(c, F, SETTABLE, NO_INTERPOLATION);
    fmi2GetRealOutputDerivatives(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, o: *const fmi2Integer, v: *mut fmi2Real) -> fmi2Status = entry::unsupported::<Fmi2, M>(c, F, AFTER_STEP, "maxOutputDerivativeOrder is 0");
    fmi2DoStep(c: fmi2Component, t: fmi2Real, h: fmi2Real, no_prior: fmi2Boolean) -> fmi2Status = entry::do_step::<Fmi2, M>(c, F, t, h, None);
    fmi2CancelStep(c: fmi2Component) -> fmi2Status = entry::unsupported::<Fmi2, M>(c, F, LIVE, SYNCHRONOUS);
    fmi2GetStatus(c: fmi2Component, s: fmi2StatusKind, v: *mut fmi2Status) -> fmi2Status = entry::status_query::<Fmi2, M, _>(c, F, v, |i| match s { fmi2DoStepStatus => Ok(i.last_step_status), _ => Err(format!("status kind {s} has no fmi2Status value (fmi2DoStepStatus only)")) });
    fmi2GetRealStatus(c: fmi2Component, s: fmi2StatusKind, v: *mut fmi2Real) -> fmi2Status = entry::status_query::<Fmi2, M, _>(c, F, v, |i| match s { fmi2LastSuccessfulTime => Ok(i.time), _ => Err(format!("status kind {s} is not a Real status (fmi2LastSuccessfulTime only)")) });
    fmi2GetIntegerStatus(c: fmi2Component, s: fmi2StatusKind, v: *mut fmi2Integer) -> fmi2Status = entry::status_query::<Fmi2, M, _>(c, F, v, |_| Err(format!("status kind {s}: FMI 2.0 defines no Integer status")));
    // The model never asks the master to end the simulation.
    fmi2GetBooleanStatus(c: fmi2Component, s: fmi2StatusKind, v: *mut fmi2Boolean) -> fmi2Status = entry::status_query::<Fmi2, M, _>(c, F, v, |_| match s { fmi2Terminated => Ok(fmi2False), _ => Err(format!("status kind {s} is not a Boolean status (fmi2Terminated only)")) });
    fmi2GetStringStatus(c: fmi2Component, s: fmi2StatusKind, v: *mut fmi2String) -> fmi2Status = entry::status_query::<Fmi2, M, _>(c, F, v, |_| Err(format!("status kind {s}: no asynchronous step is ever pending")));
} } }

__fmi2_entry_points!(__generic_entry_points);
__fmi2_entry_points!(__every_entry_point);
