//! `cargo bench -p inchworm --bench closed_loop`: the closed loop through both FMUs over
//! 600 s of the Figs. 6–7 staircase (prefilter on), stepped by the Rust master
//! (`inchworm run` on dist/InchwormSystemOpen.ssp), by the direct coupling of the crates, and
//! by a plain Jacobi loop in FMPy, all in this one run; prints wall times, real-time
//! factors and the ratio, and checks that all three end on the same encoder count.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use inchworm_controller::Params;
use inchworm_cosim::master::run;
use inchworm_plant::PlantParams;
use inchworm_scenarios::closed_loop::run as direct;
use inchworm_scenarios::scenario;

const DURATION: f64 = 600.0;

fn main() {
    // The package is the workspace root: dist/ and .venv/ live there.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dist = root.join("dist");
    let ssp = dist.join("InchwormSystemOpen.ssp");
    assert!(ssp.is_file(), "build the FMUs and the SSP first: cargo run --release -p fmu-build");
    let s = scenario::by_name("staircase").expect("a scenario");
    let controller = Params { prefilter: true, ..Params::default() };
    // The staircase scenario's options, cut to 600 s and to the one column compared, so
    // the master records no more than the FMPy loop does.
    let mut opts = s.options(&PlantParams::fia20(), &controller);
    opts.stop_time = Some(DURATION);
    opts.outputs = vec!["plant.encoder_counts".into()];
    let t = Instant::now();
    let master = run(&ssp, &opts, |_| {}).expect("master run");
    let master_s = t.elapsed().as_secs_f64();
    let master_final = *master.column("plant.encoder_counts").unwrap().last().unwrap() as i64;

    let t = Instant::now();
    let d = direct(PlantParams::fia20(), controller, |t| s.reference.value(0, t), DURATION)
        .expect("direct run");
    let direct_s = t.elapsed().as_secs_f64();
    let direct_final = *d.column("plant.encoder_counts").unwrap().last().unwrap() as i64;

    let python = root.join(".venv/bin/python");
    let out = Command::new(&python)
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/fmpy_jacobi.py"))
        .arg(&dist)
        .arg(DURATION.to_string())
        .output();
    let fmpy = out.ok().filter(|o| o.status.success()).and_then(|o| {
        let s = String::from_utf8_lossy(&o.stdout).to_string();
        let f: Vec<f64> = s.split_whitespace().skip(1).filter_map(|x| x.parse().ok()).collect();
        (f.len() == 3).then(|| (f[1], f[2] as i64))
    });

    println!("closed loop through both FMUs, {DURATION:.0} s of the Figs. 6-7 staircase, prefilter on, 2 ms Jacobi");
    println!("  Rust master (inchworm run, SSP):   {master_s:>7.3} s wall, {:>6.0}x real time, final encoder {master_final}", DURATION / master_s);
    println!("  crates coupled directly (no FMI):  {direct_s:>7.3} s wall, {:>6.0}x real time, final encoder {direct_final}", DURATION / direct_s);
    match fmpy {
        Some((wall, final_count)) => {
            println!("  FMPy Jacobi loop (Python):         {wall:>7.3} s wall, {:>6.0}x real time, final encoder {final_count}", DURATION / wall);
            println!("ratio: the Rust master is {:.1}x faster than the FMPy loop", wall / master_s);
            assert_eq!(final_count, master_final, "FMPy and the Rust master disagree");
        }
        None => println!(
            "  FMPy Jacobi loop: not run ({} missing or failed; run scripts/setup.sh)",
            python.display()
        ),
    }
    assert_eq!(master_final, direct_final, "the master and the direct coupling disagree");
}
