//! Clients of GMT's dos-actors framework (`gmt_dos-actors` 12.3) for the inchworm
//! actuator, and for any FMU:
//!
//! * [`Inchworm`]: an actuator (the controller and plant models the FMUs export, coupled
//!   as the co-simulation master couples the FMUs), reading [`uid::Reference`] and writing
//!   the encoder, DAC volts and codes, runner position and estimator outputs;
//! * [`Mount`] (the mount kinematics) and [`MirrorMount`] (three actuators and the mount,
//!   `dist/MirrorMount.ssp` as one client);
//! * [`ReferenceSource`], the reference trajectory as a source;
//! * [`FmuClient`]: any FMI 2.0 or 3.0 Co-Simulation FMU, its variables as UIDs;
//! * [`Logger`] and [`Sampler`], a sink and a rate transition.
//!
//! Every client reports failures through the framework's fallible traits (`TryUpdate`,
//! `TryRead`, `TryWrite`) as [`Error`], so a model's run ends with the message. The UIDs
//! are in [`uid`]. docs/dos-actors.md is the guide for integrated modellers.

mod error;
mod fmu_client;
mod inchworm;
mod logger;
mod mount;
mod reference;
mod table;
pub mod uid;

pub use error::Error;
pub use fmu_client::{FmuClient, FmuValue};
pub use inchworm::Inchworm;
pub use logger::{Logger, Sampler};
pub use mount::{MirrorMount, Mount};
pub use reference::ReferenceSource;
pub use table::{ssp_value, Driven};
pub use uid::FmiName;

/// The framework's client interface, for [`fmu_io!`] in other crates.
pub use interface;
