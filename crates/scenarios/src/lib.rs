//! `inchworm-scenarios`: the inchworm actuator on the `inchworm-cosim` engine — the paper's
//! scenarios and the controller options beyond it, the closed-loop analysis and the
//! actuator's sweep metrics, the plant and controller FMUs' interfaces, and the plots.
//!
//! * [`scenario`]: the named scenarios, through the master on the SSP or direct;
//! * [`closed_loop`]: the crates coupled directly (the reference) and the closed-loop analysis;
//! * [`holding`]: how well the runner holds: the parked samples, the settle time and the
//!   holding RMS, each reduced one sample at a time;
//! * [`metrics`]: the sweep metrics of a closed loop (settle time, parked RMS, estimates,
//!   slips), reduced row by row as a sweep runs them;
//! * [`gait`]: the stepping gait of docs/model.md §3, its raw measurements and the docs/model.md §2.9 check values;
//! * [`plant`]: the `InchwormPlant` FMU's interface (docs/model.md §5) and an open-loop gait run through it;
//! * [`controller`]: the `InchwormController` FMU's parameters from the controller crate's;
//! * [`bridge`]: the FMUs behind the HIL bridge (`inchworm-bridge`);
//! * [`plot`], [`sweep_plots`]: PNG plots.

pub mod bridge;
pub mod closed_loop;
pub mod controller;
pub mod gait;
pub mod holding;
pub mod metrics;
pub mod plant;
pub mod plot;
pub mod scenario;
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

/// What a scenario run reports: the engine's error as it is, or the analysis' message (a
/// trace without the loop's variables, a plot that cannot be drawn).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    #[error(transparent)]
    Engine(#[from] inchworm_cosim::Error),
    #[error("{0}")]
    Analysis(String),
}

impl From<String> for Error {
    fn from(message: String) -> Error {
        Error::Analysis(message)
    }
}
