//! The plant in continuous time (`inchworm_plant::continuous`, the Model Exchange view):
//! its derivatives are the rates of the exact solver's own trajectory, its Jacobian is the
//! derivative of its derivatives, and an event update applies the jump conditions.

#[allow(dead_code)]
mod common;

use inchworm_plant::continuous::{N_INDICATORS, N_STATES};
use inchworm_plant::{Dac, Mode, Plant, PlantParams};

/// A plant 59.5 ms into the check gaits: in DRIVE 0.5 ms after the earth brake opened,
/// the runner–flexure ring at its largest.
fn ringing() -> (Plant, Dac) {
    let gaits = common::check_gaits();
    let mut p = Plant::new(PlantParams::fia20()).unwrap();
    for dac in &gaits[..29] {
        p.step(*dac, 0.002).unwrap();
    }
    p.step(gaits[29], 0.0015).unwrap();
    assert_eq!(p.mode(), Mode::Drive);
    (p, gaits[29])
}

/// Scaled distance between two state vectors.
fn dist(a: &[f64; N_STATES], b: &[f64; N_STATES], scale: &[f64; N_STATES]) -> f64 {
    a.iter().zip(b).zip(scale).map(|((x, y), s)| ((x - y) / s).abs()).fold(0.0, f64::max)
}

#[test]
fn the_derivatives_are_the_rates_of_the_exact_trajectory() {
    let (p, dac) = ringing();
    let x0 = p.continuous_states();
    let dx = p.derivatives(dac);
    // Richardson over two forward differences of the exact propagation: O(h²).
    let diff = |h: f64| {
        let mut q = p.clone();
        let report = q.step(dac, h).unwrap();
        assert_eq!(report.brake_events, 0);
        let x = q.continuous_states();
        std::array::from_fn::<f64, N_STATES, _>(|i| (x[i] - x0[i]) / h)
    };
    let (d1, d2) = (diff(2e-7), diff(1e-7));
    let fd: [f64; N_STATES] = std::array::from_fn(|i| 2.0 * d2[i] - d1[i]);
    let scale: [f64; N_STATES] = std::array::from_fn(|i| {
        dx[i].abs().max(1e-3 * dx.iter().fold(0.0f64, |m, v| m.max(v.abs())))
    });
    let err = dist(&fd, &dx, &scale);
    eprintln!("derivatives against the exact trajectory: worst scaled error {err:.2e}; |dv3/dt| = {:.3e} m/s²", dx[5].abs());
    assert!(err < 1e-3, "{err}: {dx:?} vs {fd:?}");
    assert!(dx[5].abs() > 100.0, "the state is ringing");
    assert_eq!(dx[6].to_bits(), dx[4].to_bits(), "in DRIVE the runner moves with node 3");
}

#[test]
fn the_jacobian_is_the_derivative_of_the_derivatives() {
    let (p, dac) = ringing();
    let j = p.jacobian();
    let x0 = p.continuous_states();
    let mut worst: f64 = 0.0;
    for c in 0..N_STATES {
        // A step on the scale of the state's kind (m, m/s, V, V/s), not of its value,
        // which may be near zero.
        let kind = [
            1e-5, 1e-2, 1e-5, 1e-2, 1e-5, 1e-2, 1e-5, 1e-2, 1.0, 1e3, 1.0, 1.0, 1e3, 1.0, 1.0, 1e3,
            1.0,
        ];
        let eps = 1e-6 * (x0[c].abs() + kind[c]);
        let at = |d: f64| {
            let mut q = p.clone();
            let mut x = x0;
            x[c] += d;
            q.set_continuous_states(&x);
            q.derivatives(dac)
        };
        let (hi, lo) = (at(eps), at(-eps));
        for r in 0..N_STATES {
            let fd = (hi[r] - lo[r]) / (2.0 * eps);
            let scale = j.states[(r, c)].abs().max(1e-6 * j.states.row(r).amax());
            let e = (fd - j.states[(r, c)]).abs() / scale.max(f64::MIN_POSITIVE);
            worst = worst.max(e);
        }
    }
    for (c, field) in [(0usize, 0usize), (1, 1), (2, 2)] {
        // Inward from the 0-10 V bounds, where the held volts are clamped.
        let mut bumped = dac;
        let v = [&mut bumped.extension, &mut bumped.earth, &mut bumped.nonearth];
        let d = if *v[field] > 5.0 { -1e-3 } else { 1e-3 };
        *v[field] += d;
        let (hi, lo) = (p.derivatives(bumped), p.derivatives(dac));
        for r in 0..N_STATES {
            let fd = (hi[r] - lo[r]) / d;
            let want = j.inputs[(r, c)];
            assert!(
                (fd - want).abs() <= 1e-6 * want.abs().max(1.0),
                "input {c}, row {r}: {fd} vs {want}"
            );
        }
    }
    eprintln!("Jacobian against central differences: worst relative error {worst:.2e}");
    assert!(worst < 1e-5, "{worst}");
}

#[test]
fn an_event_update_applies_the_jump_conditions() {
    let mut p = Plant::new(PlantParams::fia20()).unwrap();
    let dac = Dac { earth: 10.0, nonearth: 10.0, extension: 0.0 };
    let mut x = p.continuous_states();
    (x[5], x[7], x[13], x[16]) = (0.1, -0.05, 60.0, 60.0);
    p.set_continuous_states(&x);
    let z = p.event_indicators();
    assert_eq!(z.len(), N_INDICATORS);
    assert_eq!((z[0], z[1]), (10.0, 10.0), "both brake volts above V_th: both switch");
    let event = p.event_update(dac, 0.25);
    assert_eq!(p.mode(), Mode::Drive);
    assert_eq!((event.step.brake_events, event.states_changed), (2, true));
    let (m3, m_r) = (0.025 / 6.0 + 0.040, 0.150);
    let v = (m3 * 0.1 + m_r * -0.05) / (m3 + m_r);
    let after = p.continuous_states();
    assert!((after[5] - v).abs() < 1e-15 && after[7] == after[5], "momentum shared: {after:?}");
    assert_eq!(p.time(), 0.25);
    // Nothing left to do: a second update at the same instant changes nothing.
    let again = p.event_update(dac, 0.25);
    assert_eq!((again.step.brake_events, again.states_changed), (0, false));
}

#[test]
fn the_rest_values_are_those_of_a_fresh_plant() {
    let p = PlantParams::fia20();
    let dac = Dac { earth: 2.0, nonearth: 7.5, extension: 4.0 };
    let fresh = Plant::new(p.clone()).unwrap();
    let (dx, z) = inchworm_plant::continuous::at_rest(&p, dac);
    assert_eq!((dx, z), (fresh.derivatives(dac), fresh.event_indicators()));
    assert_eq!(z, [-50.0, -50.0, -15.0, -15.0, -1.0]);
    assert!(
        dx[9] > 0.0 && dx[12] > 0.0 && dx[15] > 0.0,
        "the Bessel filters start to rise: {dx:?}"
    );
}
