//! An interferometer's delay line on the inchworm (docs/delay-line.md): plain Rust, no FFI,
//! no I/O.
//!
//! * [`geometry`]: the sidereal optical path difference of a star between two telescopes
//!   and its rate;
//! * [`fringes`]: what a residual path leaves of the fringes: visibility and null depth;
//! * [`tracker`]: the fringe tracker, a sampled sensor of the residual path;
//! * [`fine_stage`]: the fine PZT stage in its loop on the tracker;
//! * [`optics`]: all of these stepped once a sample around the runner's position;
//! * [`system`]: the loop closed around the inchworm's plant and controller.

pub mod disturbance;
pub mod fine_stage;
pub mod fringes;
pub mod geometry;
pub mod optics;
mod random;
pub mod system;
pub mod tracker;

pub use random::Gaussian;
