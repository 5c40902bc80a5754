//! The plant's Model Exchange interface through the FMI entry points of both standards:
//! the exact directional derivatives against central differences of
//! `GetDerivatives`/`GetContinuousStateDerivatives`, for every state and DAC input, and a
//! brake switch as a state event.

use inchworm_fmi_export::api::Fmi2;
use inchworm_fmi_export::entry::Array;
use inchworm_fmi_export::fmi3::api::Fmi3;
use inchworm_fmi_export::testing::{Harness, Master};
use inchworm_fmi_export::Var;
use inchworm_fmu_models::PlantFmu;

const N: usize = 17;
const DAC: [Var<PlantFmu>; 3] =
    [PlantFmu::DAC_EXTENSION, PlantFmu::DAC_EARTH, PlantFmu::DAC_NONEARTH];

/// The continuous states in the order of `inchworm_plant::continuous`, with their
/// derivatives.
const STATES: [(Var<PlantFmu>, Var<PlantFmu>); N] = [
    (PlantFmu::NODE1_DISPLACEMENT, PlantFmu::DER_NODE1_DISPLACEMENT),
    (PlantFmu::NODE1_VELOCITY, PlantFmu::DER_NODE1_VELOCITY),
    (PlantFmu::NODE2_DISPLACEMENT, PlantFmu::DER_NODE2_DISPLACEMENT),
    (PlantFmu::NODE2_VELOCITY, PlantFmu::DER_NODE2_VELOCITY),
    (PlantFmu::EXTENSION, PlantFmu::DER_EXTENSION),
    (PlantFmu::NODE3_VELOCITY, PlantFmu::DER_NODE3_VELOCITY),
    (PlantFmu::RUNNER_POSITION, PlantFmu::DER_RUNNER_POSITION),
    (PlantFmu::RUNNER_VELOCITY, PlantFmu::DER_RUNNER_VELOCITY),
    (PlantFmu::BESSEL_EXTENSION, PlantFmu::DER_BESSEL_EXTENSION),
    (PlantFmu::BESSEL_EXTENSION_RATE, PlantFmu::DER_BESSEL_EXTENSION_RATE),
    (PlantFmu::VOLTAGE_EXTENSION, PlantFmu::DER_VOLTAGE_EXTENSION),
    (PlantFmu::BESSEL_EARTH, PlantFmu::DER_BESSEL_EARTH),
    (PlantFmu::BESSEL_EARTH_RATE, PlantFmu::DER_BESSEL_EARTH_RATE),
    (PlantFmu::VOLTAGE_EARTH, PlantFmu::DER_VOLTAGE_EARTH),
    (PlantFmu::BESSEL_NONEARTH, PlantFmu::DER_BESSEL_NONEARTH),
    (PlantFmu::BESSEL_NONEARTH_RATE, PlantFmu::DER_BESSEL_NONEARTH_RATE),
    (PlantFmu::VOLTAGE_NONEARTH, PlantFmu::DER_VOLTAGE_NONEARTH),
];

/// The value references of the continuous states.
fn states() -> Vec<u32> {
    STATES.iter().map(|(x, _)| x.vr()).collect()
}

/// A state in HOLD with every mode of the stack and both chains moving.
fn moving() -> [f64; N] {
    [
        1e-7, 0.02, 3e-7, -0.01, 6e-6, 0.05, 0.0, 0.0, 4.0, 900.0, 35.0, 2.0, 300.0, 25.0, 1.0,
        -50.0, 12.0,
    ]
}

fn fd_check<S: Master>() {
    let h = Harness::<PlantFmu, S>::init_me("jacobian");
    assert_eq!(h.set_reals(&DAC.map(Var::vr), &[6.0, 3.0, 2.0]), 0);
    assert_eq!(h.update().0, 0);
    assert_eq!(h.enter_continuous_time_mode(), 0);
    let x0 = moving();
    assert_eq!(h.set_states(&x0), 0, "{:?}", h.logged());
    let der: Vec<u32> = STATES.iter().map(|(_, d)| d.vr()).collect();
    let f = |x: &[f64; N]| {
        assert_eq!(h.set_states(x), 0);
        let (s, d) = h.array(Array::Derivatives, N);
        assert_eq!(s, 0);
        d
    };
    let kind = [
        1e-5, 1e-2, 1e-5, 1e-2, 1e-5, 1e-2, 1e-5, 1e-2, 1.0, 1e3, 1.0, 1.0, 1e3, 1.0, 1.0, 1e3, 1.0,
    ];
    let mut worst: f64 = 0.0;
    let mut compare = |column: &[f64], fd: &[f64]| {
        let amax = column.iter().chain(fd).fold(0.0f64, |m, v| m.max(v.abs()));
        for (j, d) in column.iter().zip(fd) {
            worst = worst.max((j - d).abs() / j.abs().max(1e-6 * amax).max(f64::MIN_POSITIVE));
        }
    };
    for (c, vr) in states().into_iter().enumerate() {
        let mut seed = [0.0; N];
        seed[c] = 1.0;
        assert_eq!(h.set_states(&x0), 0);
        let (s, column) = h.directional(&der, &states(), &seed);
        assert_eq!(s, 0, "{:?}", h.logged());
        let eps = 1e-6 * (x0[c].abs() + kind[c]);
        let (mut hi, mut lo) = (x0, x0);
        hi[c] += eps;
        lo[c] -= eps;
        let (fh, fl) = (f(&hi), f(&lo));
        let fd: Vec<f64> = fh.iter().zip(&fl).map(|(a, b)| (a - b) / (2.0 * eps)).collect();
        compare(&column, &fd);
        // The states' own sensitivities are the identity.
        let (_, own) = h.directional(&[vr], &states(), &seed);
        assert_eq!(own, [1.0]);
    }
    assert_eq!(h.set_states(&x0), 0);
    for vr in DAC.map(Var::vr) {
        let (s, column) = h.directional(&der, &[vr], &[1.0]);
        assert_eq!(s, 0);
        let base = h.real(vr).1;
        let at = |v: f64| {
            assert_eq!(h.set_real(vr, v), 0, "a continuous input between events");
            h.array(Array::Derivatives, N).1
        };
        let (fh, fl) = (at(base + 1e-3), at(base - 1e-3));
        assert_eq!(h.set_real(vr, base), 0);
        let fd: Vec<f64> = fh.iter().zip(&fl).map(|(a, b)| (a - b) / 2e-3).collect();
        compare(&column, &fd);
    }
    eprintln!(
        "{}: directional derivatives against central differences, worst relative error {worst:.2e}",
        S::VERSION
    );
    assert!(worst < 1e-6, "{worst}");
    assert_eq!(
        h.directional(&[der[0]], &[PlantFmu::M_P.vr()], &[1.0]).0,
        3,
        "no derivative with respect to a parameter"
    );
}

#[test]
fn directional_derivatives_match_finite_differences_fmi2() {
    fd_check::<Fmi2>();
}

#[test]
fn directional_derivatives_match_finite_differences_fmi3() {
    fd_check::<Fmi3>();
}

/// The earth amplifier set above V_th in HOLD: its indicator is positive, and the event
/// update opens the earth brake (FREE with the non-earth brake open) and says so.
fn brake_switch<S: Master>() {
    let h = Harness::<PlantFmu, S>::init_me("switch");
    assert_eq!(h.update().0, 0);
    assert_eq!(h.enter_continuous_time_mode(), 0);
    let mut x = [0.0; N];
    x[13] = 55.0; // voltage_earth, STATES[13]
    assert_eq!(h.set_states(&x), 0);
    let (s, z) = h.array(Array::EventIndicators, 5);
    assert_eq!((s, z[0]), (0, 5.0), "earth volts − V_th");
    assert_eq!(h.enter_event_mode(), 0);
    let (s, u, term) = h.update();
    assert_eq!(
        (s, u.states_changed, term),
        (1, false, false),
        "FREE is a warning: {:?}",
        h.logged()
    );
    assert_eq!(h.integer(PlantFmu::MODE.vr()), (0, 4));
}

#[test]
fn a_brake_switch_is_a_state_event() {
    brake_switch::<Fmi2>();
    brake_switch::<Fmi3>();
}

/// A master chattering at the non-earth threshold: the non-earth volts set alternately just
/// above and below V_th, each followed by an event update (LOCKED and HOLD in turn). The
/// 20 000 updates of a 2 ms window succeed (the first window's include the one at exit
/// from initialization), the next window starts afresh, and one update too many fails with
/// the reason, asks the master to terminate and leaves the instance in the Error state.
fn chattering<S: Master>() {
    let h = Harness::<PlantFmu, S>::init_me("chatter");
    assert_eq!(h.update().0, 0);
    let mut x = [0.0; N];
    let mut k = 0u32;
    let mut chatter = |t: f64| {
        assert_eq!(h.enter_continuous_time_mode(), 0);
        assert_eq!(h.set_time(t), 0);
        k += 1;
        x[16] = if k % 2 == 1 { 50.0 + 1e-6 } else { 50.0 - 1e-6 }; // voltage_nonearth
        assert_eq!(h.set_states(&x), 0);
        assert_eq!(h.enter_event_mode(), 0);
        let (s, _, term) = h.update();
        (s, term, h.integer(PlantFmu::MODE.vr()).1, k % 2 == 1)
    };
    for i in 0..19_999 {
        let (s, term, mode, above) = chatter(1e-3 + f64::from(i) * 1e-8);
        assert_eq!(
            (s, term, mode),
            (0, false, if above { 2 } else { 1 }),
            "first window, update {i}"
        );
    }
    for i in 0..20_000 {
        let (s, term, _, _) = chatter(2.5e-3 + f64::from(i) * 1e-8);
        assert_eq!((s, term), (0, false), "second window, update {i}");
    }
    let t = 2.5e-3 + 20_000.0 * 1e-8;
    let (s, term, _, _) = chatter(t);
    assert_eq!((s, term), (3, true), "one update too many");
    let logged = h.take_logged();
    let last = logged.last().expect("the refusal is logged");
    let why = format!("more than 20000 event updates in the 2 ms from t = 0.002 s (at t = {t} s)");
    assert!(last.contains("logStatusError") && last.contains(&why), "{last}");
    // The Error state takes no further event mode.
    assert_eq!(h.enter_event_mode(), 3);
}

#[test]
fn chattering_beyond_the_event_budget_is_an_error_that_terminates() {
    chattering::<Fmi2>();
    chattering::<Fmi3>();
}
