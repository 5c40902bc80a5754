//! `cargo bench -p inchworm --bench closed_loop`: the closed loop over 600 s of the
//! Figs. 6–7 staircase (prefilter on, 2 ms Jacobi), four ways in this one run, so their
//! ratios hold on a loaded machine:
//!
//! * the Rust master stepping both FMUs (`inchworm run` on dist/InchwormSystemOpen.ssp);
//! * the crates coupled directly (no FMI), recording the scenario's full row every step;
//! * a plain Jacobi loop in FMPy on the same FMUs (`benches/fmpy_jacobi.py`, through the
//!   repository's `.venv/bin/python`; skipped, with the reason printed, without it);
//! * a speed anchor in C (`benches/rk4_anchor.c`, compiled here with the system `cc`):
//!   fixed-step RK4 of the plant's quiet 14-state linear system alone, checked against
//!   its exact propagation.
//!
//! The two Rust runs alternate, best of `REPEATS` each. Prints wall times, real-time
//! factors, per-step costs, the ratios and the machine's load average, and checks that the
//! three loops end on the same encoder count.

use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Instant;

use inchworm_controller::Params;
use inchworm_cosim::master::run;
use inchworm_plant::linear::{ix, system_matrix, Matrix, Vector, N};
use inchworm_plant::{Mode, PlantParams};
use inchworm_scenarios::closed_loop::run as direct;
use inchworm_scenarios::scenario;

const DURATION: f64 = 600.0;
const H: f64 = 0.002;
const REPEATS: usize = 3;
/// The anchor's RK4 step: 5 µs, the largest of the plant bench's RK4 steps that stays
/// within 1 count of the tight gait trace (the 4 kHz stack mode needs it).
const RK4_STEP: f64 = 5e-6;
/// Simulated seconds of the anchor: enough to time, short of the 600 s it would take minutes for.
const RK4_SECONDS: f64 = 20.0;

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|l| l.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}

/// What one way of running the loop gave: wall seconds and the final encoder count.
struct Timed {
    wall: f64,
    final_count: i64,
}

fn row(what: &str, t: &Timed, sim_s: f64) {
    println!(
        "  {what:<36} {:>8.3} s wall | {:>6.0}x real time | {:>6.2} us per 2 ms step | final encoder {}",
        t.wall,
        sim_s / t.wall,
        t.wall / (sim_s / H) * 1e6,
        t.final_count
    );
}

/// The FMPy loop, or why it did not run.
fn fmpy(root: &Path, dist: &Path) -> Result<Timed, String> {
    let python = root.join(".venv/bin/python");
    if !python.is_file() {
        return Err(format!("{} missing (scripts/setup.sh makes it)", python.display()));
    }
    let out = Command::new(&python)
        .arg(root.join("benches/fmpy_jacobi.py"))
        .arg(dist)
        .arg(DURATION.to_string())
        .output()
        .map_err(|e| format!("{}: {e}", python.display()))?;
    if !out.status.success() {
        return Err(format!(
            "benches/fmpy_jacobi.py failed: {}",
            String::from_utf8_lossy(&out.stderr).lines().last().unwrap_or("")
        ));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let f: Vec<f64> = text.split_whitespace().skip(1).filter_map(|x| x.parse().ok()).collect();
    match f[..] {
        [_, wall, count] => Ok(Timed { wall, final_count: count as i64 }),
        _ => Err(format!("benches/fmpy_jacobi.py printed `{}`", text.trim())),
    }
}

/// The C anchor: wall seconds for `RK4_SECONDS` of the quiet plant and the largest
/// deviation of its end state from the exact propagation, relative to the state's size.
fn anchor(root: &Path) -> Result<(f64, f64), String> {
    let exe = Path::new(env!("CARGO_TARGET_TMPDIR")).join("rk4_anchor");
    let cc = Command::new("cc")
        .args(["-O3", "-march=native", "-std=c99", "-o"])
        .arg(&exe)
        .arg(root.join("benches/rk4_anchor.c"))
        .output()
        .map_err(|e| format!("cc: {e}"))?;
    if !cc.status.success() {
        return Err(format!("cc failed: {}", String::from_utf8_lossy(&cc.stderr)));
    }
    let p = PlantParams::fia20();
    // HOLD, every hysteresis element sticking: the quiet step's system.
    let a = system_matrix(&p, Mode::Hold, p.play_weight.iter().sum());
    // From rest, the extension channel commanded to 5 V: the stack's ringing transient.
    let mut z0 = Vector::zeros();
    z0[ix::ONE] = 1.0;
    z0[ix::UX] = 5.0;
    let steps = (RK4_SECONDS / RK4_STEP).round() as u64;
    let mut input = String::new();
    for i in 0..N {
        for j in 0..N {
            input += &format!("{:e} ", a[(i, j)]);
        }
    }
    for v in z0.iter() {
        input += &format!("{v:e} ");
    }
    input += &format!("{RK4_STEP:e} {steps}\n");
    let mut child = Command::new(&exe)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .map_err(|e| format!("{}: {e}", exe.display()))?;
    child.stdin.take().expect("piped").write_all(input.as_bytes()).map_err(|e| e.to_string())?;
    let out = child.wait_with_output().map_err(|e| e.to_string())?;
    let v: Vec<f64> = String::from_utf8_lossy(&out.stdout)
        .split_whitespace()
        .filter_map(|x| x.parse().ok())
        .collect();
    if !out.status.success() || v.len() != N + 1 {
        return Err(format!("{} failed ({})", exe.display(), out.status));
    }
    // The exact propagation: e^{A 2 ms} applied once per 2 ms step.
    let phi: Matrix = (a * H).exp();
    let mut z = z0;
    for _ in 0..(RK4_SECONDS / H).round() as u64 {
        z = phi * z;
    }
    let scale = z.amax();
    let dev = (0..N).map(|i| (v[i + 1] - z[i]).abs()).fold(0.0, f64::max) / scale;
    Ok((v[0], dev))
}

fn main() {
    // The package is the workspace root: dist/ and .venv/ live there.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dist = root.join("dist");
    let ssp = dist.join("InchwormSystemOpen.ssp");
    assert!(ssp.is_file(), "build the FMUs and the SSP first: cargo run --release -p fmu-build");
    let load_before = load_average();
    let s = scenario::by_name("staircase").expect("a scenario");
    let controller = Params { prefilter: true, ..Params::default() };
    // The staircase scenario's options, cut to 600 s and to the one column compared, so
    // the master records no more than the FMPy loop does.
    let mut opts = s.options(&PlantParams::fia20(), &controller);
    opts.stop_time = Some(DURATION);
    opts.outputs = vec!["plant.encoder_counts".into()];

    let mut master: Option<Timed> = None;
    let mut coupled: Option<Timed> = None;
    let keep_best = |best: &mut Option<Timed>, t: Timed| {
        if best.as_ref().is_none_or(|b| t.wall < b.wall) {
            *best = Some(t);
        }
    };
    for _ in 0..REPEATS {
        let t = Instant::now();
        let m = run(&ssp, &opts, |_| {}).expect("master run");
        let wall = t.elapsed().as_secs_f64();
        let final_count = *m.column("plant.encoder_counts").unwrap().last().unwrap() as i64;
        keep_best(&mut master, Timed { wall, final_count });

        let t = Instant::now();
        let d =
            direct(PlantParams::fia20(), controller.clone(), |t| s.reference.value(0, t), DURATION)
                .expect("direct run");
        let wall = t.elapsed().as_secs_f64();
        let final_count = *d.column("plant.encoder_counts").unwrap().last().unwrap() as i64;
        keep_best(&mut coupled, Timed { wall, final_count });
    }
    let (master, coupled) = (master.expect("runs"), coupled.expect("runs"));
    let fmpy = fmpy(root, &dist);
    let anchor = anchor(root);
    let load_after = load_average();

    println!(
        "closed loop, {DURATION:.0} s of the Figs. 6-7 staircase, prefilter on, 2 ms Jacobi (Rust: best of {REPEATS} alternating runs)"
    );
    row("Rust master, both FMUs (SSP)", &master, DURATION);
    row("crates coupled directly (no FMI)", &coupled, DURATION);
    match &fmpy {
        Ok(f) => row("FMPy Jacobi loop, same FMUs", f, DURATION),
        Err(why) => println!("  FMPy Jacobi loop: not run: {why}"),
    }
    match &anchor {
        Ok((wall, dev)) => {
            let t = Timed { wall: *wall, final_count: 0 };
            println!(
                "  {:<36} {:>8.3} s wall | {:>6.0}x real time | {:>6.2} us per 2 ms step | {RK4_SECONDS:.0} s simulated, end state within {dev:.1e} of the exact propagation",
                "C RK4 anchor (quiet plant, 5 us)",
                t.wall,
                RK4_SECONDS / t.wall,
                t.wall / (RK4_SECONDS / H) * 1e6,
            );
        }
        Err(why) => println!("  C RK4 anchor: not run: {why}"),
    }
    println!("ratios:");
    println!(
        "  master: {:.0}x real time (target 2000x: {:.2} of it); {:.2} us per step more than the direct coupling ({:.2}x its wall time)",
        DURATION / master.wall,
        DURATION / master.wall / 2000.0,
        (master.wall - coupled.wall) / (DURATION / H) * 1e6,
        master.wall / coupled.wall
    );
    if let Ok(f) = &fmpy {
        println!("  master vs the FMPy loop: {:.1}x faster (target 15x)", f.wall / master.wall);
    }
    if let Ok((wall, _)) = &anchor {
        println!(
            "  master (both FMUs, events and all) vs the C RK4 of the quiet plant alone: {:.1}x faster per simulated second",
            wall / RK4_SECONDS / (master.wall / DURATION)
        );
    }
    println!("machine load average (1, 5, 15 min): {load_before} before, {load_after} after");

    if let Ok(f) = &fmpy {
        assert_eq!(f.final_count, master.final_count, "FMPy and the Rust master disagree");
    }
    assert_eq!(
        master.final_count, coupled.final_count,
        "the master and the direct coupling disagree"
    );
    if let Ok((_, dev)) = anchor {
        assert!(dev < 1e-6, "the C RK4 anchor strays from the exact propagation: {dev:e}");
    }
}
