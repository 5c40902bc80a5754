//! `cargo bench -p inchworm-plant --bench plant`: the plant alone over a 60 s gait
//! sequence (the SPEC 2.9 five-gait sequence of the reference trace, repeated 60 times),
//! all figures measured side by side in this one run:
//!
//! * the exact solver at the default tolerance: cost of one 2 ms step (median, p99, max)
//!   and the real-time factor;
//! * its encoder trace against the same solver at a 100× tighter tolerance;
//! * a plain fixed-step RK4 of the same equations at the largest of a few step sizes that
//!   stays within 2 counts of that tight trace, its cost, and the ratio.

use std::time::Instant;

use inchworm_plant::rk4::Rk4Plant;
use inchworm_plant::{Dac, Plant, PlantParams};

const H: f64 = 0.002;
const REPEATS: usize = 60;

/// The 60 s input sequence and the reference trace's encoder counts of its first second.
fn sequence() -> (Vec<Dac>, Vec<i64>) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/reference/plant-check-trace-fia20.csv");
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let rows: Vec<Vec<f64>> = text.lines().skip(1).map(|l| l.split(',').map(|x| x.parse().unwrap()).collect()).collect();
    let one: Vec<Dac> = rows.iter().map(|f| Dac { earth: f[1], nonearth: f[2], extension: f[3] }).collect();
    let counts = rows.iter().map(|f| f[4] as i64).collect();
    (one.iter().cycle().take(one.len() * REPEATS).copied().collect(), counts)
}

struct Run {
    counts: Vec<i64>,
    step_us: Vec<f64>,
    total_s: f64,
}

fn run_exact(rel_tol: f64, seq: &[Dac]) -> Run {
    let mut plant = Plant::new(PlantParams { rel_tol, ..PlantParams::fia20() }).unwrap();
    let mut counts = Vec::with_capacity(seq.len());
    let mut step_us = Vec::with_capacity(seq.len());
    let start = Instant::now();
    for d in seq {
        let t = Instant::now();
        plant.step(*d, H);
        step_us.push(t.elapsed().as_secs_f64() * 1e6);
        counts.push(plant.outputs().encoder_counts);
    }
    Run { counts, step_us, total_s: start.elapsed().as_secs_f64() }
}

fn run_rk4(h: f64, seq: &[Dac]) -> Run {
    let mut plant = Rk4Plant::new(PlantParams::fia20(), h);
    let mut counts = Vec::with_capacity(seq.len());
    let start = Instant::now();
    for d in seq {
        plant.step(*d, H);
        counts.push(plant.encoder_counts());
    }
    Run { counts, step_us: Vec::new(), total_s: start.elapsed().as_secs_f64() }
}

fn max_dev(a: &[i64], b: &[i64]) -> i64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).max().unwrap_or(0)
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

fn main() {
    let (seq, reference) = sequence();
    let sim_s = seq.len() as f64 * H;
    // Warm-up: the first run builds each configuration's propagator tables once.
    run_exact(1e-9, &seq[..500]);
    let exact = run_exact(1e-9, &seq);
    let tight = run_exact(1e-11, &seq);
    let mut sorted = exact.step_us.clone();
    sorted.sort_by(f64::total_cmp);
    let per_step_exact = exact.total_s / seq.len() as f64 * 1e6;

    println!("plant alone, {sim_s:.0} s gait sequence ({} steps of 2 ms), fia20", seq.len());
    println!();
    println!("exact solver, rel_tol 1e-9:");
    println!(
        "  2 ms step: median {:.2} us, p99 {:.2} us, max {:.1} us (a first entry into a configuration builds its tables), mean {per_step_exact:.2} us",
        percentile(&sorted, 0.5),
        percentile(&sorted, 0.99),
        sorted[sorted.len() - 1]
    );
    println!("  real-time factor: {:.0}x ({:.3} s wall for {sim_s:.0} s)", sim_s / exact.total_s, exact.total_s);
    println!(
        "  encoder trace vs rel_tol 1e-11 (100x tighter, {:.0}x real time): max |diff| {} counts over {sim_s:.0} s",
        sim_s / tight.total_s,
        max_dev(&exact.counts, &tight.counts)
    );
    println!("  vs the SPEC 2.9 reference trace (first 1 s): max |diff| {} counts", max_dev(&exact.counts, &reference));
    println!();
    println!("fixed-step RK4 of the same equations (memories updated per step, brake switches bisected to 1 ns):");
    println!("  step    | vs reference (1 s) | vs tight trace (60 s) | per 2 ms step | real time");
    let mut best_ref: Option<(f64, f64)> = None;
    let mut best_tight: Option<(f64, f64)> = None;
    let mut smallest = (0.0, 0.0);
    for h_us in [20.0, 10.0, 5.0, 2.5, 1.25] {
        let r = run_rk4(h_us * 1e-6, &seq);
        let dev_ref = max_dev(&r.counts, &reference);
        let dev_tight = max_dev(&r.counts, &tight.counts);
        println!(
            "  {h_us:>5} us | {dev_ref:>12} counts | {dev_tight:>15} counts | {:>9.2} us | {:>6.0}x",
            r.total_s / seq.len() as f64 * 1e6,
            sim_s / r.total_s
        );
        smallest = (h_us, r.total_s);
        if dev_ref <= 2 && best_ref.is_none() {
            best_ref = Some((h_us, r.total_s));
        }
        if dev_tight <= 2 && best_tight.is_none() {
            best_tight = Some((h_us, r.total_s));
        }
    }
    println!();
    for (what, best) in [("the reference trace", best_ref), ("the tight 60 s trace", best_tight)] {
        match best {
            Some((h_us, total)) => println!(
                "ratio: the exact solver is {:.1}x faster than RK4 at {h_us} us, the largest tried step within 2 counts of {what}",
                total / exact.total_s
            ),
            None => println!(
                "ratio: no RK4 step tried stays within 2 counts of {what}; the smallest, {} us, is {:.1}x slower than the exact solver",
                smallest.0,
                smallest.1 / exact.total_s
            ),
        }
    }
}
