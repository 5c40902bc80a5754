//! The C types of `fmi3PlatformTypes.h` and `fmi3FunctionTypes.h`, from the project's
//! shared FMI 3.0 ABI crate.

pub use inchworm_fmi_abi::fmi3::*;
