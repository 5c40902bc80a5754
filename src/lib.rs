//! `inchworm`: the command-line tool's package. The engine is `inchworm-cosim`
//! (crates/cosim), the actuator's scenarios, analysis and plots `inchworm-scenarios`
//! (crates/scenarios); the binary is `src/main.rs` and `src/cmd/`.
//!
//! This library only re-exports both crates under the package's historical module paths
//! (`inchworm::master`, `inchworm::closed_loop`, …), for code written against them: a new
//! program depends on `inchworm-cosim` (and `inchworm-scenarios`) directly.

pub use inchworm_cosim::{archive, fmu, master, ssp, sweep, trace};
pub use inchworm_scenarios::{
    bridge, closed_loop, controller, gait, metrics, plant, plot, scenario, sweep_plots,
};
