//! The clients' one error type: what failed, in which client, and why. It reaches the
//! framework through `TryUpdate`, `TryRead` and `TryWrite`, so a failing client ends the
//! actor model's run with this message (`Model::wait` returns it) instead of a panic.

use std::fmt;

use inchworm_fmi_import::FmuError;

#[derive(Debug)]
pub enum Error {
    /// A native model refused a value, a parameter or a step (its message).
    Model { client: String, message: String },
    /// A name the client's variable table or FMU does not have.
    UnknownVariable { client: String, name: String, known: String },
    /// The FMU import layer's error (missing file, no Co-Simulation, a refused call...).
    Fmu { client: String, source: FmuError },
    /// The client was used against its contract (a UID it was not given a variable for, a
    /// value of the wrong type, a parameter after the start).
    Usage { client: String, message: String },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Model { client, message } => write!(f, "{client}: {message}"),
            Error::UnknownVariable { client, name, known } => {
                write!(f, "{client}: no variable `{name}` (it has: {known})")
            }
            Error::Fmu { client, source } => write!(f, "{client}: {source}"),
            Error::Usage { client, message } => write!(f, "{client}: {message}"),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Fmu { source, .. } => Some(source),
            _ => None,
        }
    }
}
