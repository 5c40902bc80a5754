//! FMI 3.0 Co-Simulation export over the same core as FMI 2.0 ([`crate::entry`]): the
//! same [`crate::Model`] trait, variable table, allowed-state masks, `catch_unwind`
//! policy, log categories and serialized-state frame (a blob saved by one version
//! restores in the other). [`crate::export_fmi3!`] exports every `fmi3*` function of the
//! standard for one model; the ones this FMU does not support log why and return
//! `fmi3Error`.
//!
//! Types: `Real` variables are `Float64`, `Integer` are `Int32`, `Boolean` are `Boolean`;
//! a run of scalars the table marks as an array (`play_radius[1]` … `[5]`) is one array
//! variable `play_radius` with a `<Dimension>` ([`crate::arrays`]), get and set as all its
//! values at once. The independent variable `time`
//! (value reference [`TIME_VR`]) that FMI 3.0 requires is the layer's.

pub mod api;
pub mod ffi;
pub mod model_description;
pub mod testing;

/// Value reference of the independent variable `time`; no model table may use it.
pub const TIME_VR: u32 = 0;
