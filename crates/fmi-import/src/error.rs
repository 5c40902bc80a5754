//! Errors: [`ImportError`] for everything between the file and a live instance,
//! [`FmuError`] for the calls after that, and [`Status`], the FMI 2.0 status of a call.

use std::fmt;
use std::path::PathBuf;

use crate::VarType;

/// What went wrong unpacking the archive, reading `modelDescription.xml` or loading the binary.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// Reading the file or writing the unpacked copy failed.
    #[error("{what}: {source}")]
    Io { what: String, source: std::io::Error },
    /// The file is not a zip archive (or a damaged one).
    #[error("not an FMU: the file is not a zip archive ({0})")]
    NotZip(#[source] zip::result::ZipError),
    /// An archive entry would land outside the unpack directory (`..`, an absolute path).
    #[error("the archive entry `{0}` points outside the archive (absolute or `..` path): refused")]
    UnsafePath(String),
    /// The archive has no `modelDescription.xml` at its root.
    #[error("the archive has no modelDescription.xml at its root")]
    NoModelDescription,
    /// The archive passes a cap of [`crate::archive::Limits`] (the text says which).
    #[error("{0}: refused")]
    Limit(String),
    /// The folder of [`crate::archive::cache`] cannot be trusted (the text says why).
    #[error("{0}")]
    Cache(String),
    /// `modelDescription.xml` is malformed XML, lacks an attribute or holds a bad value.
    #[error("modelDescription.xml line {line}, column {column}: {message}")]
    Description { line: usize, column: usize, message: String },
    /// `fmiVersion` is neither 2.x nor 3.x.
    #[error(
        "modelDescription.xml has fmiVersion=\"{0}\": only FMI 2.0 and FMI 3.0 FMUs are supported"
    )]
    UnsupportedVersion(String),
    /// No `binaries/<platform>/<modelIdentifier>.<ext>` for this platform.
    #[error("the FMU has no binary for {platform} (expected {expected}; {})", carried(.available))]
    NoBinary { platform: &'static str, expected: String, available: Vec<String> },
    /// The binary could not be loaded (`library`: its path inside the FMU).
    #[error("cannot load the FMU's binary {}: {source}", library.display())]
    Load { library: PathBuf, source: LoadError },
    /// The binary lacks a required function (`library`: its path inside the FMU).
    #[error("the FMU's binary {} does not export {symbol}", library.display())]
    MissingSymbol { library: PathBuf, symbol: &'static str },
    /// `modelDescription.xml` declares a capability (`flag`) whose function the binary lacks.
    #[error(
        "modelDescription.xml declares {flag}=\"true\" but the FMU's binary {} does not export {symbol}",
        library.display()
    )]
    MissingCapability { library: PathBuf, symbol: &'static str, flag: &'static str },
    /// Another instance was asked of an FMU that declares
    /// `canBeInstantiatedOnlyOncePerProcess="true"` from the library already loaded.
    #[error(
        "{model} declares canBeInstantiatedOnlyOncePerProcess=\"true\": another instance needs a copy of its own, not the library already loaded"
    )]
    OncePerProcess { model: String },
    /// `fmi2GetTypesPlatform` is not "default".
    #[error("fmi2GetTypesPlatform returned \"{0}\", expected \"default\"")]
    TypesPlatform(String),
    /// `function` (`fmi2GetVersion`, `fmi3GetVersion`) returned another version.
    #[error("the binary's {function} returned \"{found}\", expected {expected}x")]
    BinaryVersion { function: &'static str, found: String, expected: &'static str },
    /// `function` (`fmi2Instantiate`, `fmi3InstantiateCoSimulation`) returned NULL.
    #[error(
        "{function} returned NULL for instance `{instance}` (the FMU's log messages above say why)"
    )]
    Instantiate { function: &'static str, instance: String },
    /// A string for the C side holds a NUL byte.
    #[error("{what} contains a NUL byte")]
    Nul { what: &'static str },
}

/// The end of [`ImportError::NoBinary`]'s message: the platform folders the FMU carries.
fn carried(available: &[String]) -> String {
    if available.is_empty() {
        "it carries no binaries at all: a source-only FMU?)".to_owned()
    } else {
        format!("it carries: {})", available.join(", "))
    }
}

/// Why the FMU's binary could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// An ELF file shorter than its headers say, or with damaged headers: refused before
    /// `dlopen`, which would map the missing pages and die of SIGBUS touching them.
    #[error("the file is truncated or damaged: it has {len} bytes, its ELF headers need {need}")]
    Truncated { len: u64, need: u64 },
    /// Program header entries too short to hold what the standard puts in them.
    #[error("the file is damaged: program header entries of {0} bytes")]
    EntrySize(u64),
    /// Reading the file to check it failed.
    #[error("{0}")]
    Read(#[source] std::io::Error),
    /// `dlopen` (or `LoadLibrary`) refused it.
    #[error("{0}")]
    Dlopen(#[source] libloading::Error),
}

/// The status an `fmi2*` or `fmi3*` call returned (FMI 3.0 has no Pending). `Display`
/// spells it as FMI 2.0 does; [`Status::spelled`] in the standard of a given call.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    Ok,
    Warning,
    Discard,
    Error,
    Fatal,
    Pending,
    /// A value outside the `fmi2Status` enum (a broken FMU).
    Invalid(i32),
}

impl Status {
    /// An `fmi2Status`.
    pub fn from_raw(s: i32) -> Status {
        match s {
            0 => Status::Ok,
            1 => Status::Warning,
            2 => Status::Discard,
            3 => Status::Error,
            4 => Status::Fatal,
            5 => Status::Pending,
            s => Status::Invalid(s),
        }
    }

    /// An `fmi3Status`: the FMI 2.0 values without `fmi2Pending`.
    pub fn from_fmi3(s: i32) -> Status {
        match Status::from_raw(s) {
            Status::Pending => Status::Invalid(s),
            status => status,
        }
    }

    /// The status as the standard of `function` (an `fmi3*` or `fmi2*` name) spells it.
    pub fn spelled(self, function: &str) -> String {
        let prefix = standard_of(function);
        match self {
            Status::Ok => format!("{prefix}OK"),
            Status::Invalid(_) => self.to_string(),
            other => format!("{prefix}{}", &other.to_string()[4..]),
        }
    }
}

/// `fmi3` for an FMI 3.0 function name, else `fmi2`.
fn standard_of(function: &str) -> &'static str {
    if function.starts_with("fmi3") {
        "fmi3"
    } else {
        "fmi2"
    }
}

impl fmt::Display for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Status::Ok => f.write_str("fmi2OK"),
            Status::Warning => f.write_str("fmi2Warning"),
            Status::Discard => f.write_str("fmi2Discard"),
            Status::Error => f.write_str("fmi2Error"),
            Status::Fatal => f.write_str("fmi2Fatal"),
            Status::Pending => f.write_str("fmi2Pending"),
            Status::Invalid(s) => write!(f, "the invalid status {s}"),
        }
    }
}

impl std::error::Error for Status {}

/// Everything that can go wrong between a path on disk and a finished step.
#[derive(Debug, thiserror::Error)]
pub enum FmuError {
    /// The FMU file is not there (the usual cause: it has not been built yet).
    #[error("{}: no such FMU file", .0.display())]
    Missing(PathBuf),
    /// The archive could not be unpacked, its `modelDescription.xml` parsed or its binary loaded.
    #[error("{}: cannot import the FMU: {source}", path.display())]
    Import { path: PathBuf, source: ImportError },
    /// The FMU offers no Co-Simulation interface.
    #[error(
        "{model}: the FMU has no Co-Simulation interface (modelDescription.xml lacks <CoSimulation>)"
    )]
    NotCoSimulation { model: String },
    /// The FMU offers no Model Exchange interface.
    #[error(
        "{model}: the FMU has no Model Exchange interface (modelDescription.xml lacks <ModelExchange>)"
    )]
    NotModelExchange { model: String },
    /// The FMU does not offer the FMI 3.0 interface asked for (Co-Simulation with event
    /// mode, Scheduled Execution); an FMI 2.0 FMU offers neither, nor clocks.
    #[error("{model}: the FMU (fmiVersion {fmi_version}) does not offer {}: its modelDescription.xml lacks {}{}", interface_name(*interface), interface.declared_by(), if fmi_version.starts_with("3.") { "" } else { " (FMI 2.0 has no clocks, event mode in Co-Simulation nor Scheduled Execution)" })]
    NotOffered { model: String, interface: crate::Interface, fmi_version: String },
    /// No variable of that name in `modelDescription.xml`.
    #[error("{model}: no variable named `{name}` in modelDescription.xml")]
    UnknownVariable { model: String, name: String },
    /// The variable exists but has another type than the call needs.
    #[error("{model}: variable `{name}` is {found}, expected {expected}")]
    WrongType { model: String, name: String, expected: VarType, found: VarType },
    /// A call returned Discard, Error, Fatal or (FMI 2.0) Pending.
    #[error(
        "{model}: {function} returned {} at t = {time} s (the FMU's log messages above say why)",
        status.spelled(function)
    )]
    Call {
        model: String,
        function: &'static str,
        time: f64,
        #[source]
        status: Status,
    },
    /// A call after an earlier one returned Fatal: both standards forbid any further call.
    #[error(
        "{model}: {function} refused: {fatal_in} returned {} earlier, after which {} allows no call",
        fatal_of(fatal_in).0,
        fatal_of(fatal_in).1
    )]
    AfterFatal { model: String, function: &'static str, fatal_in: &'static str },
    /// An argument the C side cannot take (a string with a NUL byte, a foreign FMU state).
    #[error("{model}: {function}: {message}")]
    InvalidArgument { model: String, function: &'static str, message: String },
    /// A call the FMU does not offer (`why`: what in its description says so).
    #[error("{model}: {function} is not available: {why}")]
    Unsupported { model: String, function: &'static str, why: String },
    /// `fmi3DoStep` returned OK but asked the master to stop: `terminateSimulation`,
    /// `earlyReturn` or `eventHandlingNeeded` set (`why` says which).
    #[error(
        "{model}: {function} from t = {time} s: {why} (last successful time {last_time} s); this master steps on a fixed grid and cannot continue"
    )]
    StepEnded {
        model: String,
        function: &'static str,
        time: f64,
        why: &'static str,
        last_time: f64,
    },
}

fn interface_name(i: crate::Interface) -> &'static str {
    match i {
        crate::Interface::CoSimulation => "Co-Simulation",
        crate::Interface::CoSimulationEventMode => "Co-Simulation with event mode",
        crate::Interface::ModelExchange => "Model Exchange",
        crate::Interface::ScheduledExecution => "Scheduled Execution",
    }
}

/// The Fatal status and the standard's name of the standard of `function`.
fn fatal_of(function: &str) -> (&'static str, &'static str) {
    if standard_of(function) == "fmi3" {
        ("fmi3Fatal", "FMI 3.0")
    } else {
        ("fmi2Fatal", "FMI 2.0")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statuses_and_fatal_refusals_are_spelled_in_the_standard_of_the_call() {
        assert_eq!(Status::Error.spelled("fmi3DoStep"), "fmi3Error");
        assert_eq!(Status::Ok.spelled("fmi3GetFMUState"), "fmi3OK");
        assert_eq!(Status::Discard.spelled("fmi2DoStep"), "fmi2Discard");
        assert_eq!(Status::from_fmi3(5), Status::Invalid(5), "FMI 3.0 has no Pending");
        let e = FmuError::Call {
            model: "M".into(),
            function: "fmi3GetFloat64",
            time: 0.5,
            status: Status::Discard,
        };
        assert_eq!(e.to_string(), "M: fmi3GetFloat64 returned fmi3Discard at t = 0.5 s (the FMU's log messages above say why)");
        let e = FmuError::AfterFatal {
            model: "M".into(),
            function: "fmi3SetFloat64",
            fatal_in: "fmi3DoStep",
        };
        assert_eq!(e.to_string(), "M: fmi3SetFloat64 refused: fmi3DoStep returned fmi3Fatal earlier, after which FMI 3.0 allows no call");
    }
}
