//! The per-sample path does not allocate (board firmware has no heap to spare): count the
//! allocations this thread makes inside `tick` over many steps and moves.

use inchworm_controller::{Controller, Params};

#[path = "../../../tests/support/counting_alloc.rs"]
mod counting_alloc;
use counting_alloc::allocations;

#[test]
fn tick_does_not_allocate() {
    for p in [
        Params::default(),
        Params {
            prefilter: true,
            feedforward: false,
            deadband: 1e-6,
            samples_per_step: 10,
            ..Params::default()
        },
        // Analog mode: entries, holds, re-centrings and exits.
        Params { analog: true, samples_per_step: 10, ..Params::default() },
        Params { disturbance_map: true, use_disturbance_map: true, ..Params::default() },
    ] {
        let before_new = allocations();
        let mut c = Controller::new(p).unwrap();
        let start = allocations();
        assert!(start > before_new, "the counter sees the buffers `new` sizes for a step");
        let mut counts = 0i64;
        for j in 0..20_000i64 {
            // Multi-step moves, fractions, idle steps and reversals.
            let reference = [0.0, 250e-6, 253e-6, -40e-6][(j / 5_000) as usize];
            let s = c.tick(counts, reference);
            counts += (s.dac[2] * 3.0) as i64 - 7;
        }
        let n = allocations() - start;
        assert_eq!(n, 0, "allocations in 20 000 ticks: {n}");
    }
}
