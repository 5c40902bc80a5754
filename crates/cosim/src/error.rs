//! What the engine reports: one error type whose messages say what and where (they are the
//! command-line tool's messages, word for word), with the import layer's own errors kept
//! as sources rather than flattened to text; and the flag that stops a run.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use inchworm_fmi_import::{FmuError, ImportError};

use crate::limits::{Number, Range};

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// An FMU could not be loaded, has no such variable, or refused a call.
    #[error(transparent)]
    Fmu(#[from] FmuError),
    /// A component of an SSP could not be loaded.
    #[error("component {component}: {source}")]
    Component {
        component: String,
        #[source]
        source: FmuError,
    },
    /// The SSP could not be unpacked: its caps, its folder, or an entry.
    #[error("{}: {}{source}", path.display(), if *.unpacking { "cannot unpack: " } else { "" })]
    Archive {
        path: PathBuf,
        /// Whether extraction itself failed (rather than the setup before it).
        unpacking: bool,
        #[source]
        source: ImportError,
    },
    /// The SSP is not a zip archive.
    #[error("{}: not an SSP archive (zip): {source}", path.display())]
    NotZip {
        path: PathBuf,
        #[source]
        source: zip::result::ZipError,
    },
    /// The SSP holds no readable `SystemStructure.ssd` at its root.
    #[error("{}: no readable SystemStructure.ssd at its root: {source}", path.display())]
    NoSsd {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The SSD or a parameter set is malformed, or asks for what this master does not do
    /// (nested systems, components that are not FMUs, paths out of the archive).
    #[error("{0}")]
    Ssp(String),
    /// An input table that cannot be read or used.
    #[error("{0}")]
    Input(String),
    /// The system and the options do not fit: an unknown name, a value of the wrong type,
    /// a stop time off the step grid, two drivers for one input.
    #[error("{0}")]
    Config(String),
    /// Where an error happened: a file, a parameter, a recorded name.
    #[error("{context}: {source}")]
    Context {
        context: String,
        #[source]
        source: Box<Error>,
    },
    /// The master's integration of a Model Exchange component failed: the integrator, a
    /// non-finite derivative, an event iteration that did not settle, too many events.
    #[error("component {component}: at t = {time} s: {message}")]
    Integration { component: String, time: f64, message: String },
    /// A number given to the master (a command-line option, a field of its options) is
    /// not finite or out of its range ([`crate::limits`]); `given` says who gave it.
    #[error("{given} = {}: {} must be {range}", Number(*value), range.what)]
    OutOfRange { given: String, value: f64, range: Range },
    /// A Model Exchange component's FMU returned a number the master cannot integrate
    /// with: not finite, or out of `range` if there is one; `call` is the FMU's function
    /// that returned it, `what` which of its values.
    #[error(
        "component {component}: at t = {time} s: {call} returned {what} = {}: {}",
        Number(*value),
        match range { Some(r) => format!("{} must be {r}", r.what), None => "not a finite number".into() }
    )]
    FmuValue {
        component: String,
        time: f64,
        call: &'static str,
        what: String,
        value: f64,
        range: Option<Range>,
    },
    /// A component's model description declares more than the master allocates for
    /// ([`crate::limits`]): refused before its FMU is unpacked.
    #[error("component {component}: the model description declares {count} {what}, more than the {limit} this master takes{}", why(what))]
    TooLarge { component: String, what: &'static str, count: u64, limit: u64 },
    /// An interface was asked of a component the run does not have.
    #[error(
        "--interface {name}={interface}: no component named `{name}` to run as {}: {}",
        interface_name(interface),
        known(components)
    )]
    NoSuchComponent { name: String, interface: &'static str, components: Vec<String> },
    /// The run's [`StopFlag`] was set; it stopped between two steps.
    #[error("stopped before the stop time")]
    Stopped,
}

/// The interface an `--interface` value names, spelled out.
pub(crate) fn interface_name(value: &str) -> &'static str {
    match value {
        "me" => "Model Exchange",
        "cs-events" => "Co-Simulation with event mode",
        "se" => "Scheduled Execution",
        _ => "Co-Simulation",
    }
}

/// Why a cap of [`Error::TooLarge`] is what it is.
fn why(what: &str) -> &'static str {
    match what {
        "continuous states" => {
            " (its Model Exchange integrator keeps dense Jacobians, whose size is the square of the states)"
        }
        _ => "",
    }
}

/// The components of [`Error::NoSuchComponent`], said.
fn known(components: &[String]) -> String {
    match components {
        [one] if one == "fmu" => "a single FMU is one component, named `fmu`".into(),
        _ => {
            let mut names: Vec<String> = components
                .iter()
                .take(20)
                .map(|c| format!("`{}`", crate::archive::cut(c, 80)))
                .collect();
            if components.len() > 20 {
                names.push(format!("and {} more", components.len() - 20));
            }
            format!("the components are {}", names.join(", "))
        }
    }
}

impl Error {
    /// This error, said to have happened in `context` (`<context>: <this>`).
    pub fn context(self, context: impl Into<String>) -> Error {
        Error::Context { context: context.into(), source: Box::new(self) }
    }

    /// Whether the run ended because its [`StopFlag`] was set.
    pub fn is_stopped(&self) -> bool {
        match self {
            Error::Stopped => true,
            Error::Context { source, .. } => source.is_stopped(),
            _ => false,
        }
    }
}

/// Asks a running simulation to stop between two steps. Cloned, it is the same flag: set
/// it from another thread, or from a signal handler (setting it is one atomic store).
#[derive(Clone, Debug, Default)]
pub struct StopFlag(Arc<AtomicBool>);

impl StopFlag {
    pub fn new() -> StopFlag {
        StopFlag::default()
    }

    pub fn set(&self) {
        self.0.store(true, Ordering::SeqCst);
    }

    pub fn is_set(&self) -> bool {
        self.0.load(Ordering::SeqCst)
    }

    /// `Err(Error::Stopped)` once the flag is set.
    pub fn check(&self) -> Result<(), Error> {
        if self.is_set() {
            Err(Error::Stopped)
        } else {
            Ok(())
        }
    }
}
