//! `export_fmi2!(Model)`: the C entry points of one FMU, each a one-line call into
//! [`crate::api`].

/// Exports every FMI 2.0 Co-Simulation function for `$model` under its standard C name.
/// Use it once, in the FMU's cdylib crate.
#[macro_export]
macro_rules! export_fmi2 {
    ($model:ty) => {
        mod __fmi2_exports {
            #![allow(non_snake_case, clippy::missing_safety_doc)]
            use super::*;
            use std::os::raw::c_char;
            use $crate::api;
            use $crate::ffi::*;
            type M = $model;

            #[no_mangle]
            pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
                api::fmi2GetTypesPlatform()
            }
            #[no_mangle]
            pub extern "C" fn fmi2GetVersion() -> *const c_char {
                api::fmi2GetVersion()
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetDebugLogging(
                c: fmi2Component,
                on: fmi2Boolean,
                n: usize,
                cats: *const fmi2String,
            ) -> fmi2Status {
                api::fmi2SetDebugLogging::<M>(c, on, n, cats)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Instantiate(
                name: fmi2String,
                ty: fmi2Type,
                guid: fmi2String,
                res: fmi2String,
                functions: *const fmi2CallbackFunctions,
                visible: fmi2Boolean,
                logging: fmi2Boolean,
            ) -> fmi2Component {
                api::fmi2Instantiate::<M>(name, ty, guid, res, functions, visible, logging)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2FreeInstance(c: fmi2Component) {
                api::fmi2FreeInstance::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetupExperiment(
                c: fmi2Component,
                td: fmi2Boolean,
                tol: fmi2Real,
                t0: fmi2Real,
                sd: fmi2Boolean,
                t1: fmi2Real,
            ) -> fmi2Status {
                api::fmi2SetupExperiment::<M>(c, td, tol, t0, sd, t1)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2EnterInitializationMode(c: fmi2Component) -> fmi2Status {
                api::fmi2EnterInitializationMode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2ExitInitializationMode(c: fmi2Component) -> fmi2Status {
                api::fmi2ExitInitializationMode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Terminate(c: fmi2Component) -> fmi2Status {
                api::fmi2Terminate::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Reset(c: fmi2Component) -> fmi2Status {
                api::fmi2Reset::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetReal(
                c: fmi2Component,
                vr: *const fmi2ValueReference,
                n: usize,
                v: *mut fmi2Real,
            ) -> fmi2Status {
                api::fmi2GetReal::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetInteger(
                c: fmi2Component,
                vr: *const fmi2ValueReference,
                n: usize,
                v: *mut fmi2Integer,
            ) -> fmi2Status {
                api::fmi2GetInteger::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetBoolean(
                c: fmi2Component,
                vr: *const fmi2ValueReference,
                n: usize,
                v: *mut fmi2Boolean,
            ) -> fmi2Status {
                api::fmi2GetBoolean::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetString(
                c: fmi2Component,
                vr: *const fmi2ValueReference,
                n: usize,
                v: *mut fmi2String,
            ) -> fmi2Status {
                api::fmi2GetString::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetReal(
                c: fmi2Component,
                vr: *const fmi2ValueReference,
                n: usize,
                v: *const fmi2Real,
            ) -> fmi2Status {
                api::fmi2SetReal::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetInteger(
                c: fmi2Component,
                vr: *const fmi2ValueReference,
                n: usize,
                v: *const fmi2Integer,
            ) -> fmi2Status {
                api::fmi2SetInteger::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetBoolean(
                c: fmi2Component,
                vr: *const fmi2ValueReference,
                n: usize,
                v: *const fmi2Boolean,
            ) -> fmi2Status {
                api::fmi2SetBoolean::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetString(
                c: fmi2Component,
                vr: *const fmi2ValueReference,
                n: usize,
                v: *const fmi2String,
            ) -> fmi2Status {
                api::fmi2SetString::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetFMUstate(
                c: fmi2Component,
                s: *mut fmi2FMUstate,
            ) -> fmi2Status {
                api::fmi2GetFMUstate::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetFMUstate(
                c: fmi2Component,
                s: fmi2FMUstate,
            ) -> fmi2Status {
                api::fmi2SetFMUstate::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2FreeFMUstate(
                c: fmi2Component,
                s: *mut fmi2FMUstate,
            ) -> fmi2Status {
                api::fmi2FreeFMUstate::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
                c: fmi2Component,
                s: fmi2FMUstate,
                size: *mut usize,
            ) -> fmi2Status {
                api::fmi2SerializedFMUstateSize::<M>(c, s, size)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SerializeFMUstate(
                c: fmi2Component,
                s: fmi2FMUstate,
                b: *mut fmi2Byte,
                size: usize,
            ) -> fmi2Status {
                api::fmi2SerializeFMUstate::<M>(c, s, b, size)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
                c: fmi2Component,
                b: *const fmi2Byte,
                size: usize,
                s: *mut fmi2FMUstate,
            ) -> fmi2Status {
                api::fmi2DeSerializeFMUstate::<M>(c, b, size, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
                c: fmi2Component,
                u: *const fmi2ValueReference,
                nu: usize,
                k: *const fmi2ValueReference,
                nk: usize,
                dk: *const fmi2Real,
                du: *mut fmi2Real,
            ) -> fmi2Status {
                api::fmi2GetDirectionalDerivative::<M>(c, u, nu, k, nk, dk, du)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
                c: fmi2Component,
                vr: *const fmi2ValueReference,
                n: usize,
                o: *const fmi2Integer,
                v: *const fmi2Real,
            ) -> fmi2Status {
                api::fmi2SetRealInputDerivatives::<M>(c, vr, n, o, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
                c: fmi2Component,
                vr: *const fmi2ValueReference,
                n: usize,
                o: *const fmi2Integer,
                v: *mut fmi2Real,
            ) -> fmi2Status {
                api::fmi2GetRealOutputDerivatives::<M>(c, vr, n, o, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2DoStep(
                c: fmi2Component,
                t: fmi2Real,
                h: fmi2Real,
                no_prior: fmi2Boolean,
            ) -> fmi2Status {
                api::fmi2DoStep::<M>(c, t, h, no_prior)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2CancelStep(c: fmi2Component) -> fmi2Status {
                api::fmi2CancelStep::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetStatus(
                c: fmi2Component,
                s: fmi2StatusKind,
                v: *mut fmi2Status,
            ) -> fmi2Status {
                api::fmi2GetStatus::<M>(c, s, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetRealStatus(
                c: fmi2Component,
                s: fmi2StatusKind,
                v: *mut fmi2Real,
            ) -> fmi2Status {
                api::fmi2GetRealStatus::<M>(c, s, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetIntegerStatus(
                c: fmi2Component,
                s: fmi2StatusKind,
                v: *mut fmi2Integer,
            ) -> fmi2Status {
                api::fmi2GetIntegerStatus::<M>(c, s, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetBooleanStatus(
                c: fmi2Component,
                s: fmi2StatusKind,
                v: *mut fmi2Boolean,
            ) -> fmi2Status {
                api::fmi2GetBooleanStatus::<M>(c, s, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetStringStatus(
                c: fmi2Component,
                s: fmi2StatusKind,
                v: *mut fmi2String,
            ) -> fmi2Status {
                api::fmi2GetStringStatus::<M>(c, s, v)
            }
        }
        pub use __fmi2_exports::*;
    };
}
