//! FMI 3.0 arrays: the hysteresis elements' radii and weights are `Float64` arrays with a
//! `<Dimension>` (the FMI 2.0 FMU keeps the scalars `play_radius[1]` …), got and set whole
//! in the standard's serialization order, with the same per-value checks as a scalar; the
//! value references of elements 2 … n are not the FMI 3.0 FMU's. The controller's arrays
//! are declared by the same rules (crate::arrays of the export layer), checked here too.

use inchworm_fmi_export::arrays::{array_name, fmi3_entries};
use inchworm_fmi_export::fmi3::api::{fmi3GetFloat64, fmi3SetFloat64, Fmi3};
use inchworm_fmi_export::testing::Harness;
use inchworm_fmi_export::Model;
use inchworm_fmu_models::{ControllerFmu, PlantFmu};

const ERROR: i32 = 3;

fn radii_and_weights(h: &Harness<PlantFmu, Fmi3>, n: usize) -> (i32, Vec<f64>) {
    let mut v = vec![f64::NAN; n];
    let vrs = [
        PlantFmu::var(inchworm_fmu_models::PlantParams::PLAY_RADIUS).vr(),
        PlantFmu::var(inchworm_fmu_models::PlantParams::PLAY_WEIGHT).vr(),
    ];
    let s = unsafe { fmi3GetFloat64::<PlantFmu>(h.c, vrs.as_ptr(), 2, v.as_mut_ptr(), n) };
    (s, v)
}

#[test]
fn the_radii_and_weights_are_arrays_got_and_set_whole() {
    let play_radius = PlantFmu::var(inchworm_fmu_models::PlantParams::PLAY_RADIUS).vr();
    let h = Harness::<PlantFmu, Fmi3>::new("arrays");
    assert_eq!(h.enter(), 0);
    assert_eq!(
        radii_and_weights(&h, 10),
        (0, vec![15.0, 30.0, 45.0, 60.0, 75.0, 0.08, 0.07, 0.06, 0.05, 0.04])
    );
    let radii = [16.0, 31.0, 46.0, 61.0, 76.0];
    assert_eq!(unsafe { fmi3SetFloat64::<PlantFmu>(h.c, &play_radius, 1, radii.as_ptr(), 5) }, 0);
    assert_eq!(radii_and_weights(&h, 10).1[..5], radii);

    // One value for an array of five, or an element's own value reference: refused,
    // nothing changed.
    let one = [1.0];
    assert_eq!(unsafe { fmi3SetFloat64::<PlantFmu>(h.c, &play_radius, 1, one.as_ptr(), 1) }, ERROR);
    assert!(h.saw(ERROR, &["nValues 1 differs from the 5 values of the 1 value references"]));
    assert_eq!(radii_and_weights(&h, 9).0, ERROR);
    let element = PlantFmu::var(inchworm_fmu_models::PlantParams::PLAY_RADIUS).element(1).vr();
    assert_eq!(unsafe { fmi3SetFloat64::<PlantFmu>(h.c, &element, 1, one.as_ptr(), 1) }, ERROR);
    assert!(h.saw(ERROR, &[&format!("unknown value reference {element}")]));
    assert_eq!(radii_and_weights(&h, 10).1[..5], radii);

    // A NaN element is refused alone, by its element's name; the others are set.
    let with_nan = [17.0, f64::NAN, 47.0, 62.0, 77.0];
    let s = unsafe { fmi3SetFloat64::<PlantFmu>(h.c, &play_radius, 1, with_nan.as_ptr(), 5) };
    assert_eq!(s, ERROR);
    assert!(h.saw(ERROR, &["play_radius[2] = NaN refused", "keeping 31 V"]), "{:?}", h.logged());
    assert_eq!(radii_and_weights(&h, 10).1[..5], [17.0, 31.0, 47.0, 62.0, 77.0]);
    assert_eq!(h.exit(), 0, "{:?}", h.logged());
}

#[test]
fn an_array_set_through_fmi3_is_the_scalars_set_through_fmi2() {
    let two = Harness::<PlantFmu>::new("fmi2");
    let three = Harness::<PlantFmu, Fmi3>::new("fmi3");
    assert_eq!((two.enter(), three.enter()), (0, 0));
    let weights = [0.09, 0.08, 0.07, 0.06, 0.05];
    for (k, w) in weights.iter().enumerate() {
        assert_eq!(
            two.set_real(
                PlantFmu::var(inchworm_fmu_models::PlantParams::PLAY_WEIGHT).element(k).vr(),
                *w
            ),
            0
        );
    }
    let play_weight = PlantFmu::var(inchworm_fmu_models::PlantParams::PLAY_WEIGHT).vr();
    assert_eq!(
        unsafe { fmi3SetFloat64::<PlantFmu>(three.c, &play_weight, 1, weights.as_ptr(), 5) },
        0
    );
    let (dac, runner) =
        (PlantFmu::var(inchworm_fmu_models::Dac::EXTENSION).vr(), PlantFmu::RUNNER_POSITION.vr());
    assert_eq!((two.exit(), three.exit()), (0, 0));
    for k in 0..200 {
        let t = k as f64 * 0.002;
        let v = if k % 40 < 20 { 10.0 } else { 0.0 };
        assert_eq!((two.set_real(dac, v), three.set_real(dac, v)), (0, 0));
        assert_eq!((two.step(t, 0.002), three.step(t, 0.002)), (0, 0));
        assert_eq!(
            two.real(runner).1.to_bits(),
            three.real(runner).1.to_bits(),
            "runner at step {k}"
        );
    }
}

#[test]
fn the_tables_declare_their_arrays() {
    fn names<M: Model>() -> Vec<(&'static str, usize)> {
        let vars = M::table();
        let entries = fmi3_entries(vars).unwrap();
        entries
            .iter()
            .filter(|e| e.is_array(vars))
            .map(|e| (array_name(&vars[e.first].var), e.len))
            .collect()
    }
    assert_eq!(names::<PlantFmu>(), [("play_radius", 5), ("play_weight", 5)]);
    assert_eq!(
        names::<ControllerFmu>(),
        [("scale_weights", 10), ("basis_peak", 10), ("scale_weights_start", 10)]
    );
}
