//! Errors: [`ImportError`] for everything between the file and a live instance,
//! [`FmuError`] for the calls after that, and [`Status`], the FMI 2.0 status of a call.

use std::fmt;
use std::path::PathBuf;

use crate::VarType;

/// What went wrong unpacking the archive, reading `modelDescription.xml` or loading the binary.
#[derive(Debug)]
pub enum ImportError {
    /// Reading the file or writing the unpacked copy failed.
    Io { what: String, source: std::io::Error },
    /// The file is not a zip archive (or a damaged one).
    NotZip(zip::result::ZipError),
    /// An archive entry would land outside the unpack directory (`..`, an absolute path).
    UnsafePath(String),
    /// The archive has no `modelDescription.xml` at its root.
    NoModelDescription,
    /// The archive passes a cap of [`crate::archive::Limits`] (the text says which).
    Limit(String),
    /// `modelDescription.xml` is malformed XML, lacks an attribute or holds a bad value.
    Description { line: usize, column: usize, message: String },
    /// `fmiVersion` is neither 2.x nor 3.x.
    UnsupportedVersion(String),
    /// No `binaries/<platform>/<modelIdentifier>.<ext>` for this platform.
    NoBinary { platform: &'static str, expected: String, available: Vec<String> },
    /// `dlopen` (or `LoadLibrary`) refused the binary (`library`: its path inside the FMU).
    Load { library: PathBuf, message: String },
    /// The binary lacks a required function (`library`: its path inside the FMU).
    MissingSymbol { library: PathBuf, symbol: &'static str },
    /// `modelDescription.xml` declares a capability (`flag`) whose function the binary lacks.
    MissingCapability { library: PathBuf, symbol: &'static str, flag: &'static str },
    /// Another instance was asked of an FMU that declares
    /// `canBeInstantiatedOnlyOncePerProcess="true"` from the library already loaded.
    OncePerProcess { model: String },
    /// `fmi2GetTypesPlatform` is not "default".
    TypesPlatform(String),
    /// `function` (`fmi2GetVersion`, `fmi3GetVersion`) returned another version.
    BinaryVersion { function: &'static str, found: String, expected: &'static str },
    /// `function` (`fmi2Instantiate`, `fmi3InstantiateCoSimulation`) returned NULL.
    Instantiate { function: &'static str, instance: String },
    /// A string for the C side holds a NUL byte.
    Nul { what: &'static str },
}

impl fmt::Display for ImportError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ImportError::Io { what, source } => write!(f, "{what}: {source}"),
            ImportError::NotZip(e) => write!(f, "not an FMU: the file is not a zip archive ({e})"),
            ImportError::UnsafePath(p) => {
                write!(
                    f,
                    "the archive entry `{p}` points outside the archive (absolute or `..` path): refused"
                )
            }
            ImportError::NoModelDescription => write!(f, "the archive has no modelDescription.xml at its root"),
            ImportError::Limit(what) => write!(f, "{what}: refused"),
            ImportError::Description { line, column, message } => {
                write!(f, "modelDescription.xml line {line}, column {column}: {message}")
            }
            ImportError::UnsupportedVersion(v) => {
                write!(
                    f,
                    "modelDescription.xml has fmiVersion=\"{v}\": only FMI 2.0 and FMI 3.0 FMUs are supported"
                )
            }
            ImportError::NoBinary {
                platform,
                expected,
                available,
            } => {
                write!(f, "the FMU has no binary for {platform} (expected {expected}")?;
                if available.is_empty() {
                    write!(f, "; it carries no binaries at all: a source-only FMU?)")
                } else {
                    write!(f, "; it carries: {})", available.join(", "))
                }
            }
            ImportError::Load { library, message } => {
                write!(f, "cannot load the FMU's binary {}: {message}", library.display())
            }
            ImportError::MissingSymbol { library, symbol } => {
                write!(f, "the FMU's binary {} does not export {symbol}", library.display())
            }
            ImportError::MissingCapability { library, symbol, flag } => write!(
                f,
                "modelDescription.xml declares {flag}=\"true\" but the FMU's binary {} does not export {symbol}",
                library.display()
            ),
            ImportError::OncePerProcess { model } => write!(
                f,
                "{model} declares canBeInstantiatedOnlyOncePerProcess=\"true\": another instance needs a copy of its own, not the library already loaded"
            ),
            ImportError::TypesPlatform(p) => {
                write!(f, "fmi2GetTypesPlatform returned \"{p}\", expected \"default\"")
            }
            ImportError::BinaryVersion { function, found, expected } => {
                write!(f, "the binary's {function} returned \"{found}\", expected {expected}x")
            }
            ImportError::Instantiate { function, instance } => write!(
                f,
                "{function} returned NULL for instance `{instance}` (the FMU's log messages above say why)"
            ),
            ImportError::Nul { what } => write!(f, "{what} contains a NUL byte"),
        }
    }
}

impl std::error::Error for ImportError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ImportError::Io { source, .. } => Some(source),
            ImportError::NotZip(e) => Some(e),
            _ => None,
        }
    }
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
#[derive(Debug)]
pub enum FmuError {
    /// The FMU file is not there (the usual cause: it has not been built yet).
    Missing(PathBuf),
    /// The archive could not be unpacked, its `modelDescription.xml` parsed or its binary loaded.
    Import { path: PathBuf, source: ImportError },
    /// The FMU offers no Co-Simulation interface.
    NotCoSimulation { model: String },
    /// The FMU offers no Model Exchange interface.
    NotModelExchange { model: String },
    /// No variable of that name in `modelDescription.xml`.
    UnknownVariable { model: String, name: String },
    /// The variable exists but has another type than the call needs.
    WrongType { model: String, name: String, expected: VarType, found: VarType },
    /// A call returned Discard, Error, Fatal or (FMI 2.0) Pending.
    Call { model: String, function: &'static str, time: f64, status: Status },
    /// A call after an earlier one returned Fatal: both standards forbid any further call.
    AfterFatal { model: String, function: &'static str, fatal_in: &'static str },
    /// An argument the C side cannot take (a string with a NUL byte, a foreign FMU state).
    InvalidArgument { model: String, function: &'static str, message: String },
    /// A call the FMU does not offer (`why`: what in its description says so).
    Unsupported { model: String, function: &'static str, why: String },
    /// `fmi3DoStep` returned OK but asked the master to stop: `terminateSimulation`,
    /// `earlyReturn` or `eventHandlingNeeded` set (`why` says which).
    StepEnded {
        model: String,
        function: &'static str,
        time: f64,
        why: &'static str,
        last_time: f64,
    },
}

impl fmt::Display for FmuError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FmuError::Missing(p) => write!(f, "{}: no such FMU file", p.display()),
            FmuError::Import { path, source } => write!(f, "{}: cannot import the FMU: {source}", path.display()),
            FmuError::NotCoSimulation { model } => write!(
                f,
                "{model}: the FMU has no Co-Simulation interface (modelDescription.xml lacks <CoSimulation>)"
            ),
            FmuError::NotModelExchange { model } => write!(
                f,
                "{model}: the FMU has no Model Exchange interface (modelDescription.xml lacks <ModelExchange>)"
            ),
            FmuError::UnknownVariable { model, name } => {
                write!(f, "{model}: no variable named `{name}` in modelDescription.xml")
            }
            FmuError::WrongType {
                model,
                name,
                expected,
                found,
            } => {
                write!(f, "{model}: variable `{name}` is {found}, expected {expected}")
            }
            FmuError::Call {
                model,
                function,
                time,
                status,
            } => write!(
                f,
                "{model}: {function} returned {} at t = {time} s (the FMU's log messages above say why)",
                status.spelled(function)
            ),
            FmuError::AfterFatal {
                model,
                function,
                fatal_in,
            } => {
                let (fatal, standard) = if standard_of(fatal_in) == "fmi3" {
                    ("fmi3Fatal", "FMI 3.0")
                } else {
                    ("fmi2Fatal", "FMI 2.0")
                };
                write!(
                    f,
                    "{model}: {function} refused: {fatal_in} returned {fatal} earlier, after which {standard} allows no call"
                )
            }
            FmuError::Unsupported { model, function, why } => {
                write!(f, "{model}: {function} is not available: {why}")
            }
            FmuError::StepEnded { model, function, time, why, last_time } => write!(
                f,
                "{model}: {function} from t = {time} s: {why} (last successful time {last_time} s); this master steps on a fixed grid and cannot continue"
            ),
            FmuError::InvalidArgument {
                model,
                function,
                message,
            } => write!(f, "{model}: {function}: {message}"),
        }
    }
}

impl std::error::Error for FmuError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            FmuError::Import { source, .. } => Some(source),
            FmuError::Call { status, .. } => Some(status),
            _ => None,
        }
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
