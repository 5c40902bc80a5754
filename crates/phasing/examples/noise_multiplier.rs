//! `cargo run --release -p inchworm-phasing --example noise_multiplier [MAX_RINGS [MIN_RINGS]]`:
//! the edge-sensor reconstructor's modes and noise multiplier against mirror size (rings
//! MIN_RINGS, default 1, to MAX_RINGS, default 8: 217 segments), as the markdown table of docs/phasing.md: the
//! piston, tip and tilt reconstructor's multiplier with a power law fitted to it, and the
//! multiplier of pistons alone (tips and tilts known) with the logarithmic law
//! `α² = a + b ln N` of least-squares reconstruction from differences fitted to it.
//!
//! The SVD of the dense interaction matrix grows as N³ (217 segments: ~10 s; 331: ~35 s on
//! a loaded 2-core machine), so ELT-class sizes are not in this table.

use inchworm_phasing::{EdgeSensors, Mirror, Reconstructor, DEFAULT_THRESHOLD};
use nalgebra::DMatrix;

/// The noise multiplier of the pistons alone: the pseudo-inverse of the piston columns
/// with the one unseen mode (the whole mirror's piston) left out.
fn piston_only(a: &DMatrix<f64>, segments: usize) -> f64 {
    let p = DMatrix::from_fn(a.nrows(), segments, |i, k| a[(i, 3 * k)]);
    let sigma = p.singular_values();
    let largest = sigma.max();
    let sum: f64 = sigma.iter().filter(|s| **s > 1e-9 * largest).map(|s| 1.0 / (s * s)).sum();
    (sum / segments as f64).sqrt()
}

/// Least squares of y on x: (a, b) of y = a + b x.
fn line(points: &[(f64, f64)]) -> (f64, f64) {
    let n = points.len() as f64;
    let (sx, sy) = points.iter().fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
    let (sxx, sxy) = points.iter().fold((0.0, 0.0), |(a, b), (x, y)| (a + x * x, b + x * y));
    let b = (n * sxy - sx * sy) / (n * sxx - sx * sx);
    ((sy - b * sx) / n, b)
}

fn main() {
    let rings = |i: usize, default: u32| {
        std::env::args().nth(i).map_or(default, |a| a.parse().expect("a number of rings"))
    };
    let (max_rings, min_rings) = (rings(1, 8), rings(2, 1));
    println!("| segments | sensors | unseen σ/σmax (largest) | focus σ/σmax | next σ/σmax | α, all seen modes | α, focus excluded | the same from 2000 draws | α, pistons alone |");
    println!("|---|---|---|---|---|---|---|---|---|");
    let (mut power, mut log) = (Vec::new(), Vec::new());
    for rings in min_rings..=max_rings {
        let started = std::time::Instant::now();
        let m = Mirror::new(rings, true, 1.44, 0.004).expect("a mirror");
        let s = EdgeSensors::new(&m, 0.005).expect("its sensors");
        let a = s.interaction(m.centres());
        let all = Reconstructor::new(&m, &a, DEFAULT_THRESHOLD).expect("a reconstructor");
        let (focus, next) = (all.modes[3].relative, all.modes[4].relative);
        let unseen = all.modes[2].relative;
        let without = Reconstructor::new(&m, &a, (focus * next).sqrt())
            .expect("a reconstructor without focus");
        let (alpha, alpha_nf) = (all.noise_multiplier(), without.noise_multiplier());
        let drawn = without.noise_multiplier_monte_carlo(2000, 1);
        let pistons = piston_only(&a, m.segments());
        let ln_n = (m.segments() as f64).ln();
        power.push((ln_n, alpha_nf.ln()));
        log.push((ln_n, pistons * pistons));
        println!(
            "| {} | {} | {unseen:.1e} | {focus:.2e} | {next:.2e} | {alpha:.1} | {alpha_nf:.3} | {drawn:.3} | {pistons:.3} |",
            m.segments(),
            s.len()
        );
        eprintln!("{} segments in {:.1} s", m.segments(), started.elapsed().as_secs_f64());
    }
    if power.len() < 2 {
        return;
    }
    let (c, p) = line(&power);
    let worst =
        power.iter().map(|(x, y)| ((c + p * x).exp() / y.exp() - 1.0).abs()).fold(0.0, f64::max);
    println!(
        "\npiston, tip and tilt, focus excluded: α = {:.3} N^{p:.3}, within {:.1} % at every size",
        c.exp(),
        100.0 * worst
    );
    let (a, b) = line(&log);
    let worst =
        log.iter().map(|(x, y)| ((a + b * x) / y).sqrt() - 1.0).map(f64::abs).fold(0.0, f64::max);
    println!(
        "pistons alone: α² = {a:.3} + {b:.3} ln N, within {:.1} % at every size",
        100.0 * worst
    );
}
