//! Profiling aid: a few gait steps, then `QUIET_STEPS` (default 10 000, 20 s) quiet
//! 2 ms steps at 0 V. Under `valgrind --tool=callgrind`, compare the instruction counts
//! of a run with `QUIET_STEPS=0` to get the cost per quiet step.

use inchworm_plant::{Dac, Plant, PlantParams};

fn main() {
    let quiet: usize =
        std::env::var("QUIET_STEPS").ok().and_then(|s| s.parse().ok()).unwrap_or(10_000);
    let mut plant = Plant::new(PlantParams::fia20()).unwrap();
    // The docs/model.md §2.9 gaits of the reference trace (1 s).
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/plant-check-trace-fia20-passive.csv"
    );
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    for line in text.lines().skip(1) {
        let f: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        plant.step(Dac { earth: f[1], nonearth: f[2], extension: f[3] }, 0.002).unwrap();
    }
    // Settle, so every configuration used below has its tables built.
    for _ in 0..500 {
        plant.step(Dac::default(), 0.002).unwrap();
    }
    let mut sum = 0i64;
    for _ in 0..quiet {
        plant.step(Dac::default(), 0.002).unwrap();
        sum = sum.wrapping_add(plant.outputs().encoder_counts);
    }
    let s = plant.scan_stats();
    println!("{} {:?} {:e}", sum, s, plant.outputs().runner_position);
}
