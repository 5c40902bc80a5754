//! The FMI boundary of InchwormReference: the default Fig. 5 step, tables with and without
//! ramps, the named profiles, refused parameters, state round trips, threads, and the
//! committed modelDescription.

use inchworm_fmi_export::ffi::*;
use inchworm_fmi_export::model_description;
use inchworm_fmi_export::testing::Harness;
use inchworm_fmu_models::reference::{MAX_POINTS, STAIRCASE_UM};
use inchworm_fmu_models::ReferenceFmu;

type H = Harness<ReferenceFmu>;

/// The output at every communication point k h, k = 0..=n (the first read before any step).
fn trace(h: &H, step: f64, n: usize) -> Vec<f64> {
    let mut out = vec![h.real(ReferenceFmu::REFERENCE.vr()).1];
    for k in 0..n {
        assert_eq!(h.step(k as f64 * step, step), fmi2OK, "{:?}", h.logged());
        out.push(h.real(ReferenceFmu::REFERENCE.vr()).1);
    }
    out
}

/// An initialized instance whose table is `points`.
fn table(points: &[(f64, f64)], ramp: f64) -> H {
    let h = H::new("table");
    assert_eq!((h.setup(), h.enter()), (fmi2OK, fmi2OK));
    assert_eq!(h.set_integer(ReferenceFmu::N_POINTS.vr(), points.len() as i32), fmi2OK);
    for (i, (t, p)) in points.iter().enumerate() {
        assert_eq!(h.set_real(ReferenceFmu::TIMES_1.element(i).vr(), *t), fmi2OK);
        assert_eq!(h.set_real(ReferenceFmu::POSITIONS_1.element(i).vr(), *p), fmi2OK);
    }
    assert_eq!(h.set_real(ReferenceFmu::RAMP_TIME.vr(), ramp), fmi2OK);
    assert_eq!(h.exit(), fmi2OK, "{:?}", h.logged());
    h
}

#[test]
fn default_is_the_fig5_step_from_t0() {
    let h = H::init("default");
    let r = trace(&h, 0.002, 500);
    assert!(r.iter().all(|&x| x == 100e-6), "100 um at every point, t = 0 included");
    // Any step size: the reference has no sample period of its own.
    let h = H::init("any step");
    assert_eq!(h.step(0.0, 0.0015), fmi2OK);
    assert_eq!(h.real(ReferenceFmu::REFERENCE.vr()), (fmi2OK, 100e-6));
}

#[test]
fn a_table_is_held_piecewise_constant_and_ramps_when_asked() {
    let h = table(&[(0.0, 0.0), (0.01, 50e-6), (0.02, -20e-6)], 0.0);
    let r = trace(&h, 0.002, 15);
    let want: Vec<f64> = (0..=15)
        .map(|k| match k {
            0..=4 => 0.0,
            5..=9 => 50e-6,
            _ => -20e-6,
        })
        .collect();
    assert_eq!(r, want, "each point's value from its own time on, the grid computed as k h");
    // Before the first point the reference is 0.
    let h = table(&[(0.004, 7e-6)], 0.0);
    assert_eq!(trace(&h, 0.002, 3), [0.0, 0.0, 7e-6, 7e-6]);
    // A ramp over 10 ms: 10 um per 2 ms from t = 0.
    let h = table(&[(0.0, 50e-6)], 0.01);
    let r = trace(&h, 0.002, 7);
    for (k, x) in r.iter().enumerate() {
        let want = 50e-6 * (k as f64 * 0.2).min(1.0);
        assert!((x - want).abs() < 1e-15, "k = {k}: {x} vs {want}");
    }
}

#[test]
fn named_profiles() {
    let h = H::new("staircase");
    assert_eq!((h.setup(), h.enter()), (fmi2OK, fmi2OK));
    assert_eq!(h.set_integer(ReferenceFmu::PROFILE.vr(), 2), fmi2OK);
    assert_eq!(h.exit(), fmi2OK);
    let mut t = 0.0;
    for (k, um) in STAIRCASE_UM.iter().enumerate() {
        // Step to just inside the level, then to its end.
        let start = k as f64 * 100.0;
        assert_eq!(h.step(t, start + 1.0 - t), fmi2OK);
        assert_eq!(h.real(ReferenceFmu::REFERENCE.vr()).1, um * 1e-6, "level {k}");
        t = start + 1.0;
    }
    let h = H::new("step");
    assert_eq!((h.setup(), h.enter()), (fmi2OK, fmi2OK));
    assert_eq!(h.set_real(ReferenceFmu::POSITIONS_1.vr(), 5e-6), fmi2OK);
    assert_eq!(h.set_integer(ReferenceFmu::PROFILE.vr(), 1), fmi2OK);
    assert_eq!(h.exit(), fmi2OK);
    assert_eq!(
        h.real(ReferenceFmu::REFERENCE.vr()),
        (fmi2OK, 100e-6),
        "profile 1 ignores the table"
    );
}

#[test]
fn bad_parameters_are_refused_with_a_message() {
    for (what, set) in [
        (
            ReferenceFmu::N_POINTS.name(),
            Box::new(|h: &H| h.set_integer(ReferenceFmu::N_POINTS.vr(), 0))
                as Box<dyn Fn(&H) -> fmi2Status>,
        ),
        (
            ReferenceFmu::N_POINTS.name(),
            Box::new(|h: &H| h.set_integer(ReferenceFmu::N_POINTS.vr(), MAX_POINTS as i32 + 1)),
        ),
        (
            ReferenceFmu::PROFILE.name(),
            Box::new(|h: &H| h.set_integer(ReferenceFmu::PROFILE.vr(), 7)),
        ),
        (
            ReferenceFmu::RAMP_TIME.name(),
            Box::new(|h: &H| h.set_real(ReferenceFmu::RAMP_TIME.vr(), -1.0)),
        ),
        (
            ReferenceFmu::TIMES_1.element(1).name(),
            Box::new(|h: &H| {
                h.set_integer(ReferenceFmu::N_POINTS.vr(), 2);
                h.set_real(ReferenceFmu::TIMES_1.vr(), 1.0);
                h.set_real(ReferenceFmu::TIMES_1.element(1).vr(), 0.5)
            }),
        ),
    ] {
        let h = H::new("params");
        assert_eq!((h.setup(), h.enter()), (fmi2OK, fmi2OK));
        assert_eq!(set(&h), fmi2OK);
        assert_eq!(h.exit(), fmi2Error);
        assert!(
            h.saw(fmi2Error, &["fmi2ExitInitializationMode", what]),
            "{what}: {:?}",
            h.logged()
        );
    }
    let h = H::init("inputs");
    assert_eq!(
        h.set_real(ReferenceFmu::REFERENCE.vr(), 1.0),
        fmi2Error,
        "the output cannot be set"
    );
    assert_eq!(h.set_real(ReferenceFmu::TIMES_1.vr(), f64::NAN), fmi2Error);
    assert_eq!(
        h.set_integer(ReferenceFmu::N_POINTS.vr(), 3),
        fmi2Error,
        "fixed parameters cannot change after initialization"
    );
    assert_eq!(h.real(999).0, fmi2Error, "999 is no variable's value reference");
}

#[test]
fn state_round_trips_replay_bit_for_bit() {
    let a = table(&[(0.0, 1e-6), (0.3, 2e-6), (0.9, 3e-6)], 0.05);
    trace(&a, 0.002, 100);
    let s = a.get_state();
    let bytes = a.serialize();
    let next = |h: &H| {
        (100..600)
            .map(|k| (h.step(k as f64 * 0.002, 0.002), h.real(ReferenceFmu::REFERENCE.vr()).1))
            .collect::<Vec<_>>()
    };
    let first = next(&a);
    assert_eq!(a.set_state(s), fmi2OK);
    assert_eq!(next(&a), first);
    assert_eq!(a.free_state(s), fmi2OK);
    let b = H::new("b");
    assert_eq!(b.deserialize(&bytes), fmi2OK, "{:?}", b.logged());
    assert_eq!(next(&b), first, "the table travels in the state");
    let mut bad = bytes.clone();
    bad[10] ^= 0x20;
    assert_eq!(b.deserialize(&bad), fmi2Error);
}

#[test]
fn four_instances_on_four_threads_match_four_serial_runs() {
    let go = |p: f64| {
        let h = table(&[(0.0, p), (0.5, -p)], 0.1);
        trace(&h, 0.002, 500)
    };
    let ps = [1e-6, 2e-6, 3e-6, 4e-6];
    let serial: Vec<_> = ps.iter().map(|&p| go(p)).collect();
    let threads: Vec<_> = ps.iter().map(|&p| std::thread::spawn(move || go(p))).collect();
    let parallel: Vec<_> = threads.into_iter().map(|t| t.join().unwrap()).collect();
    assert_eq!(serial, parallel);
}

#[test]
fn committed_model_description_matches_the_variable_table() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../modelDescription/InchwormReference.xml");
    let committed = std::fs::read_to_string(path).unwrap_or_default();
    assert!(
        committed == model_description::model_description::<ReferenceFmu>(),
        "{path} differs from the variable table: run `cargo run --release -p fmu-build` and commit modelDescription/"
    );
}
