//! Each standard's C functions behind one trait, [`Master`], so a test is written once for
//! both; and the check that every entry point refuses a foreign instance.

use std::ffi::{c_char, CStr};

use super::{callbacks, Log, C};
use crate::api::{self, fmi2EventInfo, Fmi2};
use crate::entry::Array;
use crate::ffi::*;
use crate::fmi3::api::{self as api3, Fmi3};
use crate::instance::{Interface, Standard, Status};
use crate::{EventUpdate, Model};

/// A standard as a master calls it: each call of the harness in that standard's C
/// functions. Both standards' functions return the same status codes.
pub trait Master: Standard {
    /// What must outlive the instance for its logger.
    type Keep;
    /// The functions named in messages.
    const SET_REAL: &'static str;
    const GET_REAL: &'static str;
    const DO_STEP: &'static str;
    const DESERIALIZE: &'static str;
    const SET_DEBUG_LOGGING: &'static str;
    const INSTANTIATE: &'static str;
    const SET_STATES: &'static str;
    const UPDATE: &'static str;

    /// Instantiates for `interface`, or NULL.
    unsafe fn instantiate<M: Model>(
        interface: Interface,
        name: &CStr,
        token: &CStr,
        log: &Log,
        on: bool,
    ) -> (C, Self::Keep);
    /// One Model Exchange array of `n` values.
    unsafe fn continuous_array<M: Model>(c: C, array: Array, out: *mut f64, n: usize) -> Status;
    /// `NewDiscreteStates`/`UpdateDiscreteStates`: the update and `terminateSimulation`.
    unsafe fn update<M: Model>(c: C) -> (Status, EventUpdate, bool);
    /// `CompletedIntegratorStep`: `enterEventMode` and `terminateSimulation`.
    unsafe fn completed_step<M: Model>(c: C) -> (Status, [bool; 2]);
    /// `Get*DirectionalDerivative(s)` with one value per reference.
    unsafe fn directional<M: Model>(
        c: C,
        u: &[u32],
        k: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Status;
    unsafe fn free<M: Model>(c: C);
    /// FMI 2.0's `fmi2SetupExperiment`; FMI 3.0 passes the experiment to `enter`, so the
    /// harness keeps it until then.
    unsafe fn setup<M: Model>(c: C, start: f64, stop: Option<f64>) -> Status;
    unsafe fn enter<M: Model>(c: C, start: f64, stop: Option<f64>) -> Status;
    unsafe fn exit<M: Model>(c: C) -> Status;
    unsafe fn terminate<M: Model>(c: C) -> Status;
    unsafe fn reset<M: Model>(c: C) -> Status;
    unsafe fn get_reals<M: Model>(c: C, vr: *const u32, n: usize, v: *mut f64) -> Status;
    unsafe fn set_reals<M: Model>(c: C, vr: *const u32, n: usize, v: *const f64) -> Status;
    /// The values of the array whose first element is `vr`: FMI 2.0's scalars `vr` …
    /// `vr + n - 1`, FMI 3.0's array variable `vr` whole (crate::arrays).
    unsafe fn get_array<M: Model>(c: C, vr: u32, v: &mut [f64]) -> Status;
    unsafe fn get_integer<M: Model>(c: C, vr: u32) -> (Status, i32);
    unsafe fn set_integer<M: Model>(c: C, vr: u32, v: i32) -> Status;
    unsafe fn get_boolean<M: Model>(c: C, vr: u32) -> (Status, bool);
    unsafe fn set_boolean<M: Model>(c: C, vr: u32, v: bool) -> Status;
    unsafe fn step<M: Model>(c: C, t: f64, h: f64) -> Status;
    unsafe fn set_debug_logging<M: Model>(
        c: C,
        on: bool,
        n: usize,
        cats: *const *const c_char,
    ) -> Status;
    unsafe fn get_state<M: Model>(c: C, s: *mut C) -> Status;
    unsafe fn set_state<M: Model>(c: C, s: C) -> Status;
    unsafe fn free_state<M: Model>(c: C, s: *mut C) -> Status;
    unsafe fn state_size<M: Model>(c: C, s: C, size: *mut usize) -> Status;
    unsafe fn serialize<M: Model>(c: C, s: C, b: *mut u8, size: usize) -> Status;
    unsafe fn deserialize<M: Model>(c: C, b: *const u8, size: usize, s: *mut C) -> Status;
    unsafe fn set_time<M: Model>(c: C, t: f64) -> Status;
    unsafe fn set_states<M: Model>(c: C, x: *const f64, n: usize) -> Status;
    unsafe fn enter_event_mode<M: Model>(c: C) -> Status;
    unsafe fn enter_continuous_time_mode<M: Model>(c: C) -> Status;
    /// Every function of the standard that takes an instance, called with `c` and every
    /// other argument zero: each one's name and status (`None` for the free).
    unsafe fn every_entry_point<M: Model>(c: C) -> Vec<(&'static str, Option<Status>)>;
}

/// A status, or nothing for a function that returns nothing (the frees).
pub trait IntoStatus {
    fn into_status(self) -> Option<Status>;
}

impl IntoStatus for Status {
    fn into_status(self) -> Option<Status> {
        Some(self)
    }
}

impl IntoStatus for () {
    fn into_status(self) -> Option<Status> {
        None
    }
}

/// Hands `foreign` (another model's or standard's instance, a freed one, junk) to every
/// entry point of `M` under `S`: each must refuse it with an error, and the free must
/// leave it alone, without reading through it. Returns how many entry points were called.
pub unsafe fn assert_every_entry_point_refuses<S: Master, M: Model>(
    foreign: C,
    what: &str,
) -> usize {
    let called = S::every_entry_point::<M>(foreign);
    for &(name, status) in &called {
        let refused = status.is_none_or(|s| s == crate::instance::ERROR);
        assert!(refused, "{name} of {} given {what} returned {status:?}", M::info().model_name);
    }
    called.len()
}

const fn b2(b: bool) -> fmi2Boolean {
    if b {
        fmi2True
    } else {
        fmi2False
    }
}

/// Both `Master` impls: each standard's own methods, then the ones that pass their
/// arguments straight to a function of each standard, one line for both.
macro_rules! masters {
    (names { $($c:ident = $c2:literal | $c3:literal;)* }
     $s2:ident($m2:ident) { $($own2:tt)* } $s3:ident($m3:ident) { $($own3:tt)* }
     $($method:ident($($a:ident: $t:ty),*) -> $r:ty = $f2:ident | $f3:ident;)*) => {
        impl Master for $s2 {
            $(const $c: &'static str = $c2;)*
            $($own2)*
            $( unsafe fn $method<M: Model>($($a: $t),*) -> $r { $m2::$f2::<M>($($a),*) } )*
        }
        impl Master for $s3 {
            $(const $c: &'static str = $c3;)*
            $($own3)*
            $( unsafe fn $method<M: Model>($($a: $t),*) -> $r { $m3::$f3::<M>($($a),*) } )*
        }
    };
}

masters! {
    names {
        SET_REAL = "fmi2SetReal" | "fmi3SetFloat64";
        GET_REAL = "fmi2GetReal" | "fmi3GetFloat64";
        DO_STEP = "fmi2DoStep" | "fmi3DoStep";
        DESERIALIZE = "fmi2DeSerializeFMUstate" | "fmi3DeserializeFMUState";
        SET_DEBUG_LOGGING = "fmi2SetDebugLogging" | "fmi3SetDebugLogging";
        INSTANTIATE = "fmi2Instantiate" | "fmi3InstantiateCoSimulation";
        SET_STATES = "fmi2SetContinuousStates" | "fmi3SetContinuousStates";
        UPDATE = "fmi2NewDiscreteStates" | "fmi3UpdateDiscreteStates";
    }
    Fmi2(api) {
        type Keep = Box<fmi2CallbackFunctions>;

        unsafe fn instantiate<M: Model>(interface: Interface, name: &CStr, token: &CStr, log: &Log, on: bool) -> (C, Self::Keep) {
            let f = Box::new(callbacks(log));
            let ty = match interface {
                Interface::CoSimulation => fmi2CoSimulation,
                Interface::ModelExchange => fmi2ModelExchange,
                // FMI 2.0 has no Scheduled Execution.
                Interface::ScheduledExecution => return (std::ptr::null_mut(), f),
            };
            let c = api::fmi2Instantiate::<M>(name.as_ptr(), ty, token.as_ptr(), std::ptr::null(), &*f, fmi2False, b2(on));
            (c, f)
        }
        unsafe fn continuous_array<M: Model>(c: C, array: Array, out: *mut f64, n: usize) -> Status {
            match array {
                Array::States => api::fmi2GetContinuousStates::<M>(c, out, n),
                Array::Derivatives => api::fmi2GetDerivatives::<M>(c, out, n),
                Array::EventIndicators => api::fmi2GetEventIndicators::<M>(c, out, n),
                Array::Nominals => api::fmi2GetNominalsOfContinuousStates::<M>(c, out, n),
            }
        }
        unsafe fn update<M: Model>(c: C) -> (Status, EventUpdate, bool) {
            let mut info = fmi2EventInfo { newDiscreteStatesNeeded: 7, ..Default::default() };
            let s = api::fmi2NewDiscreteStates::<M>(c, &mut info);
            assert!(info.newDiscreteStatesNeeded == fmi2False || s != 0, "one update reaches the fixed point");
            let next = (info.nextEventTimeDefined != fmi2False).then_some(info.nextEventTime);
            let u = EventUpdate { states_changed: info.valuesOfContinuousStatesChanged != fmi2False, next_event_time: next };
            (s, u, info.terminateSimulation != fmi2False)
        }
        unsafe fn directional<M: Model>(c: C, u: &[u32], k: &[u32], seed: &[f64], out: &mut [f64]) -> Status {
            assert_eq!((k.len(), u.len()), (seed.len(), out.len()), "FMI 2.0 has no separate counts");
            api::fmi2GetDirectionalDerivative::<M>(c, u.as_ptr(), u.len(), k.as_ptr(), k.len(), seed.as_ptr(), out.as_mut_ptr())
        }
        unsafe fn completed_step<M: Model>(c: C) -> (Status, [bool; 2]) {
            let (mut ev, mut term) = (7, 7);
            let s = api::fmi2CompletedIntegratorStep::<M>(c, fmi2True, &mut ev, &mut term);
            (s, [ev != fmi2False, term != fmi2False])
        }
        unsafe fn setup<M: Model>(c: C, start: f64, stop: Option<f64>) -> Status {
            api::fmi2SetupExperiment::<M>(c, fmi2False, 0.0, start, b2(stop.is_some()), stop.unwrap_or(0.0))
        }
        unsafe fn enter<M: Model>(c: C, _: f64, _: Option<f64>) -> Status {
            api::fmi2EnterInitializationMode::<M>(c)
        }
        unsafe fn get_integer<M: Model>(c: C, vr: u32) -> (Status, i32) {
            let mut v = i32::MIN;
            (api::fmi2GetInteger::<M>(c, &vr, 1, &mut v), v)
        }
        unsafe fn set_integer<M: Model>(c: C, vr: u32, v: i32) -> Status {
            api::fmi2SetInteger::<M>(c, &vr, 1, &v)
        }
        unsafe fn get_boolean<M: Model>(c: C, vr: u32) -> (Status, bool) {
            let mut v = -1;
            (api::fmi2GetBoolean::<M>(c, &vr, 1, &mut v), v != fmi2False)
        }
        unsafe fn set_boolean<M: Model>(c: C, vr: u32, v: bool) -> Status {
            api::fmi2SetBoolean::<M>(c, &vr, 1, &b2(v))
        }
        unsafe fn get_reals<M: Model>(c: C, vr: *const u32, n: usize, v: *mut f64) -> Status {
            api::fmi2GetReal::<M>(c, vr, n, v)
        }
        unsafe fn set_reals<M: Model>(c: C, vr: *const u32, n: usize, v: *const f64) -> Status {
            api::fmi2SetReal::<M>(c, vr, n, v)
        }
        unsafe fn get_array<M: Model>(c: C, vr: u32, v: &mut [f64]) -> Status {
            let vrs: Vec<u32> = (vr..).take(v.len()).collect();
            api::fmi2GetReal::<M>(c, vrs.as_ptr(), v.len(), v.as_mut_ptr())
        }
        unsafe fn step<M: Model>(c: C, t: f64, h: f64) -> Status {
            api::fmi2DoStep::<M>(c, t, h, fmi2True)
        }
        unsafe fn set_debug_logging<M: Model>(c: C, on: bool, n: usize, cats: *const *const c_char) -> Status {
            api::fmi2SetDebugLogging::<M>(c, b2(on), n, cats)
        }
        unsafe fn serialize<M: Model>(c: C, s: C, b: *mut u8, size: usize) -> Status {
            api::fmi2SerializeFMUstate::<M>(c, s, b as *mut fmi2Byte, size)
        }
        unsafe fn deserialize<M: Model>(c: C, b: *const u8, size: usize, s: *mut C) -> Status {
            api::fmi2DeSerializeFMUstate::<M>(c, b as *const fmi2Byte, size, s)
        }
    }
    Fmi3(api3) {
        type Keep = ();

        unsafe fn instantiate<M: Model>(interface: Interface, name: &CStr, token: &CStr, log: &Log, on: bool) -> (C, ()) {
            let (env, logger) = crate::fmi3::testing::log_callback(log);
            let (res, required) = (std::ptr::null(), std::ptr::null());
            let c = match interface {
                Interface::CoSimulation => api3::fmi3InstantiateCoSimulation::<M>(name.as_ptr(), token.as_ptr(), res, false, on, false, false, required, 0, env, logger, None),
                Interface::ModelExchange => api3::fmi3InstantiateModelExchange::<M>(name.as_ptr(), token.as_ptr(), res, false, on, env, logger),
                Interface::ScheduledExecution => api3::fmi3InstantiateScheduledExecution::<M>(name.as_ptr(), token.as_ptr(), res, false, on, env, logger, None, None, None),
            };
            (c, ())
        }
        unsafe fn continuous_array<M: Model>(c: C, array: Array, out: *mut f64, n: usize) -> Status {
            match array {
                Array::States => api3::fmi3GetContinuousStates::<M>(c, out, n),
                Array::Derivatives => api3::fmi3GetContinuousStateDerivatives::<M>(c, out, n),
                Array::EventIndicators => api3::fmi3GetEventIndicators::<M>(c, out, n),
                Array::Nominals => api3::fmi3GetNominalsOfContinuousStates::<M>(c, out, n),
            }
        }
        unsafe fn update<M: Model>(c: C) -> (Status, EventUpdate, bool) {
            let (mut need, mut term, mut nominals, mut values, mut defined, mut next) = (true, true, true, true, true, f64::NAN);
            let s = api3::fmi3UpdateDiscreteStates::<M>(c, &mut need, &mut term, &mut nominals, &mut values, &mut defined, &mut next);
            assert!(!need && !nominals || s != 0, "one update reaches the fixed point; nominals are constants");
            (s, EventUpdate { states_changed: values, next_event_time: defined.then_some(next) }, term)
        }
        unsafe fn directional<M: Model>(c: C, u: &[u32], k: &[u32], seed: &[f64], out: &mut [f64]) -> Status {
            api3::fmi3GetDirectionalDerivative::<M>(c, u.as_ptr(), u.len(), k.as_ptr(), k.len(), seed.as_ptr(), seed.len(), out.as_mut_ptr(), out.len())
        }
        unsafe fn completed_step<M: Model>(c: C) -> (Status, [bool; 2]) {
            let (mut ev, mut term) = (true, true);
            let s = api3::fmi3CompletedIntegratorStep::<M>(c, true, &mut ev, &mut term);
            (s, [ev, term])
        }
        // FMI 3.0 takes the experiment at `enter`.
        unsafe fn setup<M: Model>(_: C, _: f64, _: Option<f64>) -> Status {
            crate::instance::OK
        }
        unsafe fn enter<M: Model>(c: C, start: f64, stop: Option<f64>) -> Status {
            api3::fmi3EnterInitializationMode::<M>(c, false, 0.0, start, stop.is_some(), stop.unwrap_or(0.0))
        }
        unsafe fn get_integer<M: Model>(c: C, vr: u32) -> (Status, i32) {
            let mut v = i32::MIN;
            (api3::fmi3GetInt32::<M>(c, &vr, 1, &mut v, 1), v)
        }
        unsafe fn set_integer<M: Model>(c: C, vr: u32, v: i32) -> Status {
            api3::fmi3SetInt32::<M>(c, &vr, 1, &v, 1)
        }
        unsafe fn get_boolean<M: Model>(c: C, vr: u32) -> (Status, bool) {
            let mut v = false;
            (api3::fmi3GetBoolean::<M>(c, &vr, 1, &mut v, 1), v)
        }
        unsafe fn set_boolean<M: Model>(c: C, vr: u32, v: bool) -> Status {
            api3::fmi3SetBoolean::<M>(c, &vr, 1, &v, 1)
        }
        unsafe fn get_reals<M: Model>(c: C, vr: *const u32, n: usize, v: *mut f64) -> Status {
            api3::fmi3GetFloat64::<M>(c, vr, n, v, n)
        }
        unsafe fn set_reals<M: Model>(c: C, vr: *const u32, n: usize, v: *const f64) -> Status {
            api3::fmi3SetFloat64::<M>(c, vr, n, v, n)
        }
        unsafe fn get_array<M: Model>(c: C, vr: u32, v: &mut [f64]) -> Status {
            api3::fmi3GetFloat64::<M>(c, &vr, 1, v.as_mut_ptr(), v.len())
        }
        unsafe fn step<M: Model>(c: C, t: f64, h: f64) -> Status {
            let (mut ev, mut term, mut early, mut last) = (true, true, true, f64::NAN);
            api3::fmi3DoStep::<M>(c, t, h, true, &mut ev, &mut term, &mut early, &mut last)
        }
        unsafe fn set_debug_logging<M: Model>(c: C, on: bool, n: usize, cats: *const *const c_char) -> Status {
            api3::fmi3SetDebugLogging::<M>(c, on, n, cats)
        }
        unsafe fn serialize<M: Model>(c: C, s: C, b: *mut u8, size: usize) -> Status {
            api3::fmi3SerializeFMUState::<M>(c, s, b, size)
        }
        unsafe fn deserialize<M: Model>(c: C, b: *const u8, size: usize, s: *mut C) -> Status {
            api3::fmi3DeserializeFMUState::<M>(c, b, size, s)
        }
    }
    free(c: C) -> () = fmi2FreeInstance | fmi3FreeInstance;
    exit(c: C) -> Status = fmi2ExitInitializationMode | fmi3ExitInitializationMode;
    terminate(c: C) -> Status = fmi2Terminate | fmi3Terminate;
    reset(c: C) -> Status = fmi2Reset | fmi3Reset;
    get_state(c: C, s: *mut C) -> Status = fmi2GetFMUstate | fmi3GetFMUState;
    set_state(c: C, s: C) -> Status = fmi2SetFMUstate | fmi3SetFMUState;
    free_state(c: C, s: *mut C) -> Status = fmi2FreeFMUstate | fmi3FreeFMUState;
    state_size(c: C, s: C, size: *mut usize) -> Status = fmi2SerializedFMUstateSize | fmi3SerializedFMUStateSize;
    set_time(c: C, t: f64) -> Status = fmi2SetTime | fmi3SetTime;
    set_states(c: C, x: *const f64, n: usize) -> Status = fmi2SetContinuousStates | fmi3SetContinuousStates;
    enter_event_mode(c: C) -> Status = fmi2EnterEventMode | fmi3EnterEventMode;
    enter_continuous_time_mode(c: C) -> Status = fmi2EnterContinuousTimeMode | fmi3EnterContinuousTimeMode;
    every_entry_point(c: C) -> Vec<(&'static str, Option<Status>)> = every_entry_point | every_entry_point;
}
