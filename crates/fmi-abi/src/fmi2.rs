//! The FMI 2.0 C ABI (`fmi2TypesPlatform.h`, `fmi2FunctionTypes.h`), written out by hand:
//! the standard froze it in 2014, and a page of declarations spares every build of the
//! FMUs and the master a libclang/bindgen run.

use std::os::raw::{c_char, c_int, c_uint, c_void};

pub type fmi2Component = *mut c_void;
pub type fmi2ComponentEnvironment = *mut c_void;
pub type fmi2FMUstate = *mut c_void;
pub type fmi2ValueReference = c_uint;
pub type fmi2Real = f64;
pub type fmi2Integer = c_int;
pub type fmi2Boolean = c_int;
pub type fmi2Char = c_char;
pub type fmi2String = *const fmi2Char;
pub type fmi2Byte = c_char;

pub const fmi2True: fmi2Boolean = 1;
pub const fmi2False: fmi2Boolean = 0;

/// `fmi2Status` (a C enum, `int` on every supported platform).
pub type fmi2Status = c_int;
pub const fmi2OK: fmi2Status = 0;
pub const fmi2Warning: fmi2Status = 1;
pub const fmi2Discard: fmi2Status = 2;
pub const fmi2Error: fmi2Status = 3;
pub const fmi2Fatal: fmi2Status = 4;
pub const fmi2Pending: fmi2Status = 5;

/// `fmi2Type`.
pub type fmi2Type = c_int;
pub const fmi2ModelExchange: fmi2Type = 0;
pub const fmi2CoSimulation: fmi2Type = 1;

/// `fmi2StatusKind`.
pub type fmi2StatusKind = c_int;
pub const fmi2DoStepStatus: fmi2StatusKind = 0;
pub const fmi2PendingStatus: fmi2StatusKind = 1;
pub const fmi2LastSuccessfulTime: fmi2StatusKind = 2;
pub const fmi2Terminated: fmi2StatusKind = 3;

/// `fmi2CallbackLogger`: C-variadic. Rust can hold and call such a pointer but not define
/// the function, which lives in `logger.c`.
pub type fmi2CallbackLogger = unsafe extern "C" fn(
    fmi2ComponentEnvironment,
    fmi2String,
    fmi2Status,
    fmi2String,
    fmi2String,
    ...
);
pub type fmi2CallbackAllocateMemory = unsafe extern "C" fn(usize, usize) -> *mut c_void;
pub type fmi2CallbackFreeMemory = unsafe extern "C" fn(*mut c_void);
pub type fmi2StepFinished = unsafe extern "C" fn(fmi2ComponentEnvironment, fmi2Status);

/// `fmi2CallbackFunctions`. FMUs may keep the pointer to it (not a copy), so an importer
/// must keep it alive until `fmi2FreeInstance` has returned.
#[repr(C)]
#[derive(Clone, Copy)]
pub struct fmi2CallbackFunctions {
    pub logger: Option<fmi2CallbackLogger>,
    pub allocateMemory: Option<fmi2CallbackAllocateMemory>,
    pub freeMemory: Option<fmi2CallbackFreeMemory>,
    pub stepFinished: Option<fmi2StepFinished>,
    pub componentEnvironment: fmi2ComponentEnvironment,
}

pub type fmi2GetTypesPlatformTYPE = unsafe extern "C" fn() -> *const c_char;
pub type fmi2GetVersionTYPE = unsafe extern "C" fn() -> *const c_char;
pub type fmi2SetDebugLoggingTYPE =
    unsafe extern "C" fn(fmi2Component, fmi2Boolean, usize, *const fmi2String) -> fmi2Status;
pub type fmi2InstantiateTYPE = unsafe extern "C" fn(
    fmi2String,
    fmi2Type,
    fmi2String,
    fmi2String,
    *const fmi2CallbackFunctions,
    fmi2Boolean,
    fmi2Boolean,
) -> fmi2Component;
pub type fmi2FreeInstanceTYPE = unsafe extern "C" fn(fmi2Component);
pub type fmi2SetupExperimentTYPE = unsafe extern "C" fn(
    fmi2Component,
    fmi2Boolean,
    fmi2Real,
    fmi2Real,
    fmi2Boolean,
    fmi2Real,
) -> fmi2Status;
pub type fmi2EnterInitializationModeTYPE = unsafe extern "C" fn(fmi2Component) -> fmi2Status;
pub type fmi2ExitInitializationModeTYPE = unsafe extern "C" fn(fmi2Component) -> fmi2Status;
pub type fmi2TerminateTYPE = unsafe extern "C" fn(fmi2Component) -> fmi2Status;
pub type fmi2ResetTYPE = unsafe extern "C" fn(fmi2Component) -> fmi2Status;

pub type fmi2GetRealTYPE = unsafe extern "C" fn(
    fmi2Component,
    *const fmi2ValueReference,
    usize,
    *mut fmi2Real,
) -> fmi2Status;
pub type fmi2GetIntegerTYPE = unsafe extern "C" fn(
    fmi2Component,
    *const fmi2ValueReference,
    usize,
    *mut fmi2Integer,
) -> fmi2Status;
pub type fmi2GetBooleanTYPE = unsafe extern "C" fn(
    fmi2Component,
    *const fmi2ValueReference,
    usize,
    *mut fmi2Boolean,
) -> fmi2Status;
pub type fmi2GetStringTYPE = unsafe extern "C" fn(
    fmi2Component,
    *const fmi2ValueReference,
    usize,
    *mut fmi2String,
) -> fmi2Status;
pub type fmi2SetRealTYPE = unsafe extern "C" fn(
    fmi2Component,
    *const fmi2ValueReference,
    usize,
    *const fmi2Real,
) -> fmi2Status;
pub type fmi2SetIntegerTYPE = unsafe extern "C" fn(
    fmi2Component,
    *const fmi2ValueReference,
    usize,
    *const fmi2Integer,
) -> fmi2Status;
pub type fmi2SetBooleanTYPE = unsafe extern "C" fn(
    fmi2Component,
    *const fmi2ValueReference,
    usize,
    *const fmi2Boolean,
) -> fmi2Status;
pub type fmi2SetStringTYPE = unsafe extern "C" fn(
    fmi2Component,
    *const fmi2ValueReference,
    usize,
    *const fmi2String,
) -> fmi2Status;

pub type fmi2GetFMUstateTYPE = unsafe extern "C" fn(fmi2Component, *mut fmi2FMUstate) -> fmi2Status;
pub type fmi2SetFMUstateTYPE = unsafe extern "C" fn(fmi2Component, fmi2FMUstate) -> fmi2Status;
pub type fmi2FreeFMUstateTYPE =
    unsafe extern "C" fn(fmi2Component, *mut fmi2FMUstate) -> fmi2Status;
pub type fmi2SerializedFMUstateSizeTYPE =
    unsafe extern "C" fn(fmi2Component, fmi2FMUstate, *mut usize) -> fmi2Status;
pub type fmi2SerializeFMUstateTYPE =
    unsafe extern "C" fn(fmi2Component, fmi2FMUstate, *mut fmi2Byte, usize) -> fmi2Status;
pub type fmi2DeSerializeFMUstateTYPE =
    unsafe extern "C" fn(fmi2Component, *const fmi2Byte, usize, *mut fmi2FMUstate) -> fmi2Status;

pub type fmi2SetRealInputDerivativesTYPE = unsafe extern "C" fn(
    fmi2Component,
    *const fmi2ValueReference,
    usize,
    *const fmi2Integer,
    *const fmi2Real,
) -> fmi2Status;
pub type fmi2DoStepTYPE =
    unsafe extern "C" fn(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean) -> fmi2Status;
pub type fmi2CancelStepTYPE = unsafe extern "C" fn(fmi2Component) -> fmi2Status;
pub type fmi2GetStatusTYPE =
    unsafe extern "C" fn(fmi2Component, fmi2StatusKind, *mut fmi2Status) -> fmi2Status;
pub type fmi2GetRealStatusTYPE =
    unsafe extern "C" fn(fmi2Component, fmi2StatusKind, *mut fmi2Real) -> fmi2Status;
pub type fmi2GetIntegerStatusTYPE =
    unsafe extern "C" fn(fmi2Component, fmi2StatusKind, *mut fmi2Integer) -> fmi2Status;
pub type fmi2GetBooleanStatusTYPE =
    unsafe extern "C" fn(fmi2Component, fmi2StatusKind, *mut fmi2Boolean) -> fmi2Status;
pub type fmi2GetStringStatusTYPE =
    unsafe extern "C" fn(fmi2Component, fmi2StatusKind, *mut fmi2String) -> fmi2Status;

/// What `fmi2GetTypesPlatform` and `fmi2GetVersion` return, NUL-terminated.
pub const fmi2TypesPlatform: &[u8] = b"default\0";
pub const fmi2Version: &[u8] = b"2.0\0";

/// `fmi2EventInfo`, filled by `fmi2NewDiscreteStates`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct fmi2EventInfo {
    pub newDiscreteStatesNeeded: fmi2Boolean,
    pub terminateSimulation: fmi2Boolean,
    pub nominalsOfContinuousStatesChanged: fmi2Boolean,
    pub valuesOfContinuousStatesChanged: fmi2Boolean,
    pub nextEventTimeDefined: fmi2Boolean,
    pub nextEventTime: fmi2Real,
}

// Model Exchange.
pub type fmi2EnterEventModeTYPE = unsafe extern "C" fn(fmi2Component) -> fmi2Status;
pub type fmi2NewDiscreteStatesTYPE =
    unsafe extern "C" fn(fmi2Component, *mut fmi2EventInfo) -> fmi2Status;
pub type fmi2EnterContinuousTimeModeTYPE = unsafe extern "C" fn(fmi2Component) -> fmi2Status;
pub type fmi2CompletedIntegratorStepTYPE = unsafe extern "C" fn(
    fmi2Component,
    fmi2Boolean,
    *mut fmi2Boolean,
    *mut fmi2Boolean,
) -> fmi2Status;
pub type fmi2SetTimeTYPE = unsafe extern "C" fn(fmi2Component, fmi2Real) -> fmi2Status;
pub type fmi2SetContinuousStatesTYPE =
    unsafe extern "C" fn(fmi2Component, *const fmi2Real, usize) -> fmi2Status;
/// The shape of `fmi2GetDerivatives`, `fmi2GetEventIndicators`, `fmi2GetContinuousStates`
/// and `fmi2GetNominalsOfContinuousStates`.
pub type fmi2GetRealVectorTYPE =
    unsafe extern "C" fn(fmi2Component, *mut fmi2Real, usize) -> fmi2Status;
pub type fmi2GetDirectionalDerivativeTYPE = unsafe extern "C" fn(
    fmi2Component,
    *const fmi2ValueReference,
    usize,
    *const fmi2ValueReference,
    usize,
    *const fmi2Real,
    *mut fmi2Real,
) -> fmi2Status;
