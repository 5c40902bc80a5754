//! Generic FMI 2.0 Co-Simulation export.
//!
//! A model implements [`Model`]: its variable table, start values, get/set by value
//! reference, initialization, one communication step, and its state as bytes. This crate
//! owns everything else, once for every FMU: the C ABI ([`ffi`]), the instance state
//! machine with the standard's allowed-call table, argument checks, `catch_unwind` on
//! every entry point, logging through the master's callback, FMU state snapshots and
//! their versioned serialized form, and `modelDescription.xml`. An FMU crate is its model
//! plus one [`export_fmi2!`] line, as in the Modelica Association's Reference-FMUs, where
//! all FMI glue is shared and each model is a small equations file.

pub mod api;
mod export;
pub mod ffi;
mod instance;
pub mod model_description;
mod state_blob;
mod table;
pub mod testing;

pub use table::{Causality, Initial, Kind, ModelInfo, Start, Unit, Variability, Variable};

/// The name of the variable with value reference `vr`, for messages ("?" if none).
pub fn variable_name(variables: &[Variable], vr: u32) -> &'static str {
    variables.iter().find(|v| v.vr == vr).map_or("?", |v| v.name)
}

/// Outcome of setting one value: accepted, or accepted after a change the master should
/// hear about (e.g. a voltage clamped into range).
pub type SetResult = Result<Option<String>, String>;

/// Something a step has to tell the master.
#[derive(Clone, Debug, PartialEq)]
pub enum Message {
    Event(String),
    Warning(String),
}

/// A simulation model exported as an FMI 2.0 Co-Simulation FMU.
///
/// The export layer has already checked every value reference against [`Model::variables`]
/// (it exists, has the right type, may be set in the current state) before a getter or
/// setter is called, so implementations match on value references without a fallback
/// that could silently accept a wrong one: an unmatched reference there is a bug in the
/// table and is reported as an error.
pub trait Model: Clone + Send + 'static {
    /// Identity, defaults and units of the FMU.
    fn info() -> &'static ModelInfo;
    /// The variable table: the single source of the value references, the XML and the docs.
    fn variables() -> &'static [Variable];
    /// A fresh instance with every variable at its start value.
    fn new() -> Self;

    fn get_real(&self, vr: u32) -> Result<f64, String>;
    fn get_integer(&self, vr: u32) -> Result<i32, String>;
    fn get_boolean(&self, vr: u32) -> Result<bool, String>;
    fn set_real(&mut self, vr: u32, value: f64) -> SetResult;
    fn set_integer(&mut self, vr: u32, value: i32) -> SetResult;
    fn set_boolean(&mut self, vr: u32, value: bool) -> SetResult;

    /// Called by `fmi2ExitInitializationMode`: validate parameters and build the model.
    fn exit_initialization(&mut self, start_time: f64) -> Result<(), String>;

    /// Refuses a step the model cannot take (e.g. a step size it does not support) before
    /// anything runs; a refusal leaves the instance as it was.
    fn check_step(&self, _t: f64, _h: f64) -> Result<(), String> {
        Ok(())
    }

    /// One communication step from `t` of length `h` (both checked by the layer). An `Err`
    /// is a failure of the model and moves the instance to the Error state.
    /// `Ok` carries what to log: events (debug logging, category logEvents) and warnings
    /// (the step succeeded, with status fmi2Warning).
    fn do_step(&mut self, t: f64, h: f64) -> Result<Vec<Message>, String>;

    /// Appends everything needed to continue bit for bit: parameters, inputs, state.
    fn save(&self, out: &mut Vec<u8>);
    /// Restores what [`Model::save`] wrote; on error `self` is unchanged.
    fn load(&mut self, bytes: &[u8]) -> Result<(), String>;
}
