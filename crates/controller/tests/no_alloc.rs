//! The per-sample path does not allocate (board firmware has no heap to spare): count the
//! allocations this thread makes inside `tick` over many steps and moves.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use inchworm_controller::{Controller, Params};

struct Counting;

thread_local! {
    // Per thread, so the test harness's own threads do not count.
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|a| a.set(a.get() + 1));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.with(|a| a.set(a.get() + 1));
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

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
        let before_new = ALLOCATIONS.with(Cell::get);
        let mut c = Controller::new(p).unwrap();
        let start = ALLOCATIONS.with(Cell::get);
        assert!(start > before_new, "the counter sees the buffers `new` sizes for a step");
        let mut counts = 0i64;
        for j in 0..20_000i64 {
            // Multi-step moves, fractions, idle steps and reversals.
            let reference = [0.0, 250e-6, 253e-6, -40e-6][(j / 5_000) as usize];
            let s = c.tick(counts, reference);
            counts += (s.dac[2] * 3.0) as i64 - 7;
        }
        let n = ALLOCATIONS.with(Cell::get) - start;
        assert_eq!(n, 0, "allocations in 20 000 ticks: {n}");
    }
}
