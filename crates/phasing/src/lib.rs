//! A segmented primary's co-phasing geometry and its reconstruction (docs/phasing.md):
//! the hexagonal mirror's segments and shared edges ([`geometry`]), the edge sensors two
//! per shared edge near its ends and the interaction matrix from segment piston, tip and
//! tilt to their readings ([`sensors`]), and the reconstructor: the interaction matrix's
//! singular modes, those the sensors cannot see (the whole mirror's piston, tip and tilt)
//! and those they barely see excluded by a threshold, the pseudo-inverse over the rest,
//! and its noise multiplier ([`reconstructor`]).
//!
//! Plain Rust, no I/O: the FMUs, the systems and the scenarios are built on it.
//!
//! A segment's pose is the `InchwormMount`'s: its surface is
//! `z = piston + tip (y − y_k) + tilt (x − x_k)` about its centre `(x_k, y_k)`.

pub mod cophasing;
pub mod disturbances;
pub mod geometry;
pub mod reconstructor;
pub mod sensors;

pub use geometry::{Edge, Mirror};
pub use reconstructor::{Mode, Reconstructor, DEFAULT_THRESHOLD};
pub use sensors::{EdgeSensors, Interaction, Sensor};

/// A mirror, sensor layout or reconstructor that cannot be built, with what is wrong.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PhasingError {
    #[error("{name} = {value} {unit}: {why}")]
    Parameter { name: &'static str, value: f64, unit: &'static str, why: String },
    #[error("{0}")]
    Geometry(String),
    #[error("{0}")]
    Threshold(String),
    #[error("{0}")]
    Loop(String),
}

/// A finite value within `[lo, hi]`, or the error naming it.
pub(crate) fn check(
    name: &'static str,
    value: f64,
    lo: f64,
    hi: f64,
    unit: &'static str,
) -> Result<f64, PhasingError> {
    if value.is_finite() && (lo..=hi).contains(&value) {
        Ok(value)
    } else {
        Err(PhasingError::Parameter {
            name,
            value,
            unit,
            why: format!("must be finite, {lo} to {hi} {unit}"),
        })
    }
}
