//! `export_fmi3!(Model)`: every `fmi3*` function of FMI 3.0 under its C name, each a
//! one-line call into [`crate::fmi3::api`].

/// Exports every FMI 3.0 function for `$model`. Use it once, in the FMU's cdylib crate
/// (never next to [`crate::export_fmi2!`]: one library, one FMI version).
#[macro_export]
macro_rules! export_fmi3 {
    ($model:ty) => {
        mod __fmi3_exports {
            #![allow(non_snake_case, clippy::missing_safety_doc, clippy::too_many_arguments)]
            use super::*;
            use $crate::fmi3::api;
            use $crate::fmi3::ffi::*;
            type M = $model;

            #[no_mangle]
            pub extern "C" fn fmi3GetVersion() -> *const ::std::os::raw::c_char {
                api::fmi3GetVersion()
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3FreeInstance(c: fmi3Instance) {
                api::fmi3FreeInstance::<M>(c)
            }

            $crate::__fmi3_thunks! {
                fmi3SetDebugLogging(c: fmi3Instance, on: fmi3Boolean, n: usize, cats: *const fmi3String) -> fmi3Status;
                fmi3InstantiateModelExchange(name: fmi3String, token: fmi3String, res: fmi3String, visible: fmi3Boolean, logging: fmi3Boolean, env: fmi3InstanceEnvironment, log: fmi3LogMessageCallback) -> fmi3Instance;
                fmi3InstantiateCoSimulation(name: fmi3String, token: fmi3String, res: fmi3String, visible: fmi3Boolean, logging: fmi3Boolean, event_mode: fmi3Boolean, early: fmi3Boolean, req: *const fmi3ValueReference, nreq: usize, env: fmi3InstanceEnvironment, log: fmi3LogMessageCallback, update: fmi3IntermediateUpdateCallback) -> fmi3Instance;
                fmi3InstantiateScheduledExecution(name: fmi3String, token: fmi3String, res: fmi3String, visible: fmi3Boolean, logging: fmi3Boolean, env: fmi3InstanceEnvironment, log: fmi3LogMessageCallback, clock: fmi3ClockUpdateCallback, lock: fmi3LockPreemptionCallback, unlock: fmi3UnlockPreemptionCallback) -> fmi3Instance;
                fmi3EnterInitializationMode(c: fmi3Instance, td: fmi3Boolean, tol: fmi3Float64, t0: fmi3Float64, sd: fmi3Boolean, t1: fmi3Float64) -> fmi3Status;
                fmi3ExitInitializationMode(c: fmi3Instance) -> fmi3Status;
                fmi3EnterEventMode(c: fmi3Instance) -> fmi3Status;
                fmi3Terminate(c: fmi3Instance) -> fmi3Status;
                fmi3Reset(c: fmi3Instance) -> fmi3Status;
                fmi3GetFloat32(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3Float32, nv: usize) -> fmi3Status;
                fmi3GetFloat64(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3Float64, nv: usize) -> fmi3Status;
                fmi3GetInt8(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3Int8, nv: usize) -> fmi3Status;
                fmi3GetUInt8(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3UInt8, nv: usize) -> fmi3Status;
                fmi3GetInt16(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3Int16, nv: usize) -> fmi3Status;
                fmi3GetUInt16(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3UInt16, nv: usize) -> fmi3Status;
                fmi3GetInt32(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3Int32, nv: usize) -> fmi3Status;
                fmi3GetUInt32(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3UInt32, nv: usize) -> fmi3Status;
                fmi3GetInt64(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3Int64, nv: usize) -> fmi3Status;
                fmi3GetUInt64(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3UInt64, nv: usize) -> fmi3Status;
                fmi3GetBoolean(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3Boolean, nv: usize) -> fmi3Status;
                fmi3GetString(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3String, nv: usize) -> fmi3Status;
                fmi3GetBinary(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, sizes: *mut usize, v: *mut fmi3Binary, nv: usize) -> fmi3Status;
                fmi3GetClock(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *mut fmi3Clock) -> fmi3Status;
                fmi3SetFloat32(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3Float32, nv: usize) -> fmi3Status;
                fmi3SetFloat64(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3Float64, nv: usize) -> fmi3Status;
                fmi3SetInt8(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3Int8, nv: usize) -> fmi3Status;
                fmi3SetUInt8(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3UInt8, nv: usize) -> fmi3Status;
                fmi3SetInt16(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3Int16, nv: usize) -> fmi3Status;
                fmi3SetUInt16(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3UInt16, nv: usize) -> fmi3Status;
                fmi3SetInt32(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3Int32, nv: usize) -> fmi3Status;
                fmi3SetUInt32(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3UInt32, nv: usize) -> fmi3Status;
                fmi3SetInt64(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3Int64, nv: usize) -> fmi3Status;
                fmi3SetUInt64(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3UInt64, nv: usize) -> fmi3Status;
                fmi3SetBoolean(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3Boolean, nv: usize) -> fmi3Status;
                fmi3SetString(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3String, nv: usize) -> fmi3Status;
                fmi3SetBinary(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, sizes: *const usize, v: *const fmi3Binary, nv: usize) -> fmi3Status;
                fmi3SetClock(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, v: *const fmi3Clock) -> fmi3Status;
                fmi3GetNumberOfVariableDependencies(c: fmi3Instance, vr: fmi3ValueReference, n: *mut usize) -> fmi3Status;
                fmi3GetVariableDependencies(c: fmi3Instance, dep: fmi3ValueReference, ed: *mut usize, ind: *mut fmi3ValueReference, ei: *mut usize, kinds: *mut fmi3DependencyKind, n: usize) -> fmi3Status;
                fmi3GetFMUState(c: fmi3Instance, s: *mut fmi3FMUState) -> fmi3Status;
                fmi3SetFMUState(c: fmi3Instance, s: fmi3FMUState) -> fmi3Status;
                fmi3FreeFMUState(c: fmi3Instance, s: *mut fmi3FMUState) -> fmi3Status;
                fmi3SerializedFMUStateSize(c: fmi3Instance, s: fmi3FMUState, size: *mut usize) -> fmi3Status;
                fmi3SerializeFMUState(c: fmi3Instance, s: fmi3FMUState, b: *mut fmi3Byte, size: usize) -> fmi3Status;
                fmi3DeserializeFMUState(c: fmi3Instance, b: *const fmi3Byte, size: usize, s: *mut fmi3FMUState) -> fmi3Status;
                fmi3GetDirectionalDerivative(c: fmi3Instance, u: *const fmi3ValueReference, nu: usize, k: *const fmi3ValueReference, nk: usize, seed: *const fmi3Float64, ns: usize, sens: *mut fmi3Float64, nsens: usize) -> fmi3Status;
                fmi3GetAdjointDerivative(c: fmi3Instance, u: *const fmi3ValueReference, nu: usize, k: *const fmi3ValueReference, nk: usize, seed: *const fmi3Float64, ns: usize, sens: *mut fmi3Float64, nsens: usize) -> fmi3Status;
                fmi3EnterConfigurationMode(c: fmi3Instance) -> fmi3Status;
                fmi3ExitConfigurationMode(c: fmi3Instance) -> fmi3Status;
                fmi3GetIntervalDecimal(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, iv: *mut fmi3Float64, q: *mut fmi3IntervalQualifier) -> fmi3Status;
                fmi3GetIntervalFraction(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, cnt: *mut fmi3UInt64, res: *mut fmi3UInt64, q: *mut fmi3IntervalQualifier) -> fmi3Status;
                fmi3GetShiftDecimal(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, sh: *mut fmi3Float64) -> fmi3Status;
                fmi3GetShiftFraction(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, cnt: *mut fmi3UInt64, res: *mut fmi3UInt64) -> fmi3Status;
                fmi3SetIntervalDecimal(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, iv: *const fmi3Float64) -> fmi3Status;
                fmi3SetIntervalFraction(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, cnt: *const fmi3UInt64, res: *const fmi3UInt64) -> fmi3Status;
                fmi3SetShiftDecimal(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, sh: *const fmi3Float64) -> fmi3Status;
                fmi3SetShiftFraction(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, cnt: *const fmi3UInt64, res: *const fmi3UInt64) -> fmi3Status;
                fmi3EvaluateDiscreteStates(c: fmi3Instance) -> fmi3Status;
                fmi3UpdateDiscreteStates(c: fmi3Instance, a: *mut fmi3Boolean, b: *mut fmi3Boolean, d: *mut fmi3Boolean, e: *mut fmi3Boolean, f: *mut fmi3Boolean, t: *mut fmi3Float64) -> fmi3Status;
                fmi3EnterContinuousTimeMode(c: fmi3Instance) -> fmi3Status;
                fmi3CompletedIntegratorStep(c: fmi3Instance, no_prior: fmi3Boolean, ev: *mut fmi3Boolean, term: *mut fmi3Boolean) -> fmi3Status;
                fmi3SetTime(c: fmi3Instance, t: fmi3Float64) -> fmi3Status;
                fmi3SetContinuousStates(c: fmi3Instance, x: *const fmi3Float64, n: usize) -> fmi3Status;
                fmi3GetContinuousStateDerivatives(c: fmi3Instance, dx: *mut fmi3Float64, n: usize) -> fmi3Status;
                fmi3GetEventIndicators(c: fmi3Instance, z: *mut fmi3Float64, n: usize) -> fmi3Status;
                fmi3GetContinuousStates(c: fmi3Instance, x: *mut fmi3Float64, n: usize) -> fmi3Status;
                fmi3GetNominalsOfContinuousStates(c: fmi3Instance, x: *mut fmi3Float64, n: usize) -> fmi3Status;
                fmi3GetNumberOfEventIndicators(c: fmi3Instance, n: *mut usize) -> fmi3Status;
                fmi3GetNumberOfContinuousStates(c: fmi3Instance, n: *mut usize) -> fmi3Status;
                fmi3EnterStepMode(c: fmi3Instance) -> fmi3Status;
                fmi3GetOutputDerivatives(c: fmi3Instance, vr: *const fmi3ValueReference, n: usize, o: *const fmi3Int32, v: *mut fmi3Float64, nv: usize) -> fmi3Status;
                fmi3DoStep(c: fmi3Instance, t: fmi3Float64, h: fmi3Float64, no_prior: fmi3Boolean, ev: *mut fmi3Boolean, term: *mut fmi3Boolean, early: *mut fmi3Boolean, last: *mut fmi3Float64) -> fmi3Status;
                fmi3ActivateModelPartition(c: fmi3Instance, clock: fmi3ValueReference, t: fmi3Float64) -> fmi3Status;
            }
        }
        pub use __fmi3_exports::*;
    };
}

/// The `extern "C"` thunks of [`export_fmi3!`]: one per signature line.
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi3_thunks {
    ($( $name:ident ( $($arg:ident : $ty:ty),* ) -> $ret:ty ; )*) => {
        $(
            #[no_mangle]
            pub unsafe extern "C" fn $name($($arg: $ty),*) -> $ret {
                api::$name::<M>($($arg),*)
            }
        )*
    };
}
