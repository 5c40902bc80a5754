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
//! * [`poses`]: every mirror mount's pose of a run and whether all its actuators are held,
//!   as the poses CSV of python/inchworm_segments;
//! * [`plot`], [`sweep_plots`]: PNG plots.

pub mod actuators;
pub mod bridge;
pub mod closed_loop;
pub mod controller;
pub mod gait;
pub mod holding;
pub mod metrics;
pub mod plant;
pub mod plot;
pub mod poses;
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

/// What a scenario run reports: the engine's error as it is, an FMU's or a model crate's
/// error as it is, or what the analysis found missing (a trace without the loop's
/// variables, a value outside an FMU's interface).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    #[error(transparent)]
    Engine(#[from] inchworm_cosim::Error),
    /// An FMU of the scenarios' own drivers (the plant FMU's gait, the bridge's FMUs).
    #[error(transparent)]
    Fmu(#[from] inchworm_cosim::fmu::FmuError),
    /// The plant crate refused its parameters.
    #[error(transparent)]
    PlantParams(#[from] inchworm_plant::ParamError),
    /// The plant crate's step failed.
    #[error(transparent)]
    PlantStep(#[from] inchworm_plant::StepError),
    /// The controller crate refused its parameters (its message).
    #[error("{0}")]
    Controller(String),
    /// A `--param NAME=VALUE` the FMU at `path` refused.
    #[error("{}: parameter `{name}`: {source}", path.display())]
    Parameter {
        path: std::path::PathBuf,
        name: String,
        #[source]
        source: Box<inchworm_cosim::Error>,
    },
    /// The plant FMU's `mode` is none of its four.
    #[error("the plant FMU gave mode {0}, not 1–4")]
    PlantMode(i32),
    /// The plant FMU's `slip_events` is negative.
    #[error("the plant FMU gave {0} slip events")]
    SlipEvents(i32),
    /// The controller FMU lacks a clock the bridge drives it by (Scheduled Execution).
    #[error("{}: no {causality} clock `{name}` in modelDescription.xml (the bridge activates `sample_clock` and reads `gait_step`)", path.display())]
    NoClock {
        path: std::path::PathBuf,
        name: &'static str,
        causality: inchworm_cosim::fmu::Causality,
    },
    /// The controller FMU's sample clock does not tick at the bridge's period.
    #[error("{}: the clock `{name}` ticks every {} s; the bridge ticks every {period} s", path.display(), interval.map_or("(no intervalDecimal)".to_string(), |i| i.to_string()))]
    ClockInterval {
        path: std::path::PathBuf,
        name: &'static str,
        interval: Option<f64>,
        period: f64,
    },
    /// The controller FMU's DAC code does not fit the wire's 16 bits.
    #[error("the controller FMU gave DAC code {0}, outside 0–65535")]
    DacCode(i32),
    /// A trace without a variable the analysis reads.
    #[error("the trace has no `{0}`")]
    NoVariable(String),
    /// A trace without a row.
    #[error("the trace is empty")]
    EmptyTrace,
    /// A gait step's amplitude outside [-1, 1].
    #[error("step amplitude {0} is outside [-1, 1]")]
    Amplitude(f64),
    /// A file the scenario writes (its folder, its CSV) cannot be written.
    #[error("{}: {source}", path.display())]
    Write {
        path: std::path::PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A plot cannot be drawn.
    #[error("{}: cannot draw the plot: {source}", path.display())]
    Plot {
        path: std::path::PathBuf,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The plot font cannot be read.
    #[error("{}: cannot read the plot font: {source} (on Debian: apt-get install fonts-dejavu-core, or pass --font)", path.display())]
    FontFile {
        path: std::path::PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The plot font is not a font plotters can use.
    #[error("{}: not a TrueType/OpenType font", .0.display())]
    NotAFont(std::path::PathBuf),
}
