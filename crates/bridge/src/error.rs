//! What stops the bridge itself (rather than ending a run with a fault): the model's own
//! error, the link's, the run log's, or a board that refused the session; each keeps what
//! caused it as its source.

use std::io;

use inchworm_hil_protocol::Fault;

use crate::describe_fault;

/// The error of a model behind the bridge ([`crate::Mechanism`], [`crate::Compensator`]):
/// the model's own, whatever its type (an FMU's call, a plain-Rust model's check).
pub type ModelError = Box<dyn std::error::Error + Send + Sync>;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The model failed.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// Sending or receiving on the link failed.
    #[error("link: {0}")]
    Link(#[source] io::Error),
    /// The run log could not be written.
    #[error("run log: {0}")]
    RunLog(#[source] io::Error),
    /// The board refused the session (its fault says why).
    #[error("the board refused the session: {}", describe_fault(.0))]
    Refused(Fault),
    /// The board answered BUSY (in a session with another controller) until the
    /// handshake's deadline, `seconds` after the first HELLO.
    #[error("the board refused the session for {seconds:.1} s: {}", describe_fault(.fault))]
    Busy { fault: Fault, seconds: f64 },
    /// No HELLO came back within `seconds`.
    #[error("no HELLO answer from the board within {seconds:.1} s")]
    NoAnswer { seconds: f64 },
    /// The board did not say armed within `seconds`.
    #[error("the board did not arm within {seconds:.1} s")]
    NotArmed { seconds: f64 },
}
