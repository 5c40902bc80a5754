//! The master's steady loop allocates nothing: `Simulation::step` and
//! `Simulation::sample_row` through both FMUs of the closed loop, both couplings, FMI 2.0
//! and FMI 3.0 systems, counted on this thread. The count covers the master and the
//! import layer (this binary's allocator); the FMUs' own code runs on their own allocator,
//! and crates/plant-fmu3/tests/no_alloc.rs counts it.

use inchworm_cosim::master::{Coupling, InputTable, Options, System};
use inchworm_fmu_models::{ControllerFmu, PlantFmu};

#[path = "support/counting_alloc.rs"]
mod counting_alloc;
use counting_alloc::allocations;

use inchworm_dist::path as dist;

/// Allocations in `steps` steps and rows after 500 steps of warm-up, and whether the
/// runner moved over them (so the gaits, brake switches and estimator ran).
fn steady_loop(ssp: &str, coupling: Coupling, steps: usize) -> (u64, bool) {
    let opts = Options {
        stop_time: Some(20.0),
        step_size: Some(0.002),
        coupling,
        params: vec![],
        parameter_set: None,
        // A move, then back: both gait directions inside the counted steps.
        input: Some(
            InputTable::steps(ControllerFmu::REFERENCE.name(), &[(0.0, 60e-6), (1.5, -20e-6)])
                .unwrap(),
        ),
        // An Integer that feeds the controller, a Real and a Boolean read for the rows
        // alone: every kind of read the master makes.
        outputs: [PlantFmu::ENCODER_COUNTS, PlantFmu::RUNNER_POSITION, PlantFmu::EARTH_CLOSED]
            .map(|v| format!("plant.{}", v.name()))
            .to_vec(),
    };
    let mut sim = System::load(&dist(ssp)).unwrap().initialise(&opts).unwrap();
    for _ in 0..500 {
        sim.step().unwrap();
        sim.sample_row().unwrap();
    }
    let first = sim.sample_row().unwrap()[0];
    let before = allocations();
    let mut last = first;
    for _ in 0..steps {
        sim.step().unwrap();
        last = sim.sample_row().unwrap()[0];
    }
    let n = allocations() - before;
    (n, last != first)
}

#[test]
fn the_steady_loop_allocates_nothing() {
    for ssp in ["InchwormSystemOpen.ssp", "fmi3/InchwormSystemOpen.ssp"] {
        for coupling in [Coupling::Jacobi, Coupling::GaussSeidel] {
            let (n, moved) = steady_loop(ssp, coupling, 2000);
            assert!(moved, "{ssp}, {coupling:?}: the runner moved over the counted steps");
            assert_eq!(n, 0, "{ssp}, {coupling:?}: allocations in 2000 steps and rows");
        }
    }
}

/// The counter sees what the loop would allocate: `sample` copies its row.
#[test]
fn the_counter_sees_a_sampled_row() {
    let opts = Options {
        stop_time: Some(1.0),
        step_size: Some(0.002),
        coupling: Coupling::Jacobi,
        params: vec![],
        parameter_set: None,
        input: Some(InputTable::steps(ControllerFmu::REFERENCE.name(), &[(0.0, 60e-6)]).unwrap()),
        outputs: vec![format!("plant.{}", PlantFmu::ENCODER_COUNTS.name())],
    };
    let mut sim = System::load(&dist("InchwormSystemOpen.ssp")).unwrap().initialise(&opts).unwrap();
    sim.step().unwrap();
    let before = allocations();
    let row = sim.sample().unwrap();
    assert_eq!(allocations() - before, 1, "one Vec for the row {row:?}");
}
