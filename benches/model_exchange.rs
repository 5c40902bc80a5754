//! `cargo bench -p inchworm --bench model_exchange [-- SSP [SECONDS]]`: the Fig. 5 closed
//! loop (dist/InchwormSystem.ssp, default parameters, 2 ms Jacobi) with the plant stepped
//! by its own Co-Simulation (the exact solver) and with the plant's Model Exchange
//! integrated by the master (diffsol's BDF, docs/model-exchange.md), side by side: wall
//! and CPU times and their ratios, the largest encoder difference in counts, and what the
//! integration cost. Then the same for SECONDS (default 120) of the Figs. 6–7 staircase
//! (`--parameter-set staircase`): its first level is Fig. 5's 100 µm, held for 100 s, so
//! a run shorter than that repeats Fig. 5 (the same DAC codes, the same integrator
//! steps); 120 s include the move to its second level, 60 µm.

use std::path::{Path, PathBuf};
use std::time::Instant;

use inchworm_cosim::{Coupling, Error, Interfaces, Options, System, Trace};

const ENCODER: &str = "plant.encoder_counts";

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
    let cpu = cpu_seconds();
    let t = Instant::now();
    let sim = System::load_as(ssp, interfaces).and_then(|s| s.initialise(opts)).expect("load");
    let mut trace = Trace::new(sim.record_names().to_vec());
    let mut cost = String::new();
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
    }
    sim.terminate().expect("terminate");
    (trace, t.elapsed().as_secs_f64(), cpu_seconds() - cpu, cost)
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
    Ok(())
}
