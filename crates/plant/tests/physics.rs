//! Modes, jump conditions, event timing, slips, hysteresis and encoder (docs/model.md §2).

use inchworm_plant::hysteresis::{play, stop};
use inchworm_plant::{Dac, Mode, Plant, PlantParams};

const H: f64 = 0.002;

fn dac(earth: f64, nonearth: f64, extension: f64) -> Dac {
    Dac { earth, nonearth, extension }
}

fn hold(plant: &mut Plant, d: Dac, samples: usize) {
    for _ in 0..samples {
        plant.step(d, H).unwrap();
    }
}

/// Step response of the analog chain to `u` volts, closed form: partial fractions of
/// `G ω_a 3w² u / (s (s² + 3ws + 3w²)(s + ω_a))`.
fn chain_step_response(p: &PlantParams, u: f64, t: f64) -> f64 {
    #[derive(Clone, Copy)]
    struct C(f64, f64);
    let mul = |a: C, b: C| C(a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
    let div = |a: C, b: C| {
        let d = b.0 * b.0 + b.1 * b.1;
        C((a.0 * b.0 + a.1 * b.1) / d, (a.1 * b.0 - a.0 * b.1) / d)
    };
    let sub = |a: C, b: C| C(a.0 - b.0, a.1 - b.1);
    let w = 2.0 * std::f64::consts::PI * p.f_bessel / 1.36165;
    let wa = 2.0 * std::f64::consts::PI * p.f_amp;
    let poles =
        [C(-1.5 * w, w * 3f64.sqrt() / 2.0), C(-1.5 * w, -w * 3f64.sqrt() / 2.0), C(-wa, 0.0)];
    let gain = p.amp_gain * wa * 3.0 * w * w * u;
    let mut y = p.amp_gain * u;
    for (k, &pk) in poles.iter().enumerate() {
        let mut den = pk;
        for (j, &pj) in poles.iter().enumerate() {
            if j != k {
                den = mul(den, sub(pk, pj));
            }
        }
        let r = div(C(gain, 0.0), den);
        let e = C((pk.0 * t).exp() * (pk.1 * t).cos(), (pk.0 * t).exp() * (pk.1 * t).sin());
        y += mul(r, e).0;
    }
    y
}

#[test]
fn long_idle_run_stays_at_rest_to_the_count() {
    let mut plant = Plant::new(PlantParams::fia20()).unwrap();
    for k in 0..5000 {
        let r = plant.step(dac(0.0, 0.0, 0.0), H).unwrap();
        let o = plant.outputs();
        assert_eq!((o.encoder_counts, o.mode, r.brake_events), (0, Mode::Hold, 0), "sample {k}");
    }
    let o = plant.outputs();
    assert_eq!(o.runner_position, 0.0);
    assert_eq!(o.extension, 0.0);
    assert_eq!(plant.velocities(), [0.0; 4]);
    assert!((plant.time() - 10.0).abs() < 1e-9);
}

#[test]
fn brake_switch_is_located_at_the_analytic_crossing() {
    let p = PlantParams::fia20();
    // Closed form: bisect the step response for 50 V.
    let (mut lo, mut hi) = (0.0, H);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if chain_step_response(&p, 10.0, mid) < p.v_th {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let analytic = 0.5 * (lo + hi);
    for (name, d, mode) in [
        ("non-earth", dac(0.0, 10.0, 0.0), Mode::Locked),
        ("earth", dac(10.0, 0.0, 0.0), Mode::Free),
    ] {
        let mut plant = Plant::new(p.clone()).unwrap();
        let r = plant.step(d, H).unwrap();
        let t = r.first_brake_event.expect("a brake switch in the first 2 ms");
        let err = t - analytic;
        assert!(
            err.abs() <= 10e-9,
            "{name} brake switch at {t:.12} s, analytic crossing {analytic:.12} s: error {err:.3e} s > 10 ns"
        );
        assert!(
            err >= 0.0 && err <= 2.0 * p.rel_tol,
            "{name}: located {err:.3e} s after the crossing, resolution {}",
            p.rel_tol
        );
        assert_eq!((r.brake_events, plant.mode()), (1, mode), "{name}");
    }
    // A 100x tighter tolerance moves the located time by less than the default resolution.
    let tight = PlantParams { rel_tol: 1e-11, ..p.clone() };
    let mut plant = Plant::new(tight).unwrap();
    let t = plant.step(dac(0.0, 10.0, 0.0), H).unwrap().first_brake_event.unwrap();
    assert!((t - analytic).abs() <= 2e-11, "tight tolerance: error {:.3e} s", t - analytic);
}

#[test]
fn gait_walks_through_hold_locked_drive_locked_hold_with_their_jump_conditions() {
    let mut plant = Plant::new(PlantParams::fia20()).unwrap();
    // Non-earth closes: LOCKED freezes every mechanical state.
    hold(&mut plant, dac(0.0, 10.0, 0.0), 14);
    assert_eq!(plant.mode(), Mode::Locked);
    assert_eq!(plant.velocities(), [0.0; 4]);
    let frozen = plant.positions();
    // The extension channel still charges in LOCKED, nothing moves.
    hold(&mut plant, dac(0.0, 10.0, 3.0), 10);
    assert_eq!(plant.positions(), frozen, "LOCKED must freeze positions");
    assert!(plant.outputs().voltage_extension > 29.0);
    hold(&mut plant, dac(0.0, 10.0, 0.0), 20);

    // Earth opens: DRIVE, the runner rides node 3 at a fixed offset and the brake
    // disturbance pushes it forward.
    hold(&mut plant, dac(10.0, 10.0, 0.0), 1);
    assert_eq!(plant.mode(), Mode::Drive);
    let [_, _, x3, x4] = plant.positions();
    let offset = x4 - x3;
    let mut peak = 0.0f64;
    for _ in 0..13 {
        plant.step(dac(10.0, 10.0, 0.0), H).unwrap();
        let [_, _, x3, x4] = plant.positions();
        assert!(((x4 - x3) - offset).abs() < 1e-15, "runner left node 3 in DRIVE");
        let [_, _, v3, v4] = plant.velocities();
        assert_eq!(v3, v4);
        peak = peak.max(plant.outputs().runner_position);
    }
    let static_shift = 175.0 / (3.0e7 + 5.0e6 + 2.0e4);
    let settled = plant.outputs().runner_position;
    assert!(
        (settled - static_shift).abs() < 0.25 * static_shift,
        "brake disturbance shift {settled:.3e} m, static estimate {static_shift:.3e} m"
    );
    assert!(peak > settled, "the runner-flexure mode rings after the switch");

    // Extension moves runner and node 3 together.
    hold(&mut plant, dac(10.0, 10.0, 10.0), 15);
    let moved = plant.outputs().runner_position - settled;
    assert!((15e-6..25e-6).contains(&moved), "full extension moved the runner {moved:.3e} m");

    // Earth closes: LOCKED.
    hold(&mut plant, dac(0.0, 10.0, 10.0), 13);
    assert_eq!(plant.mode(), Mode::Locked);
    let runner_locked = plant.outputs().runner_position;
    // Non-earth opens: HOLD, the runner stays clamped while node 3 retracts.
    hold(&mut plant, dac(0.0, 0.0, 10.0), 15);
    assert_eq!(plant.mode(), Mode::Hold);
    assert_eq!(plant.velocities()[3], 0.0);
    hold(&mut plant, dac(0.0, 0.0, 0.0), 14);
    assert_eq!(plant.outputs().runner_position, runner_locked, "HOLD must keep the runner still");
    // The retracted stack keeps the residual strain of its hysteresis: the static balance
    // (k_p + k_f) δ = T_em (ξ − κδ) with ξ + H[ξ] = κδ at V_X = 0, for the memories held.
    let p = PlantParams::fia20();
    let m = plant.play_memories();
    let kappa = p.t_em / p.c;
    let g = p.t_em / (p.k_p + p.k_f + p.t_em * kappa);
    let h =
        |xi: f64| (0..5).map(|i| p.play_weight[i] * stop(m[i], xi, p.play_radius[i])).sum::<f64>();
    let residual = |xi: f64| xi + h(xi) - kappa * g * xi;
    let (mut lo, mut hi) = (-100.0f64, 100.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if residual(mid) > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let static_extension = g * lo;
    let extension = plant.outputs().extension;
    assert!(
        (extension - static_extension).abs() < 0.02 * static_extension.abs() + 1e-8,
        "retracted extension {extension:.4e} m, static balance {static_extension:.4e} m"
    );
    assert!(
        extension.abs() < 0.2 * moved,
        "residual strain {extension:.3e} m of a {moved:.3e} m step"
    );
    assert_eq!(plant.outputs().slip_events, 0);
}

#[test]
fn opening_both_brakes_slips_the_runner_and_counts_it() {
    let mut plant = Plant::new(PlantParams::fia20()).unwrap();
    // One forward gait puts the runner ~23 µm out, held by the earth brake.
    let gait = [
        (14, dac(0.0, 0.0, 0.0)),
        (15, dac(0.0, 10.0, 0.0)),
        (14, dac(10.0, 10.0, 0.0)),
        (15, dac(10.0, 10.0, 10.0)),
        (13, dac(0.0, 10.0, 10.0)),
        (15, dac(0.0, 0.0, 10.0)),
        (14, dac(0.0, 0.0, 0.0)),
    ];
    for (n, d) in gait {
        hold(&mut plant, d, n);
    }
    let start = plant.outputs().runner_position;
    assert!(start > 20e-6);
    // Earth opens with the non-earth open: FREE, the environment spring pulls the runner
    // back; its period is 2π √(m_r / k_e) = 17.2 ms, so after 8 ms it is near the far side.
    let r = plant.step(dac(10.0, 0.0, 0.0), H).unwrap();
    assert_eq!((r.slips, plant.mode()), (1, Mode::Free));
    hold(&mut plant, dac(10.0, 0.0, 0.0), 3);
    let o = plant.outputs();
    assert_eq!(o.slip_events, 1);
    assert!(
        o.runner_position < 0.5 * start,
        "runner slipped from {start:.3e} m to {:.3e} m",
        o.runner_position
    );
    // Closing the earth brake again clamps it wherever it is: HOLD, no new slip.
    hold(&mut plant, dac(0.0, 0.0, 0.0), 5);
    assert_eq!((plant.mode(), plant.outputs().slip_events), (Mode::Hold, 1));
    let clamped = plant.outputs().runner_position;
    hold(&mut plant, dac(0.0, 0.0, 0.0), 20);
    assert_eq!(plant.outputs().runner_position, clamped);
}

#[test]
fn locked_stack_charge_traces_the_maxwell_slip_loop() {
    let p = PlantParams::fia20();
    let mut plant = Plant::new(p.clone()).unwrap();
    hold(&mut plant, dac(0.0, 10.0, 0.0), 20);
    assert_eq!(plant.mode(), Mode::Locked);
    // With the mechanics frozen, ξ + H[ξ] = V_X. Drive V_X up to 80 V: every element with
    // r < ξ slipped and its memory is ξ_peak − r (the Bessel filter overshoots by 0.4 %, so
    // ξ_peak is a little above the final ξ and the elements then stick again); the others
    // never slipped and keep their memory 0.
    hold(&mut plant, dac(0.0, 10.0, 8.0), 40);
    let xi = plant.charge_voltage();
    let m = plant.play_memories();
    let peak = m[0] + p.play_radius[0];
    assert!(peak >= xi && peak - xi < 1.0, "ξ peak {peak} V, final ξ {xi} V");
    let mut slipped = 0;
    for (i, (mi, r)) in m.iter().zip(p.play_radius).enumerate() {
        let expect = play(0.0, peak, r);
        slipped += usize::from(expect != 0.0);
        assert!(
            (mi - expect).abs() < 1e-9,
            "element {} memory {mi} V after the rise, expected {expect} V",
            i + 1
        );
    }
    assert_eq!(slipped, 4, "at ξ ≈ {xi:.1} V the elements of radius 15..60 V slipped, 75 V not");
    let h_sum = |m: [f64; 5], xi: f64| {
        (0..5).map(|i| p.play_weight[i] * stop(m[i], xi, p.play_radius[i])).sum::<f64>()
    };
    let vx = plant.outputs().voltage_extension;
    assert!(
        (xi + h_sum(m, xi) - vx).abs() < 1e-6,
        "ξ + H[ξ] = {} V, V_X = {vx} V",
        xi + h_sum(m, xi)
    );
    // Down to 20 V: the elements whose band ξ left slipped down and hold ξ_trough + r, the
    // others keep their memory from the rise.
    hold(&mut plant, dac(0.0, 10.0, 2.0), 40);
    let xi2 = plant.charge_voltage();
    let m2 = plant.play_memories();
    let trough = m2[0] - p.play_radius[0];
    assert!(trough <= xi2 && xi2 - trough < 1.0);
    for i in 0..5 {
        let expect = play(m[i], trough, p.play_radius[i]);
        assert!(
            (m2[i] - expect).abs() < 1e-9,
            "element {} memory {} V after the fall, expected {} V",
            i + 1,
            m2[i],
            expect
        );
    }
    assert!(m2[0] < m[0], "the radius-15 V element slipped back down");
    assert_eq!(m2[4], m[4], "the radius-75 V element never slipped");
    let vx2 = plant.outputs().voltage_extension;
    assert!((xi2 + h_sum(m2, xi2) - vx2).abs() < 1e-6);
    // The loop is passive: on the way down ξ is above its value on the way up at the same
    // V_X (the charge lags), so ξ at 20 V after the 80 V peak exceeds the virgin value.
    let mut virgin = Plant::new(p.clone()).unwrap();
    hold(&mut virgin, dac(0.0, 10.0, 0.0), 20);
    hold(&mut virgin, dac(0.0, 10.0, 2.0), 40);
    assert!(xi2 > virgin.charge_voltage(), "descending branch {xi2} V above the virgin curve");
}

#[test]
fn encoder_rounds_half_away_from_zero_and_noise_is_seeded() {
    let noisy = PlantParams { encoder_noise: 3e-9, noise_seed: 42, ..PlantParams::fia20() };
    let run = |p: PlantParams| {
        let mut plant = Plant::new(p).unwrap();
        (0..200)
            .map(|_| {
                plant.step(dac(0.0, 0.0, 0.0), H).unwrap();
                plant.outputs().encoder_counts
            })
            .collect::<Vec<_>>()
    };
    let a = run(noisy.clone());
    let b = run(noisy.clone());
    assert_eq!(a, b, "the same seed replays the same noise");
    assert!(a.iter().any(|&c| c != 0), "noise of 2.5 counts rms shows in 200 samples");
    let c = run(PlantParams { noise_seed: 43, ..noisy });
    assert_ne!(a, c);
    assert!(run(PlantParams::fia20()).iter().all(|&c| c == 0));
}

#[test]
fn state_round_trip_replays_bit_for_bit() {
    let mut plant = Plant::new(PlantParams::fia20()).unwrap();
    hold(&mut plant, dac(0.0, 10.0, 0.0), 15);
    hold(&mut plant, dac(10.0, 10.0, 0.0), 3);
    let mut bytes = Vec::new();
    plant.save_state(&mut bytes);
    let cont = |p: &mut Plant| {
        (0..30)
            .map(|_| {
                p.step(dac(10.0, 10.0, 5.0), H).unwrap();
                p.positions()
            })
            .collect::<Vec<_>>()
    };
    let first = cont(&mut plant);
    let mut fresh = Plant::new(PlantParams::fia20()).unwrap();
    fresh.load_state(&bytes).unwrap();
    assert_eq!(cont(&mut fresh), first);
    assert!(fresh.load_state(&bytes[..bytes.len() - 1]).is_err());
    let mut bad = bytes.clone();
    bad.push(0);
    assert!(fresh.load_state(&bad).is_err());
}

#[test]
fn fia6_moves_less_per_step_than_fia20() {
    let step_size = |p: PlantParams| {
        let mut plant = Plant::new(p).unwrap();
        hold(&mut plant, dac(0.0, 10.0, 0.0), 15);
        hold(&mut plant, dac(10.0, 10.0, 0.0), 14);
        let before = plant.outputs().runner_position;
        hold(&mut plant, dac(10.0, 10.0, 10.0), 15);
        plant.outputs().runner_position - before
    };
    let (a, b) = (step_size(PlantParams::fia20()), step_size(PlantParams::fia6()));
    assert!(b < 0.5 * a, "fia6 extension {b:.3e} m vs fia20 {a:.3e} m");
}

#[test]
fn random_drive_with_random_step_sizes_stays_finite_and_consistent() {
    // Seeded LCG: DAC volts anywhere in 0–10 V (often right at the 5 V threshold after the
    // ×10 gain), step sizes 0.1–5 ms, 20 000 steps. Nothing may go non-finite, the mode must
    // always agree with the brake voltages, and no step may run out of its event budget.
    let mut seed = 0x1234_5678_9abc_def0u64;
    let mut next = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    for params in [
        PlantParams::fia20(),
        PlantParams::fia6(),
        PlantParams { gamma: 0.5, ..PlantParams::fia20() },
    ] {
        let mut plant = Plant::new(params.clone()).unwrap();
        let mut t = 0.0;
        for k in 0..20_000 {
            let pick = |u: f64| {
                if u < 0.2 {
                    5.0
                } else if u < 0.4 {
                    0.0
                } else if u < 0.6 {
                    10.0
                } else {
                    10.0 * u
                }
            };
            let d = dac(pick(next()), pick(next()), 10.0 * next());
            let h = 1e-4 + 4.9e-3 * next();
            let r = plant.step(d, h).unwrap();
            t += h;
            assert!(!r.event_budget_exhausted, "step {k}: event budget exhausted");
            let o = plant.outputs();
            assert!(
                o.runner_position.is_finite() && o.extension.is_finite(),
                "step {k}: non-finite state"
            );
            assert!(
                o.runner_position.abs() < 0.01 && o.extension.abs() < 1e-4,
                "step {k}: runaway {o:?}"
            );
            assert_eq!(
                o.mode,
                Mode::from_brakes(o.voltage_earth < params.v_th, o.voltage_nonearth >= params.v_th),
                "step {k}"
            );
        }
        assert!((plant.time() - t).abs() < 1e-9);
    }
}
