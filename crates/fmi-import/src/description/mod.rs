//! `modelDescription.xml` of FMI 2.0 or FMI 3.0, read as a stream of XML events into one
//! [`ModelDescription`]. Only what a Co-Simulation master needs is kept; every other
//! element (`<Annotations>`, `<VendorAnnotations>`, `<UnitDefinitions>`,
//! `<TypeDefinitions>`, `<LogCategories>`, `<ModelStructure>`, and whatever a vendor
//! invents) and every unknown attribute is skipped, as real FMUs carry them.
//!
//! The reading is split by what it reads: [`ModelDescription`] and its parts are
//! `model`'s; `reader` is the walk over the events both standards share (attribute,
//! number and enumeration parsing, `start` values, duplicate names, the end-of-file check:
//! a truncated file is refused); `elements` reads the root, `<CoSimulation>` and
//! `<ModelExchange>` (the `modelIdentifier` must be a plain file name: it names the library
//! to load), `<DefaultExperiment>` and the continuous states of `<ModelStructure>`; `fmi2`
//! and `fmi3` only say how each standard spells a variable. The text helpers (positions,
//! attribute lookup, value checks, clipping untrusted text) are in `text`; the size cap is
//! defined with the archive's other caps.
//! Every error carries the line and column it was found at.

mod elements;
mod fmi2;
mod fmi3;
mod model;
mod reader;
#[cfg(test)]
mod tests;
pub(crate) mod text;

pub use crate::archive::{ENV_DESCRIPTION, MAX_DESCRIPTION_BYTES};
pub use model::{
    ArrayElement, Causality, Clock, CoSimulation, ContinuousState, DefaultExperiment, Initial,
    IntervalVariability, ModelDescription, ModelExchange, ScheduledExecution, VarType, Variability,
    Variable, MAX_ARRAY_ELEMENTS,
};
pub(crate) use reader::{Doc, Element, Standard};
