//! `cargo bench -p inchworm-plant --bench plant`: the plant alone over a 60 s gait
//! sequence (the docs/model.md §2.9 five-gait sequence of the reference trace, repeated 60 times),
//! all figures measured side by side in this one run:
//!
//! * the exact solver at the default tolerance: cost of one 2 ms step (median, p99, max)
//!   and the real-time factor;
//! * its encoder trace against the same solver at a 100× tighter tolerance;
//! * a plain fixed-step RK4 of the same equations at the largest of a few step sizes that
//!   stays within 2 counts of that tight trace, its cost, and the ratio;
//! * the quiet-step scan bound against the full scan of every point (the solver before the
//!   bound, kept callable as `Plant::set_scan_always`), on the gait sequence and on a
//!   regulation sequence (each second of gaits followed by 5 s of parked, constant volts):
//!   per-step median and p99, real-time factor, the ratio, and a check that both paths
//!   give the same bits;
//! * the quiet 2 ms step (the plant parked at 0 V after the gaits): per-step median and p99
//!   of the quiet step against the event loop alone, and a check that both give the same bits;
//! * the distribution of the default path's 2 ms step over the gait sequence (each step's
//!   least time over three runs), and the steps by the stops they make (located events and
//!   turns of `ξ`): which steps make the p99.
//!
//! Wall-clock figures mean something only on an idle machine; `docs/plant-solver.md` gives
//! the stable measure, callgrind instruction counts (`crates/plant/examples/quiet.rs`).

use std::time::Instant;

use inchworm_plant::rk4::Rk4Plant;
use inchworm_plant::{Dac, Plant, PlantParams};

const H: f64 = 0.002;
const REPEATS: usize = 60;

/// The 60 s input sequence and the reference trace's encoder counts of its first second.
fn sequence() -> (Vec<Dac>, Vec<i64>) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/plant-check-trace-fia20-passive.csv"
    );
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let rows: Vec<Vec<f64>> =
        text.lines().skip(1).map(|l| l.split(',').map(|x| x.parse().unwrap()).collect()).collect();
    let one: Vec<Dac> =
        rows.iter().map(|f| Dac { earth: f[1], nonearth: f[2], extension: f[3] }).collect();
    let counts = rows.iter().map(|f| f[4] as i64).collect();
    (one.iter().cycle().take(one.len() * REPEATS).copied().collect(), counts)
}

/// Regulation: each second of the five gaits followed by 5 s of the parked (all-zero)
/// volts a controller in its deadband holds, 10 times (60 s).
fn regulation(gaits: &[Dac]) -> Vec<Dac> {
    let one = &gaits[..500];
    let mut seq = Vec::new();
    for _ in 0..10 {
        seq.extend_from_slice(one);
        seq.extend(std::iter::repeat_n(Dac::default(), 2500));
    }
    seq
}

struct Run {
    counts: Vec<i64>,
    step_us: Vec<f64>,
    total_s: f64,
    /// Every step's runner position and state bits, folded: equal for bit-identical runs.
    bits: u64,
    skipped: u64,
    scanned: u64,
}

fn run_exact(rel_tol: f64, seq: &[Dac]) -> Run {
    run_exact_path(rel_tol, seq, false)
}

fn run_exact_path(rel_tol: f64, seq: &[Dac], scan_always: bool) -> Run {
    let mut plant = Plant::new(PlantParams { rel_tol, ..PlantParams::fia20() }).unwrap();
    plant.set_scan_always(scan_always);
    let mut counts = Vec::with_capacity(seq.len());
    let mut step_us = Vec::with_capacity(seq.len());
    let mut bits = 0u64;
    let start = Instant::now();
    for d in seq {
        let t = Instant::now();
        plant.step(*d, H).unwrap();
        step_us.push(t.elapsed().as_secs_f64() * 1e6);
        let o = plant.outputs();
        counts.push(o.encoder_counts);
        bits = bits.rotate_left(5)
            ^ o.runner_position.to_bits()
            ^ o.extension.to_bits().rotate_left(17)
            ^ o.voltage_extension.to_bits().rotate_left(31);
    }
    let total_s = start.elapsed().as_secs_f64();
    let bits = fold_state(&plant, bits);
    let stats = plant.scan_stats();
    Run { counts, step_us, total_s, bits, skipped: stats.skipped, scanned: stats.scanned }
}

/// `bits` with the plant's saved state folded in.
fn fold_state(plant: &Plant, mut bits: u64) -> u64 {
    let mut state = Vec::new();
    plant.save_state(&mut state);
    for b in state {
        bits = bits.rotate_left(3) ^ u64::from(b);
    }
    bits
}

fn summary(r: &Run, sim_s: f64) -> String {
    let mut sorted = r.step_us.clone();
    sorted.sort_by(f64::total_cmp);
    format!(
        "median {:>5.2} us | p99 {:>5.2} us | mean {:>5.2} us | {:>5.0}x",
        percentile(&sorted, 0.5),
        percentile(&sorted, 0.99),
        r.total_s / r.step_us.len() as f64 * 1e6,
        sim_s / r.total_s
    )
}

fn compare_paths(gaits: &[Dac]) {
    println!("quiet-step scan bound vs the full scan of every point (rel_tol 1e-9, best of 3 alternating runs):");
    let reg = regulation(gaits);
    for (name, seq) in [("gait 60 s", gaits), ("regulation 60 s", &reg[..])] {
        let sim_s = seq.len() as f64 * H;
        let mut full = Vec::new();
        let mut bound = Vec::new();
        for _ in 0..3 {
            full.push(run_exact_path(1e-9, seq, true));
            bound.push(run_exact_path(1e-9, seq, false));
        }
        let pick =
            |v: Vec<Run>| v.into_iter().min_by(|a, b| a.total_s.total_cmp(&b.total_s)).unwrap();
        let (full, bound) = (pick(full), pick(bound));
        let long = bound.skipped + bound.scanned;
        println!("  {name:<16} full scan | {}", summary(&full, sim_s));
        println!(
            "  {:<16} bound     | {} | long scans skipped {}/{long} ({:.0} %)",
            "",
            summary(&bound, sim_s),
            bound.skipped,
            100.0 * bound.skipped as f64 / long.max(1) as f64
        );
        println!(
            "  {:<16} ratio {:.2}x faster (mean step), results {}",
            "",
            full.total_s / bound.total_s,
            if full.bits == bound.bits && full.counts == bound.counts {
                "bit-identical"
            } else {
                "DIFFER (bug)"
            }
        );
    }
}

/// The quiet 2 ms step: the gait second, 1 s of settling at 0 V, then 20 s of quiet steps,
/// each timed; with `scan_always`, on the event loop alone.
fn run_quiet(gaits: &[Dac], scan_always: bool) -> Run {
    let mut plant = Plant::new(PlantParams::fia20()).unwrap();
    plant.set_scan_always(scan_always);
    for d in gaits[..500].iter().chain(std::iter::repeat_n(&Dac::default(), 500)) {
        plant.step(*d, H).unwrap();
    }
    let steps = 10_000;
    let quiet_before = plant.scan_stats().quiet;
    let mut step_us = Vec::with_capacity(steps);
    let mut bits = 0u64;
    let start = Instant::now();
    for _ in 0..steps {
        let t = Instant::now();
        plant.step(Dac::default(), H).unwrap();
        step_us.push(t.elapsed().as_secs_f64() * 1e6);
        bits = bits.rotate_left(5) ^ plant.outputs().extension.to_bits();
    }
    let total_s = start.elapsed().as_secs_f64();
    let bits = fold_state(&plant, bits);
    let stats = plant.scan_stats();
    Run {
        counts: Vec::new(),
        step_us,
        total_s,
        bits,
        skipped: stats.quiet - quiet_before,
        scanned: stats.scanned,
    }
}

fn compare_quiet(gaits: &[Dac]) {
    println!("quiet 2 ms step, parked at 0 V after the gaits (20 s, each step timed, best of 3 alternating runs):");
    let (mut event_loop, mut quiet) = (Vec::new(), Vec::new());
    for _ in 0..3 {
        event_loop.push(run_quiet(gaits, true));
        quiet.push(run_quiet(gaits, false));
    }
    let pick = |v: Vec<Run>| v.into_iter().min_by(|a, b| a.total_s.total_cmp(&b.total_s)).unwrap();
    let (event_loop, quiet) = (pick(event_loop), pick(quiet));
    let sim_s = quiet.step_us.len() as f64 * H;
    println!("  event loop  | {}", summary(&event_loop, sim_s));
    println!(
        "  quiet step  | {} | quiet steps {}/{}",
        summary(&quiet, sim_s),
        quiet.skipped,
        quiet.step_us.len()
    );
    println!(
        "  ratio {:.2}x faster (mean step), results {}",
        event_loop.total_s / quiet.total_s,
        if event_loop.bits == quiet.bits { "bit-identical" } else { "DIFFER (bug)" }
    );
}

/// One step of the default path: its cost (µs, the least over the runs), its stops
/// (located events and turns of `ξ`), its brake switches, and whether the quiet step took it.
#[derive(Clone, Copy)]
struct Timed {
    us: f64,
    stops: u64,
    brakes: u32,
    quiet: bool,
}

/// The default path over the gait sequence, each step timed in `RUNS` runs and its least
/// time kept (what the step costs with the interruptions of a loaded machine filtered out):
/// the distribution, and the steps by how many stops they made.
fn distribution(seq: &[Dac]) {
    const RUNS: usize = 3;
    let mut steps: Vec<Timed> = Vec::new();
    for run in 0..RUNS {
        let mut plant = Plant::new(PlantParams::fia20()).unwrap();
        for (k, d) in seq.iter().enumerate() {
            let before = plant.scan_stats();
            let t = Instant::now();
            let report = plant.step(*d, H).unwrap();
            let us = t.elapsed().as_secs_f64() * 1e6;
            let after = plant.scan_stats();
            let step = Timed {
                us,
                stops: after.stops - before.stops,
                brakes: report.brake_events,
                quiet: after.quiet > before.quiet,
            };
            if run == 0 {
                steps.push(step);
            } else {
                steps[k].us = steps[k].us.min(us);
            }
        }
    }
    // The first second builds every configuration's tables: not a steady step.
    let steady = &steps[500..];
    let mut us: Vec<f64> = steady.iter().map(|s| s.us).collect();
    us.sort_by(f64::total_cmp);
    let p99 = percentile(&us, 0.99);
    println!("default path over the gait sequence after its first second, each step's least time over {RUNS} runs:");
    println!(
        "  all {} steps: median {:.2} us | p90 {:.2} us | p99 {p99:.2} us | p99.9 {:.2} us | max {:.2} us",
        us.len(),
        percentile(&us, 0.5),
        percentile(&us, 0.9),
        percentile(&us, 0.999),
        us[us.len() - 1]
    );
    println!("  by stops in the step | steps | share | median | p99 | mean brake switches | share of the steps at or above the p99");
    type Member = fn(&Timed) -> bool;
    let classes: [(&str, Member); 6] = [
        ("quiet step", |s| s.quiet),
        ("event loop, 0 stops", |s| !s.quiet && s.stops == 0),
        ("1-2 stops", |s| (1..=2).contains(&s.stops)),
        ("3-5 stops", |s| (3..=5).contains(&s.stops)),
        ("6-10 stops", |s| (6..=10).contains(&s.stops)),
        ("more than 10", |s| s.stops > 10),
    ];
    let tail = steady.iter().filter(|s| s.us >= p99).count().max(1);
    for (name, member) in classes {
        let of: Vec<&Timed> = steady.iter().filter(|s| member(s)).collect();
        if of.is_empty() {
            continue;
        }
        let mut t: Vec<f64> = of.iter().map(|s| s.us).collect();
        t.sort_by(f64::total_cmp);
        println!(
            "  {name:<20} | {:>5} | {:>4.1} % | {:>5.2} us | {:>5.2} us | {:>4.2} | {:>5.1} %",
            of.len(),
            100.0 * of.len() as f64 / steady.len() as f64,
            percentile(&t, 0.5),
            percentile(&t, 0.99),
            of.iter().map(|s| f64::from(s.brakes)).sum::<f64>() / of.len() as f64,
            100.0 * of.iter().filter(|s| s.us >= p99).count() as f64 / tail as f64
        );
    }
}

fn run_rk4(h: f64, seq: &[Dac]) -> Run {
    let mut plant = Rk4Plant::new(PlantParams::fia20(), h);
    let mut counts = Vec::with_capacity(seq.len());
    let start = Instant::now();
    for d in seq {
        plant.step(*d, H);
        counts.push(plant.encoder_counts());
    }
    Run {
        counts,
        step_us: Vec::new(),
        total_s: start.elapsed().as_secs_f64(),
        bits: 0,
        skipped: 0,
        scanned: 0,
    }
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
    println!(
        "  real-time factor: {:.0}x ({:.3} s wall for {sim_s:.0} s)",
        sim_s / exact.total_s,
        exact.total_s
    );
    println!(
        "  encoder trace vs rel_tol 1e-11 (100x tighter, {:.0}x real time): max |diff| {} counts over {sim_s:.0} s",
        sim_s / tight.total_s,
        max_dev(&exact.counts, &tight.counts)
    );
    println!(
        "  vs the docs/model.md §2.9 reference trace (first 1 s): max |diff| {} counts",
        max_dev(&exact.counts, &reference)
    );
    println!();
    compare_paths(&seq);
    println!();
    compare_quiet(&seq);
    println!();
    distribution(&seq);
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
