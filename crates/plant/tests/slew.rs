//! Open-loop slews over the stroke (docs/model.md §2.5): full forward gaits advance the
//! runner steadily at γ = 0 over 40 mm, and fall steadily toward the stall of the paper's
//! Fig. 11 when the brake disturbance grows with the load (γ = 10).

use inchworm_controller::gait::{Direction, Timing};
use inchworm_plant::{Dac, Plant, PlantParams};

/// Runner position (m) after each of `gaits` full forward gaits, and the slips seen.
fn slew(gamma: f64, gaits: usize) -> (Vec<f64>, u32) {
    let timing = Timing::new(100);
    let mut plant = Plant::new(PlantParams { gamma, ..PlantParams::fia20() }).unwrap();
    let mut after = Vec::with_capacity(gaits);
    for _ in 0..gaits {
        for k in 1..=100 {
            let [earth, nonearth, extension] = timing.volts(Direction::Forward, 1.0, k);
            plant.step(Dac { earth, nonearth, extension }, 0.002).unwrap();
        }
        after.push(plant.outputs().runner_position);
    }
    (after, plant.outputs().slip_events)
}

fn advances(after: &[f64]) -> Vec<f64> {
    std::iter::once(after[0]).chain(after.windows(2).map(|w| w[1] - w[0])).collect()
}

#[test]
fn forty_millimetres_of_full_gaits_advance_steadily() {
    // The environment spring (k_e = 20 N/mm) loads the stack more with every millimetre, so
    // the advance per gait falls as the runner nears the stack's blocking force (about
    // T_em · 100 V = 880 N, 44 mm out); it must fall smoothly, never backward.
    let (after, slips) = slew(0.0, 9000);
    let gaits = 1 + after.iter().position(|&x| x >= 40e-3).expect("the slew reaches 40 mm");
    let adv = advances(&after[..gaits]);
    let um = |x: f64| x * 1e6;
    let largest_change = adv.windows(2).skip(1).map(|w| (w[1] - w[0]).abs()).fold(0.0, f64::max);
    // The band about the mean of the previous ten advances.
    let mut widest = 0.0f64;
    for g in 11..gaits {
        let mean = adv[g - 10..g].iter().sum::<f64>() / 10.0;
        widest = widest.max((adv[g] - mean).abs());
    }
    eprintln!(
        "γ = 0: 40 mm in {gaits} gaits, first advance {:.4} µm, second {:.4} µm, last {:.4} µm, largest gait-to-gait change {:.4} µm, widest departure from the running mean {:.4} µm, slips {slips}",
        um(adv[0]),
        um(adv[1]),
        um(adv[gaits - 1]),
        um(largest_change),
        um(widest)
    );
    assert_eq!(slips, 0);
    for (g, a) in adv.iter().enumerate() {
        assert!(*a > 0.0, "gait {} moved backward by {:.4} µm", g + 1, um(-a));
    }
    for (g, w) in adv.windows(2).enumerate().skip(1) {
        assert!(
            w[1] <= w[0],
            "gait {}: advance rose from {:.4} to {:.4} µm",
            g + 2,
            um(w[0]),
            um(w[1])
        );
    }
    assert!(um(widest) < 0.1, "an advance left the running mean by {:.4} µm", um(widest));
}

#[test]
fn a_growing_brake_disturbance_slows_the_slew_toward_stall() {
    let gaits = 600;
    let (after, slips) = slew(10.0, gaits);
    let adv = advances(&after);
    let um = |x: f64| x * 1e6;
    let largest_change = adv.windows(2).skip(1).map(|w| (w[1] - w[0]).abs()).fold(0.0, f64::max);
    eprintln!(
        "γ = 10: {:.3} mm in {gaits} gaits, first advance {:.4} µm, second {:.4} µm, last {:.4} µm, largest gait-to-gait change {:.4} µm, slips {slips}",
        after[gaits - 1] * 1e3,
        um(adv[0]),
        um(adv[1]),
        um(adv[gaits - 1]),
        um(largest_change)
    );
    assert_eq!(slips, 0);
    for (g, w) in adv.windows(2).enumerate().skip(1) {
        assert!(
            w[1] <= w[0],
            "gait {}: advance rose from {:.4} to {:.4} µm",
            g + 2,
            um(w[0]),
            um(w[1])
        );
    }
    assert!(adv[gaits - 1] < 0.1 * adv[1], "the slew did not approach stall");
}
