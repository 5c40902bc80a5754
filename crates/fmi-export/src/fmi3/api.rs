//! The FMI 3.0 entry points, generic over the model; [`crate::export_fmi3!`] exports each
//! under its C name. The shape and the status policy are those of the FMI 2.0 entry points
//! ([`crate::api`]): check the instance pointer and the state mask, check the arguments,
//! run the body inside `catch_unwind`, log every refusal with the function and the reason.
//! A refused call returns `fmi3Error` and leaves the instance as it was; a failure of the
//! model moves it to Error; a panic returns `fmi3Fatal` and moves it to Fatal.
#![allow(
    non_snake_case,
    non_upper_case_globals,
    clippy::missing_safety_doc,
    clippy::too_many_arguments
)]

use std::ffi::{CStr, CString};
use std::os::raw::c_char;
use std::panic::{catch_unwind, AssertUnwindSafe};

use super::ffi::*;
use super::instance::{Instance3, Snapshot3, State3, INSTANCE3_MAGIC};
use super::TIME_VR;
use crate::instance::{Categories, LogCategory};
use crate::table::{Kind, Variable};
use crate::{model_description, state_blob, Message, Model};

const I: u16 = State3::Instantiated as u16;
const IM: u16 = State3::InitializationMode as u16;
const SM: u16 = State3::StepMode as u16;
const T: u16 = State3::Terminated as u16;
const E: u16 = State3::Error as u16;

const LIVE: u16 = I | IM | SM | T | E;
const GETTABLE: u16 = IM | SM | T | E;
const SETTABLE: u16 = I | IM | SM;
const STATE_CALLS: u16 = I | IM | SM | T | E;

unsafe fn with_instance<M: Model>(
    c: fmi3Instance,
    func: &str,
    allowed: u16,
    body: impl FnOnce(&mut Instance3<M>) -> fmi3Status,
) -> fmi3Status {
    if c.is_null() {
        return fmi3Error;
    }
    let inst = &mut *(c as *mut Instance3<M>);
    if inst.magic != INSTANCE3_MAGIC {
        return fmi3Error;
    }
    if inst.state as u16 & allowed == 0 {
        inst.log(
            fmi3Error,
            LogCategory::StatusError,
            &format!("{func}: illegal call sequence: not allowed in state {}", inst.state.name()),
        );
        return fmi3Error;
    }
    inst.log(fmi3OK, LogCategory::All, func);
    match catch_unwind(AssertUnwindSafe(|| body(&mut *inst))) {
        Ok(status) => status,
        Err(panic) => {
            let what = crate::instance::panic_text(panic.as_ref());
            inst.state = State3::Fatal;
            inst.log(
                fmi3Fatal,
                LogCategory::StatusError,
                &format!("{func}: internal error, instance unusable: {what}"),
            );
            fmi3Fatal
        }
    }
}

fn refuse<M: Model>(inst: &Instance3<M>, func: &str, why: &str) -> fmi3Status {
    inst.log(fmi3Error, LogCategory::StatusError, &format!("{func}: {why}"));
    fmi3Error
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

/// FMI 3.0 type name of a table kind.
pub fn type_name(k: Kind) -> &'static str {
    match k {
        Kind::Real => "Float64",
        Kind::Integer => "Int32",
        Kind::Boolean => "Boolean",
    }
}

fn variable<M: Model>(vr: u32) -> Option<&'static Variable> {
    M::variables().iter().find(|v| v.vr == vr)
}

fn lookup<M: Model>(vr: u32, kind: Kind) -> Result<&'static Variable, String> {
    match variable::<M>(vr) {
        None if vr == TIME_VR => Err(format!(
            "value reference {vr} is the independent variable time (Float64, not settable)"
        )),
        None => Err(format!("unknown value reference {vr}")),
        Some(v) if v.kind != kind => Err(format!(
            "value reference {vr} ({}) is {}, not {}",
            v.name,
            type_name(v.kind),
            type_name(kind)
        )),
        Some(v) => Ok(v),
    }
}

pub fn fmi3GetVersion() -> *const c_char {
    fmi3Version.as_ptr() as *const c_char
}

/// As FMI 2.0 (FMI 3.0 section 2.3.1 keeps the rules): on with no categories enables all,
/// on with names enables exactly those, off with names disables those, off with none
/// disables all; a NULL or unknown name refuses the call and changes nothing.
pub unsafe fn fmi3SetDebugLogging<M: Model>(
    c: fmi3Instance,
    loggingOn: fmi3Boolean,
    nCategories: usize,
    categories: *const fmi3String,
) -> fmi3Status {
    with_instance::<M>(c, "fmi3SetDebugLogging", LIVE, |inst| {
        const F: &str = "fmi3SetDebugLogging";
        let Some(names) = slice(categories, nCategories) else {
            return refuse(inst, F, "categories is NULL");
        };
        let mut named = Vec::with_capacity(names.len());
        for &p in names {
            if p.is_null() {
                return refuse(inst, F, "a category name is NULL; logging left unchanged");
            }
            let name = CStr::from_ptr(p).to_string_lossy();
            match LogCategory::from_name(&name) {
                Some(cat) => named.push(cat),
                None => {
                    let known: Vec<_> = LogCategory::ALL.iter().map(|c| c.name()).collect();
                    return refuse(
                        inst,
                        F,
                        &format!(
                            "unknown log category \"{name}\" (this FMU has {}); logging left unchanged",
                            known.join(", ")
                        ),
                    );
                }
            }
        }
        let named = Categories::of(&named);
        inst.categories = match (loggingOn, names.is_empty()) {
            (true, true) => Categories::ALL,
            (true, false) => named,
            (false, true) => Categories::NONE,
            (false, false) => inst.categories.without(named),
        };
        fmi3OK
    })
}

unsafe fn log_without_instance(
    env: fmi3InstanceEnvironment,
    logger: fmi3LogMessageCallback,
    message: &str,
) {
    if let Some(logger) = logger {
        let msg = CString::new(message.replace('\0', " ")).unwrap_or_default();
        logger(env, fmi3Error, c"logStatusError".as_ptr(), msg.as_ptr());
    }
}

pub unsafe fn fmi3InstantiateModelExchange<M: Model>(
    _instanceName: fmi3String,
    _instantiationToken: fmi3String,
    _resourcePath: fmi3String,
    _visible: fmi3Boolean,
    _loggingOn: fmi3Boolean,
    instanceEnvironment: fmi3InstanceEnvironment,
    logMessage: fmi3LogMessageCallback,
) -> fmi3Instance {
    let _ = catch_unwind(AssertUnwindSafe(|| {
        log_without_instance(
            instanceEnvironment,
            logMessage,
            "fmi3InstantiateModelExchange: not supported: this FMU implements Co-Simulation only",
        );
    }));
    std::ptr::null_mut()
}

pub unsafe fn fmi3InstantiateScheduledExecution<M: Model>(
    _instanceName: fmi3String,
    _instantiationToken: fmi3String,
    _resourcePath: fmi3String,
    _visible: fmi3Boolean,
    _loggingOn: fmi3Boolean,
    instanceEnvironment: fmi3InstanceEnvironment,
    logMessage: fmi3LogMessageCallback,
    _clockUpdate: fmi3ClockUpdateCallback,
    _lockPreemption: fmi3LockPreemptionCallback,
    _unlockPreemption: fmi3UnlockPreemptionCallback,
) -> fmi3Instance {
    let _ = catch_unwind(AssertUnwindSafe(|| {
        log_without_instance(instanceEnvironment, logMessage, "fmi3InstantiateScheduledExecution: not supported: this FMU implements Co-Simulation only");
    }));
    std::ptr::null_mut()
}

pub unsafe fn fmi3InstantiateCoSimulation<M: Model>(
    instanceName: fmi3String,
    instantiationToken: fmi3String,
    _resourcePath: fmi3String,
    _visible: fmi3Boolean,
    loggingOn: fmi3Boolean,
    eventModeUsed: fmi3Boolean,
    earlyReturnAllowed: fmi3Boolean,
    _requiredIntermediateVariables: *const fmi3ValueReference,
    nRequiredIntermediateVariables: usize,
    instanceEnvironment: fmi3InstanceEnvironment,
    logMessage: fmi3LogMessageCallback,
    _intermediateUpdate: fmi3IntermediateUpdateCallback,
) -> fmi3Instance {
    let result = catch_unwind(AssertUnwindSafe(|| {
        let fail = |msg: &str| {
            log_without_instance(
                instanceEnvironment,
                logMessage,
                &format!("fmi3InstantiateCoSimulation: {msg}"),
            );
            std::ptr::null_mut()
        };
        if instanceName.is_null() || *instanceName == 0 {
            return fail("instanceName is NULL or empty");
        }
        if eventModeUsed {
            return fail(
                "eventModeUsed requested, but this FMU has no event mode (hasEventMode=\"false\")",
            );
        }
        if nRequiredIntermediateVariables != 0 {
            return fail("requiredIntermediateVariables given, but this FMU provides no intermediate updates");
        }
        // earlyReturnAllowed is a permission: the FMU never returns early.
        let _ = earlyReturnAllowed;
        let token = model_description::guid::<M>();
        if instantiationToken.is_null() {
            return fail("instantiationToken is NULL");
        }
        let given = CStr::from_ptr(instantiationToken).to_string_lossy();
        if given != token {
            return fail(&format!("instantiationToken \"{given}\" does not match this FMU's \"{token}\" (modelDescription.xml from another build?)"));
        }
        let name = CStr::from_ptr(instanceName).to_owned();
        let inst = Instance3::<M>::new(name, instanceEnvironment, logMessage, loggingOn);
        Box::into_raw(Box::new(inst)) as fmi3Instance
    }));
    result.unwrap_or(std::ptr::null_mut())
}

pub unsafe fn fmi3FreeInstance<M: Model>(c: fmi3Instance) {
    if c.is_null() {
        return;
    }
    let inst = c as *mut Instance3<M>;
    if (*inst).magic != INSTANCE3_MAGIC {
        return;
    }
    let _ = catch_unwind(AssertUnwindSafe(|| drop(Box::from_raw(inst))));
}

pub unsafe fn fmi3EnterInitializationMode<M: Model>(
    c: fmi3Instance,
    _toleranceDefined: fmi3Boolean,
    _tolerance: fmi3Float64,
    startTime: fmi3Float64,
    stopTimeDefined: fmi3Boolean,
    stopTime: fmi3Float64,
) -> fmi3Status {
    with_instance::<M>(c, "fmi3EnterInitializationMode", I, |inst| {
        const F: &str = "fmi3EnterInitializationMode";
        if !startTime.is_finite() {
            return refuse(inst, F, &format!("startTime {startTime} is not finite"));
        }
        let stop = if stopTimeDefined {
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
        inst.state = State3::InitializationMode;
        fmi3OK
    })
}

pub unsafe fn fmi3ExitInitializationMode<M: Model>(c: fmi3Instance) -> fmi3Status {
    with_instance::<M>(c, "fmi3ExitInitializationMode", IM, |inst| {
        match inst.model.exit_initialization(inst.start_time) {
            Ok(()) => {
                // Without event mode, Co-Simulation goes straight to step mode.
                inst.state = State3::StepMode;
                fmi3OK
            }
            Err(msg) => {
                inst.state = State3::Error;
                refuse(inst, "fmi3ExitInitializationMode", &msg)
            }
        }
    })
}

pub unsafe fn fmi3EnterEventMode<M: Model>(c: fmi3Instance) -> fmi3Status {
    with_instance::<M>(c, "fmi3EnterEventMode", LIVE, |inst| {
        refuse(
            inst,
            "fmi3EnterEventMode",
            "not supported: hasEventMode is false (fmi3DoStep never asks for event handling)",
        )
    })
}

pub unsafe fn fmi3EnterStepMode<M: Model>(c: fmi3Instance) -> fmi3Status {
    with_instance::<M>(c, "fmi3EnterStepMode", LIVE, |inst| {
        refuse(inst, "fmi3EnterStepMode", "not supported: hasEventMode is false, so the FMU is never in event mode (fmi3ExitInitializationMode enters step mode)")
    })
}

pub unsafe fn fmi3Terminate<M: Model>(c: fmi3Instance) -> fmi3Status {
    with_instance::<M>(c, "fmi3Terminate", SM, |inst| {
        inst.state = State3::Terminated;
        fmi3OK
    })
}

pub unsafe fn fmi3Reset<M: Model>(c: fmi3Instance) -> fmi3Status {
    with_instance::<M>(c, "fmi3Reset", LIVE, |inst| {
        inst.model = M::new();
        inst.state = State3::Instantiated;
        inst.time = 0.0;
        inst.start_time = 0.0;
        inst.stop_time = None;
        fmi3OK
    })
}

/// Refuses a call whose value count is not one per scalar value reference.
fn check_counts<M: Model>(
    inst: &Instance3<M>,
    func: &str,
    nvr: usize,
    nvalues: usize,
) -> Result<(), fmi3Status> {
    if nvr == nvalues {
        Ok(())
    } else {
        Err(refuse(
            inst,
            func,
            &format!("nValues {nvalues} differs from nValueReferences {nvr} (every variable of this FMU is a scalar)"),
        ))
    }
}

macro_rules! getter {
    ($name:ident, $cty:ty, $kind:expr, $get:ident, $conv:expr, $special:expr) => {
        pub unsafe fn $name<M: Model>(
            c: fmi3Instance,
            vr: *const fmi3ValueReference,
            nvr: usize,
            value: *mut $cty,
            nValues: usize,
        ) -> fmi3Status {
            with_instance::<M>(c, stringify!($name), GETTABLE, |inst| {
                const F: &str = stringify!($name);
                if let Err(s) = check_counts(inst, F, nvr, nValues) {
                    return s;
                }
                let (Some(vrs), Some(values)) = (slice(vr, nvr), slice_mut(value, nvr)) else {
                    return refuse(inst, F, "valueReferences or values is NULL");
                };
                for (r, out) in vrs.iter().zip(values.iter_mut()) {
                    let got = $special(inst, *r).unwrap_or_else(|| {
                        lookup::<M>(*r, $kind).and_then(|_| inst.model.$get(*r))
                    });
                    match got {
                        Ok(v) => *out = $conv(v),
                        Err(msg) => return refuse(inst, F, &msg),
                    }
                }
                fmi3OK
            })
        }
    };
}

/// The independent variable `time`, the layer's own Float64.
fn time_of<M: Model>(inst: &Instance3<M>, vr: u32) -> Option<Result<f64, String>> {
    (vr == TIME_VR && variable::<M>(TIME_VR).is_none()).then_some(Ok(inst.time))
}

fn no_special<M: Model, T>(_: &Instance3<M>, _: u32) -> Option<Result<T, String>> {
    None
}

getter!(fmi3GetFloat64, fmi3Float64, Kind::Real, get_real, |v: f64| v, time_of::<M>);
getter!(fmi3GetInt32, fmi3Int32, Kind::Integer, get_integer, |v: i32| v, no_special::<M, i32>);
getter!(
    fmi3GetBoolean,
    fmi3Boolean,
    Kind::Boolean,
    get_boolean,
    |v: bool| v,
    no_special::<M, bool>
);

fn check_settable<M: Model>(inst: &Instance3<M>, v: &Variable) -> Result<(), String> {
    let ok = match inst.state {
        State3::Instantiated | State3::InitializationMode => v.settable_before_init(),
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
    ($name:ident, $cty:ty, $read:ty, $kind:expr, $set:ident, $conv:expr, $admit:expr) => {
        pub unsafe fn $name<M: Model>(
            c: fmi3Instance,
            vr: *const fmi3ValueReference,
            nvr: usize,
            value: *const $cty,
            nValues: usize,
        ) -> fmi3Status {
            with_instance::<M>(c, stringify!($name), SETTABLE, |inst| {
                const F: &str = stringify!($name);
                if let Err(s) = check_counts(inst, F, nvr, nValues) {
                    return s;
                }
                // Read as `$read`: a C bool the master filled with another byte than 0 or
                // 1 must not become an invalid Rust bool.
                let (Some(vrs), Some(values)) = (slice(vr, nvr), slice(value as *const $read, nvr))
                else {
                    return refuse(inst, F, "valueReferences or values is NULL");
                };
                let mut status = fmi3OK;
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
                                fmi3Warning,
                                LogCategory::StatusWarning,
                                &format!("{F}: {warning}"),
                            );
                            status = status.max(fmi3Warning);
                        }
                        Err(msg) => status = status.max(refuse(inst, F, &msg)),
                    }
                }
                status
            })
        }
    };
}

fn admit_real<M: Model>(m: &M, v: &Variable, x: f64) -> Result<(f64, Option<String>), String> {
    v.admit_real(x, m.get_real(v.vr)?)
}

fn admit_any<M: Model, T>(_: &M, _: &Variable, x: T) -> Result<(T, Option<String>), String> {
    Ok((x, None))
}

setter!(fmi3SetFloat64, fmi3Float64, f64, Kind::Real, set_real, |v: f64| v, admit_real::<M>);
setter!(fmi3SetInt32, fmi3Int32, i32, Kind::Integer, set_integer, |v: i32| v, admit_any::<M, i32>);
setter!(
    fmi3SetBoolean,
    fmi3Boolean,
    u8,
    Kind::Boolean,
    set_boolean,
    |v: u8| v != 0,
    admit_any::<M, bool>
);

/// The answer for a type the FMU has no variables of: nothing to do for no references,
/// else the first reference named (unknown, or of which type it is).
unsafe fn no_variables_of<M: Model>(
    c: fmi3Instance,
    func: &str,
    allowed: u16,
    ty: &str,
    vr: *const fmi3ValueReference,
    nvr: usize,
) -> fmi3Status {
    with_instance::<M>(c, func, allowed, |inst| match slice(vr, nvr) {
        None => refuse(inst, func, "valueReferences is NULL"),
        Some([]) => fmi3OK,
        Some([r, ..]) => {
            let what = match variable::<M>(*r) {
                Some(v) => {
                    format!("value reference {r} ({}) is {}, not {ty}", v.name, type_name(v.kind))
                }
                None if *r == TIME_VR => format!("value reference {r} (time) is Float64, not {ty}"),
                None => format!("unknown value reference {r}: this FMU has no {ty} variables"),
            };
            refuse(inst, func, &what)
        }
    })
}

macro_rules! absent_type {
    ($get:ident, $set:ident, $cty:ty, $ty:literal) => {
        pub unsafe fn $get<M: Model>(
            c: fmi3Instance,
            vr: *const fmi3ValueReference,
            nvr: usize,
            _values: *mut $cty,
            _nValues: usize,
        ) -> fmi3Status {
            no_variables_of::<M>(c, stringify!($get), GETTABLE, $ty, vr, nvr)
        }
        pub unsafe fn $set<M: Model>(
            c: fmi3Instance,
            vr: *const fmi3ValueReference,
            nvr: usize,
            _values: *const $cty,
            _nValues: usize,
        ) -> fmi3Status {
            no_variables_of::<M>(c, stringify!($set), SETTABLE, $ty, vr, nvr)
        }
    };
}

absent_type!(fmi3GetFloat32, fmi3SetFloat32, fmi3Float32, "Float32");
absent_type!(fmi3GetInt8, fmi3SetInt8, fmi3Int8, "Int8");
absent_type!(fmi3GetUInt8, fmi3SetUInt8, fmi3UInt8, "UInt8");
absent_type!(fmi3GetInt16, fmi3SetInt16, fmi3Int16, "Int16");
absent_type!(fmi3GetUInt16, fmi3SetUInt16, fmi3UInt16, "UInt16");
absent_type!(fmi3GetUInt32, fmi3SetUInt32, fmi3UInt32, "UInt32");
absent_type!(fmi3GetInt64, fmi3SetInt64, fmi3Int64, "Int64");
absent_type!(fmi3GetUInt64, fmi3SetUInt64, fmi3UInt64, "UInt64");
absent_type!(fmi3GetString, fmi3SetString, fmi3String, "String");

pub unsafe fn fmi3GetBinary<M: Model>(
    c: fmi3Instance,
    vr: *const fmi3ValueReference,
    nvr: usize,
    _valueSizes: *mut usize,
    _values: *mut fmi3Binary,
    _nValues: usize,
) -> fmi3Status {
    no_variables_of::<M>(c, "fmi3GetBinary", GETTABLE, "Binary", vr, nvr)
}

pub unsafe fn fmi3SetBinary<M: Model>(
    c: fmi3Instance,
    vr: *const fmi3ValueReference,
    nvr: usize,
    _valueSizes: *const usize,
    _values: *const fmi3Binary,
    _nValues: usize,
) -> fmi3Status {
    no_variables_of::<M>(c, "fmi3SetBinary", SETTABLE, "Binary", vr, nvr)
}

pub unsafe fn fmi3GetClock<M: Model>(
    c: fmi3Instance,
    vr: *const fmi3ValueReference,
    nvr: usize,
    _values: *mut fmi3Clock,
) -> fmi3Status {
    no_variables_of::<M>(c, "fmi3GetClock", LIVE, "Clock", vr, nvr)
}

pub unsafe fn fmi3SetClock<M: Model>(
    c: fmi3Instance,
    vr: *const fmi3ValueReference,
    nvr: usize,
    _values: *const fmi3Clock,
) -> fmi3Status {
    no_variables_of::<M>(c, "fmi3SetClock", LIVE, "Clock", vr, nvr)
}

/// An entry point this FMU does not support: logged with the reason, `fmi3Error`.
unsafe fn unsupported<M: Model>(c: fmi3Instance, func: &str, why: &str) -> fmi3Status {
    with_instance::<M>(c, func, LIVE, |inst| refuse(inst, func, &format!("not supported: {why}")))
}

const NO_CLOCKS: &str = "this FMU has no clocks";
const NOT_ME: &str = "this FMU implements Co-Simulation only (no Model Exchange)";

pub unsafe fn fmi3GetNumberOfVariableDependencies<M: Model>(
    c: fmi3Instance,
    _valueReference: fmi3ValueReference,
    _nDependencies: *mut usize,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3GetNumberOfVariableDependencies", "providesPerElementDependencies is false (ModelStructure declares every output as depending on all inputs)")
}

pub unsafe fn fmi3GetVariableDependencies<M: Model>(
    c: fmi3Instance,
    _dependent: fmi3ValueReference,
    _elementIndicesOfDependent: *mut usize,
    _independents: *mut fmi3ValueReference,
    _elementIndicesOfIndependents: *mut usize,
    _dependencyKinds: *mut fmi3DependencyKind,
    _nDependencies: usize,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3GetVariableDependencies", "providesPerElementDependencies is false (ModelStructure declares every output as depending on all inputs)")
}

fn encode_snapshot<M: Model>(s: &Snapshot3<M>) -> Result<Vec<u8>, String> {
    let state = s.state.to_blob().ok_or("an FMU state in Error or Fatal is never saved")?;
    let payload = state_blob::save_model(&s.model)?;
    let h = state_blob::Header {
        state,
        time: s.time,
        start_time: s.start_time,
        stop_time: s.stop_time,
    };
    Ok(state_blob::encode(model_description::guid::<M>(), &h, &payload))
}

unsafe fn own_snapshot<'a, M: Model>(
    inst: &Instance3<M>,
    state: fmi3FMUState,
) -> Option<&'a mut Snapshot3<M>> {
    let p = state as *mut Snapshot3<M>;
    inst.snapshots.contains(&p).then(|| &mut *p)
}

unsafe fn store_snapshot<M: Model>(
    inst: &mut Instance3<M>,
    slot: *mut fmi3FMUState,
    snap: Snapshot3<M>,
) -> fmi3Status {
    if let Some(existing) = own_snapshot(inst, *slot) {
        *existing = snap;
    } else {
        let p = Box::into_raw(Box::new(snap));
        inst.snapshots.push(p);
        *slot = p as fmi3FMUState;
    }
    fmi3OK
}

pub unsafe fn fmi3GetFMUState<M: Model>(c: fmi3Instance, state: *mut fmi3FMUState) -> fmi3Status {
    with_instance::<M>(c, "fmi3GetFMUState", STATE_CALLS, |inst| {
        if state.is_null() {
            return refuse(inst, "fmi3GetFMUState", "FMUState is NULL");
        }
        if inst.state == State3::Error {
            return refuse(
                inst,
                "fmi3GetFMUState",
                "an instance in Error state has no state worth saving",
            );
        }
        let snap = inst.snapshot();
        store_snapshot(inst, state, snap)
    })
}

pub unsafe fn fmi3SetFMUState<M: Model>(c: fmi3Instance, state: fmi3FMUState) -> fmi3Status {
    with_instance::<M>(c, "fmi3SetFMUState", STATE_CALLS, |inst| match own_snapshot(inst, state) {
        Some(s) => {
            let s = s.clone();
            inst.restore(&s);
            fmi3OK
        }
        None => refuse(
            inst,
            "fmi3SetFMUState",
            "FMUState was not created by fmi3GetFMUState of this instance (or was freed)",
        ),
    })
}

pub unsafe fn fmi3FreeFMUState<M: Model>(c: fmi3Instance, state: *mut fmi3FMUState) -> fmi3Status {
    with_instance::<M>(c, "fmi3FreeFMUState", STATE_CALLS, |inst| {
        if state.is_null() || (*state).is_null() {
            return fmi3OK;
        }
        let p = *state as *mut Snapshot3<M>;
        match inst.snapshots.iter().position(|&s| s == p) {
            Some(i) => {
                inst.snapshots.swap_remove(i);
                drop(Box::from_raw(p));
                *state = std::ptr::null_mut();
                fmi3OK
            }
            None => refuse(
                inst,
                "fmi3FreeFMUState",
                "FMUState was not created by this instance (or was freed already)",
            ),
        }
    })
}

pub unsafe fn fmi3SerializedFMUStateSize<M: Model>(
    c: fmi3Instance,
    state: fmi3FMUState,
    size: *mut usize,
) -> fmi3Status {
    with_instance::<M>(c, "fmi3SerializedFMUStateSize", STATE_CALLS, |inst| {
        const F: &str = "fmi3SerializedFMUStateSize";
        if size.is_null() {
            return refuse(inst, F, "size is NULL");
        }
        match own_snapshot(inst, state) {
            Some(s) => match encode_snapshot(s) {
                Ok(blob) => {
                    *size = blob.len();
                    fmi3OK
                }
                Err(msg) => refuse(inst, F, &msg),
            },
            None => refuse(inst, F, "FMUState was not created by this instance"),
        }
    })
}

pub unsafe fn fmi3SerializeFMUState<M: Model>(
    c: fmi3Instance,
    state: fmi3FMUState,
    bytes: *mut fmi3Byte,
    size: usize,
) -> fmi3Status {
    with_instance::<M>(c, "fmi3SerializeFMUState", STATE_CALLS, |inst| {
        const F: &str = "fmi3SerializeFMUState";
        let Some(s) = own_snapshot(inst, state) else {
            return refuse(inst, F, "FMUState was not created by this instance");
        };
        let blob = match encode_snapshot(s) {
            Ok(blob) => blob,
            Err(msg) => return refuse(inst, F, &msg),
        };
        let Some(out) = slice_mut(bytes, size) else {
            return refuse(inst, F, "serializedState is NULL");
        };
        if out.len() < blob.len() {
            return refuse(
                inst,
                F,
                &format!(
                    "buffer of {} bytes is smaller than the state ({} bytes)",
                    out.len(),
                    blob.len()
                ),
            );
        }
        out[..blob.len()].copy_from_slice(&blob);
        fmi3OK
    })
}

pub unsafe fn fmi3DeserializeFMUState<M: Model>(
    c: fmi3Instance,
    bytes: *const fmi3Byte,
    size: usize,
    state: *mut fmi3FMUState,
) -> fmi3Status {
    with_instance::<M>(c, "fmi3DeserializeFMUState", STATE_CALLS, |inst| {
        const F: &str = "fmi3DeserializeFMUState";
        let (Some(blob), false) = (slice(bytes, size), state.is_null()) else {
            return refuse(inst, F, "serializedState or FMUState is NULL");
        };
        let (header, payload) = match state_blob::decode(model_description::guid::<M>(), blob) {
            Ok(x) => x,
            Err(msg) => return refuse(inst, F, &msg),
        };
        let fmi_state = match State3::from_blob(header.state) {
            Ok(s) => s,
            Err(msg) => return refuse(inst, F, &msg),
        };
        let model = match state_blob::load_model::<M>(payload) {
            Ok(m) => m,
            Err(msg) => return refuse(inst, F, &format!("model state refused: {msg}")),
        };
        let snap = Snapshot3 {
            model,
            state: fmi_state,
            time: header.time,
            start_time: header.start_time,
            stop_time: header.stop_time,
        };
        store_snapshot(inst, state, snap)
    })
}

pub unsafe fn fmi3GetDirectionalDerivative<M: Model>(
    c: fmi3Instance,
    _unknowns: *const fmi3ValueReference,
    _nUnknowns: usize,
    _knowns: *const fmi3ValueReference,
    _nKnowns: usize,
    _seed: *const fmi3Float64,
    _nSeed: usize,
    _sensitivity: *mut fmi3Float64,
    _nSensitivity: usize,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3GetDirectionalDerivative", "providesDirectionalDerivatives is false (estimate derivatives by finite differences over fmi3GetFMUState and fmi3SetFMUState)")
}

pub unsafe fn fmi3GetAdjointDerivative<M: Model>(
    c: fmi3Instance,
    _unknowns: *const fmi3ValueReference,
    _nUnknowns: usize,
    _knowns: *const fmi3ValueReference,
    _nKnowns: usize,
    _seed: *const fmi3Float64,
    _nSeed: usize,
    _sensitivity: *mut fmi3Float64,
    _nSensitivity: usize,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3GetAdjointDerivative", "providesAdjointDerivatives is false")
}

pub unsafe fn fmi3EnterConfigurationMode<M: Model>(c: fmi3Instance) -> fmi3Status {
    unsupported::<M>(c, "fmi3EnterConfigurationMode", "this FMU has no structural parameters")
}

pub unsafe fn fmi3ExitConfigurationMode<M: Model>(c: fmi3Instance) -> fmi3Status {
    unsupported::<M>(
        c,
        "fmi3ExitConfigurationMode",
        "this FMU has no structural parameters, so it is never in configuration mode",
    )
}

pub unsafe fn fmi3GetIntervalDecimal<M: Model>(
    c: fmi3Instance,
    _vr: *const fmi3ValueReference,
    _nvr: usize,
    _intervals: *mut fmi3Float64,
    _qualifiers: *mut fmi3IntervalQualifier,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3GetIntervalDecimal", NO_CLOCKS)
}

pub unsafe fn fmi3GetIntervalFraction<M: Model>(
    c: fmi3Instance,
    _vr: *const fmi3ValueReference,
    _nvr: usize,
    _counters: *mut fmi3UInt64,
    _resolutions: *mut fmi3UInt64,
    _qualifiers: *mut fmi3IntervalQualifier,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3GetIntervalFraction", NO_CLOCKS)
}

pub unsafe fn fmi3GetShiftDecimal<M: Model>(
    c: fmi3Instance,
    _vr: *const fmi3ValueReference,
    _nvr: usize,
    _shifts: *mut fmi3Float64,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3GetShiftDecimal", NO_CLOCKS)
}

pub unsafe fn fmi3GetShiftFraction<M: Model>(
    c: fmi3Instance,
    _vr: *const fmi3ValueReference,
    _nvr: usize,
    _counters: *mut fmi3UInt64,
    _resolutions: *mut fmi3UInt64,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3GetShiftFraction", NO_CLOCKS)
}

pub unsafe fn fmi3SetIntervalDecimal<M: Model>(
    c: fmi3Instance,
    _vr: *const fmi3ValueReference,
    _nvr: usize,
    _intervals: *const fmi3Float64,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3SetIntervalDecimal", NO_CLOCKS)
}

pub unsafe fn fmi3SetIntervalFraction<M: Model>(
    c: fmi3Instance,
    _vr: *const fmi3ValueReference,
    _nvr: usize,
    _counters: *const fmi3UInt64,
    _resolutions: *const fmi3UInt64,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3SetIntervalFraction", NO_CLOCKS)
}

pub unsafe fn fmi3SetShiftDecimal<M: Model>(
    c: fmi3Instance,
    _vr: *const fmi3ValueReference,
    _nvr: usize,
    _shifts: *const fmi3Float64,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3SetShiftDecimal", NO_CLOCKS)
}

pub unsafe fn fmi3SetShiftFraction<M: Model>(
    c: fmi3Instance,
    _vr: *const fmi3ValueReference,
    _nvr: usize,
    _counters: *const fmi3UInt64,
    _resolutions: *const fmi3UInt64,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3SetShiftFraction", NO_CLOCKS)
}

pub unsafe fn fmi3EvaluateDiscreteStates<M: Model>(c: fmi3Instance) -> fmi3Status {
    unsupported::<M>(c, "fmi3EvaluateDiscreteStates", "providesEvaluateDiscreteStates is false")
}

pub unsafe fn fmi3UpdateDiscreteStates<M: Model>(
    c: fmi3Instance,
    _discreteStatesNeedUpdate: *mut fmi3Boolean,
    _terminateSimulation: *mut fmi3Boolean,
    _nominalsOfContinuousStatesChanged: *mut fmi3Boolean,
    _valuesOfContinuousStatesChanged: *mut fmi3Boolean,
    _nextEventTimeDefined: *mut fmi3Boolean,
    _nextEventTime: *mut fmi3Float64,
) -> fmi3Status {
    unsupported::<M>(
        c,
        "fmi3UpdateDiscreteStates",
        "hasEventMode is false, so the FMU is never in event mode",
    )
}

pub unsafe fn fmi3EnterContinuousTimeMode<M: Model>(c: fmi3Instance) -> fmi3Status {
    unsupported::<M>(c, "fmi3EnterContinuousTimeMode", NOT_ME)
}

pub unsafe fn fmi3CompletedIntegratorStep<M: Model>(
    c: fmi3Instance,
    _noSetFMUStatePriorToCurrentPoint: fmi3Boolean,
    _enterEventMode: *mut fmi3Boolean,
    _terminateSimulation: *mut fmi3Boolean,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3CompletedIntegratorStep", NOT_ME)
}

pub unsafe fn fmi3SetTime<M: Model>(c: fmi3Instance, _time: fmi3Float64) -> fmi3Status {
    unsupported::<M>(c, "fmi3SetTime", NOT_ME)
}

pub unsafe fn fmi3SetContinuousStates<M: Model>(
    c: fmi3Instance,
    _x: *const fmi3Float64,
    _nx: usize,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3SetContinuousStates", NOT_ME)
}

pub unsafe fn fmi3GetContinuousStateDerivatives<M: Model>(
    c: fmi3Instance,
    _derivatives: *mut fmi3Float64,
    _nx: usize,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3GetContinuousStateDerivatives", NOT_ME)
}

pub unsafe fn fmi3GetEventIndicators<M: Model>(
    c: fmi3Instance,
    _indicators: *mut fmi3Float64,
    _n: usize,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3GetEventIndicators", NOT_ME)
}

pub unsafe fn fmi3GetContinuousStates<M: Model>(
    c: fmi3Instance,
    _x: *mut fmi3Float64,
    _nx: usize,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3GetContinuousStates", NOT_ME)
}

pub unsafe fn fmi3GetNominalsOfContinuousStates<M: Model>(
    c: fmi3Instance,
    _nominals: *mut fmi3Float64,
    _nx: usize,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3GetNominalsOfContinuousStates", NOT_ME)
}

pub unsafe fn fmi3GetNumberOfEventIndicators<M: Model>(
    c: fmi3Instance,
    _n: *mut usize,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3GetNumberOfEventIndicators", NOT_ME)
}

pub unsafe fn fmi3GetNumberOfContinuousStates<M: Model>(
    c: fmi3Instance,
    _n: *mut usize,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3GetNumberOfContinuousStates", NOT_ME)
}

pub unsafe fn fmi3ActivateModelPartition<M: Model>(
    c: fmi3Instance,
    _clockReference: fmi3ValueReference,
    _activationTime: fmi3Float64,
) -> fmi3Status {
    unsupported::<M>(
        c,
        "fmi3ActivateModelPartition",
        "this FMU implements Co-Simulation only (no Scheduled Execution)",
    )
}

pub unsafe fn fmi3GetOutputDerivatives<M: Model>(
    c: fmi3Instance,
    _vr: *const fmi3ValueReference,
    _nvr: usize,
    _orders: *const fmi3Int32,
    _values: *mut fmi3Float64,
    _nValues: usize,
) -> fmi3Status {
    unsupported::<M>(c, "fmi3GetOutputDerivatives", "maxOutputDerivativeOrder is 0")
}

/// Sets the four results of `fmi3DoStep` the master reads; a NULL one is skipped (the call
/// has already been refused for it).
unsafe fn step_results(
    eventHandlingNeeded: *mut fmi3Boolean,
    terminateSimulation: *mut fmi3Boolean,
    earlyReturn: *mut fmi3Boolean,
    lastSuccessfulTime: *mut fmi3Float64,
    (terminate, time): (bool, f64),
) {
    if !eventHandlingNeeded.is_null() {
        *eventHandlingNeeded = false;
    }
    if !terminateSimulation.is_null() {
        *terminateSimulation = terminate;
    }
    if !earlyReturn.is_null() {
        *earlyReturn = false;
    }
    if !lastSuccessfulTime.is_null() {
        *lastSuccessfulTime = time;
    }
}

/// One communication step. The FMU has no event mode and never returns early, so
/// `eventHandlingNeeded` and `earlyReturn` are always false; `lastSuccessfulTime` is the
/// end of the step, or the unchanged FMU time when the step was refused or failed;
/// `terminateSimulation` is true only when the model failed (the instance is then in Error).
pub unsafe fn fmi3DoStep<M: Model>(
    c: fmi3Instance,
    currentCommunicationPoint: fmi3Float64,
    communicationStepSize: fmi3Float64,
    _noSetFMUStatePriorToCurrentPoint: fmi3Boolean,
    eventHandlingNeeded: *mut fmi3Boolean,
    terminateSimulation: *mut fmi3Boolean,
    earlyReturn: *mut fmi3Boolean,
    lastSuccessfulTime: *mut fmi3Float64,
) -> fmi3Status {
    with_instance::<M>(c, "fmi3DoStep", SM, |inst| {
        const F: &str = "fmi3DoStep";
        let results = |outcome| {
            step_results(
                eventHandlingNeeded,
                terminateSimulation,
                earlyReturn,
                lastSuccessfulTime,
                outcome,
            )
        };
        results((false, inst.time));
        if eventHandlingNeeded.is_null()
            || terminateSimulation.is_null()
            || earlyReturn.is_null()
            || lastSuccessfulTime.is_null()
        {
            return refuse(
                inst,
                F,
                "eventHandlingNeeded, terminateSimulation, earlyReturn or lastSuccessfulTime is NULL",
            );
        }
        let (t, h) = (currentCommunicationPoint, communicationStepSize);
        if !(h.is_finite() && h > 0.0) {
            return refuse(inst, F, &format!("communicationStepSize {h} must be finite and > 0"));
        }
        if !t.is_finite() || !crate::api::same_time(t, inst.time) {
            return refuse(
                inst,
                F,
                &format!("currentCommunicationPoint {t} does not match the FMU time {} (a step must start where the last one ended)", inst.time),
            );
        }
        if let Some(stop) = inst.stop_time {
            if t + h > stop && !crate::api::same_time(t + h, stop) {
                return refuse(
                    inst,
                    F,
                    &format!(
                        "step to {} passes the stop time {stop} set in fmi3EnterInitializationMode",
                        t + h
                    ),
                );
            }
        }
        if let Err(msg) = inst.model.check_step(t, h) {
            return refuse(inst, F, &msg);
        }
        match inst.model.do_step(t, h) {
            Ok(messages) => {
                inst.time = t + h;
                results((false, inst.time));
                let mut status = fmi3OK;
                for m in messages {
                    match m {
                        Message::Event(text) => inst.log(fmi3OK, LogCategory::Events, &text),
                        Message::Warning(text) => {
                            inst.log(
                                fmi3Warning,
                                LogCategory::StatusWarning,
                                &format!("{F}: {text}"),
                            );
                            status = fmi3Warning;
                        }
                    }
                }
                status
            }
            Err(msg) => {
                inst.state = State3::Error;
                results((true, inst.time));
                refuse(inst, F, &msg)
            }
        }
    })
}
