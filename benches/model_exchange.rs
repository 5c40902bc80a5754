//! `cargo bench -p inchworm --bench model_exchange [-- SSP [SECONDS]]`: the Fig. 5 closed
//! loop (dist/InchwormSystem.ssp, default parameters, 2 ms Jacobi) with the plant stepped
//! by its own Co-Simulation (the exact solver) and with the plant's Model Exchange
//! integrated by the master (diffsol's BDF, docs/model-exchange.md), side by side: wall
//! and CPU times and their ratios, the largest encoder difference in counts, and what the
//! integration cost. Then the same for SECONDS (default 120) of the Figs. 6–7 staircase
//! (`--parameter-set staircase`): its first level is Fig. 5's 100 µm, held for 100 s, so
//! a run shorter than that repeats Fig. 5 (the same DAC codes, the same integrator
//! steps); 120 s include the move to its second level, 60 µm.
//!
//! Last, the plant alone (`dist/InchwormPlant.fmu`) on the check trace's gaits
//! (tests/data/plant-check-trace-fia20-passive.csv, 1 s): its Co-Simulation and the
//! master's BDF on its Model Exchange, beside FMPy's CVode on the same Model Exchange
//! (`benches/fmpy_me.py` through the repository's `.venv/bin/python`; skipped, with the
//! reason printed, without it) at FMPy's default tolerance and at rtol 1e-8, output every 1
//! and 2 ms: wall and CPU time, steps, evaluations and the largest difference in counts
//! from the Co-Simulation plant, with the machine's load average.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use inchworm_cosim::input::InputTable;
use inchworm_cosim::{Coupling, Error, Interfaces, Options, System, Trace};

const ENCODER: &str = inchworm_scenarios::closed_loop::ENCODER_COUNTS;

/// The process's user and system CPU time (s): with the other cores busy the wall time
/// of a run varies, its CPU time much less.
#[cfg(unix)]
fn cpu_seconds() -> f64 {
    // SAFETY: getrusage only writes the struct it is given.
    let mut u: libc::rusage = unsafe { std::mem::zeroed() };
    let rc = unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut u) };
    assert_eq!(rc, 0, "getrusage");
    let s = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    s(u.ru_utime) + s(u.ru_stime)
}

#[cfg(not(unix))]
fn cpu_seconds() -> f64 {
    f64::NAN
}

/// The run's trace, wall and CPU seconds, and what the ME integration cost.
fn run(ssp: &Path, interfaces: &Interfaces, opts: &Options) -> (Trace, f64, f64, String) {
    let (trace, wall, cpu, cost, _) = run_stats(ssp, interfaces, opts);
    (trace, wall, cpu, cost)
}

/// [`run`], and the ME integration's steps and derivative and Jacobian-product evaluations.
fn run_stats(
    ssp: &Path,
    interfaces: &Interfaces,
    opts: &Options,
) -> (Trace, f64, f64, String, [u64; 3]) {
    let cpu = cpu_seconds();
    let t = Instant::now();
    let sim = System::load_as(ssp, interfaces).and_then(|s| s.initialise(opts)).expect("load");
    let mut trace = Trace::new(sim.record_names().to_vec());
    let mut cost = String::new();
    let mut counts = [0; 3];
    let mut sim = sim;
    for _ in 0..sim.n_steps() {
        sim.step().expect("step");
        trace.push(sim.time(), sim.sample().expect("sample"));
    }
    for (name, s) in sim.model_exchange_stats() {
        cost = format!(
            "{name}: {} BDF steps, {} derivative and {} Jacobian-vector calls, {} state and {} time events",
            s.steps, s.derivatives, s.jacobian_products, s.state_events, s.time_events
        );
        counts = [s.steps, s.derivatives, s.jacobian_products];
    }
    sim.terminate().expect("terminate");
    (trace, t.elapsed().as_secs_f64(), cpu_seconds() - cpu, cost, counts)
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|l| l.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}

/// The check trace's DAC volts as an input table (the text FMPy's input files have too): a
/// repeated time row at each change, so that both hold the volts piecewise constant.
fn gait_input(trace_csv: &str) -> String {
    let mut lines = trace_csv.lines();
    let head: Vec<&str> = lines.next().expect("header").split(',').collect();
    let names = inchworm_fmu_models::PlantFmu::DAC_INPUTS.map(|v| v.name());
    let col = |n: &str| head.iter().position(|h| *h == n).expect(n);
    let (t, dac) = (col("time"), names.map(col));
    let mut out = format!("time,{}\n", names.join(","));
    let mut prev: Option<Vec<&str>> = None;
    let mut last = 0.0;
    for line in lines.filter(|l| !l.is_empty()) {
        let f: Vec<&str> = line.split(',').collect();
        let cur: Vec<&str> = dac.iter().map(|&i| f[i]).collect();
        if let Some(p) = prev.as_ref().filter(|p| **p != cur) {
            out += &format!("{},{}\n", f[t], p.join(","));
        }
        if prev.as_ref() != Some(&cur) {
            out += &format!("{},{}\n", f[t], cur.join(","));
        }
        last = f[t].parse::<f64>().expect("time");
        prev = Some(cur);
    }
    out + &format!("{},{}\n", last + 0.002, prev.expect("rows").join(","))
}

/// What `benches/fmpy_me.py` printed, or why it did not run.
fn fmpy_me(root: &Path, plant: &Path, gait: &Path, cs: &Path) -> Result<String, String> {
    let python = root.join(".venv/bin/python");
    if !python.is_file() {
        return Err(format!("{} missing (scripts/setup.sh makes it)", python.display()));
    }
    let out = Command::new(&python)
        .arg(root.join("benches/fmpy_me.py"))
        .args([plant, gait, cs])
        .output()
        .map_err(|e| format!("{}: {e}", python.display()))?;
    if !out.status.success() {
        return Err(format!(
            "benches/fmpy_me.py failed: {}",
            String::from_utf8_lossy(&out.stderr).lines().last().unwrap_or("")
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// The plant alone on the check trace's gaits: its CS and the master's ME, then FMPy's
/// CVode on the ME, side by side.
fn plant_alone(root: &Path, dist: &Path) {
    const COUNTS: &str =
        inchworm_fmu_models::PlantFmu::name_of(inchworm_fmu_models::PlantFmu::ENCODER_COUNTS);
    let plant = dist.join("InchwormPlant.fmu");
    let trace =
        std::fs::read_to_string(root.join("tests/data/plant-check-trace-fia20-passive.csv"))
            .expect("tests/data's check trace");
    let gait = gait_input(&trace);
    let opts = Options {
        stop_time: Some(1.0),
        step_size: Some(0.002),
        coupling: Coupling::Jacobi,
        params: vec![],
        parameter_set: None,
        input: Some(InputTable::parse(&gait).expect("gait input")),
        outputs: vec![COUNTS.into()],
    };
    let me = Interfaces { model_exchange: vec!["fmu".into()], ..Interfaces::default() };
    let (cs, cs_s, cs_cpu, _, _) = run_stats(&plant, &Interfaces::default(), &opts);
    let (bdf, me_s, me_cpu, _, [steps, rhs, jac]) = run_stats(&plant, &me, &opts);
    let (a, b) = (cs.column(COUNTS).unwrap(), bdf.column(COUNTS).unwrap());
    let worst = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    println!("The plant alone on the check trace's gaits, 1 s, {} samples of 2 ms", a.len());
    println!(
        "  {:<44} {:>8} {:>8} {:>8} {:>8} {:>16} {:>7}",
        "run", "wall s", "CPU s", "x real", "steps", "RHS + Jacobian", "counts"
    );
    let line = |name: &str, wall: f64, cpu: f64, steps: &str, evals: &str, worst: &str| {
        println!(
            "  {name:<44} {wall:>8.4} {cpu:>8.4} {:>8.1} {steps:>8} {evals:>16} {worst:>7}",
            1.0 / wall
        );
    };
    line("master, plant CS (exact solver)", cs_s, cs_cpu, "", "", "");
    line(
        "master, plant ME (BDF, rtol 1e-9, atol 1e-11)",
        me_s,
        me_cpu,
        &steps.to_string(),
        &format!("{rhs} + {jac}"),
        &worst.to_string(),
    );
    let dir = std::env::temp_dir().join(format!("inchworm-bench-me-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary folder");
    let (gait_csv, cs_csv) = (dir.join("gait.csv"), dir.join("cs.csv"));
    std::fs::write(&gait_csv, &gait).expect("gait.csv");
    // The trace's rows are the samples at the end of each step: 2 ms, 4 ms, …, 1 s.
    let samples: String =
        a.iter().enumerate().map(|(k, c)| format!("{},{c}\n", 0.002 * (k + 1) as f64)).collect();
    std::fs::write(&cs_csv, format!("time,{COUNTS}\n{samples}")).expect("cs.csv");
    let fmpy = fmpy_me(root, &plant, &gait_csv, &cs_csv);
    let _ = std::fs::remove_dir_all(&dir);
    let text = match fmpy {
        Ok(text) => text,
        Err(why) => return println!("  FMPy's CVode skipped: {why}"),
    };
    let mut call_us = None;
    let mut callbacks = (0.0, 0.0);
    for l in text.lines() {
        let f: Vec<&str> = l.split_whitespace().collect();
        match f[..] {
            ["fmpy-me", rtol, interval, wall, cpu, steps, rhs, jac_rhs, root, worst, _] => {
                let (wall, cpu): (f64, f64) = (wall.parse().unwrap(), cpu.parse().unwrap());
                let interval = interval.parse::<f64>().unwrap() * 1e3;
                line(
                    &format!("FMPy CVode, rtol {rtol}, output every {interval} ms"),
                    wall,
                    cpu,
                    steps,
                    &format!("{rhs} + {jac_rhs}, {root} roots"),
                    worst,
                );
                let n: f64 = [rhs, jac_rhs, root].iter().map(|x| x.parse::<f64>().unwrap()).sum();
                callbacks = (n, wall);
            }
            ["fmpy-call", us] => call_us = us.parse::<f64>().ok(),
            _ => println!("  benches/fmpy_me.py printed `{l}`"),
        }
    }
    if let Some(us) = call_us {
        let (n, wall) = callbacks;
        println!(
            "  FMPy's right-hand side through its Python callback and ctypes: {us:.2} us a call; its last run's \
             {n} callbacks (RHS, Jacobian's RHS, roots) at that: {:.3} s of its {wall:.3} s ({:.0} %)",
            n * us * 1e-6,
            100.0 * n * us * 1e-6 / wall
        );
        println!(
            "  the master's ME: {:.2} us of CPU a BDF step, {:.2} us an evaluation (RHS or Jacobian product)",
            me_cpu / steps as f64 * 1e6,
            me_cpu / (rhs + jac) as f64 * 1e6
        );
    }
}

fn compare(label: &str, ssp: &Path, opts: &Options) {
    let plant_me = Interfaces { model_exchange: vec!["plant".into()], ..Interfaces::default() };
    let (cs, cs_s, cs_cpu, _) = run(ssp, &Interfaces::default(), opts);
    let (me, me_s, me_cpu, cost) = run(ssp, &plant_me, opts);
    let (a, b) = (cs.column(ENCODER).unwrap(), me.column(ENCODER).unwrap());
    let worst = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    let stop = opts.stop_time.unwrap();
    println!("{label}, {stop} s, 2 ms Jacobi");
    println!(
        "  plant CS (exact solver):    {cs_s:>8.3} s wall, {cs_cpu:>8.3} s CPU, {:>8.1}x real time",
        stop / cs_s
    );
    println!(
        "  plant ME (master's BDF):    {me_s:>8.3} s wall, {me_cpu:>8.3} s CPU, {:>8.2}x real time",
        stop / me_s
    );
    println!(
        "  ME / CS:                    {:>8.0}x wall, {:>8.0}x CPU",
        me_s / cs_s,
        me_cpu / cs_cpu
    );
    println!("  largest encoder difference: {worst} counts over {} samples", a.len());
    println!("  {cost}");
}

fn main() -> Result<(), Error> {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let ssp =
        args.first().map(PathBuf::from).unwrap_or_else(|| root.join("dist/InchwormSystem.ssp"));
    let staircase: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(120.0);
    assert!(ssp.is_file(), "build the FMUs and the SSP first: cargo run --release -p fmu-build");
    let load = load_average();
    let opts = |stop: f64, set: Option<&str>| Options {
        stop_time: Some(stop),
        step_size: Some(0.002),
        coupling: Coupling::Jacobi,
        params: vec![],
        parameter_set: set.map(str::to_owned),
        input: None,
        outputs: vec![ENCODER.into()],
    };
    compare("Fig. 5 (100 um step, full control)", &ssp, &opts(2.0, None));
    compare("Figs. 6-7 staircase", &ssp, &opts(staircase, Some("staircase")));
    let dist = ssp.parent().unwrap_or(Path::new("."));
    plant_alone(root, dist);
    println!("machine load average (1, 5, 15 min): {load} before, {} after", load_average());
    Ok(())
}
