//! The unit tests of the Model Exchange master's own pieces (the integration itself is
//! tested through FMUs in `crates/cosim/tests/model_exchange.rs`).

use super::*;

#[test]
fn stats_read_as_one_line_naming_each_count() {
    let s = MeStats {
        steps: 413_624,
        derivatives: 599_342,
        jacobian_products: 153_986,
        state_events: 228,
        time_events: 0,
        step_events: 1,
    };
    assert_eq!(
        s.to_string(),
        "413624 integrator steps, 599342 derivative and 153986 Jacobian-product evaluations, 228 state, 0 time and 1 step events"
    );
}

/// A seed answered from the kept Jacobian is exactly a unit vector: diffsol's columns
/// `e_j`, and nothing near one.
#[test]
fn only_exact_unit_seeds_are_columns() {
    use super::eval::unit_seed;
    assert_eq!(unit_seed(&[0.0, 1.0, 0.0]), Some(1));
    assert_eq!(unit_seed(&[1.0]), Some(0));
    assert_eq!(unit_seed(&[0.0, 0.0, 0.0]), None);
    assert_eq!(unit_seed(&[1.0, 1.0, 0.0]), None);
    assert_eq!(unit_seed(&[0.0, 1.0 + f64::EPSILON, 0.0]), None);
    assert_eq!(unit_seed(&[1e-300, 1.0, 0.0]), None);
    assert_eq!(unit_seed(&[-0.0, 1.0, 0.0]), None);
    assert_eq!(unit_seed(&[0.0, -1.0, 0.0]), None);
}
