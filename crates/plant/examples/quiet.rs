//! Profiling aid: the reference gaits (1 s, which builds every configuration's tables),
//! 1 s of settling, `GAIT_REPEATS` (default 0) more passes of the gait second, then
//! `QUIET_STEPS` (default 10 000, 20 s) quiet 2 ms steps at 0 V. Under
//! `valgrind --tool=callgrind`, the difference of the instruction counts of two runs gives
//! the cost of what they differ by: a quiet step (`QUIET_STEPS=10000` against `0`) or a
//! gait second with its tables built (`GAIT_REPEATS=10 QUIET_STEPS=0` against
//! `GAIT_REPEATS=0 QUIET_STEPS=0`).

use inchworm_plant::{Dac, Plant, PlantParams};

fn count(var: &str, default: usize) -> usize {
    std::env::var(var).ok().and_then(|s| s.parse().ok()).unwrap_or(default)
}

fn main() {
    let quiet = count("QUIET_STEPS", 10_000);
    let repeats = count("GAIT_REPEATS", 0);
    let mut plant = Plant::new(PlantParams::fia20()).unwrap();
    // The docs/model.md §2.9 gaits of the reference trace (1 s).
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/plant-check-trace-fia20-passive.csv"
    );
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let gaits: Vec<Dac> = text
        .lines()
        .skip(1)
        .map(|line| {
            let f: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
            Dac { earth: f[1], nonearth: f[2], extension: f[3] }
        })
        .collect();
    let mut sum = 0i64;
    for d in &gaits {
        plant.step(*d, 0.002).unwrap();
    }
    // Settle, so every configuration used below has its tables built.
    for _ in 0..500 {
        plant.step(Dac::default(), 0.002).unwrap();
    }
    for _ in 0..repeats {
        for d in &gaits {
            plant.step(*d, 0.002).unwrap();
            sum = sum.wrapping_add(plant.outputs().encoder_counts);
        }
    }
    for _ in 0..quiet {
        plant.step(Dac::default(), 0.002).unwrap();
        sum = sum.wrapping_add(plant.outputs().encoder_counts);
    }
    let s = plant.scan_stats();
    println!("{} {:?} {:e}", sum, s, plant.outputs().runner_position);
}
