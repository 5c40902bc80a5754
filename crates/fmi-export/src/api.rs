//! The FMI 2.0 Co-Simulation entry points, generic over the model. [`crate::export_fmi2!`]
//! instantiates each for one model under its C name.
//!
//! Every function follows one shape, as in the Reference-FMUs: check the instance pointer
//! and that the call is allowed in the current state (bit masks below, FMI 2.0 section
//! 4.2.4), check the arguments, run the body inside `catch_unwind`, log every refusal
//! with the function name and the reason, and return a defined status.
//!
//! Status policy: a refused call (wrong state, bad argument, a NaN input) returns
//! `fmi2Error` and leaves the instance as it was, so the master can correct the call and
//! go on, and no data is lost; a failure of the model itself (invalid parameters at
//! `fmi2ExitInitializationMode`) moves the instance to the Error state, from which only
//! reset, free, getters and state restore are allowed; a Rust panic (a bug) returns
//! `fmi2Fatal` and moves it to Fatal, from which only `fmi2FreeInstance` is allowed.
#![allow(
    non_snake_case,
    non_upper_case_globals,
    clippy::missing_safety_doc,
    clippy::too_many_arguments
)]

use std::ffi::{CStr, CString};
use std::os::raw::c_char;
use std::panic::{catch_unwind, AssertUnwindSafe};

use crate::ffi::*;
use crate::instance::{Categories, Instance, LogCategory, Snapshot, State, INSTANCE_MAGIC};
use crate::table::{Kind, Variable};
use crate::{model_description, state_blob, Message, Model};

const I: u16 = State::Instantiated as u16;
const IM: u16 = State::InitializationMode as u16;
const SC: u16 = State::StepComplete as u16;
const SIP: u16 = State::StepInProgress as u16;
const SF: u16 = State::StepFailed as u16;
const SCA: u16 = State::StepCanceled as u16;
const T: u16 = State::Terminated as u16;
const E: u16 = State::Error as u16;

const LIVE: u16 = I | IM | SC | SIP | SF | SCA | T | E;
const GETTABLE: u16 = IM | SC | SF | SCA | T | E;
const SETTABLE: u16 = I | IM | SC;
const STATE_CALLS: u16 = I | IM | SC | SF | SCA | T | E;
const STATUS_CALLS: u16 = SC | SIP | SF | SCA | T;

/// Runs `body` on the instance behind `c` if the call is allowed in its state.
unsafe fn with_instance<M: Model>(
    c: fmi2Component,
    func: &str,
    allowed: u16,
    body: impl FnOnce(&mut Instance<M>) -> fmi2Status,
) -> fmi2Status {
    if c.is_null() {
        return fmi2Error;
    }
    let inst = &mut *(c as *mut Instance<M>);
    if inst.magic != INSTANCE_MAGIC {
        return fmi2Error;
    }
    if inst.state as u16 & allowed == 0 {
        inst.log(
            fmi2Error,
            LogCategory::StatusError,
            &format!("{func}: illegal call sequence: not allowed in state {}", inst.state.name()),
        );
        return fmi2Error;
    }
    inst.log(fmi2OK, LogCategory::All, func);
    match catch_unwind(AssertUnwindSafe(|| body(&mut *inst))) {
        Ok(status) => status,
        Err(panic) => {
            let what = crate::instance::panic_text(panic.as_ref());
            inst.state = State::Fatal;
            inst.log(
                fmi2Fatal,
                LogCategory::StatusError,
                &format!("{func}: internal error, instance unusable: {what}"),
            );
            fmi2Fatal
        }
    }
}

fn refuse<M: Model>(inst: &Instance<M>, func: &str, why: &str) -> fmi2Status {
    inst.log(fmi2Error, LogCategory::StatusError, &format!("{func}: {why}"));
    fmi2Error
}

fn worst(a: fmi2Status, b: fmi2Status) -> fmi2Status {
    a.max(b)
}

unsafe fn slice<'a, T>(ptr: *const T, n: usize) -> Option<&'a [T]> {
    if n == 0 {
        Some(&[])
    } else if ptr.is_null() {
        None
    } else {
        Some(std::slice::from_raw_parts(ptr, n))
    }
}

unsafe fn slice_mut<'a, T>(ptr: *mut T, n: usize) -> Option<&'a mut [T]> {
    if n == 0 {
        Some(&mut [])
    } else if ptr.is_null() {
        None
    } else {
        Some(std::slice::from_raw_parts_mut(ptr, n))
    }
}

fn variable<M: Model>(vr: u32) -> Option<&'static Variable> {
    M::variables().iter().find(|v| v.vr == vr)
}

/// The variable behind `vr`, if it exists and has type `kind`.
fn lookup<M: Model>(vr: u32, kind: Kind) -> Result<&'static Variable, String> {
    match variable::<M>(vr) {
        None => Err(format!("unknown value reference {vr}")),
        Some(v) if v.kind != kind => {
            Err(format!("value reference {vr} ({}) is {:?}, not {kind:?}", v.name, v.kind))
        }
        Some(v) => Ok(v),
    }
}

pub fn fmi2GetTypesPlatform() -> *const c_char {
    fmi2TypesPlatform.as_ptr() as *const c_char
}

pub fn fmi2GetVersion() -> *const c_char {
    fmi2Version.as_ptr() as *const c_char
}

/// FMI 2.0 section 2.1.5: on with no categories enables all of them; on with categories
/// enables exactly those; off with categories disables those; off with none disables
/// all. A NULL or unknown name refuses the whole call and changes nothing, so a master's
/// typo cannot leave half of its request applied.
pub unsafe fn fmi2SetDebugLogging<M: Model>(
    c: fmi2Component,
    loggingOn: fmi2Boolean,
    nCategories: usize,
    categories: *const fmi2String,
) -> fmi2Status {
    with_instance::<M>(c, "fmi2SetDebugLogging", LIVE, |inst| {
        const FUNC: &str = "fmi2SetDebugLogging";
        let Some(names) = slice(categories, nCategories) else {
            return refuse(inst, FUNC, "categories is NULL");
        };
        let mut named = Vec::with_capacity(names.len());
        for &p in names {
            if p.is_null() {
                return refuse(inst, FUNC, "a category name is NULL; logging left unchanged");
            }
            let name = CStr::from_ptr(p).to_string_lossy();
            match LogCategory::from_name(&name) {
                Some(cat) => named.push(cat),
                None => {
                    let known: Vec<_> = LogCategory::ALL.iter().map(|c| c.name()).collect();
                    return refuse(
                        inst,
                        FUNC,
                        &format!(
                            "unknown log category \"{name}\" (this FMU has {}); logging left unchanged",
                            known.join(", ")
                        ),
                    );
                }
            }
        }
        let named = Categories::of(&named);
        inst.categories = match (loggingOn != fmi2False, names.is_empty()) {
            (true, true) => Categories::ALL,
            (true, false) => named,
            (false, true) => Categories::NONE,
            (false, false) => inst.categories.without(named),
        };
        fmi2OK
    })
}

/// Logs through the master's callback before an instance exists.
unsafe fn log_without_instance(
    functions: *const fmi2CallbackFunctions,
    name: fmi2String,
    message: &str,
) {
    if functions.is_null() {
        return;
    }
    if let Some(logger) = (*functions).logger {
        let msg = CString::new(message.replace('\0', " ")).unwrap_or_default();
        let fallback = b"?\0";
        let name = if name.is_null() { fallback.as_ptr() as *const c_char } else { name };
        logger(
            (*functions).componentEnvironment,
            name,
            fmi2Error,
            c"logStatusError".as_ptr(),
            c"%s".as_ptr(),
            msg.as_ptr(),
        );
    }
}

pub unsafe fn fmi2Instantiate<M: Model>(
    instanceName: fmi2String,
    fmuType: fmi2Type,
    fmuGUID: fmi2String,
    _fmuResourceLocation: fmi2String,
    functions: *const fmi2CallbackFunctions,
    _visible: fmi2Boolean,
    loggingOn: fmi2Boolean,
) -> fmi2Component {
    let result = catch_unwind(AssertUnwindSafe(|| {
        let fail = |msg: &str| {
            log_without_instance(functions, instanceName, &format!("fmi2Instantiate: {msg}"));
            std::ptr::null_mut()
        };
        if functions.is_null() {
            return std::ptr::null_mut();
        }
        if instanceName.is_null() || *instanceName == 0 {
            return fail("instanceName is NULL or empty");
        }
        if fmuType != fmi2CoSimulation {
            return fail(
                "this FMU implements Co-Simulation only (fmuType must be fmi2CoSimulation)",
            );
        }
        let guid = model_description::guid::<M>();
        if fmuGUID.is_null() {
            return fail("fmuGUID is NULL");
        }
        let given = CStr::from_ptr(fmuGUID).to_string_lossy();
        if given != guid {
            return fail(&format!("fmuGUID \"{given}\" does not match this FMU's \"{guid}\" (modelDescription.xml from another build?)"));
        }
        let name = CStr::from_ptr(instanceName).to_owned();
        let inst = Box::new(Instance::<M>::new(name, *functions, loggingOn != fmi2False));
        Box::into_raw(inst) as fmi2Component
    }));
    result.unwrap_or(std::ptr::null_mut())
}

pub unsafe fn fmi2FreeInstance<M: Model>(c: fmi2Component) {
    if c.is_null() {
        return;
    }
    let inst = c as *mut Instance<M>;
    if (*inst).magic != INSTANCE_MAGIC {
        return;
    }
    // Dropping a model only frees memory; a panic there must still not unwind into C.
    let _ = catch_unwind(AssertUnwindSafe(|| drop(Box::from_raw(inst))));
}

pub unsafe fn fmi2SetupExperiment<M: Model>(
    c: fmi2Component,
    _toleranceDefined: fmi2Boolean,
    _tolerance: fmi2Real,
    startTime: fmi2Real,
    stopTimeDefined: fmi2Boolean,
    stopTime: fmi2Real,
) -> fmi2Status {
    with_instance::<M>(c, "fmi2SetupExperiment", I, |inst| {
        const F: &str = "fmi2SetupExperiment";
        if !startTime.is_finite() {
            return refuse(inst, F, &format!("startTime {startTime} is not finite"));
        }
        let stop = if stopTimeDefined != fmi2False {
            if !stopTime.is_finite() || stopTime < startTime {
                return refuse(
                    inst,
                    F,
                    &format!("stopTime {stopTime} is not finite or before startTime {startTime}"),
                );
            }
            Some(stopTime)
        } else {
            None
        };
        inst.start_time = startTime;
        inst.time = startTime;
        inst.stop_time = stop;
        fmi2OK
    })
}

pub unsafe fn fmi2EnterInitializationMode<M: Model>(c: fmi2Component) -> fmi2Status {
    with_instance::<M>(c, "fmi2EnterInitializationMode", I, |inst| {
        inst.state = State::InitializationMode;
        fmi2OK
    })
}

pub unsafe fn fmi2ExitInitializationMode<M: Model>(c: fmi2Component) -> fmi2Status {
    with_instance::<M>(c, "fmi2ExitInitializationMode", IM, |inst| {
        match inst.model.exit_initialization(inst.start_time) {
            Ok(()) => {
                inst.state = State::StepComplete;
                fmi2OK
            }
            Err(msg) => {
                inst.state = State::Error;
                refuse(inst, "fmi2ExitInitializationMode", &msg)
            }
        }
    })
}

pub unsafe fn fmi2Terminate<M: Model>(c: fmi2Component) -> fmi2Status {
    with_instance::<M>(c, "fmi2Terminate", SC | SF | SCA, |inst| {
        inst.state = State::Terminated;
        fmi2OK
    })
}

pub unsafe fn fmi2Reset<M: Model>(c: fmi2Component) -> fmi2Status {
    with_instance::<M>(c, "fmi2Reset", LIVE, |inst| {
        inst.model = M::new();
        inst.state = State::Instantiated;
        inst.time = 0.0;
        inst.start_time = 0.0;
        inst.stop_time = None;
        inst.last_step_status = fmi2OK;
        fmi2OK
    })
}

macro_rules! getter {
    ($name:ident, $cty:ty, $kind:expr, $get:ident, $conv:expr) => {
        pub unsafe fn $name<M: Model>(
            c: fmi2Component,
            vr: *const fmi2ValueReference,
            nvr: usize,
            value: *mut $cty,
        ) -> fmi2Status {
            with_instance::<M>(c, stringify!($name), GETTABLE, |inst| {
                const FUNC: &str = stringify!($name);
                let (Some(vrs), Some(values)) = (slice(vr, nvr), slice_mut(value, nvr)) else {
                    return refuse(inst, FUNC, "vr or value is NULL");
                };
                for (r, out) in vrs.iter().zip(values.iter_mut()) {
                    let got = lookup::<M>(*r, $kind).and_then(|_| inst.model.$get(*r));
                    match got {
                        Ok(v) => *out = $conv(v),
                        Err(msg) => return refuse(inst, FUNC, &msg),
                    }
                }
                fmi2OK
            })
        }
    };
}

getter!(fmi2GetReal, fmi2Real, Kind::Real, get_real, |v: f64| v);
getter!(fmi2GetInteger, fmi2Integer, Kind::Integer, get_integer, |v: i32| v);
getter!(fmi2GetBoolean, fmi2Boolean, Kind::Boolean, get_boolean, |v: bool| if v {
    fmi2True
} else {
    fmi2False
});

/// Whether the variable may be set in the instance's current state.
fn check_settable<M: Model>(inst: &Instance<M>, v: &Variable) -> Result<(), String> {
    let ok = match inst.state {
        State::Instantiated | State::InitializationMode => v.settable_before_init(),
        _ => v.settable_after_init(),
    };
    if ok {
        Ok(())
    } else {
        Err(format!(
            "{} ({:?}, {:?}) cannot be set in state {}",
            v.name,
            v.causality,
            v.variability,
            inst.state.name()
        ))
    }
}

macro_rules! setter {
    ($name:ident, $cty:ty, $kind:expr, $set:ident, $conv:expr, $admit:expr) => {
        pub unsafe fn $name<M: Model>(
            c: fmi2Component,
            vr: *const fmi2ValueReference,
            nvr: usize,
            value: *const $cty,
        ) -> fmi2Status {
            with_instance::<M>(c, stringify!($name), SETTABLE, |inst| {
                const FUNC: &str = stringify!($name);
                let (Some(vrs), Some(values)) = (slice(vr, nvr), slice(value, nvr)) else {
                    return refuse(inst, FUNC, "vr or value is NULL");
                };
                // Each value stands alone: a refused one keeps its previous value and does
                // not stop the others, and the call reports the worst outcome.
                let mut status = fmi2OK;
                for (r, v) in vrs.iter().zip(values.iter()) {
                    let result = lookup::<M>(*r, $kind).and_then(|var| {
                        check_settable(inst, var)?;
                        let (value, warning) = $admit(&inst.model, var, $conv(*v))?;
                        inst.model.$set(*r, value)?;
                        Ok(warning)
                    });
                    match result {
                        Ok(None) => {}
                        Ok(Some(warning)) => {
                            inst.log(
                                fmi2Warning,
                                LogCategory::StatusWarning,
                                &format!("{FUNC}: {warning}"),
                            );
                            status = worst(status, fmi2Warning);
                        }
                        Err(msg) => status = worst(status, refuse(inst, FUNC, &msg)),
                    }
                }
                status
            })
        }
    };
}

/// A Real is admitted by its table entry (finite; an input clamped into its range).
fn admit_real<M: Model>(m: &M, v: &Variable, x: f64) -> Result<(f64, Option<String>), String> {
    v.admit_real(x, m.get_real(v.vr)?)
}

/// Integers and Booleans have no value a model could refuse by the table.
fn admit_any<M: Model, T>(_: &M, _: &Variable, x: T) -> Result<(T, Option<String>), String> {
    Ok((x, None))
}

setter!(fmi2SetReal, fmi2Real, Kind::Real, set_real, |v: f64| v, admit_real::<M>);
setter!(fmi2SetInteger, fmi2Integer, Kind::Integer, set_integer, |v: i32| v, admit_any::<M, i32>);
setter!(
    fmi2SetBoolean,
    fmi2Boolean,
    Kind::Boolean,
    set_boolean,
    |v: fmi2Boolean| v != fmi2False,
    admit_any::<M, bool>
);

pub unsafe fn fmi2GetString<M: Model>(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *mut fmi2String,
) -> fmi2Status {
    with_instance::<M>(c, "fmi2GetString", GETTABLE, |inst| {
        match (slice(vr, nvr), slice_mut(value, nvr)) {
            (Some([]), Some(_)) => fmi2OK,
            (Some(vrs), Some(_)) => refuse(
                inst,
                "fmi2GetString",
                &format!("unknown value reference {}: this FMU has no String variables", vrs[0]),
            ),
            _ => refuse(inst, "fmi2GetString", "vr or value is NULL"),
        }
    })
}

pub unsafe fn fmi2SetString<M: Model>(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *const fmi2String,
) -> fmi2Status {
    with_instance::<M>(c, "fmi2SetString", SETTABLE, |inst| {
        match (slice(vr, nvr), slice(value, nvr)) {
            (Some([]), Some(_)) => fmi2OK,
            (Some(vrs), Some(_)) => refuse(
                inst,
                "fmi2SetString",
                &format!("unknown value reference {}: this FMU has no String variables", vrs[0]),
            ),
            _ => refuse(inst, "fmi2SetString", "vr or value is NULL"),
        }
    })
}

fn encode_snapshot<M: Model>(s: &Snapshot<M>) -> Result<Vec<u8>, String> {
    let payload = state_blob::save_model(&s.model)?;
    let h = state_blob::Header {
        state: s.state,
        time: s.time,
        start_time: s.start_time,
        stop_time: s.stop_time,
    };
    Ok(state_blob::encode(model_description::guid::<M>(), &h, &payload))
}

/// The snapshot behind `state` if this instance handed it out.
unsafe fn own_snapshot<'a, M: Model>(
    inst: &Instance<M>,
    state: fmi2FMUstate,
) -> Option<&'a mut Snapshot<M>> {
    let p = state as *mut Snapshot<M>;
    inst.snapshots.contains(&p).then(|| &mut *p)
}

/// Stores `snap` into `*slot`: in place if it already holds one of ours, else a new one.
unsafe fn store_snapshot<M: Model>(
    inst: &mut Instance<M>,
    slot: *mut fmi2FMUstate,
    snap: Snapshot<M>,
) -> fmi2Status {
    if let Some(existing) = own_snapshot(inst, *slot) {
        *existing = snap;
    } else {
        let p = Box::into_raw(Box::new(snap));
        inst.snapshots.push(p);
        *slot = p as fmi2FMUstate;
    }
    fmi2OK
}

pub unsafe fn fmi2GetFMUstate<M: Model>(c: fmi2Component, state: *mut fmi2FMUstate) -> fmi2Status {
    with_instance::<M>(c, "fmi2GetFMUstate", STATE_CALLS, |inst| {
        if state.is_null() {
            return refuse(inst, "fmi2GetFMUstate", "FMUstate is NULL");
        }
        let snap = inst.snapshot();
        store_snapshot(inst, state, snap)
    })
}

pub unsafe fn fmi2SetFMUstate<M: Model>(c: fmi2Component, state: fmi2FMUstate) -> fmi2Status {
    with_instance::<M>(c, "fmi2SetFMUstate", STATE_CALLS, |inst| match own_snapshot(inst, state) {
        Some(s) => {
            let s = s.clone();
            inst.restore(&s);
            fmi2OK
        }
        None => refuse(
            inst,
            "fmi2SetFMUstate",
            "FMUstate was not created by fmi2GetFMUstate of this instance (or was freed)",
        ),
    })
}

pub unsafe fn fmi2FreeFMUstate<M: Model>(c: fmi2Component, state: *mut fmi2FMUstate) -> fmi2Status {
    with_instance::<M>(c, "fmi2FreeFMUstate", STATE_CALLS, |inst| {
        if state.is_null() || (*state).is_null() {
            return fmi2OK;
        }
        let p = *state as *mut Snapshot<M>;
        match inst.snapshots.iter().position(|&s| s == p) {
            Some(i) => {
                inst.snapshots.swap_remove(i);
                drop(Box::from_raw(p));
                *state = std::ptr::null_mut();
                fmi2OK
            }
            None => refuse(
                inst,
                "fmi2FreeFMUstate",
                "FMUstate was not created by this instance (or was freed already)",
            ),
        }
    })
}

pub unsafe fn fmi2SerializedFMUstateSize<M: Model>(
    c: fmi2Component,
    state: fmi2FMUstate,
    size: *mut usize,
) -> fmi2Status {
    with_instance::<M>(c, "fmi2SerializedFMUstateSize", STATE_CALLS, |inst| {
        if size.is_null() {
            return refuse(inst, "fmi2SerializedFMUstateSize", "size is NULL");
        }
        match own_snapshot(inst, state) {
            Some(s) => match encode_snapshot(s) {
                Ok(blob) => {
                    *size = blob.len();
                    fmi2OK
                }
                Err(msg) => refuse(inst, "fmi2SerializedFMUstateSize", &msg),
            },
            None => refuse(
                inst,
                "fmi2SerializedFMUstateSize",
                "FMUstate was not created by this instance",
            ),
        }
    })
}

pub unsafe fn fmi2SerializeFMUstate<M: Model>(
    c: fmi2Component,
    state: fmi2FMUstate,
    bytes: *mut fmi2Byte,
    size: usize,
) -> fmi2Status {
    with_instance::<M>(c, "fmi2SerializeFMUstate", STATE_CALLS, |inst| {
        const FUNC: &str = "fmi2SerializeFMUstate";
        let Some(s) = own_snapshot(inst, state) else {
            return refuse(inst, FUNC, "FMUstate was not created by this instance");
        };
        let blob = match encode_snapshot(s) {
            Ok(blob) => blob,
            Err(msg) => return refuse(inst, FUNC, &msg),
        };
        let Some(out) = slice_mut(bytes as *mut u8, size) else {
            return refuse(inst, FUNC, "serializedState is NULL");
        };
        if out.len() < blob.len() {
            return refuse(
                inst,
                FUNC,
                &format!(
                    "buffer of {} bytes is smaller than the state ({} bytes)",
                    out.len(),
                    blob.len()
                ),
            );
        }
        out[..blob.len()].copy_from_slice(&blob);
        fmi2OK
    })
}

pub unsafe fn fmi2DeSerializeFMUstate<M: Model>(
    c: fmi2Component,
    bytes: *const fmi2Byte,
    size: usize,
    state: *mut fmi2FMUstate,
) -> fmi2Status {
    with_instance::<M>(c, "fmi2DeSerializeFMUstate", STATE_CALLS, |inst| {
        const FUNC: &str = "fmi2DeSerializeFMUstate";
        let (Some(blob), false) = (slice(bytes as *const u8, size), state.is_null()) else {
            return refuse(inst, FUNC, "serializedState or FMUstate is NULL");
        };
        let (header, payload) = match state_blob::decode(model_description::guid::<M>(), blob) {
            Ok(x) => x,
            Err(msg) => return refuse(inst, FUNC, &msg),
        };
        let model = match state_blob::load_model::<M>(payload) {
            Ok(m) => m,
            Err(msg) => return refuse(inst, FUNC, &format!("model state refused: {msg}")),
        };
        let snap = Snapshot {
            model,
            state: header.state,
            time: header.time,
            start_time: header.start_time,
            stop_time: header.stop_time,
        };
        store_snapshot(inst, state, snap)
    })
}

pub unsafe fn fmi2GetDirectionalDerivative<M: Model>(
    c: fmi2Component,
    _vUnknown_ref: *const fmi2ValueReference,
    _nUnknown: usize,
    _vKnown_ref: *const fmi2ValueReference,
    _nKnown: usize,
    _dvKnown: *const fmi2Real,
    _dvUnknown: *mut fmi2Real,
) -> fmi2Status {
    with_instance::<M>(c, "fmi2GetDirectionalDerivative", GETTABLE, |inst| {
        refuse(inst, "fmi2GetDirectionalDerivative", "not supported: providesDirectionalDerivative is false (estimate derivatives by finite differences over fmi2GetFMUstate and fmi2SetFMUstate)")
    })
}

pub unsafe fn fmi2SetRealInputDerivatives<M: Model>(
    c: fmi2Component,
    _vr: *const fmi2ValueReference,
    _nvr: usize,
    _order: *const fmi2Integer,
    _value: *const fmi2Real,
) -> fmi2Status {
    with_instance::<M>(c, "fmi2SetRealInputDerivatives", SETTABLE, |inst| {
        refuse(inst, "fmi2SetRealInputDerivatives", "not supported: canInterpolateInputs is false (inputs are held constant over each communication step)")
    })
}

pub unsafe fn fmi2GetRealOutputDerivatives<M: Model>(
    c: fmi2Component,
    _vr: *const fmi2ValueReference,
    _nvr: usize,
    _order: *const fmi2Integer,
    _value: *mut fmi2Real,
) -> fmi2Status {
    with_instance::<M>(c, "fmi2GetRealOutputDerivatives", SC | SF | SCA | T | E, |inst| {
        refuse(inst, "fmi2GetRealOutputDerivatives", "not supported: maxOutputDerivativeOrder is 0")
    })
}

pub unsafe fn fmi2DoStep<M: Model>(
    c: fmi2Component,
    currentCommunicationPoint: fmi2Real,
    communicationStepSize: fmi2Real,
    _noSetFMUStatePriorToCurrentPoint: fmi2Boolean,
) -> fmi2Status {
    with_instance::<M>(c, "fmi2DoStep", SC, |inst| {
        const FUNC: &str = "fmi2DoStep";
        let (t, h) = (currentCommunicationPoint, communicationStepSize);
        if !(h.is_finite() && h > 0.0) {
            return refuse(
                inst,
                FUNC,
                &format!("communicationStepSize {h} must be finite and > 0"),
            );
        }
        if !t.is_finite() || !same_time(t, inst.time) {
            return refuse(
                inst,
                FUNC,
                &format!("currentCommunicationPoint {t} does not match the FMU time {} (a step must start where the last one ended)", inst.time),
            );
        }
        if let Some(stop) = inst.stop_time {
            if t + h > stop && !same_time(t + h, stop) {
                return refuse(
                    inst,
                    FUNC,
                    &format!(
                        "step to {} passes the stop time {stop} set in fmi2SetupExperiment",
                        t + h
                    ),
                );
            }
        }
        if let Err(msg) = inst.model.check_step(t, h) {
            return refuse(inst, FUNC, &msg);
        }
        match inst.model.do_step(t, h) {
            Ok(messages) => {
                // The master's clock is the reference: following it keeps t and the FMU
                // time equal however the master accumulates it.
                inst.time = t + h;
                let mut status = fmi2OK;
                for m in messages {
                    match m {
                        Message::Event(text) => inst.log(fmi2OK, LogCategory::Events, &text),
                        Message::Warning(text) => {
                            inst.log(
                                fmi2Warning,
                                LogCategory::StatusWarning,
                                &format!("{FUNC}: {text}"),
                            );
                            status = fmi2Warning;
                        }
                    }
                }
                inst.last_step_status = status;
                status
            }
            Err(msg) => {
                inst.state = State::Error;
                inst.last_step_status = fmi2Error;
                refuse(inst, FUNC, &msg)
            }
        }
    })
}

/// Communication points from `t += h` and from `k · h` differ by rounding; they are the
/// same point when within 1e-9 of the time (and within a few ulps at t = 0).
pub(crate) fn same_time(a: f64, b: f64) -> bool {
    let scale = a.abs().max(b.abs());
    (a - b).abs() <= (1e-9 * scale).max(4.0 * f64::EPSILON * scale).max(f64::MIN_POSITIVE)
}

pub unsafe fn fmi2CancelStep<M: Model>(c: fmi2Component) -> fmi2Status {
    with_instance::<M>(c, "fmi2CancelStep", LIVE, |inst| {
        refuse(inst, "fmi2CancelStep", "not supported: fmi2DoStep always completes synchronously, so there is no step in progress to cancel")
    })
}

pub unsafe fn fmi2GetStatus<M: Model>(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2Status,
) -> fmi2Status {
    with_instance::<M>(c, "fmi2GetStatus", STATUS_CALLS, |inst| {
        if value.is_null() {
            return refuse(inst, "fmi2GetStatus", "value is NULL");
        }
        match s {
            fmi2DoStepStatus => {
                *value = inst.last_step_status;
                fmi2OK
            }
            _ => refuse(
                inst,
                "fmi2GetStatus",
                &format!("status kind {s} has no fmi2Status value (fmi2DoStepStatus only)"),
            ),
        }
    })
}

pub unsafe fn fmi2GetRealStatus<M: Model>(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2Real,
) -> fmi2Status {
    with_instance::<M>(c, "fmi2GetRealStatus", STATUS_CALLS, |inst| {
        if value.is_null() {
            return refuse(inst, "fmi2GetRealStatus", "value is NULL");
        }
        match s {
            fmi2LastSuccessfulTime => {
                *value = inst.time;
                fmi2OK
            }
            _ => refuse(
                inst,
                "fmi2GetRealStatus",
                &format!("status kind {s} is not a Real status (fmi2LastSuccessfulTime only)"),
            ),
        }
    })
}

pub unsafe fn fmi2GetIntegerStatus<M: Model>(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2Integer,
) -> fmi2Status {
    with_instance::<M>(c, "fmi2GetIntegerStatus", STATUS_CALLS, |inst| {
        let _ = value;
        refuse(
            inst,
            "fmi2GetIntegerStatus",
            &format!("status kind {s}: FMI 2.0 defines no Integer status"),
        )
    })
}

pub unsafe fn fmi2GetBooleanStatus<M: Model>(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2Boolean,
) -> fmi2Status {
    with_instance::<M>(c, "fmi2GetBooleanStatus", STATUS_CALLS, |inst| {
        if value.is_null() {
            return refuse(inst, "fmi2GetBooleanStatus", "value is NULL");
        }
        match s {
            fmi2Terminated => {
                // The model never asks the master to end the simulation.
                *value = fmi2False;
                fmi2OK
            }
            _ => refuse(
                inst,
                "fmi2GetBooleanStatus",
                &format!("status kind {s} is not a Boolean status (fmi2Terminated only)"),
            ),
        }
    })
}

pub unsafe fn fmi2GetStringStatus<M: Model>(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2String,
) -> fmi2Status {
    with_instance::<M>(c, "fmi2GetStringStatus", STATUS_CALLS, |inst| {
        let _ = value;
        refuse(
            inst,
            "fmi2GetStringStatus",
            &format!("status kind {s}: no asynchronous step is ever pending"),
        )
    })
}
