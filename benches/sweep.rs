//! Sweep throughput: runs per second of the Fig. 5 step (10 s, 5000 steps of 2 ms) on 1
//! worker and on every core side by side, and what a run costs beyond its steps: a sweep's
//! reset against loading the system afresh, and a run inside a sweep against one plain
//! `inchworm run` process.
//!
//! `cargo bench -p inchworm --bench sweep` (needs dist/: `cargo run --release -p fmu-build`).
//! On a shared machine the figures move with the other load: each is the best of `REPEATS`.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use std::sync::Arc;

use inchworm_cosim::master::{Coupling, InputTable, Options, System};
use inchworm_cosim::sweep::exec::{self, Setup};
use inchworm_cosim::sweep::plan::{self, Plan};
use inchworm_scenarios::closed_loop;
use inchworm_scenarios::metrics::LoopMetrics;

const REPEATS: usize = 3;
const RUNS: usize = 40;

/// The least of `REPEATS` timings (s).
fn best(mut f: impl FnMut() -> f64) -> f64 {
    (0..REPEATS).map(|_| f()).fold(f64::INFINITY, f64::min)
}

/// CPU time (user + system, s) this process has used so far, all threads.
fn cpu_time() -> f64 {
    rusage(libc::RUSAGE_SELF)
}

/// CPU time (s) of the children waited for so far.
fn child_cpu_time() -> f64 {
    rusage(libc::RUSAGE_CHILDREN)
}

fn rusage(who: libc::c_int) -> f64 {
    // SAFETY: getrusage writes into the struct it is given.
    let mut u: libc::rusage = unsafe { std::mem::zeroed() };
    unsafe { libc::getrusage(who, &mut u) };
    let tv = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    tv(u.ru_utime) + tv(u.ru_stime)
}

fn main() {
    let ssp = Path::new(env!("CARGO_MANIFEST_DIR")).join("dist/InchwormSystemOpen.ssp");
    if !ssp.is_file() {
        eprintln!("bench sweep: build dist/ first: cargo run --release -p fmu-build");
        std::process::exit(1);
    }
    let input =
        InputTable::steps(closed_loop::REFERENCE, &[(0.0, 100e-6)]).expect("one finite row");
    let metric_names = ["settle:1e-6", "rms:6:10", "disturbance"];
    let setup = Setup {
        system: ssp.clone(),
        options: Options {
            stop_time: Some(10.0),
            step_size: None,
            coupling: Coupling::Jacobi,
            params: vec![],
            parameter_set: Some("full-control".into()),
            input: Some(input.clone()),
            outputs: vec![],
        },
        metrics: Arc::new(LoopMetrics::parse(&metric_names).expect("valid")),
    };
    let sweeps = [
        plan::parse_sample("plant.T_em=normal(8.8,0.22)").expect("valid"),
        plan::parse_sample("plant.k_p=normal(3e7,7.5e5)").expect("valid"),
    ];
    let p = Plan::build(&sweeps, RUNS, 1).expect("valid");
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());

    // Runs per second of wall time, and the CPU the process got meanwhile (cores busy on
    // average): on a machine others share, a rate below `jobs` × the 1-worker rate with
    // fewer than `jobs` cores busy is the machine's load, not the sweep's.
    // The repeat with the best rate: (runs/s, cores busy, CPU s per run).
    let rate = |jobs: usize| {
        let mut best = (0.0f64, 0.0, 0.0);
        for _ in 0..REPEATS {
            let (t, c) = (Instant::now(), cpu_time());
            let out = exec::run_plan(&setup, &p, jobs, |_| {});
            assert!(out.iter().all(|o| o.error.is_none()));
            let (wall, cpu) = (t.elapsed().as_secs_f64(), cpu_time() - c);
            if RUNS as f64 / wall > best.0 {
                best = (RUNS as f64 / wall, cpu / wall, cpu / RUNS as f64);
            }
        }
        best
    };
    let (r1, b1, c1) = rate(1);
    let (rn, bn, cn) = rate(cores);
    println!("sweep of {RUNS} Fig. 5 runs (10 s, 2 ms Jacobi), best of {REPEATS}:");
    println!(
        "  {:>2} worker : {r1:7.2} runs/s  ({:.2} ms/run; CPU {:.2} ms/run, {:.2} cores busy)",
        1,
        1e3 / r1,
        c1 * 1e3,
        b1
    );
    println!(
        "  {cores:>2} workers: {rn:7.2} runs/s  ({:.2} ms/run; CPU {:.2} ms/run, {:.2} cores busy)  speed-up {:.2}x",
        1e3 / rn,
        cn * 1e3,
        bn,
        rn / r1
    );
    if let Ok(l) = std::fs::read_to_string("/proc/loadavg") {
        println!(
            "  machine load average (1, 5, 15 min): {}",
            l.split_whitespace().take(3).collect::<Vec<_>>().join(" ")
        );
    }

    // What a run costs apart from its steps: load + initialise against reset.
    let opts = Options {
        stop_time: Some(10.0),
        step_size: None,
        coupling: Coupling::Jacobi,
        params: vec![("plant.T_em".into(), "8.8".into())],
        parameter_set: Some("full-control".into()),
        input: Some(input),
        outputs: setup.metrics.recorded(),
    };
    let load = best(|| {
        let t = Instant::now();
        let sim = System::load(&ssp).and_then(|s| s.initialise(&opts)).expect("loads");
        let dt = t.elapsed().as_secs_f64();
        drop(sim);
        dt
    });
    let mut sim = System::load(&ssp).and_then(|s| s.initialise(&opts)).expect("loads");
    let reset = best(|| {
        let t = Instant::now();
        sim.reset(&opts).expect("resets");
        t.elapsed().as_secs_f64()
    });
    println!(
        "  load + initialise (unzip, instantiate): {:.2} ms; reset + initialise: {:.3} ms",
        load * 1e3,
        reset * 1e3
    );

    // One plain `inchworm run` process recording what the sweep records.
    let dir = std::env::temp_dir().join(format!("inchworm-bench-sweep-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let csv = dir.join("ref.csv");
    std::fs::write(&csv, "time,reference\n0,100e-6\n").expect("write");
    let mut args: Vec<String> = vec![
        "run".into(),
        ssp.display().to_string(),
        "--input".into(),
        csv.display().to_string(),
        "--stop-time".into(),
        "10".into(),
        "--parameter-set".into(),
        "full-control".into(),
        "--out".into(),
        dir.join("run.csv").display().to_string(),
    ];
    for n in closed_loop::recorded() {
        args.push("--output".into());
        args.push(n);
    }
    let mut plain_cpu = f64::INFINITY;
    let plain = best(|| {
        let (t, c) = (Instant::now(), child_cpu_time());
        let st = Command::new(env!("CARGO_BIN_EXE_inchworm")).args(&args).output().expect("runs");
        assert!(st.status.success(), "{}", String::from_utf8_lossy(&st.stderr));
        plain_cpu = plain_cpu.min(child_cpu_time() - c);
        t.elapsed().as_secs_f64()
    });
    let _ = std::fs::remove_dir_all(&dir);
    println!(
        "  one plain `inchworm run` process: {:.2} ms; one run in a 1-worker sweep: {:.2} ms (overhead of the plain run: {:.2} ms, {:.0} %)",
        plain * 1e3,
        1e3 / r1,
        plain * 1e3 - 1e3 / r1,
        (plain * r1 - 1.0) * 100.0
    );
    println!(
        "  CPU: the plain run process {:.2} ms, a run in a 1-worker sweep {:.2} ms (overhead {:.2} ms)",
        plain_cpu * 1e3,
        c1 * 1e3,
        (plain_cpu - c1) * 1e3
    );
}
