//! The closed loop three ways gives one trace: (a) the crates coupled directly and (b) the
//! two packaged FMUs loaded with the `fmi` crate and coupled by a 2 ms Jacobi loop give
//! bit-identical encoder traces (the FMPy loop (c) is in tests/python).

use std::path::Path;

use inchworm::closed_loop::{run, run_fmus};
use inchworm_controller::Params;
use inchworm_plant::PlantParams;

const DIST: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/dist");

#[test]
fn fig5_through_the_fmus_equals_the_direct_coupling_bit_for_bit() {
    let plant = Path::new(DIST).join("InchwormPlant.fmu");
    let ctrl = Path::new(DIST).join("InchwormController.fmu");
    assert!(
        plant.is_file() && ctrl.is_file(),
        "build the FMUs first: cargo run --release -p fmu-build"
    );
    for p in [
        Params::default(),
        Params {
            feedforward: false,
            use_scale_factor_estimate: false,
            use_disturbance_estimate: false,
            ..Params::default()
        },
    ] {
        let direct = run(PlantParams::fia20(), p.clone(), |_| 100e-6, 10.0).unwrap();
        let fmus = run_fmus(&plant, &ctrl, &[], &p, |_| 100e-6, 10.0).unwrap();
        assert_eq!(direct.encoder_counts.len(), fmus.encoder_counts.len());
        let first_diff =
            direct.encoder_counts.iter().zip(&fmus.encoder_counts).position(|(a, b)| a != b);
        assert_eq!(first_diff, None, "encoder traces differ first at sample {first_diff:?}");
        assert_eq!(direct.dac, fmus.dac);
        assert_eq!(direct.runner_position, fmus.runner_position);
        assert_eq!(direct.disturbance_estimate, fmus.disturbance_estimate);
        assert_eq!(direct.scale_weights, fmus.scale_weights);
        assert!(fmus.settle_time(1e-6).is_some());
    }
}
