//! FMI 3.0 FMUs behind the same `CsFmu`: loading, variables, stepping bit for bit like the
//! FMI 2.0 FMU, errors that name the `fmi3*` call, and FMU state.

mod common;

use common::dist;
use inchworm_fmi_import::{CsFmu, FmuError, VarType};
use inchworm_fmu_models::{ControllerFmu, Dac, PlantFmu, PlantParams};

fn load_pair() -> (CsFmu, CsFmu) {
    let f2 = CsFmu::load(&dist("InchwormPlant.fmu"), "plant2", false).unwrap();
    let f3 = CsFmu::load(&dist("fmi3/InchwormPlant.fmu"), "plant3", false).unwrap();
    (f2, f3)
}

#[test]
fn an_fmi3_fmu_loads_with_the_fmi2_variables() {
    let (f2, f3) = load_pair();
    assert_eq!(f3.fmi_version(), "3.0");
    assert_eq!(f3.binary_version(), "3.0");
    assert_eq!(f3.guid(), f2.guid(), "instantiationToken is the FMI 2.0 GUID");
    assert!(
        f3.library_path().starts_with(f3.unpacked_dir().join("binaries/x86_64-linux"))
            || !cfg!(target_arch = "x86_64")
    );
    // An FMI 3.0 array's element k is the FMI 2.0 scalar one value reference k after the
    // array's (the tables are one), addressed by the same name.
    let names = |f: &CsFmu| {
        let vr = |v: &inchworm_fmi_import::Variable| match v.element {
            Some(e) => e.array_vr + e.index,
            None => v.vr,
        };
        f.variables().map(|v| (v.name.clone(), vr(v), v.ty, v.causality)).collect::<Vec<_>>()
    };
    assert_eq!(names(&f3), names(&f2), "the independent time is left out, the rest matches");
    let arrays: Vec<_> =
        f3.variables().filter_map(|v| v.element).filter(|e| e.index == 0).collect();
    assert_eq!(
        arrays.iter().map(|e| (e.array_vr, e.len)).collect::<Vec<_>>(),
        [(113, 5), (118, 5)]
    );
    assert_eq!(f3.default_step_size(), Some(0.002));
    assert!(matches!(f3.var("time"), Err(FmuError::UnknownVariable { .. })));
    assert_eq!(f3.var_of(PlantFmu::ENCODER_COUNTS.name(), VarType::Integer).unwrap().vr, 10);
}

#[test]
fn the_fmi3_plant_steps_bit_for_bit_like_the_fmi2_plant() {
    let (mut f2, mut f3) = load_pair();
    for f in [&mut f2, &mut f3] {
        f.enter_initialization(None, 0.0, Some(1.0)).unwrap();
        let tem = f.var_of(PlantParams::T_EM.name(), VarType::Real).unwrap().vr;
        f.set_real(&[tem], &[2.5]).unwrap();
        f.exit_initialization().unwrap();
    }
    let dac = f3.vrs_of(&PlantFmu::DAC_INPUTS.map(|v| v.name()), VarType::Real).unwrap();
    let enc = f3.var_of(PlantFmu::ENCODER_COUNTS.name(), VarType::Integer).unwrap().vr;
    let closed = f3.var_of(PlantFmu::EARTH_CLOSED.name(), VarType::Boolean).unwrap().vr;
    for k in 0..400 {
        let phase = (k / 15) % 6;
        let volts = [
            [0.0, 0.0, 0.0],
            [0.0, 10.0, 0.0],
            [10.0, 10.0, 0.0],
            [10.0, 10.0, 10.0],
            [0.0, 10.0, 10.0],
            [0.0, 0.0, 10.0],
        ][phase];
        let mut seen = Vec::new();
        for f in [&mut f2, &mut f3] {
            f.set_real(&dac, &volts).unwrap();
            f.do_step(0.002).unwrap();
            let (mut c, mut b, mut x) = ([0], [false], [0.0]);
            f.get_integer(&[enc], &mut c).unwrap();
            f.get_boolean(&[closed], &mut b).unwrap();
            f.get_real(&[12], &mut x).unwrap();
            seen.push((c[0], b[0], x[0].to_bits()));
        }
        assert_eq!(seen[0], seen[1], "sample {k}");
    }
    assert!(f3.real(PlantFmu::RUNNER_POSITION.name()).unwrap() != 0.0, "the gait moved the runner");
    f3.terminate().unwrap();
}

#[test]
fn a_refused_fmi3_call_is_an_error_naming_the_call() {
    let (_, mut f3) = load_pair();
    f3.enter_initialization(None, 0.0, None).unwrap();
    f3.exit_initialization().unwrap();
    let dac = f3.var_of(PlantFmu::var(Dac::EARTH).name(), VarType::Real).unwrap().vr;
    let e = f3.set_real(&[dac], &[f64::NAN]).unwrap_err();
    assert!(matches!(e, FmuError::Call { function: "fmi3SetFloat64", .. }), "{e}");
    assert!(e.to_string().contains("fmi3SetFloat64 returned fmi3Error at t = 0 s"), "{e}");
    f3.set_real(&[dac], &[12.0]).expect("a clamped value is a warning, the call succeeds");
    f3.do_step(0.002).unwrap();
    assert_eq!(f3.time(), 0.002);
    f3.reset().unwrap();
    f3.enter_initialization(None, 0.0, None).unwrap();
    f3.exit_initialization().unwrap();
    f3.do_step(0.002).unwrap();
}

#[test]
fn both_fmi3_fmus_of_the_system_load() {
    let c = CsFmu::load(&dist("fmi3/InchwormController.fmu"), "controller3", false).unwrap();
    assert_eq!(c.fmi_version(), "3.0");
    assert_eq!(c.causality(ControllerFmu::ENCODER_COUNTS.name()).as_deref(), Some("input"));
}

#[test]
fn array_elements_are_got_and_set_by_their_fmi2_names() {
    let (mut f2, mut f3) = load_pair();
    let (radius, weight) =
        (PlantFmu::var(PlantParams::PLAY_RADIUS), PlantFmu::var(PlantParams::PLAY_WEIGHT));
    let names =
        [radius.element(1), PlantFmu::var(PlantParams::C), weight.element(4), radius.element(3)]
            .map(|v| v.name());
    for f in [&mut f2, &mut f3] {
        f.enter_initialization(None, 0.0, Some(1.0)).unwrap();
        let vrs = f.vrs_of(&names, VarType::Real).unwrap();
        let mut v = [0.0; 4];
        f.get_real(&vrs, &mut v).unwrap();
        assert_eq!(v, [30.0, 4e-6, 0.04, 60.0]);
        f.set_real(&vrs, &[31.0, 5e-6, 0.045, 61.0]).unwrap();
        f.get_real(&vrs, &mut v).unwrap();
        assert_eq!(v, [31.0, 5e-6, 0.045, 61.0]);
        let all: Vec<u32> = (0..5).map(|k| f.var(radius.element(k).name()).unwrap().vr).collect();
        let mut radii = [0.0; 5];
        f.get_real(&all, &mut radii).unwrap();
        assert_eq!(radii, [15.0, 31.0, 45.0, 61.0, 75.0], "only the elements named changed");
        f.exit_initialization().unwrap();
    }
    // A NaN element is refused by the FMU, naming the element.
    let vr = f3.var(weight.element(1).name()).unwrap().vr;
    let e = f3.set_real(&[vr], &[f64::NAN]).unwrap_err().to_string();
    assert!(e.contains("fmi3SetFloat64"), "{e}");
}
