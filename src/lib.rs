//! `inchworm`: runs the project's FMUs (or any FMI 2.0 Co-Simulation FMU) and writes results
//! (CSV) and plots (PNG). The command-line front end is `src/main.rs`.
//!
//! * [`fmu`]: a small FMI 2.0 Co-Simulation import layer on the `fmi` crate;
//! * [`gait`]: the stepping gait of SPEC 3, its raw measurements and the SPEC 2.9 check values;
//! * [`plant`]: the `InchwormPlant` FMU's interface (SPEC 5) and an open-loop gait run through it;
//! * [`plot`]: PNG plots;
//! * [`closed_loop`], [`scenario`]: the closed loop, direct or through the FMUs, and the paper's scenarios.

pub mod closed_loop;
pub mod fmu;
pub mod gait;
pub mod plant;
pub mod plot;
pub mod scenario;
pub mod master;
pub mod ssp;
