//! `Set*` calls of many references: every reference is checked before any value is
//! stored, however long the call, so a refused reference anywhere in
//! it refuses the call whole; run for FMI 2.0 and FMI 3.0.

// The toy's models and macros serve the other test files too.
#[allow(unused_macros, dead_code)]
#[macro_use]
mod toy;

use inchworm_fmi_export::api::Fmi2;
use inchworm_fmi_export::fmi3::api::Fmi3;
use inchworm_fmi_export::testing::{Harness, Master};
use toy::*;

type H<S> = Harness<Toy, S>;

const OK: i32 = 0;
const ERROR: i32 = 3;

for_both!(long_set_calls_check_every_reference_first, short_set_calls_check_every_reference_first);

/// `n` references to `u` followed by `last`, and the values 1, 2, … for them.
fn call(n: usize, last: &[u32]) -> (Vec<u32>, Vec<f64>) {
    let vrs: Vec<u32> = std::iter::repeat_n(U, n).chain(last.iter().copied()).collect();
    let values = (1..=vrs.len()).map(|k| k as f64 * 0.25).collect();
    (vrs, values)
}

/// Longer calls than the references a `Set*` keeps resolved between its check and its
/// writes: the second pass finds each reference again, and a bad one at the end has
/// stored nothing before it.
fn long_set_calls_check_every_reference_first<S: Master>() {
    calls_check_every_reference_first::<S>(40);
}

/// Calls whose references are all kept resolved between the check and the writes.
fn short_set_calls_check_every_reference_first<S: Master>() {
    calls_check_every_reference_first::<S>(2);
}

fn calls_check_every_reference_first<S: Master>(n: usize) {
    let h = H::<S>::init("set");
    assert_eq!(h.set_real(U, 9.0), OK);
    // Unknown, of another type, and (FMI 3.0) time, which is not settable.
    for bad in [999, STEPS + 1000, GAIN, 0] {
        let (vrs, values) = call(n, &[bad]);
        assert_eq!(h.set_reals(&vrs, &values), ERROR, "reference {bad}");
        assert_eq!(h.real(U), (OK, 9.0), "nothing stored before the refused reference {bad}");
    }
    let want = format!("{}: unknown value reference 999", S::SET_REAL);
    assert!(h.logged().iter().any(|l| l.contains(&want)), "{:?}", h.logged());
    let (vrs, values) = call(n, &[]);
    // All good: every value is written in order, the last one stays.
    assert_eq!(h.set_reals(&vrs, &values), OK);
    assert_eq!(h.real(U), (OK, values[n - 1]));
    // A refused value (not a reference) stands alone: the others are stored.
    let (mut vrs, mut values) = call(n, &[X]);
    vrs.push(U);
    values.push(3.5);
    assert_eq!(h.set_reals(&vrs, &values), ERROR, "x is an output");
    assert_eq!(h.real(U), (OK, 3.5));
}
