//! A fixed-step co-simulation master for FMI 2.0 and 3.0 Co-Simulation FMUs: a flat SSP system or a
//! single FMU, Jacobi or Gauss–Seidel coupling, parameters and parameter sets, a CSV of
//! inputs for unconnected inputs, and the chosen variables recorded at every
//! communication point.

mod batches;
mod checkpoint;
mod clocked;
mod clocks;
mod component;
mod parallel;
mod parameters;
pub mod partition;
mod simulation;
mod system;
mod timing;

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use crate::fmu::{FmuState, VarType};
pub use crate::input::InputTable;
use crate::model_exchange::{Carry, MeStats, Tolerance};
use crate::ssp::{Archive, End};
use crate::trace::Trace;
use crate::{Error, StopFlag};
use batches::Batches;
use component::Component;
pub use parallel::Parallel;
pub use parameters::set_param;
pub use timing::{run_timed, Timing};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coupling {
    /// Every component steps on the others' outputs from the start of the step.
    Jacobi,
    /// Components step in order, each on the outputs the earlier ones just produced.
    GaussSeidel,
}

#[derive(Clone, Debug)]
pub struct Options {
    pub stop_time: Option<f64>,
    pub step_size: Option<f64>,
    pub coupling: Coupling,
    /// `component.variable` (or `variable` for a single FMU) = value text.
    pub params: Vec<(String, String)>,
    pub parameter_set: Option<String>,
    pub input: Option<InputTable>,
    /// Names to record; empty: every system output connector (or every FMU output).
    pub outputs: Vec<String>,
}

/// A variable of one component, resolved.
#[derive(Clone, Copy, Debug)]
struct Port {
    component: usize,
    vr: u32,
    ty: VarType,
}

/// Where an input gets its value each step: the latest read of a component output, or a
/// system input.
#[derive(Clone, Copy, Debug)]
enum Feed {
    Latest(usize),
    SystemInput(usize),
}

/// Where a row finds one recorded value.
#[derive(Clone, Copy, Debug)]
enum Column {
    /// A port's latest read, `latest[j]`.
    Latest(usize),
    /// A system input at the row's time.
    SystemInput(usize),
}

/// Which components the master integrates as Model Exchange, and how finely. A component
/// whose FMU offers only Model Exchange always is; one named here is, if its FMU offers
/// Model Exchange (if not, loading it fails and says so). Every name must be a component
/// of the run ([`System::load_as`] refuses another: [`Error::NoSuchComponent`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Interfaces {
    /// Component names (`fmu` for a single FMU), or `*` for every component whose FMU
    /// offers Model Exchange.
    pub model_exchange: Vec<String>,
    /// Component names to run as Co-Simulation even under `*` (`--interface NAME=cs`).
    pub co_simulation: Vec<String>,
    /// Component names to run as FMI 3.0 Co-Simulation with event mode, stepped from
    /// clock tick to clock tick (`--interface NAME=cs-events`).
    pub event_mode: Vec<String>,
    /// Component names to run in FMI 3.0 Scheduled Execution, their model partitions
    /// activated at their clocks' ticks (`--interface NAME=se`).
    pub scheduled_execution: Vec<String>,
    /// Within [`limits::RTOL`] and [`limits::ATOL`].
    ///
    /// [`limits::RTOL`]: crate::limits::RTOL
    /// [`limits::ATOL`]: crate::limits::ATOL
    pub tolerance: Tolerance,
}

/// A system loaded and not yet initialized: its components instantiated, its connectors
/// and connections read (phase 1 of [`run`]).
pub struct System {
    /// Kept for the parameter sets, and because the components' FMUs were unpacked in it.
    archive: Option<Archive>,
    components: Vec<Component>,
    inputs: Vec<String>,
    outputs: Vec<String>,
    connections: Vec<(End, End)>,
    /// The SSD's declared connector types (empty for a single FMU).
    connector_types: BTreeMap<End, String>,
    stop_time: Option<f64>,
    step_size: Option<f64>,
    /// The SSD's components that other parts run ([`System::load_part`]): their
    /// parameters are those parts' to set. Empty for a whole system.
    elsewhere: BTreeSet<String>,
}

/// An initialized system stepping on a fixed communication grid `k h` (phase 3 of [`run`]).
pub struct Simulation {
    components: Vec<Component>,
    /// The latest read of every component output that feeds an input (the first
    /// `sources`), then of every recorded output that feeds none.
    latest: Vec<f64>,
    sources: usize,
    /// The outputs that feed inputs.
    source_batches: Batches,
    /// The recorded outputs that feed no input, into `latest[sources..]`.
    record_batches: Batches,
    /// Both, each component's of one type in one call: what a step of a system without
    /// clocks reads.
    read_batches: Batches,
    /// The recorded outputs in `latest` are those of the FMUs now: the last step read them
    /// with the sources and nothing has been called since. A row then takes them as they
    /// are.
    rows_read: bool,
    destinations: Vec<(Port, Feed)>,
    destination_batches: Batches,
    /// The clocked inputs of the clocked components, set at their ticks.
    ticked: clocks::TickInputs,
    /// Whether a component runs with event mode or in Scheduled Execution.
    clocked: bool,
    /// The values about to be written to `destinations`.
    values: Vec<f64>,
    /// Where each value of a row comes from, in the order of `record_names`.
    columns: Vec<Column>,
    record_names: Vec<String>,
    /// The row [`Simulation::sample_row`] fills, kept so that a step's row allocates nothing.
    row: Vec<f64>,
    input: Option<InputTable>,
    input_columns: Vec<Option<usize>>,
    /// Per system input, the row of the input table it was read from last.
    input_rows: Vec<usize>,
    coupling: Coupling,
    h: f64,
    n_steps: u64,
    k: u64,
    stop: Option<StopFlag>,
    _archive: Option<Archive>,
    /// The [`System`] this was initialised from, without its components and archive
    /// (which the simulation holds), for [`Simulation::reset`]; `None` after a reset failed.
    loaded: Option<System>,
}

/// What a finished [`Simulation::run_into`] leaves besides its rows.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunEnd {
    /// What integrating each Model Exchange component cost, by component name (empty when
    /// every component ran its Co-Simulation).
    pub model_exchange: Vec<(String, MeStats)>,
}

/// Runs `path` (an `.ssp`, or a single `.fmu`): loads it, initializes it, steps it to the
/// stop time and records the chosen variables at every communication point, t = 0 first.
///
/// The whole trace is kept in memory: for short runs (scenarios, tests). A long run
/// streams its rows with [`Simulation::run_into`]. [`run_timed`] also says where the run's
/// wall time went.
pub fn run(path: &Path, opts: &Options, progress: impl FnMut(f64)) -> Result<Trace, Error> {
    run_timed(path, opts, progress).map(|(trace, _)| trace)
}

/// A communication point of a running [`Simulation`] to come back to: every component's
/// FMU state (`fmi2GetFMUstate` / `fmi3GetFMUState`, whichever standard the component is)
/// and the master's own state there (the step counter and the outputs last read, which
/// feed the next step), and what a Model Exchange component's integrator carries past the
/// point. Restoring it makes the steps after it repeat bit for bit, so a
/// study can branch many runs from one settled transient. The FMU states live in their
/// components: give a checkpoint back with [`Simulation::release`]; those not released
/// are freed with the simulation.
pub struct Checkpoint {
    states: Vec<FmuState>,
    /// Each component's integrator carry (`None` for a Co-Simulation component).
    carries: Vec<Option<Carry>>,
    k: u64,
    latest: Vec<f64>,
}
