//! A freed instance handed back to every entry point: refused, never read. Alone in its
//! test binary, so that no other test's instance can be allocated at the freed address
//! while it runs (the registry would rightly take that one for live).

// The toy's per-standard test macro and its CS-only variant serve the other files.
#[allow(unused_macros, dead_code)]
#[macro_use]
mod toy;

use inchworm_fmi_export::api::Fmi2;
use inchworm_fmi_export::fmi3::api::Fmi3;
use inchworm_fmi_export::registry::live_count;
use inchworm_fmi_export::testing::{assert_every_entry_point_refuses as refuses, Harness, Master};
use toy::*;

fn freed<S: Master>(all: usize) {
    let h = Harness::<Toy, S>::init("freed");
    let c = h.c;
    assert_eq!(live_count(), 1);
    drop(h);
    assert_eq!(live_count(), 0);
    // SAFETY: the layer reads nothing through a pointer it does not know as live.
    assert_eq!(unsafe { refuses::<S, Toy>(c, "a freed instance") }, all);
    unsafe { S::free::<Toy>(c) };
    assert_eq!(live_count(), 0, "a second free is a no-op");
}

#[test]
fn a_freed_instance_is_refused_by_every_entry_point_and_a_second_free_is_a_no_op() {
    freed::<Fmi2>(41);
    freed::<Fmi3>(71);
}
