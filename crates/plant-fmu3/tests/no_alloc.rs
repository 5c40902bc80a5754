//! The hot path allocates nothing with logging off: `Set*`, `Get*` and `DoStep` of the
//! plant and the controller FMU, through FMI 2.0 and FMI 3.0, counted per call on this
//! thread: the plant in a steady loop of gaits (brake switches and all), the controller
//! in a closed loop against a synthetic encoder that makes it move and iterate; outputs and
//! parameters of every type.

use inchworm_fmi_export::api::Fmi2;
use inchworm_fmi_export::fmi3::api::Fmi3;
use inchworm_fmi_export::testing::{Harness, Master};
use inchworm_fmi_export::Var;
use inchworm_fmu_models::{ControllerFmu, ControllerParams, PlantFmu};

#[path = "../../../tests/support/counting_alloc.rs"]
mod counting_alloc;
use counting_alloc::allocations;

const H: f64 = 0.002;

/// Forward gaits, sample by sample: the allocations counted in each kind of call.
fn plant<S: Master>() -> [u64; 3] {
    let h = Harness::<PlantFmu, S>::init("alloc");
    let (dac, outputs) = (PlantFmu::DAC_INPUTS.map(Var::vr), PlantFmu::REAL_OUTPUTS.map(Var::vr));
    let (counts, k_p) =
        (PlantFmu::ENCODER_COUNTS.vr(), PlantFmu::var(inchworm_fmu_models::PlantParams::K_P).vr());
    let mut counted = [0u64; 3];
    for k in 0..2000usize {
        let v = match k % 100 {
            0..=14 => [0.0, 0.0, 0.0],
            15..=29 => [0.0, 10.0, 0.0],
            30..=43 => [10.0, 10.0, 0.0],
            44..=58 => [10.0, 10.0, 10.0],
            59..=71 => [0.0, 10.0, 10.0],
            72..=86 => [0.0, 0.0, 10.0],
            _ => [0.0, 0.0, 0.0],
        };
        let warm = k >= 200;
        let before = allocations();
        assert_eq!(h.set_reals(&dac, &v), 0);
        let set = allocations();
        assert_eq!(h.step(k as f64 * H, H), 0);
        let step = allocations();
        for vr in outputs {
            assert_eq!(h.real(vr).0, 0);
        }
        assert_eq!(h.integer(counts).0, 0);
        // A parameter too: it is read through a copy of the parameter set.
        assert_eq!(h.real(k_p), (0, 3.0e7));
        let get = allocations();
        if warm {
            counted[0] += set - before;
            counted[1] += step - set;
            counted[2] += get - step;
        }
    }
    assert_ne!(h.integer(counts).1, 0, "the runner moved");
    assert!(h.logged().is_empty());
    counted
}

const DAC: [Var<ControllerFmu>; 3] = ControllerFmu::DAC_OUTPUTS;
const CODES: [Var<ControllerFmu>; 3] = ControllerFmu::DAC_CODES;

/// A synthetic encoder moving 2 nm per powered extension sample: the allocations counted
/// in each kind of call.
fn controller<S: Master>() -> [u64; 3] {
    let h = Harness::<ControllerFmu, S>::init("alloc");
    let (encoder_counts, reference_vr) =
        (ControllerFmu::ENCODER_COUNTS.vr(), ControllerFmu::REFERENCE.vr());
    let (dac_vrs, codes) = (DAC.map(Var::vr), CODES.map(Var::vr));
    let (n_steps, prefilter) =
        (ControllerFmu::N_STEPS.vr(), ControllerFmu::var(ControllerParams::PREFILTER).vr());
    let (deadband, samples_per_step) = (
        ControllerFmu::var(ControllerParams::DEADBAND).vr(),
        ControllerFmu::var(ControllerParams::SAMPLES_PER_STEP).vr(),
    );
    let mut counted = [0u64; 3];
    let (mut counts, mut moves) = (0, 0);
    for k in 0..3000usize {
        let reference = if k < 1500 { 60e-6 } else { -20e-6 };
        let warm = k >= 200;
        let before = allocations();
        assert_eq!(h.set_real(reference_vr, reference), 0);
        assert_eq!(h.set_integer(encoder_counts, counts), 0);
        let set = allocations();
        assert_eq!(h.step(k as f64 * H, H), 0);
        let step = allocations();
        let mut dac = [0.0; 3];
        for (vr, v) in dac_vrs.iter().zip(&mut dac) {
            let (status, value) = h.real(*vr);
            assert_eq!(status, 0);
            *v = value;
        }
        for vr in codes {
            assert_eq!(h.integer(vr).0, 0);
        }
        // Parameters of each type, read through a copy of the parameters.
        assert_eq!(h.real(deadband), (0, 0.0));
        assert_eq!(h.integer(samples_per_step), (0, 100));
        assert_eq!(h.boolean(prefilter), (0, false));
        moves = moves.max(h.integer(n_steps).1);
        let get = allocations();
        counts += if dac[2] > 5.0 { 2 } else { -1 } * i32::from(dac[1] > 5.0);
        if warm {
            counted[0] += set - before;
            counted[1] += step - set;
            counted[2] += get - step;
        }
    }
    assert!(moves > 0, "the controller moved");
    assert!(h.logged().is_empty());
    counted
}

#[test]
fn plant_set_step_and_get_allocate_nothing_through_fmi2() {
    assert_eq!(plant::<Fmi2>(), [0, 0, 0], "allocations in Set, DoStep, Get over 1800 samples");
}

#[test]
fn plant_set_step_and_get_allocate_nothing_through_fmi3() {
    assert_eq!(plant::<Fmi3>(), [0, 0, 0], "allocations in Set, DoStep, Get over 1800 samples");
}

#[test]
fn controller_set_step_and_get_allocate_nothing_through_fmi2() {
    assert_eq!(
        controller::<Fmi2>(),
        [0, 0, 0],
        "allocations in Set, DoStep, Get over 2800 samples"
    );
}

#[test]
fn controller_set_step_and_get_allocate_nothing_through_fmi3() {
    assert_eq!(
        controller::<Fmi3>(),
        [0, 0, 0],
        "allocations in Set, DoStep, Get over 2800 samples"
    );
}
