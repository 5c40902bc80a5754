//! FMI 3.0 arrays through the master: the systems with FMI 3.0 FMUs (the mixed closed loop,
//! whose plant is FMI 3.0; the open loop of FMI 3.0 controller and plant) take the same
//! parameter bindings (`play_radius[3]` of an SSV, `--param controller.basis_peak[10]=…`)
//! and traces the same elements (`controller.scale_weights[3]`) by the names the FMI 2.0
//! FMUs' scalars have, and gives the FMI 2.0 system's trace bit for bit.

use inchworm_cosim::master::{run, Coupling, InputTable, Options};
use inchworm_cosim::trace::Trace;
use inchworm_fmu_models::{ControllerFmu, ControllerParams, PlantFmu, PlantParams};

use inchworm_dist::path as dist;

/// What the runs trace: the plant's encoder and the controller's weights 3 and 10.
fn traced() -> [String; 3] {
    [
        format!("plant.{}", PlantFmu::ENCODER_COUNTS.name()),
        format!("controller.{}", ControllerFmu::SCALE_WEIGHTS[2].name()),
        format!("controller.{}", ControllerFmu::SCALE_WEIGHTS[9].name()),
    ]
}

/// The closed loop's options, or the open loop's with the Fig. 5 step as its input.
fn options(params: &[(String, &str)], open: bool) -> Options {
    Options {
        stop_time: Some(3.0),
        step_size: Some(0.002),
        coupling: Coupling::Jacobi,
        params: params.iter().map(|(n, v)| (n.clone(), v.to_string())).collect(),
        parameter_set: Some("fia6".into()),
        input: open.then(|| InputTable::parse("time,reference\n0,1e-4\n").unwrap()),
        outputs: traced().to_vec(),
    }
}

fn columns(t: &Trace) -> Vec<Vec<u64>> {
    traced().iter().map(|c| t.column(c).unwrap().iter().map(|x| x.to_bits()).collect()).collect()
}

#[test]
fn array_elements_are_bound_set_and_traced_by_name_in_both_standards() {
    let radius = PlantFmu::var(PlantParams::PLAY_RADIUS);
    let weight = PlantFmu::var(PlantParams::PLAY_WEIGHT);
    let peak = ControllerFmu::var(ControllerParams::BASIS_PEAKS);
    let start = ControllerFmu::var(ControllerParams::SCALE_WEIGHTS_START);
    let changed = [
        (format!("plant.{}", radius.element(2).name()), "44"),
        (format!("plant.{}", weight.element(4).name()), "0.041"),
        (format!("controller.{}", peak.element(9).name()), "2.5e-5"),
        (format!("controller.{}", start.element(2).name()), "0.9"),
    ];
    for (fmi2, fmi3, open) in [
        ("InchwormSystem.ssp", "fmi3/InchwormSystemMixed.ssp", false),
        ("InchwormSystemOpen.ssp", "fmi3/InchwormSystemOpen.ssp", true),
    ] {
        let two = run(&dist(fmi2), &options(&changed, open), |_| {}).unwrap();
        let three = run(&dist(fmi3), &options(&changed, open), |_| {}).unwrap();
        assert_eq!(columns(&two), columns(&three), "{fmi3}: FMI 3.0 arrays = FMI 2.0 scalars");
        let w3 = three.column(&traced()[1]).unwrap()[0];
        assert_eq!(w3, 0.9, "{fmi3}: the start weight set");
        let unchanged = run(&dist(fmi3), &options(&[], open), |_| {}).unwrap();
        assert_ne!(columns(&unchanged)[0], columns(&three)[0], "{fmi3}: the elements set count");
    }
}
