//! A master in miniature for tests: drives one instance of any [`Model`] through the
//! generic entry points of either standard ([`crate::api`], [`crate::fmi3::api`]: the code
//! every exported symbol calls) and records what the instance logs. One harness,
//! [`Harness<M, S>`], for both: a test written once over `S: Master` runs for each.
//!
//! `harness` holds the instance, `master` each standard's C functions behind one trait
//! and the refusal check over every entry point, `log` the logger that captures messages;
//! the serialized-state helpers are here.
// The FMU-state handles passed back in are the ones this harness got from the layer.
// The `Master` functions are the C functions themselves, unsafe on the same terms: an
// instance pointer from `instantiate`, and pointers valid for the counts given.
#![allow(clippy::not_unsafe_ptr_arg_deref, clippy::missing_safety_doc)]

mod harness;
mod log;
mod master;

use std::ffi::c_void;

use crate::model_description::guid;
use crate::{state_blob, Model};
pub use harness::Harness;
pub use log::{callbacks, categories_of, Log};
pub use master::{assert_every_entry_point_refuses, IntoStatus, Master};

/// An instance pointer as the C functions take it.
type C = *mut c_void;

/// The model's payload inside a serialized FMU state of `M`.
pub fn payload_of<M: Model>(blob: &[u8]) -> Vec<u8> {
    let (build, _, payload) = state_blob::decode(blob).expect("a blob of M");
    assert_eq!(build.guid, guid::<M>(), "a blob of M");
    payload.to_vec()
}

/// `blob` with its payload replaced and its CRC made right again, to test how a model
/// payload that passes the frame's checks is read.
pub fn with_payload<M: Model>(blob: &[u8], payload: &[u8]) -> Vec<u8> {
    let (build, header, _) = state_blob::decode(blob).expect("a blob of M");
    assert_eq!(build.guid, guid::<M>(), "a blob of M");
    state_blob::encode(&build, &header, payload)
}
