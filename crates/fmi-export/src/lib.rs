//! Generic FMI 2.0 and FMI 3.0 Co-Simulation export of one model, over one core.
//!
//! A model implements [`Model`]: its variable table with an accessor in every row
//! ([`table!`]), initialization, one communication step, and its dynamic state as bytes.
//! This crate owns everything else, once for every FMU and for both standards: the
//! instance and its state machine with the allowed-call masks ([`instance`]), every entry
//! point's body ([`entry`]: argument checks, finite values, the declared ranges of inputs,
//! `catch_unwind`, logging, FMU state snapshots and their versioned serialized form, the
//! status policy), and `modelDescription.xml`. Each standard adds only its facts
//! ([`Facts`], side by side in one table) and its C functions, one line each ([`api`],
//! [`fmi3::api`]). An FMU crate is its model plus one [`export_fmi2!`] or
//! [`export_fmi3!`] line, as in the Modelica Association's Reference-FMUs, where all FMI
//! glue is shared and each model is a small equations file.

pub mod access;
pub mod api;
pub mod arrays;
pub mod entry;
mod export;
pub mod ffi;
pub mod fmi3;
pub mod instance;
pub mod model_description;
pub mod registry;
pub mod standards;
mod state;
mod state_blob;
mod table;
pub mod testing;

pub use access::{
    parameter_values, row_named, row_of, start_value, Access, Declares, Row, Value, Var,
};
pub use entry::same_time;
pub use inchworm_declare;
pub use inchworm_state_bytes::{Reader, Writer};
pub use instance::{Clip, Facts, Interface, LogCategory, Modes, Scheduler, Standard, State};
pub use table::{
    Admission, Causality, ClockKind, Initial, Kind, ModelInfo, Start, Unit, Variability, Variable,
    Wording,
};

/// Something a step has to tell the master.
#[derive(Clone, Debug, PartialEq)]
pub enum Message {
    /// Logged under `logEvents` (debug logging, status fmi2OK).
    Event(String),
    /// Logged under `logStatusWarning`; the step returns fmi2Warning.
    Warning(String),
}

/// Where [`Model::do_step`] reports. The layer keeps one per instance, so a step that
/// reports nothing costs nothing, and an event's text is formatted only when the master
/// has `logEvents` (or `logAll`) on: the hot path stays free of formatting and allocation.
#[derive(Debug, Default)]
pub struct StepLog {
    events_wanted: bool,
    messages: Vec<Message>,
}

impl StepLog {
    pub fn new(events_wanted: bool) -> Self {
        StepLog { events_wanted, messages: Vec::new() }
    }
    /// Whether an event would be logged; a model may skip work that only feeds one.
    pub fn events_wanted(&self) -> bool {
        self.events_wanted
    }
    /// An event, logged under `logEvents` when that category is on; dropped unformatted
    /// when it is not.
    pub fn event(&mut self, text: std::fmt::Arguments) {
        if self.events_wanted {
            self.messages.push(Message::Event(text.to_string()));
        }
    }
    /// A warning: always logged, and the step returns Warning.
    pub fn warning(&mut self, text: std::fmt::Arguments) {
        self.messages.push(Message::Warning(text.to_string()));
    }
    /// What was reported since the last [`StepLog::drain`].
    #[inline]
    pub fn messages(&self) -> &[Message] {
        &self.messages
    }
    #[inline]
    pub(crate) fn reset(&mut self, events_wanted: bool) {
        self.events_wanted = events_wanted;
        self.messages.clear();
    }
    pub(crate) fn drain(&mut self) -> std::vec::Drain<'_, Message> {
        self.messages.drain(..)
    }
}

/// One continuous state of a Model Exchange interface: the variable that holds it, the
/// variable that holds its derivative (both Reals of the table, read through their
/// rows), and the magnitude the integrator scales its error by.
#[derive(Clone, Copy, Debug)]
pub struct ContinuousState {
    pub value: u32,
    pub derivative: u32,
    pub nominal: f64,
}

/// What a model adds for Model Exchange: its continuous states and its event indicators
/// (Reals of the table whose sign changes are the state events). The layer reads them by
/// value reference, so the XML's `derivative=` attributes, `<Derivatives>` and
/// `<EventIndicator>` lists and the C arrays all come from this one declaration.
#[derive(Clone, Copy, Debug)]
pub struct ModelExchange {
    pub states: &'static [ContinuousState],
    pub event_indicators: &'static [u32],
    /// The model computes exact directional derivatives
    /// ([`Model::directional_derivative`]), for both interfaces.
    pub directional_derivatives: bool,
}

/// What one event-mode update tells the master.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EventUpdate {
    /// A jump: the integrator must restart from the states it reads back.
    pub states_changed: bool,
    /// The next time event, if the model has one scheduled.
    pub next_event_time: Option<f64>,
}

/// A simulation model exported as an FMI 2.0 or 3.0 FMU: Co-Simulation always, and Model
/// Exchange when [`Model::model_exchange`] declares its states (the methods after it have
/// defaults for a model without).
///
/// The layer reads and writes the model only through the rows of [`Model::table`], after
/// checking every value reference against it (it exists, has the right type, may be set
/// in the current state) and every value (finite; an input inside its declared range).
pub trait Model: Clone + Send + 'static {
    /// Identity, defaults and units of the FMU.
    fn info() -> &'static ModelInfo;
    /// The variable table, accessors in its rows ([`table!`]): the single source of the
    /// value references, the XML, the docs and every `Get*`/`Set*`.
    fn table() -> &'static [Row<Self>];
    /// A fresh instance with every variable at its start value.
    fn new() -> Self;

    /// The declarations of [`Model::table`], in order.
    fn variables() -> impl ExactSizeIterator<Item = &'static Variable> + Clone {
        Self::table().iter().map(|r| &r.var)
    }

    /// Called by `fmi2ExitInitializationMode`: validate parameters and build the model.
    fn exit_initialization(&mut self, start_time: f64) -> Result<(), String>;

    /// Refuses a step the model cannot take (e.g. a step size it does not support) before
    /// anything runs; a refusal leaves the instance as it was.
    fn check_step(&self, _t: f64, _h: f64) -> Result<(), String> {
        Ok(())
    }

    /// Refuses a time a Model Exchange master sets that the model cannot reach from where
    /// it is in bounded work (its next event update runs everything up to that time); a
    /// refusal leaves the instance as it was.
    fn check_time(&self, _t: f64) -> Result<(), String> {
        Ok(())
    }

    /// One communication step from `t` of length `h` (both checked by the layer). An `Err`
    /// is a failure of the model and moves the instance to the Error state. What to log
    /// goes to `log`: events (debug logging, category logEvents, formatted only when
    /// wanted) and warnings (the step succeeded, with status Warning).
    fn do_step(&mut self, t: f64, h: f64, log: &mut StepLog) -> Result<(), String>;

    /// Appends everything beyond the parameters needed to continue bit for bit: inputs
    /// and dynamic state. The layer saves the parameters before it, from the table.
    fn save_state(&self, w: &mut Writer);
    /// Restores what [`Model::save_state`] wrote, into a fresh model whose parameters the
    /// layer has already restored; on error the layer discards the model.
    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String>;

    /// The Model Exchange interface; `None` (the default): Co-Simulation only, and the XML
    /// has no `<ModelExchange>`.
    fn model_exchange() -> Option<&'static ModelExchange> {
        None
    }

    /// Called after a successful [`Model::exit_initialization`] of a Model Exchange
    /// instance, for a model whose Model Exchange formulation is not its Co-Simulation one
    /// to build it; an `Err` fails the exit as one of `exit_initialization` does.
    fn enter_model_exchange(&mut self) -> Result<(), String> {
        Ok(())
    }

    /// The master's time in Model Exchange (`SetTime`, checked by the layer), for a model
    /// whose outputs, rates or indicators depend on time as well as on its states.
    fn set_time(&mut self, _t: f64) {}

    /// Sets the continuous states, in the order of [`ModelExchange::states`], from the
    /// master's integrator (finite, checked by the layer).
    fn set_continuous_states(&mut self, _x: &[f64]) -> Result<(), String> {
        Err("this model has no continuous states".into())
    }

    /// A Model Exchange array whole (`Get*` of the continuous states, their derivatives or
    /// the event indicators), in the order of [`ModelExchange`], for a model that computes
    /// it in one evaluation where a read through each variable's row would take one per
    /// element; `out` has the declared length. Returns whether it wrote `out`: `false`
    /// (the default) has the layer read each variable through its row. The values must be
    /// those the rows give (each model's tests compare them); one that is not finite is
    /// refused through its row, with its name.
    fn me_array(&self, _array: entry::Array, _out: &mut [f64]) -> bool {
        false
    }

    /// Event mode at time `t`: the discrete-time equations and the jumps. Called once per
    /// `NewDiscreteStates`/`UpdateDiscreteStates`; a model whose one update reaches the
    /// fixed point of its event iteration never asks for another. An `Err` moves the
    /// instance to Error, as a failed step does.
    fn update_discrete_states(
        &mut self,
        _t: f64,
        _log: &mut StepLog,
    ) -> Result<EventUpdate, String> {
        Err("this model has no Model Exchange interface".into())
    }

    /// A tick of the input clock `clock` (a [`Kind::Clock`] row declared with
    /// [`Variable::periodic_clock`]) at `t`: the model partition of that clock. The layer
    /// runs it when the importer activates the clock (FMI 3.0 Co-Simulation or Model
    /// Exchange in event mode, at `fmi3UpdateDiscreteStates`; Scheduled Execution, at
    /// `fmi3ActivateModelPartition`) and has checked that `t` is a tick of it. An output
    /// clock the partition ticks reads true through its row until
    /// [`Model::clear_output_clocks`]. An `Err` moves the instance to Error.
    fn activate_clock(&mut self, _clock: u32, _t: f64, _log: &mut StepLog) -> Result<(), String> {
        Err("this model has no clocks".into())
    }

    /// Deactivates every output clock: on leaving event mode, before a model partition
    /// runs, and once a Scheduled Execution importer has read it.
    fn clear_output_clocks(&mut self) {}

    /// A communication step of an instance whose clocked partitions run at their clocks'
    /// activations (FMI 3.0 Co-Simulation with `eventModeUsed`): what the model computes
    /// between ticks. The layer ends such a step at the next tick at the latest. The
    /// default is [`Model::do_step`]: a model without clocked partitions steps alike.
    fn step_between_ticks(&mut self, t: f64, h: f64, log: &mut StepLog) -> Result<(), String> {
        self.do_step(t, h, log)
    }

    /// `out[i] = Σ_j ∂unknowns[i]/∂knowns[j] · seed[j]` at the current state, for a model
    /// whose [`ModelExchange::directional_derivatives`] is true. The layer has checked that
    /// every reference is a Real of the table and every seed finite; a pair the model has
    /// no derivative for is an `Err` naming it.
    fn directional_derivative(
        &self,
        _unknowns: &[u32],
        _knowns: &[u32],
        _seed: &[f64],
        _out: &mut [f64],
    ) -> Result<(), String> {
        Err("this model provides no directional derivatives".into())
    }
}
