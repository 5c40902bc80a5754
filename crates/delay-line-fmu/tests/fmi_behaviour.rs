//! The FMI boundary of InchwormDelayLine: driven with the runner positions of the
//! library's delay line, it shows that loop's samples to the bit; steps off the 2 ms
//! grid, bad parameters and a runner out of its stroke are refused by name; its state
//! round trips.

use inchworm_controller::Params;
use inchworm_delay_line::system::{self, DelayLineParams};
use inchworm_fmi_export::ffi::*;
use inchworm_fmi_export::testing::Harness;
use inchworm_fmu_models::DelayLineFmu as D;
use inchworm_plant::PlantParams;

type H = Harness<D>;
const T: f64 = 0.002;

/// Sets the runner position and takes step `k`.
fn step(h: &H, k: usize, runner: f64) {
    assert_eq!(h.set_real(D::RUNNER_POSITION.vr(), runner), fmi2OK);
    assert_eq!(h.step(k as f64 * T, T), fmi2OK, "{:?}", h.logged());
}

#[test]
fn it_shows_the_library_loop_s_samples_to_the_bit() {
    let p = DelayLineParams::default();
    let run = system::run(&p, PlantParams::fia20(), Params::default(), 3.0).unwrap();
    let h = H::init("line");
    let n = run.time.len() - 1;
    for k in 0..n {
        step(&h, k, run.runner[k]);
        let got = |v: inchworm_fmi_export::Var<D>| h.real(v.vr()).1;
        assert_eq!(got(D::RESIDUAL), run.residual[k], "residual of sample {k}");
        assert_eq!(got(D::PATH), run.path[k]);
        assert_eq!(got(D::CART_PATH), run.cart[k]);
        assert_eq!(got(D::FINE_PATH), run.fine[k]);
        assert_eq!(h.boolean(D::LOCKED.vr()).1, run.locked[k], "lock of sample {k}");
    }
    // 3 s hold 60 science frames of 50 ms: the last one's visibility is the one the
    // figures reduce from the recorded residual.
    use inchworm_delay_line::fringes::{null_depth_of, visibility_of};
    let frame = &run.residual[n - 25..n];
    let figures = [
        (D::VISIBILITY_H, visibility_of(frame, 1.65e-6)),
        (D::VISIBILITY_N, visibility_of(frame, 10e-6)),
        (D::NULL_N, null_depth_of(frame, 10e-6)),
    ];
    for (v, want) in figures {
        let got = h.real(v.vr()).1;
        assert!((got - want).abs() < 1e-12, "{}: {got} against {want}", v.name());
    }
}

#[test]
fn steps_off_the_sample_grid_bad_parameters_and_the_end_of_the_stroke_are_refused() {
    let h = H::init("grid");
    assert_eq!(h.step(0.0, 0.003), fmi2Error);
    assert!(h.saw(fmi2Error, &["0.003 s", "every 0.002 s"]), "{:?}", h.logged());
    let h = H::init("long");
    assert_eq!(h.step(0.0, 1e6), fmi2Error, "a step's work is bounded");
    // A step of several samples runs each on the runner position set before it.
    let h = H::init("multi");
    assert_eq!(h.step(0.0, 5.0 * T), fmi2OK);
    let h = H::new("params");
    assert_eq!((h.setup(), h.enter()), (fmi2OK, fmi2OK));
    assert_eq!(h.set_real(D::var(DelayLineParams::HOUR_ANGLE).vr(), 175.0), fmi2OK);
    assert_eq!(h.exit(), fmi2Error, "the star is below the horizon");
    assert!(h.saw(fmi2Error, &["below the horizon"]), "{:?}", h.logged());
    let h = H::init("stroke");
    step(&h, 0, 1e-3);
    assert_eq!(h.set_real(D::RUNNER_POSITION.vr(), 6e-3), fmi2OK);
    assert_eq!(h.step(T, T), fmi2Error);
    assert!(h.saw(fmi2Error, &["beyond half the stroke"]), "{:?}", h.logged());
}

#[test]
fn state_round_trips_and_continues_to_the_same_bits() {
    let a = H::init("a");
    for k in 0..200 {
        step(&a, k, 1e-9 * k as f64);
    }
    let bytes = a.serialize();
    let b = H::new("b");
    assert_eq!(b.deserialize(&bytes), fmi2OK, "{:?}", b.logged());
    for k in 200..400 {
        step(&a, k, 1e-9 * k as f64);
        step(&b, k, 1e-9 * k as f64);
        for v in [D::REFERENCE, D::RESIDUAL, D::FINE_PATH, D::VISIBILITY_H] {
            assert_eq!(a.real(v.vr()), b.real(v.vr()), "{} at step {k}", v.name());
        }
    }
    let c = H::new("c");
    assert_ne!(c.deserialize(&bytes[..bytes.len() - 3]), fmi2OK);
}

#[test]
fn committed_model_description_matches_the_variable_table() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../modelDescription/InchwormDelayLine.xml");
    let committed = std::fs::read_to_string(path).unwrap_or_default();
    assert!(
        committed == inchworm_fmi_export::model_description::model_description::<D>(),
        "modelDescription/InchwormDelayLine.xml differs: run `cargo run --release -p fmu-build`"
    );
}
