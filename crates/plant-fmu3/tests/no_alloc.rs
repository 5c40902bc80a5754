//! The hot path allocates nothing with logging off: `Set*`, `Get*` and `DoStep` of the
//! plant and the controller FMU, through FMI 2.0 and FMI 3.0, counted per call on this
//! thread: the plant in a steady loop of gaits (brake switches and all), the controller
//! in a closed loop against a synthetic encoder that makes it move and iterate; outputs and
//! parameters of every type.

use inchworm_fmi_export::api::Fmi2;
use inchworm_fmi_export::fmi3::api::Fmi3;
use inchworm_fmi_export::testing::{Harness, Master};
use inchworm_fmu_models::{ControllerFmu, PlantFmu};

#[path = "../../../tests/support/counting_alloc.rs"]
mod counting_alloc;
use counting_alloc::allocations;

const PLANT_DAC: [u32; 3] = [1, 2, 3];
const OUTPUTS: [u32; 6] = [11, 12, 13, 14, 15, 16];
const PLANT_COUNTS: u32 = 10;
const PLANT_K_P: u32 = 101;
const H: f64 = 0.002;

/// Forward gaits, sample by sample: the allocations counted in each kind of call.
fn plant<S: Master>() -> [u64; 3] {
    let h = Harness::<PlantFmu, S>::init("alloc");
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
        assert_eq!(h.set_reals(&PLANT_DAC, &v), 0);
        let set = allocations();
        assert_eq!(h.step(k as f64 * H, H), 0);
        let step = allocations();
        for vr in OUTPUTS {
            assert_eq!(h.real(vr).0, 0);
        }
        assert_eq!(h.integer(PLANT_COUNTS).0, 0);
        // A parameter too: it is read through a copy of the parameter set.
        assert_eq!(h.real(PLANT_K_P), (0, 3.0e7));
        let get = allocations();
        if warm {
            counted[0] += set - before;
            counted[1] += step - set;
            counted[2] += get - step;
        }
    }
    assert_ne!(h.integer(PLANT_COUNTS).1, 0, "the runner moved");
    assert!(h.logged().is_empty());
    counted
}

const ENCODER_COUNTS: u32 = 1;
const REFERENCE: u32 = 2;
const DAC: [u32; 3] = [10, 11, 12];
const CODES: [u32; 3] = [13, 14, 15];
const N_STEPS: u32 = 20;
const PREFILTER: u32 = 101;
const DEADBAND: u32 = 104;
const SAMPLES_PER_STEP: u32 = 105;

/// A synthetic encoder moving 2 nm per powered extension sample: the allocations counted
/// in each kind of call.
fn controller<S: Master>() -> [u64; 3] {
    let h = Harness::<ControllerFmu, S>::init("alloc");
    let mut counted = [0u64; 3];
    let (mut counts, mut moves) = (0, 0);
    for k in 0..3000usize {
        let reference = if k < 1500 { 60e-6 } else { -20e-6 };
        let warm = k >= 200;
        let before = allocations();
        assert_eq!(h.set_real(REFERENCE, reference), 0);
        assert_eq!(h.set_integer(ENCODER_COUNTS, counts), 0);
        let set = allocations();
        assert_eq!(h.step(k as f64 * H, H), 0);
        let step = allocations();
        let mut dac = [0.0; 3];
        for (vr, v) in DAC.iter().zip(&mut dac) {
            let (status, value) = h.real(*vr);
            assert_eq!(status, 0);
            *v = value;
        }
        for vr in CODES {
            assert_eq!(h.integer(vr).0, 0);
        }
        // Parameters of each type, read through a copy of the parameters.
        assert_eq!(h.real(DEADBAND), (0, 0.0));
        assert_eq!(h.integer(SAMPLES_PER_STEP), (0, 100));
        assert_eq!(h.boolean(PREFILTER), (0, false));
        moves = moves.max(h.integer(N_STEPS).1);
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
