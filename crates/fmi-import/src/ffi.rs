//! The raw FMI 2.0 C types and function signatures, from the project's shared ABI crate.

pub use inchworm_fmi_abi::fmi2::*;
