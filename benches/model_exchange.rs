//! `cargo bench -p inchworm --bench model_exchange [-- SSP [SECONDS]]`: the Fig. 5 closed
//! loop (dist/InchwormSystem.ssp, default parameters, 2 ms Jacobi) with the plant stepped
//! by its own Co-Simulation (the exact solver) and with the plant's Model Exchange
//! integrated by the master (diffsol's BDF, docs/model-exchange.md), side by side: wall
//! times, the largest encoder difference in counts, and what the integration cost. Then
//! the same for SECONDS (default 10) of the Figs. 6–7 staircase (`--parameter-set
//! staircase`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use inchworm_cosim::model_exchange::Tolerance;
use inchworm_cosim::{Coupling, Error, Interfaces, Options, System, Trace};

const ENCODER: &str = "plant.encoder_counts";

fn run(ssp: &Path, interfaces: &Interfaces, opts: &Options) -> (Trace, f64, String) {
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
    (trace, t.elapsed().as_secs_f64(), cost)
}

fn compare(label: &str, ssp: &Path, opts: &Options) {
    let plant_me =
        Interfaces { model_exchange: vec!["plant".into()], tolerance: Tolerance::default() };
    let (cs, cs_s, _) = run(ssp, &Interfaces::default(), opts);
    let (me, me_s, cost) = run(ssp, &plant_me, opts);
    let (a, b) = (cs.column(ENCODER).unwrap(), me.column(ENCODER).unwrap());
    let worst = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    let stop = opts.stop_time.unwrap();
    println!("{label}, {stop} s, 2 ms Jacobi");
    println!("  plant CS (exact solver):    {cs_s:>8.3} s wall, {:>8.1}x real time", stop / cs_s);
    println!("  plant ME (master's BDF):    {me_s:>8.3} s wall, {:>8.2}x real time, {:.0}x the CS wall time", stop / me_s, me_s / cs_s);
    println!("  largest encoder difference: {worst} counts over {} samples", a.len());
    println!("  {cost}");
}

fn main() -> Result<(), Error> {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let ssp =
        args.first().map(PathBuf::from).unwrap_or_else(|| root.join("dist/InchwormSystem.ssp"));
    let staircase: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(10.0);
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
