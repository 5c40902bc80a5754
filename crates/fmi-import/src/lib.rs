//! A tolerant FMI 2.0 and FMI 3.0 import layer, Co-Simulation and Model Exchange: loads any vendor's FMU,
//! finds variables by name, and says what went wrong and where when a file, name or
//! value is bad. Both standards go through the same code up to the C calls:
//!
//! * [`archive`] unpacks what a run reads of the FMU into a fresh temporary directory
//!   (zip-slip-safe, capped), removed when the last instance made from it is dropped, or
//!   takes it from the cache of unpacked FMUs ([`archive::cache`]) when a program turns
//!   it on;
//! * [`description`] reads `modelDescription.xml` of either standard into one
//!   [`ModelDescription`] with one strict reader (line/column errors, a truncated file
//!   refused, duplicate names, numbers, `modelIdentifier` a plain file name, a size cap);
//! * `binary` finds `binaries/<platform>/<modelIdentifier>.<ext>` (FMI 2.0 folder or FMI
//!   3.0 tuple), checks an ELF file whole and loads it;
//! * `backend` calls it: `Fmi2Backend` the `fmi2*` functions, `Fmi3Backend` the `fmi3*`
//!   ones, each natively, behind one trait;
//! * the FMU's log messages arrive as `log` records whose target is the instance name
//!   (level by status: OK → info, Warning → warn, Discard/Error/Fatal → error), prefixed
//!   by the log category (FMI 2.0's C-variadic logger is formatted in `logger.c`).
//!
//! On top, an [`Instance`] adds what a master needs: variables looked up by name with
//! their type checked, value-reference/value slices that always have matching lengths (the
//! raw calls trust the caller on that), FMU state save/restore/serialize, and errors that
//! name the FMU, the real C function (`fmi2DoStep`, `fmi3GetFloat64`, …) and the time.
//! The interface is in the type: an instance is owned by a [`CsFmu`] (Co-Simulation:
//! `do_step`, the communication time kept as `start + k · h` so it never drifts from the
//! FMU's own clock) or by an [`MeFmu`] (Model Exchange: continuous states, derivatives,
//! event indicators, event mode) or, in FMI 3.0, by an [`SeFmu`] (Scheduled Execution:
//! `fmi3ActivateModelPartition`, the `clockUpdate` and preemption callbacks), and
//! [`Loaded`] is one of them, picked from the description. A [`CsFmu`] made with event mode
//! steps to clock ticks and handles them in event mode; both it and an [`SeFmu`] set and
//! read clocks and their intervals ([`ModelDescription::clocks`] has the declarations).
//! Warning lets the call succeed (with a warning logged); Discard, Error, Fatal and
//! (FMI 2.0) Pending are errors; after Fatal every further call is refused, as both
//! standards demand.

pub mod archive;
mod backend;
mod binary;
mod clocks;
mod co_simulation;
pub mod description;
mod error;
mod ffi;
mod fmu_state;
mod instance;
mod loaded;
mod logger;
mod model_exchange;
mod scheduled_execution;
mod values;

pub use backend::clocks::{Activation, Interval, IntervalQualifier, StepEnd};
pub use backend::me::EventUpdate;
pub use binary::{fmi2_platform, fmi3_platform};
pub use co_simulation::CsFmu;
pub use description::{
    ArrayElement, Causality, Clock, CoSimulation, ContinuousState, DefaultExperiment, Initial,
    IntervalVariability, ModelDescription, ModelExchange, ScheduledExecution, VarType, Variability,
    Variable,
};
pub use error::{FmuError, ImportError, LoadError, Status};
pub use fmu_state::FmuState;
pub use instance::{Instance, Interface, Var};
pub use loaded::Loaded;
pub use model_exchange::MeFmu;
pub use scheduled_execution::SeFmu;
