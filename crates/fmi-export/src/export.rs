//! The two macros every standard's glue is made of. A standard lists each C function
//! once, as `name(args) -> ret = body;` (in [`crate::api`] for FMI 2.0,
//! [`crate::fmi3::api`] for FMI 3.0); [`__generic_entry_points!`] turns the list into
//! functions generic over the model, and [`__thunks!`] into the `#[no_mangle] extern "C"`
//! symbols of one FMU, each calling its generic function. `export_fmi2!` and
//! `export_fmi3!` are that second expansion for one model.

/// The generic entry points of a list; `F` is the function's C name inside each body.
#[doc(hidden)]
#[macro_export]
macro_rules! __generic_entry_points {
    ($( $name:ident ( $($arg:ident : $ty:ty),* ) -> $ret:ty = $body:expr ; )*) => {
        $(
            #[allow(unused_variables, dead_code, clippy::unused_unit)]
            pub unsafe fn $name<M: $crate::Model>($($arg: $ty),*) -> $ret {
                const F: &str = stringify!($name);
                $body
            }
        )*
    };
}

/// For the behaviour suites: `every_entry_point::<M>(c)`, which calls every function of a
/// list that takes an instance, each with `c` and every other argument zero (NULL
/// pointers, 0, false, no callback), and returns each one's name and status (`None` for
/// the frees, which return nothing). Handed another FMU's instance, a freed one or junk,
/// each must refuse it without reading through it.
#[doc(hidden)]
#[macro_export]
macro_rules! __every_entry_point {
    ($( $name:ident ( $($arg:ident : $ty:ty),* ) -> $ret:ty = $body:expr ; )*) => {
        #[allow(clippy::missing_safety_doc)]
        pub unsafe fn every_entry_point<M: $crate::Model>(
            c: *mut ::std::ffi::c_void,
        ) -> ::std::vec::Vec<(&'static str, ::std::option::Option<::std::os::raw::c_int>)> {
            let mut called = ::std::vec::Vec::new();
            $( $crate::__call_with_instance!(called, c, $name ( $($arg : $ty),* )); )*
            called
        }
    };
}

/// One function of [`__every_entry_point!`]: called if its first argument is the instance.
#[doc(hidden)]
#[macro_export]
macro_rules! __call_with_instance {
    ($called:ident, $c:ident, $name:ident ( c : $cty:ty $(, $arg:ident : $ty:ty)* )) => {
        let status = $name::<M>($c as $cty $(, ::std::mem::zeroed::<$ty>())*);
        $called.push((stringify!($name), $crate::testing::IntoStatus::into_status(status)));
    };
    ($called:ident, $c:ident, $name:ident ( $($arg:ident : $ty:ty),* )) => {};
}

/// The C symbols of a list for the model `M` in scope, calling `__api::<name>::<M>`.
#[doc(hidden)]
#[macro_export]
macro_rules! __thunks {
    ($( $name:ident ( $($arg:ident : $ty:ty),* ) -> $ret:ty = $body:expr ; )*) => {
        $(
            #[no_mangle]
            pub unsafe extern "C" fn $name($($arg: $ty),*) -> $ret {
                __api::$name::<M>($($arg),*)
            }
        )*
    };
}

/// Exports every FMI 2.0 Co-Simulation function for `$model` under its standard C name.
/// Use it once, in the FMU's cdylib crate.
#[macro_export]
macro_rules! export_fmi2 {
    ($model:ty) => {
        mod __fmi2_exports {
            #![allow(non_snake_case, clippy::missing_safety_doc, clippy::too_many_arguments)]
            use super::*;
            use $crate::api as __api;
            use $crate::api::fmi2EventInfo;
            use $crate::ffi::*;
            type M = $model;

            #[no_mangle]
            pub extern "C" fn fmi2GetTypesPlatform() -> *const ::std::os::raw::c_char {
                __api::fmi2GetTypesPlatform()
            }
            #[no_mangle]
            pub extern "C" fn fmi2GetVersion() -> *const ::std::os::raw::c_char {
                __api::fmi2GetVersion()
            }
            $crate::__fmi2_entry_points!(__thunks);
        }
        pub use __fmi2_exports::*;
    };
}

/// Exports every FMI 3.0 function for `$model`. Use it once, in the FMU's cdylib crate
/// (never next to [`export_fmi2!`]: one library, one FMI version).
#[macro_export]
macro_rules! export_fmi3 {
    ($model:ty) => {
        mod __fmi3_exports {
            #![allow(non_snake_case, clippy::missing_safety_doc, clippy::too_many_arguments)]
            use super::*;
            use $crate::fmi3::api as __api;
            use $crate::fmi3::ffi::*;
            type M = $model;

            #[no_mangle]
            pub extern "C" fn fmi3GetVersion() -> *const ::std::os::raw::c_char {
                __api::fmi3GetVersion()
            }
            $crate::__fmi3_entry_points!(__thunks);
        }
        pub use __fmi3_exports::*;
    };
}
