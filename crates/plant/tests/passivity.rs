//! The hysteresis only ever absorbs energy (docs/model.md §2.4.4): over closed voltage cycles
//! in LOCKED the energy into it is the Maxwell-slip loop area, and free rings of the
//! mechanism lose energy monotonically and decay.

use inchworm_plant::hysteresis::stop;
use inchworm_plant::{Dac, Mode, Plant, PlantParams};

const H: f64 = 0.002;

fn dac(earth: f64, nonearth: f64, extension: f64) -> Dac {
    Dac { earth, nonearth, extension }
}

/// `H[ξ]` of the plant's current memories.
fn hysteresis_voltage(p: &PlantParams, memories: [f64; 5], xi: f64) -> f64 {
    (0..5).map(|i| p.play_weight[i] * stop(memories[i], xi, p.play_radius[i])).sum()
}

/// `C Σ w_i 2 r_i (Δξ − 2 r_i)₊`: the energy one closed cycle of peak-to-peak `Δξ` dissipates.
fn loop_energy(p: &PlantParams, dxi: f64) -> f64 {
    (0..5)
        .map(|i| {
            p.c * p.play_weight[i]
                * 2.0
                * p.play_radius[i]
                * (dxi - 2.0 * p.play_radius[i]).max(0.0)
        })
        .sum()
}

/// Energy into the hysteresis element, `C ∫ u_h dξ`, over one triangle cycle of the extension
/// DAC between `lo` and `hi` volts (LOCKED, 2 V/s), and the cycle's `Δξ` from the memories.
fn cycle(plant: &mut Plant, lo: f64, hi: f64) -> (f64, f64) {
    let p = plant.params().clone();
    // ξ is sampled every 10 µs: the trapezoid rule is exact on each linear piece of H.
    let sub = 200;
    let mut xi = plant.charge_voltage();
    let mut uh = hysteresis_voltage(&p, plant.play_memories(), xi);
    let mut energy = 0.0;
    let mut peak = f64::NEG_INFINITY;
    let mut trough = f64::INFINITY;
    let samples = ((hi - lo) / 0.004).round() as usize;
    let path = (0..=samples)
        .map(|k| lo + (hi - lo) * k as f64 / samples as f64)
        .chain((0..=samples).rev().map(|k| lo + (hi - lo) * k as f64 / samples as f64))
        .chain(std::iter::repeat_n(lo, 100));
    for u in path {
        for _ in 0..sub {
            plant.step(dac(0.0, 10.0, u), H / sub as f64).unwrap();
            let xi1 = plant.charge_voltage();
            let uh1 = hysteresis_voltage(&p, plant.play_memories(), xi1);
            energy += p.c * 0.5 * (uh + uh1) * (xi1 - xi);
            (xi, uh) = (xi1, uh1);
            peak = peak.max(xi);
            trough = trough.min(xi);
        }
    }
    assert_eq!(plant.mode(), Mode::Locked);
    (energy, peak - trough)
}

#[test]
fn closed_cycles_in_locked_dissipate_the_maxwell_slip_loop_area() {
    let p = PlantParams::fia20();
    let mut plant = Plant::new(p.clone()).unwrap();
    for _ in 0..20 {
        plant.step(dac(0.0, 10.0, 1.0), H).unwrap();
    }
    for (lo, hi) in [(1.0, 9.0), (2.0, 6.0), (3.0, 3.8), (0.5, 10.0), (4.0, 7.0)] {
        // The first cycle from a new range sets the memories; the second is closed.
        cycle(&mut plant, lo, hi);
        let xi0 = plant.charge_voltage();
        let (energy, dxi) = cycle(&mut plant, lo, hi);
        let xi1 = plant.charge_voltage();
        assert!((xi1 - xi0).abs() < 1e-9, "cycle {lo}..{hi} V closes: ξ {xi0} -> {xi1} V");
        let expect = loop_energy(&p, dxi);
        let scale = p.c * p.play_weight.iter().sum::<f64>() * dxi * dxi;
        eprintln!(
            "cycle {lo}..{hi} V: Δξ {dxi:.4} V, energy into H {energy:.6e} J, loop area {expect:.6e} J"
        );
        assert!(energy >= -1e-9 * scale, "cycle {lo}..{hi} V returned {energy:.3e} J");
        assert!(
            (energy - expect).abs() <= 1e-6 * expect.max(scale),
            "cycle {lo}..{hi} V: energy into H {energy:.9e} J, expected {expect:.9e} J (Δξ {dxi} V)"
        );
    }
}

/// Stored energy of the mechanism and the transducer with the extension unpowered (V_X = 0,
/// so the source does no work): kinetic, elastic, the piezo capacitance `C u_p²/2`, the
/// strained hysteresis elements `C Σ w_i E_i²/2` and, in DRIVE, the brake disturbance's
/// potential `−F_d0 y4` (γ = 0).
fn stored_energy(plant: &Plant) -> f64 {
    let p = plant.params();
    let o = plant.outputs();
    assert_eq!(o.voltage_extension, 0.0, "the source is off");
    let l = p.l_p / 3.0;
    let x = plant.positions();
    let y = [x[0] - l, x[1] - 2.0 * l, x[2] - 3.0 * l, x[3] - p.l_r];
    let v = plant.velocities();
    let (k, m1, m3) = (3.0 * p.k_p, p.m_p / 3.0, p.m_p / 6.0 + p.m_b);
    let xi = plant.charge_voltage();
    let memories = plant.play_memories();
    let e_h: f64 = (0..5)
        .map(|i| stop(memories[i], xi, p.play_radius[i]))
        .collect::<Vec<_>>()
        .iter()
        .zip(p.play_weight)
        .map(|(e, w)| 0.5 * p.c * w * e * e)
        .sum();
    let u_p = -hysteresis_voltage(p, memories, xi);
    let mut energy = 0.5 * m1 * (v[0] * v[0] + v[1] * v[1])
        + 0.5 * k * (y[0] * y[0] + (y[1] - y[0]).powi(2) + (y[2] - y[1]).powi(2))
        + 0.5 * p.k_f * y[2] * y[2]
        + 0.5 * p.c * u_p * u_p
        + e_h;
    match plant.mode() {
        Mode::Drive => {
            energy += 0.5 * (m3 + p.m_r) * v[2] * v[2] + 0.5 * p.k_e * y[3] * y[3] - p.f_d0 * y[3];
        }
        _ => energy += 0.5 * m3 * v[2] * v[2],
    }
    energy
}

/// Rings from the given state for 60 ms, sampled every 5 µs: the stored energy never rises,
/// and the amplitude of `track` about its final value decays. Returns the envelope per 5 ms (µm).
fn ring(plant: &mut Plant, d: Dac, track: impl Fn(&Plant) -> f64) -> Vec<f64> {
    let dt = 5e-6;
    // The first step brings the elements to their slip limits (a state set by hand may
    // strain them beyond): the energy is watched from there on.
    plant.step(d, dt).unwrap();
    let mut energy = stored_energy(plant);
    let e0 = energy;
    let mut trace = Vec::new();
    for k in 0..12_000 {
        plant.step(d, dt).unwrap();
        let e = stored_energy(plant);
        assert!(
            e <= energy + 1e-9 * e0,
            "stored energy rose from {energy:.9e} J to {e:.9e} J at {:.6} s",
            k as f64 * dt
        );
        energy = e;
        trace.push(track(plant));
    }
    let last = *trace.last().unwrap();
    let envelope: Vec<f64> = trace
        .chunks(1000)
        .map(|w| w.iter().map(|x| 1e6 * (x - last).abs()).fold(0.0, f64::max))
        .collect();
    eprintln!("energy {e0:.4e} J -> {energy:.4e} J, envelope per 5 ms (µm) {envelope:.4?}");
    envelope
}

#[test]
fn a_ring_from_80_um_of_stack_deflection_in_hold_decays() {
    let mut plant = Plant::new(PlantParams::fia20()).unwrap();
    let d = 80e-6;
    plant.set_mechanics([d / 3.0, 2.0 * d / 3.0, d, 0.0], [0.0; 4]);
    let envelope = ring(&mut plant, dac(0.0, 0.0, 0.0), |p| p.outputs().extension);
    assert_eq!(plant.mode(), Mode::Hold);
    for w in envelope.windows(2).skip(1) {
        assert!(w[1] <= w[0], "the ring grew: envelope {envelope:.3?}");
    }
    assert!(envelope[10] < 0.05 * envelope[0], "the ring did not decay: {envelope:.3?}");
}

#[test]
fn a_ring_from_1_m_per_s_in_drive_decays() {
    let mut plant = Plant::new(PlantParams::fia20()).unwrap();
    // Non-earth closes, then the earth opens: DRIVE with the extension unpowered.
    for (samples, d) in [(15, dac(0.0, 10.0, 0.0)), (20, dac(10.0, 10.0, 0.0))] {
        for _ in 0..samples {
            plant.step(d, H).unwrap();
        }
    }
    assert_eq!(plant.mode(), Mode::Drive);
    let x = plant.positions();
    let p = plant.params().clone();
    let l = p.l_p / 3.0;
    let y = [x[0] - l, x[1] - 2.0 * l, x[2] - 3.0 * l, x[3] - p.l_r];
    plant.set_mechanics(y, [1.0 / 3.0, 2.0 / 3.0, 1.0, 1.0]);
    let envelope = ring(&mut plant, dac(10.0, 10.0, 0.0), |p| p.outputs().runner_position);
    assert_eq!(plant.mode(), Mode::Drive);
    for w in envelope.windows(2).skip(1) {
        assert!(w[1] <= w[0], "the ring grew: envelope {envelope:.3?}");
    }
    assert!(envelope[10] < 0.05 * envelope[0], "the ring did not decay: {envelope:.3?}");
}
