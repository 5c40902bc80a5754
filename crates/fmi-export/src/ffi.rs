//! The C types of `fmi2TypesPlatform.h` and `fmi2FunctionTypes.h`, from the project's
//! shared ABI crate: declared by hand, so the FMUs build without libclang.

pub use inchworm_fmi_abi::fmi2::*;
