//! `inchworm-scenarios`: the inchworm actuator on the `inchworm-cosim` engine, by what each
//! part is about. Every module has its own small error type, so a caller matches only what
//! that part can report.
//!
//! **Closed loop** (the paper's scenarios, docs/model.md §4.1)
//! * [`scenario`]: the named scenarios, through the master on the SSP or direct
//!   ([`scenario::Error`]);
//! * [`closed_loop`]: the crates coupled directly (the reference) and the closed-loop
//!   analysis ([`closed_loop::Error`], [`closed_loop::TraceError`]);
//! * [`holding`]: how well the runner holds: the parked samples, the settle time and the
//!   holding RMS, each reduced one sample at a time;
//! * [`gait`]: the stepping gait of docs/model.md §3, its raw measurements and the
//!   docs/model.md §2.9 check values ([`gait::AmplitudeError`]).
//!
//! **The FMUs' interfaces**
//! * [`plant`]: the `InchwormPlant` FMU's interface (docs/model.md §5) and an open-loop gait
//!   run through it ([`plant::Error`]);
//! * [`controller`]: the `InchwormController` FMU's parameters from the controller crate's;
//! * [`bridge`]: the FMUs behind the HIL bridge (`inchworm-bridge`, [`bridge::Error`]).
//!
//! **Mirrors and segmented primaries** (many actuators in one system)
//! * [`actuators`]: every actuator of such a system, found by its components' names and
//!   reduced to the sweep's metrics;
//! * [`poses`]: every mirror mount's pose of a run and whether all its actuators are held,
//!   as the poses CSV of python/inchworm_segments.
//!
//! **The interferometer's delay line**
//! * [`delay_line`]: a run of `inchworm_delay_line` as CSV and plots, the designer's
//!   survey and the largest rate each gait follows.
//!
//! **Sweeps and plots**
//! * [`metrics`]: the sweep metrics of a closed loop (settle time, parked RMS, estimates,
//!   slips), reduced row by row as a sweep runs them;
//! * [`plot`], [`sweep_plots`]: PNG plots ([`plot::FontError`]).

pub mod actuators;
pub mod bridge;
pub mod closed_loop;
pub mod controller;
pub mod delay_line;
pub mod gait;
pub mod holding;
pub mod metrics;
pub mod plant;
pub mod plot;
pub mod poses;
pub mod scenario;
pub mod segmented;
pub mod sweep_plots;

/// Every parameter of `model` as `<component>.<name>` values for the master, from the
/// model's variable table: the FMU runs exactly `model`'s parameters.
pub(crate) fn component_parameters<M: inchworm_fmi_export::Model>(
    component: &str,
    model: &M,
) -> Vec<(String, String)> {
    inchworm_fmi_export::parameter_values(model)
        .map(|(name, value)| (format!("{component}.{name}"), value.to_string()))
        .collect()
}
