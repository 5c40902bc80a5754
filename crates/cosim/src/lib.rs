//! `inchworm-cosim`: a fixed-step co-simulation engine for FMI Co-Simulation FMUs (2.0 and
//! 3.0, through the project's import layer `inchworm-fmi-import`). It knows systems, not
//! models: no plant or controller name appears in it.
//!
//! * [`ssp`], [`archive`]: reading an SSP 1.0 file (system structure, parameter sets and
//!   bindings), unpacked within caps and kept inside its folder;
//! * [`master`]: a flat SSP system or a single FMU in load / initialise / step phases,
//!   Jacobi or Gauss–Seidel coupling, parameters, [`InputTable`]s for unconnected inputs;
//! * [`input`]: piecewise-constant input tables (`time,<name>,…` CSV);
//! * [`limits`]: the sizes the master takes from a model description and the ranges of
//!   the numbers it is given, defined once;
//! * [`trace`]: what a run records, and its CSV;
//! * [`sweep`]: grid and Monte Carlo plans, their execution on worker threads, generic
//!   metrics (`final`, `min`, `max` of any recorded variable) and the results table;
//! * [`fmu`]: the import layer, re-exported.
//!
//! A run that must stop early (Ctrl-C in a command-line tool, a GUI's cancel button) shares
//! a [`StopFlag`] with the simulation: the engine installs no signal handler of its own.
//!
//! # Example
//!
//! The Fig. 5 closed loop of the project's `dist/InchwormSystem.ssp` (built by
//! `cargo run --release -p fmu-build`) for 2 s, the encoder position at every 2 ms:
//!
//! ```no_run
//! use std::path::Path;
//! use inchworm_cosim::{master, Coupling, Options};
//!
//! let opts = Options {
//!     stop_time: Some(2.0),
//!     step_size: Some(0.002),
//!     coupling: Coupling::Jacobi,
//!     params: vec![],
//!     parameter_set: None,
//!     input: None,
//!     outputs: vec!["plant.encoder_position".into()],
//! };
//! let trace = master::run(Path::new("dist/InchwormSystem.ssp"), &opts, |_| {})?;
//! let x = trace.column("plant.encoder_position").expect("recorded");
//! println!("{} rows, at 2 s the encoder reads {} m", trace.rows.len(), x[x.len() - 1]);
//! # Ok::<(), inchworm_cosim::Error>(())
//! ```
//!
//! Phase by phase, with a stop flag and the rows streamed as they come:
//!
//! ```no_run
//! # use std::path::Path;
//! # use inchworm_cosim::{master::System, Coupling, Options, StopFlag};
//! # let opts = Options { stop_time: Some(2.0), step_size: Some(0.002), coupling: Coupling::Jacobi,
//! #     params: vec![], parameter_set: None, input: None, outputs: vec![] };
//! let stop = StopFlag::new();
//! let sim = System::load(Path::new("dist/InchwormSystem.ssp"))?.initialise(&opts)?;
//! let sim = sim.stop_when(stop.clone()); // `stop.set()` from any thread ends the run
//! sim.run_into(
//!     |t, row| {
//!         println!("{t} {row:?}");
//!         Ok::<(), inchworm_cosim::Error>(())
//!     },
//!     |_fraction| {},
//! )?;
//! # Ok::<(), inchworm_cosim::Error>(())
//! ```

pub mod archive;
mod error;
pub mod float_text;
pub mod input;
pub mod limits;
pub mod master;
pub mod model_exchange;
pub mod output;
pub mod ssp;
pub mod sweep;
pub mod trace;

/// The FMI import layer (`inchworm-fmi-import`), re-exported: [`fmu::CsFmu`] loads one FMU
/// for Co-Simulation, [`fmu::MeFmu`] for Model Exchange.
pub use inchworm_fmi_import as fmu;

pub use error::{Error, StopFlag};
pub use master::{
    Checkpoint, Coupling, InputTable, Interfaces, Options, RunEnd, Simulation, System,
};
pub use trace::Trace;
