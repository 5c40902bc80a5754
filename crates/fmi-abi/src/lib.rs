//! The C ABI of both FMI standards, declared once for the whole project: the export layer
//! (`inchworm-fmi-export`) implements these signatures, the import layer
//! (`inchworm-fmi-import`) calls them, and the packager (`fmu-build`) and the importer read
//! the one [`platform`] table, so an FMU is packed into the folder it is looked up in.
#![allow(non_camel_case_types, non_snake_case, non_upper_case_globals)]

pub mod fmi2;
pub mod fmi3;
pub mod platform;
