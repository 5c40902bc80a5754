//! FMI 2.0 Co-Simulation import: the project's own layer, `inchworm-fmi-import`
//! (crates/fmi-import), re-exported under its historical name.
//!
//! It loads any vendor's FMI 2.0 CS FMU (vendor annotations, unknown elements and
//! attributes are tolerated), looks variables up by name with their type checked, keeps
//! the communication time as `start + k · h`, and refuses a bad file, name or value with
//! an error that says what and where: [`FmuError`] names the FMU, the call, the variable
//! and the time; [`ImportError`] the archive entry, the `modelDescription.xml` line or
//! the missing binary or symbol.
//!
//! Messages the FMU sends through its logger callback arrive as `log` records whose
//! target is the instance name (formatted in C, level by status, text prefixed by the log
//! category); the binary prints them.

pub use inchworm_fmi_import::*;
