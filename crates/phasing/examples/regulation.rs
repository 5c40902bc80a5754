//! The segmented mirror co-phased and then regulated under the disturbances, for the three
//! controller modes (stepping, deadband, analog), through the edge sensors and the
//! reconstructor and with perfect knowledge (docs/phasing.md, "Regulation"):
//!
//! ```text
//! cargo run --release -p inchworm-phasing --example regulation -- \
//!     [SECONDS] [--rings R] [--rate HZ] [--noise NM] [--mode M] [--out DIR] [--sweep]
//! ```
//!
//! `--mode` runs one of the modes alone. `--rings` takes 1 to 16 (7 to 817 segments, ELT-class); poses are written up to 6 rings
//! (127 segments), the optics' largest. SECONDS (default 20) is the run; the cell's deformation ramps to 1 µm of co-phasing
//! error over it, and the regulation's numbers are from a quarter of the run on. The
//! global loop runs at `--rate` (default 10 Hz), averaging its last fifth of a period; the
//! sensors' white noise is `--noise` (default 1 nm). With `--out`, it writes
//! `regulation.csv` (the table) and every run's poses at every sample,
//! `poses-<mode>-<knowledge>.csv`, which `python -m inchworm_segments --poses` turns into
//! the coronagraph's figures. The poses written are those the optics see: the whole
//! mirror's piston, tip and tilt, which no edge sensor sees, taken out by the telescope's
//! pointing ([`Pointing`]).
//!
//! `--sweep` varies one factor at a time about those defaults (the sensors' noise 0 to
//! 10 nm, the rate 1 to 50 Hz, the mirror 7 to 91 segments) and writes
//! `sensitivity.csv` with `--out`.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use inchworm_cosim::output;
use inchworm_phasing::cophasing::{
    self, controller, GlobalLoop, Knowledge, Pointing, Setup, MODES, SAMPLE_PERIOD,
};
use inchworm_phasing::disturbances::{CellDeformation, Disturbances, SensorNoise, Wind};
use inchworm_phasing::{EdgeSensors, Mirror, Reconstructor};
use inchworm_scenarios::segmented;

/// `fmu-build segmented`'s default seed: its errors and its actuators' draws.
const SEED: u64 = 1;

/// One configuration: the mirror's rings, the global loop's rate (Hz), the sensors' white
/// noise (m).
#[derive(Clone, Copy, Debug)]
struct Case {
    rings: u32,
    rate: f64,
    noise: f64,
}

struct Args {
    seconds: f64,
    case: Case,
    out: Option<PathBuf>,
    sweep: bool,
    modes: Vec<&'static str>,
}

fn number(name: &str, v: &str, lo: f64, hi: f64, unit: &str) -> Result<f64, String> {
    v.parse::<f64>()
        .ok()
        .filter(|x| (lo..=hi).contains(x))
        .ok_or(format!("{name} {v}: a number from {lo} to {hi} {unit}"))
}

fn parse() -> Result<Args, String> {
    let case = Case { rings: 3, rate: 10.0, noise: 1e-9 };
    let mut args = Args { seconds: 20.0, case, out: None, sweep: false, modes: MODES.to_vec() };
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        let mut value = |name: &str| it.next().ok_or(format!("{name} needs a value"));
        match a.as_str() {
            "--rings" => {
                let v = value("--rings")?;
                args.case.rings = v
                    .parse()
                    .ok()
                    .filter(|r| (1..=16).contains(r))
                    .ok_or(format!("--rings {v}: a whole number from 1 to 16 (817 segments)"))?
            }
            "--rate" => args.case.rate = number("--rate", &value("--rate")?, 0.1, 250.0, "Hz")?,
            "--noise" => {
                args.case.noise = 1e-9 * number("--noise", &value("--noise")?, 0.0, 1e3, "nm")?
            }
            "--out" => args.out = Some(PathBuf::from(value("--out")?)),
            "--sweep" => args.sweep = true,
            "--mode" => {
                let v = value("--mode")?;
                let mode = MODES
                    .iter()
                    .find(|m| **m == v)
                    .ok_or(format!("--mode {v}: one of {MODES:?}"))?;
                args.modes = vec![mode];
            }
            s => args.seconds = number("SECONDS", s, 1.0, 3600.0, "s")?,
        }
    }
    Ok(args)
}

/// One run's numbers.
struct Row {
    case: Case,
    mode: &'static str,
    knowledge: &'static str,
    parked: f64,
    every_sample: f64,
    apart: Option<f64>,
    wall: f64,
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("regulation: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<(), String> {
    let args = parse()?;
    // The optics take up to 6 rings (127 segments); larger mirrors write their table alone.
    let poses = !args.sweep && args.case.rings <= 6;
    let names: Vec<String> = if args.sweep {
        vec!["sensitivity.csv".into()]
    } else if !poses {
        vec!["regulation.csv".into()]
    } else {
        args.modes
            .iter()
            .flat_map(|m| ["perfect", "edge-sensors"].map(|k| format!("poses-{m}-{k}.csv")))
            .chain(["regulation.csv".to_string()])
            .collect()
    };
    if let Some(dir) = &args.out {
        let paths: Vec<PathBuf> = names.iter().map(|f| dir.join(f)).collect();
        let outputs: Vec<(&str, &Path)> =
            names.iter().zip(&paths).map(|(f, p)| (f.as_str(), p.as_path())).collect();
        output::check(&outputs, &[]).map_err(|e| e.to_string())?;
    }
    println!(
        "{:.1} s: sensors' bias 2 nm and drift 10 nm in 8 h; the cell to 1 µm over the run; wind 5 nm, 20 nrad, 1 Hz; regulation from {} s",
        args.seconds,
        args.seconds / 4.0
    );
    println!("segments rate_Hz noise_nm mode      knowledge     parked_nm every_sample_nm apart_nm wall_s");
    let cases = if args.sweep {
        let d = args.case;
        let mut cases = vec![d];
        cases.extend([0.0, 3e-9, 10e-9].map(|noise| Case { noise, ..d }));
        cases.extend([1.0, 2.0, 5.0, 25.0, 50.0].map(|rate| Case { rate, ..d }));
        cases.extend([1, 2, 5].map(|rings| Case { rings, ..d }));
        cases
    } else {
        vec![args.case]
    };
    let mut rows = Vec::new();
    for case in cases {
        let poses_out = if poses { args.out.as_deref() } else { None };
        for row in study(case, &args.modes, args.seconds, poses_out)? {
            print_row(&row);
            rows.push(row);
        }
    }
    if let Some(dir) = &args.out {
        let mut table = String::from(
            "segments,rate_hz,noise_nm,mode,knowledge,parked_nm,every_sample_nm,apart_from_perfect_nm,wall_s\n",
        );
        for r in &rows {
            let apart = r.apart.map(|a| format!("{:.4}", a * 1e9)).unwrap_or_default();
            table.push_str(&format!(
                "{},{},{},{},{},{:.4},{:.4},{},{:.3}\n",
                segments(r.case.rings),
                r.case.rate,
                r.case.noise * 1e9,
                r.mode,
                r.knowledge,
                r.parked * 1e9,
                r.every_sample * 1e9,
                apart,
                r.wall
            ));
        }
        let name = names.last().expect("a table");
        output::write(&dir.join(name), table.as_bytes()).map_err(|e| e.to_string())?;
        println!("regulation: wrote {} files in {}", names.len(), dir.display());
    }
    Ok(())
}

fn segments(rings: u32) -> u32 {
    3 * rings * (rings + 1) + 1
}

fn print_row(r: &Row) {
    let apart = r.apart.map(|a| format!("{:.3}", a * 1e9)).unwrap_or_default();
    println!(
        "{:8} {:7} {:8} {:9} {:13} {:9.3} {:15.3} {:>8} {:6.2}",
        segments(r.case.rings),
        r.case.rate,
        r.case.noise * 1e9,
        r.mode,
        r.knowledge,
        r.parked * 1e9,
        r.every_sample * 1e9,
        apart,
        r.wall
    );
}

/// Every mode with perfect knowledge and through the edge sensors, for `case`; every run's
/// poses written into `out` when given.
fn study(
    case: Case,
    modes: &[&'static str],
    seconds: f64,
    out: Option<&Path>,
) -> Result<Vec<Row>, String> {
    let err = |e: inchworm_phasing::PhasingError| e.to_string();
    let mirror = Mirror::new(case.rings, true, 0.15, 0.003).map_err(err)?;
    let n = mirror.segments();
    let sensors = EdgeSensors::new(&mirror, 0.005).map_err(err)?;
    // The normal equations: the SVD's reconstructor at its default threshold (the closed-form
    // tests), in seconds at ELT-class sizes.
    let start = std::time::Instant::now();
    let reconstructor = Reconstructor::normal_equations(
        &mirror,
        &sensors.sparse(mirror.centres()),
        sensors.dihedral,
    )
    .map_err(err)?;
    eprintln!(
        "regulation: {n} segments' reconstructor in {:.2} s, noise multiplier {:.3}",
        start.elapsed().as_secs_f64(),
        reconstructor.noise_multiplier()
    );
    let published = SensorNoise::published();
    let disturbances = Disturbances {
        sensors: Some(
            SensorNoise::new(case.noise, published.bias, published.drift, 1).map_err(err)?,
        ),
        cell: Some(CellDeformation::new(1e-6, seconds, 3).map_err(err)?),
        wind: Some(Wind::published()),
    };
    let period = ((1.0 / case.rate) / SAMPLE_PERIOD).round().max(1.0) as usize;
    let global = GlobalLoop { period, gain: 1.0, average: (period / 5).max(1) };
    let pointing = Pointing::new(&mirror);
    let from = ((seconds / 4.0) / SAMPLE_PERIOD).round() as usize;
    let mut rows = Vec::new();
    for &mode in modes {
        let setup = Setup {
            mirror: mirror.clone(),
            sensors: sensors.clone(),
            errors: segmented::errors(SEED, n),
            plants: segmented::draws(SEED, 3 * n).iter().map(|d| d.plant()).collect(),
            controller: controller(mode).expect("a mode of MODES"),
            disturbances,
        };
        let mut perfect_parked: Option<Vec<[f64; 3]>> = None;
        for (name, knowledge) in [
            ("perfect", Knowledge::Perfect),
            ("edge-sensors", Knowledge::EdgeSensors(reconstructor.clone())),
        ] {
            let mut csv = Vec::new();
            let start = std::time::Instant::now();
            let result =
                cophasing::run_observed(&setup, &knowledge, global, seconds, |t, poses| {
                    if out.is_some() {
                        write_row(&mut csv, t, &pointing.correct(poses));
                    }
                })
                .map_err(err)?;
            let wall = start.elapsed().as_secs_f64();
            let tail = &result.cophasing_rms[from..];
            let every_sample = (tail.iter().map(|r| r * r).sum::<f64>() / tail.len() as f64).sqrt();
            let parked = cophasing::cophasing_rms(&mirror, &result.parked);
            let apart =
                perfect_parked.as_ref().map(|p| cophasing::apart(&mirror, p, &result.parked));
            if perfect_parked.is_none() {
                perfect_parked = Some(result.parked.clone());
            }
            if let Some(dir) = out {
                let mut file = header(n);
                file.extend(csv);
                output::write(&dir.join(format!("poses-{mode}-{name}.csv")), &file)
                    .map_err(|e| e.to_string())?;
            }
            rows.push(Row { case, mode, knowledge: name, parked, every_sample, apart, wall });
        }
    }
    Ok(rows)
}

/// The poses CSV's header, python/inchworm_segments' columns.
fn header(n: usize) -> Vec<u8> {
    let mut h = String::from("time");
    for k in 0..n {
        h.push_str(&format!(",seg{k}_piston_m,seg{k}_tip_rad,seg{k}_tilt_rad"));
    }
    h.push('\n');
    h.into_bytes()
}

/// One sample's row; every float as Rust prints it, which reads back to the same bits.
fn write_row(csv: &mut Vec<u8>, t: f64, poses: &[[f64; 3]]) {
    write!(csv, "{t}").expect("writing to memory");
    for p in poses {
        write!(csv, ",{},{},{}", p[0], p[1], p[2]).expect("writing to memory");
    }
    csv.push(b'\n');
}
