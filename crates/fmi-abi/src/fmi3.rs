//! The FMI 3.0 C ABI (`fmi3PlatformTypes.h`, `fmi3FunctionTypes.h`), written out by hand
//! like its FMI 2.0 sibling: no libclang run for any build. FMI 3.0's logger is a plain
//! (non-variadic) function, so both sides are Rust only.

use std::os::raw::{c_char, c_int, c_void};

pub type fmi3Instance = *mut c_void;
pub type fmi3InstanceEnvironment = *mut c_void;
pub type fmi3FMUState = *mut c_void;
pub type fmi3ValueReference = u32;
pub type fmi3Float32 = f32;
pub type fmi3Float64 = f64;
pub type fmi3Int8 = i8;
pub type fmi3UInt8 = u8;
pub type fmi3Int16 = i16;
pub type fmi3UInt16 = u16;
pub type fmi3Int32 = i32;
pub type fmi3UInt32 = u32;
pub type fmi3Int64 = i64;
pub type fmi3UInt64 = u64;
/// C99 `bool`: one byte, 0 or 1 (Rust's `bool` has the same ABI).
pub type fmi3Boolean = bool;
pub type fmi3Char = c_char;
pub type fmi3String = *const fmi3Char;
pub type fmi3Byte = u8;
pub type fmi3Binary = *const fmi3Byte;
pub type fmi3Clock = bool;

pub const fmi3True: fmi3Boolean = true;
pub const fmi3False: fmi3Boolean = false;
pub const fmi3ClockActive: fmi3Clock = true;
pub const fmi3ClockInactive: fmi3Clock = false;

/// The value of `fmi3GetVersion`.
pub const fmi3Version: &[u8] = b"3.0\0";

/// `fmi3Status` (a C enum, `int`).
pub type fmi3Status = c_int;
pub const fmi3OK: fmi3Status = 0;
pub const fmi3Warning: fmi3Status = 1;
pub const fmi3Discard: fmi3Status = 2;
pub const fmi3Error: fmi3Status = 3;
pub const fmi3Fatal: fmi3Status = 4;

/// `fmi3DependencyKind`.
pub type fmi3DependencyKind = c_int;
pub const fmi3Independent: fmi3DependencyKind = 0;
pub const fmi3Constant: fmi3DependencyKind = 1;
pub const fmi3Fixed: fmi3DependencyKind = 2;
pub const fmi3Tunable: fmi3DependencyKind = 3;
pub const fmi3Discrete: fmi3DependencyKind = 4;
pub const fmi3Dependent: fmi3DependencyKind = 5;

/// `fmi3IntervalQualifier`.
pub type fmi3IntervalQualifier = c_int;
pub const fmi3IntervalNotYetKnown: fmi3IntervalQualifier = 0;
pub const fmi3IntervalUnchanged: fmi3IntervalQualifier = 1;
pub const fmi3IntervalChanged: fmi3IntervalQualifier = 2;

pub type fmi3LogMessageCallback =
    Option<unsafe extern "C" fn(fmi3InstanceEnvironment, fmi3Status, fmi3String, fmi3String)>;
pub type fmi3ClockUpdateCallback = Option<unsafe extern "C" fn(fmi3InstanceEnvironment)>;
pub type fmi3IntermediateUpdateCallback = Option<
    unsafe extern "C" fn(
        fmi3InstanceEnvironment,
        fmi3Float64,
        fmi3Boolean,
        fmi3Boolean,
        fmi3Boolean,
        fmi3Boolean,
        *mut fmi3Boolean,
        *mut fmi3Float64,
    ),
>;
pub type fmi3LockPreemptionCallback = Option<unsafe extern "C" fn()>;
pub type fmi3UnlockPreemptionCallback = Option<unsafe extern "C" fn()>;

// The function types an importer of a Co-Simulation FMU looks up.
pub type fmi3GetVersionTYPE = unsafe extern "C" fn() -> *const c_char;
pub type fmi3SetDebugLoggingTYPE =
    unsafe extern "C" fn(fmi3Instance, fmi3Boolean, usize, *const fmi3String) -> fmi3Status;
pub type fmi3InstantiateCoSimulationTYPE = unsafe extern "C" fn(
    fmi3String,
    fmi3String,
    fmi3String,
    fmi3Boolean,
    fmi3Boolean,
    fmi3Boolean,
    fmi3Boolean,
    *const fmi3ValueReference,
    usize,
    fmi3InstanceEnvironment,
    fmi3LogMessageCallback,
    fmi3IntermediateUpdateCallback,
) -> fmi3Instance;
pub type fmi3FreeInstanceTYPE = unsafe extern "C" fn(fmi3Instance);
pub type fmi3EnterInitializationModeTYPE = unsafe extern "C" fn(
    fmi3Instance,
    fmi3Boolean,
    fmi3Float64,
    fmi3Float64,
    fmi3Boolean,
    fmi3Float64,
) -> fmi3Status;
pub type fmi3InstanceOnlyTYPE = unsafe extern "C" fn(fmi3Instance) -> fmi3Status;
pub type fmi3ExitInitializationModeTYPE = fmi3InstanceOnlyTYPE;
pub type fmi3TerminateTYPE = fmi3InstanceOnlyTYPE;
pub type fmi3ResetTYPE = fmi3InstanceOnlyTYPE;
pub type fmi3GetFloat64TYPE = unsafe extern "C" fn(
    fmi3Instance,
    *const fmi3ValueReference,
    usize,
    *mut fmi3Float64,
    usize,
) -> fmi3Status;
pub type fmi3GetInt32TYPE = unsafe extern "C" fn(
    fmi3Instance,
    *const fmi3ValueReference,
    usize,
    *mut fmi3Int32,
    usize,
) -> fmi3Status;
pub type fmi3GetBooleanTYPE = unsafe extern "C" fn(
    fmi3Instance,
    *const fmi3ValueReference,
    usize,
    *mut fmi3Boolean,
    usize,
) -> fmi3Status;
pub type fmi3SetFloat64TYPE = unsafe extern "C" fn(
    fmi3Instance,
    *const fmi3ValueReference,
    usize,
    *const fmi3Float64,
    usize,
) -> fmi3Status;
pub type fmi3SetInt32TYPE = unsafe extern "C" fn(
    fmi3Instance,
    *const fmi3ValueReference,
    usize,
    *const fmi3Int32,
    usize,
) -> fmi3Status;
pub type fmi3SetBooleanTYPE = unsafe extern "C" fn(
    fmi3Instance,
    *const fmi3ValueReference,
    usize,
    *const fmi3Boolean,
    usize,
) -> fmi3Status;
pub type fmi3GetFMUStateTYPE = unsafe extern "C" fn(fmi3Instance, *mut fmi3FMUState) -> fmi3Status;
pub type fmi3SetFMUStateTYPE = unsafe extern "C" fn(fmi3Instance, fmi3FMUState) -> fmi3Status;
pub type fmi3FreeFMUStateTYPE = unsafe extern "C" fn(fmi3Instance, *mut fmi3FMUState) -> fmi3Status;
pub type fmi3DoStepTYPE = unsafe extern "C" fn(
    fmi3Instance,
    fmi3Float64,
    fmi3Float64,
    fmi3Boolean,
    *mut fmi3Boolean,
    *mut fmi3Boolean,
    *mut fmi3Boolean,
    *mut fmi3Float64,
) -> fmi3Status;
pub type fmi3GetStringTYPE = unsafe extern "C" fn(
    fmi3Instance,
    *const fmi3ValueReference,
    usize,
    *mut fmi3String,
    usize,
) -> fmi3Status;
pub type fmi3SetStringTYPE = unsafe extern "C" fn(
    fmi3Instance,
    *const fmi3ValueReference,
    usize,
    *const fmi3String,
    usize,
) -> fmi3Status;
pub type fmi3SerializedFMUStateSizeTYPE =
    unsafe extern "C" fn(fmi3Instance, fmi3FMUState, *mut usize) -> fmi3Status;
pub type fmi3SerializeFMUStateTYPE =
    unsafe extern "C" fn(fmi3Instance, fmi3FMUState, *mut fmi3Byte, usize) -> fmi3Status;
pub type fmi3DeserializeFMUStateTYPE =
    unsafe extern "C" fn(fmi3Instance, *const fmi3Byte, usize, *mut fmi3FMUState) -> fmi3Status;

// Model Exchange.
pub type fmi3InstantiateModelExchangeTYPE = unsafe extern "C" fn(
    fmi3String,
    fmi3String,
    fmi3String,
    fmi3Boolean,
    fmi3Boolean,
    fmi3InstanceEnvironment,
    fmi3LogMessageCallback,
) -> fmi3Instance;
pub type fmi3EnterEventModeTYPE = fmi3InstanceOnlyTYPE;
pub type fmi3EnterContinuousTimeModeTYPE = fmi3InstanceOnlyTYPE;
pub type fmi3UpdateDiscreteStatesTYPE = unsafe extern "C" fn(
    fmi3Instance,
    *mut fmi3Boolean,
    *mut fmi3Boolean,
    *mut fmi3Boolean,
    *mut fmi3Boolean,
    *mut fmi3Boolean,
    *mut fmi3Float64,
) -> fmi3Status;
pub type fmi3CompletedIntegratorStepTYPE = unsafe extern "C" fn(
    fmi3Instance,
    fmi3Boolean,
    *mut fmi3Boolean,
    *mut fmi3Boolean,
) -> fmi3Status;
pub type fmi3SetTimeTYPE = unsafe extern "C" fn(fmi3Instance, fmi3Float64) -> fmi3Status;
pub type fmi3SetContinuousStatesTYPE =
    unsafe extern "C" fn(fmi3Instance, *const fmi3Float64, usize) -> fmi3Status;
/// The shape of `fmi3GetContinuousStateDerivatives`, `fmi3GetEventIndicators`,
/// `fmi3GetContinuousStates` and `fmi3GetNominalsOfContinuousStates`.
pub type fmi3GetFloat64VectorTYPE =
    unsafe extern "C" fn(fmi3Instance, *mut fmi3Float64, usize) -> fmi3Status;
pub type fmi3GetDirectionalDerivativeTYPE = unsafe extern "C" fn(
    fmi3Instance,
    *const fmi3ValueReference,
    usize,
    *const fmi3ValueReference,
    usize,
    *const fmi3Float64,
    usize,
    *mut fmi3Float64,
    usize,
) -> fmi3Status;

// Clocks, event mode in Co-Simulation, and Scheduled Execution.
pub type fmi3InstantiateScheduledExecutionTYPE = unsafe extern "C" fn(
    fmi3String,
    fmi3String,
    fmi3String,
    fmi3Boolean,
    fmi3Boolean,
    fmi3InstanceEnvironment,
    fmi3LogMessageCallback,
    fmi3ClockUpdateCallback,
    fmi3LockPreemptionCallback,
    fmi3UnlockPreemptionCallback,
) -> fmi3Instance;
pub type fmi3EnterStepModeTYPE = fmi3InstanceOnlyTYPE;
pub type fmi3SetClockTYPE = unsafe extern "C" fn(
    fmi3Instance,
    *const fmi3ValueReference,
    usize,
    *const fmi3Clock,
) -> fmi3Status;
pub type fmi3GetClockTYPE = unsafe extern "C" fn(
    fmi3Instance,
    *const fmi3ValueReference,
    usize,
    *mut fmi3Clock,
) -> fmi3Status;
pub type fmi3GetIntervalDecimalTYPE = unsafe extern "C" fn(
    fmi3Instance,
    *const fmi3ValueReference,
    usize,
    *mut fmi3Float64,
    *mut fmi3IntervalQualifier,
) -> fmi3Status;
pub type fmi3GetShiftDecimalTYPE = unsafe extern "C" fn(
    fmi3Instance,
    *const fmi3ValueReference,
    usize,
    *mut fmi3Float64,
) -> fmi3Status;
pub type fmi3ActivateModelPartitionTYPE =
    unsafe extern "C" fn(fmi3Instance, fmi3ValueReference, fmi3Float64) -> fmi3Status;
