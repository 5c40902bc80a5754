//! `inchworm`: runs the project's FMUs (or any FMI 2.0 Co-Simulation FMU) and writes results
//! (CSV) and plots (PNG). The command-line front end is `src/main.rs`.
//!
//! * [`fmu`]: FMI 2.0 Co-Simulation import (the project's own layer, `inchworm-fmi-import`, re-exported);
//! * [`gait`]: the stepping gait of docs/model.md §3, its raw measurements and the docs/model.md §2.9 check values;
//! * [`plant`]: the `InchwormPlant` FMU's interface (docs/model.md §5) and an open-loop gait run through it;
//! * [`plot`]: PNG plots;
//! * [`controller`]: the `InchwormController` FMU's parameters from the controller crate's;
//! * [`trace`]: what every run records, the master's and the direct coupling's alike;
//! * [`closed_loop`]: the crates coupled directly (the reference) and the closed-loop analysis;
//! * [`scenario`]: the paper's scenarios, through the master on the SSP or direct;
//! * [`master`], [`ssp`]: the co-simulation master for SSP systems and single FMUs, in
//!   load / initialise / step phases;
//! * [`archive`]: unpacking an SSP within caps, and keeping its paths inside it;
//! * [`bridge`]: the FMUs behind the HIL bridge (`inchworm-bridge`);
//! * [`sweep`]: grid and Monte Carlo sweeps of a system, their plan, metrics and results.

pub mod archive;
pub mod bridge;
pub mod closed_loop;
pub mod controller;
pub mod fmu;
pub mod gait;
pub mod master;
pub mod plant;
pub mod plot;
pub mod scenario;
pub mod ssp;
pub mod sweep;
pub mod trace;
