//! `inchworm sweep`: a grid and/or Monte Carlo sweep over any parameters of a system, each
//! run reduced to metrics; the plan, the results table and summary plots written to a
//! folder. With `--plan` it runs a plan made elsewhere, and with `--row`/`--json` prints
//! each run as one JSON line (what another engine, such as python/inchworm_dask, calls).

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::time::Instant;

use clap::Args;

use inchworm_cosim::sweep::exec::{self, Setup};
use inchworm_cosim::sweep::metrics::Metrics;
use inchworm_cosim::sweep::plan::{self, Plan};
use inchworm_cosim::sweep::{self as sw};
use inchworm_cosim::Error;
use inchworm_scenarios::metrics::{self, LoopMetrics};
use inchworm_scenarios::{plot, sweep_plots as plots};

use super::{signals, Text};

use super::run::SimArgs;

#[derive(Args)]
pub struct SweepArgs {
    /// The system (.ssp) or FMU (.fmu).
    pub file: PathBuf,
    /// A grid axis: component.variable=a:b:n (n points, ends included) or =v1;v2;…;
    /// repeatable (cartesian product, first axis outermost).
    #[arg(long = "grid", value_name = "NAME=a:b:n")]
    pub grids: Vec<String>,
    /// A Monte Carlo axis: component.variable=normal(mean,sd), uniform(lo,hi) or
    /// lognormal(mu,sigma) (of the logarithm); repeatable.
    #[arg(long = "sample", value_name = "NAME=DIST(a,b)")]
    pub samples_of: Vec<String>,
    /// Monte Carlo draws (per grid point).
    #[arg(long, default_value_t = 100)]
    pub samples: usize,
    /// Seed of the splitmix64 stream the draws come from.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// A metric per run: settle[:TOL], rms:FROM:TO, disturbance, slips, final:NAME,
    /// min:NAME, max:NAME; repeatable; default (for the actuator's systems): settle:1e-6,
    /// disturbance, slips, final:plant.encoder_position.
    #[arg(long = "metric", value_name = "METRIC")]
    pub metrics: Vec<String>,
    /// Worker threads, each with its own loaded system; default: every core.
    #[arg(long)]
    pub jobs: Option<usize>,
    #[command(flatten)]
    pub sim: SimArgs,
    /// The folder for plan.csv, results.csv and the plots.
    #[arg(long, default_value = "out/sweep")]
    pub out: PathBuf,
    /// Write <out>/plan.csv and stop.
    #[arg(long)]
    pub plan_only: bool,
    /// Run this plan (a plan.csv) instead of one from --grid/--sample.
    #[arg(long, conflicts_with_all = ["grids", "samples_of"])]
    pub plan: Option<PathBuf>,
    /// With --plan: run only the row whose run index is K, and print it as one JSON line;
    /// repeatable.
    #[arg(long = "row", value_name = "K", requires = "plan")]
    pub rows: Vec<usize>,
    /// Print each run as one JSON line on stdout instead of writing files.
    #[arg(long)]
    pub json: bool,
    /// Skip the summary plots.
    #[arg(long)]
    pub no_plots: bool,
    /// Histogram bins.
    #[arg(long, default_value_t = 30)]
    pub bins: usize,
    #[arg(long, default_value = plot::DEFAULT_FONT)]
    pub font: PathBuf,
}

fn plan_of(args: &SweepArgs) -> Result<Plan, String> {
    if let Some(p) = &args.plan {
        // Read line by line: with --row only the rows asked for are kept, whatever the
        // plan's size.
        let f = std::fs::File::open(p).map_err(|e| format!("{}: {e}", p.display()))?;
        let only = (!args.rows.is_empty()).then_some(args.rows.as_slice());
        return Plan::read(std::io::BufReader::new(f), only)
            .map_err(|e| format!("{}: {e}", p.display()));
    }
    let mut sweeps = Vec::new();
    for g in &args.grids {
        sweeps.push(plan::parse_grid(g).text()?);
    }
    for s in &args.samples_of {
        sweeps.push(plan::parse_sample(s).text()?);
    }
    if sweeps.is_empty() {
        return Err("nothing to sweep: give --grid, --sample or --plan".into());
    }
    Plan::build(&sweeps, args.samples, args.seed).text()
}

/// A progress line on stderr, redrawn at most 10 times a second: bar, count, rate, ETA.
struct Progress {
    total: usize,
    start: Instant,
    last: Option<Instant>,
}

impl Progress {
    fn show(&mut self, done: usize) {
        let now = Instant::now();
        if done < self.total && self.last.is_some_and(|l| now.duration_since(l).as_millis() < 100) {
            return;
        }
        self.last = Some(now);
        let el = self.start.elapsed().as_secs_f64();
        let rate = done as f64 / el.max(1e-9);
        let eta = (self.total - done) as f64 / rate.max(1e-9);
        let w = 30;
        let filled = done * w / self.total.max(1);
        eprint!(
            "\r[{}{}] {done}/{} {rate:.1} runs/s ETA {}:{:02} ",
            "#".repeat(filled),
            "-".repeat(w - filled),
            self.total,
            (eta as u64) / 60,
            (eta as u64) % 60
        );
        if done == self.total {
            eprintln!();
        }
    }
}

fn safe_name(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_ascii_alphanumeric() || c == '.' || c == '-' { c } else { '_' })
        .collect()
}

/// The most summary plots a sweep draws: one histogram per metric and one scatter plot
/// per metric and parameter, so a plan of many columns would otherwise write thousands.
const MAX_PLOTS: usize = 64;

/// The most metrics a sweep computes.
const MAX_METRICS: usize = 64;

/// The most histogram bins: the counts are allocated per plot, and a 1000-pixel-wide
/// plot shows no more.
const MAX_BINS: usize = 1000;

/// The most worker threads: each holds a loaded system (its FMUs unpacked and loaded).
const MAX_JOBS: usize = 256;

/// The number of summary plots, refused above [`MAX_PLOTS`] with the arithmetic.
fn plot_count(metrics: usize, parameters: usize) -> Result<usize, String> {
    let plots = parameters.checked_add(1).and_then(|p| p.checked_mul(metrics));
    match plots {
        Some(n) if n <= MAX_PLOTS => Ok(n),
        _ => Err(format!(
            "{metrics} metrics × (1 histogram + {parameters} parameters) = {} plots: more than the {MAX_PLOTS} a sweep draws; give --no-plots, or fewer metrics or parameters",
            plots.map_or("too many".to_string(), |n| n.to_string())
        )),
    }
}

/// Everything the sweep will write, checked before the first run (a sweep may take
/// hours, and a path refused at the end loses all of it): the font, the plot count, the
/// folder made and writable, and no file to write a folder.
fn check_outputs(args: &SweepArgs, plan: &Plan, metrics: &[String]) -> Result<(), String> {
    let mut files = vec![args.out.join("plan.csv"), args.out.join("results.csv")];
    if !args.no_plots {
        if args.bins > MAX_BINS {
            return Err(format!(
                "--bins {}: more than the {MAX_BINS} bins a histogram draws",
                args.bins
            ));
        }
        plot_count(metrics.len(), plan.names.len())?;
        plot::load_font(&args.font).text()?;
        for m in metrics {
            files.push(args.out.join(format!("hist_{}.png", safe_name(m))));
            for name in &plan.names {
                files.push(args.out.join(format!("{}_vs_{}.png", safe_name(m), safe_name(name))));
            }
        }
    }
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    if let Some(f) = files.iter().find(|f| f.is_dir()) {
        return Err(format!("{}: is a folder, cannot write the file there", f.display()));
    }
    // A file made and removed: the folder takes new files (permissions, a read-only disk).
    tempfile::Builder::new()
        .prefix(".inchworm-sweep-")
        .tempfile_in(&args.out)
        .map_err(|e| format!("{}: cannot write there: {e}", args.out.display()))?;
    Ok(())
}

pub fn run(args: &SweepArgs) -> Result<(), String> {
    let metrics = if args.metrics.is_empty() {
        LoopMetrics::parse(&metrics::DEFAULT)
    } else {
        LoopMetrics::parse(&args.metrics)
    }
    .text()?;
    let metric_names = metrics.names();
    if metric_names.len() > MAX_METRICS {
        return Err(format!(
            "{} metrics: more than the {MAX_METRICS} a sweep computes",
            metric_names.len()
        ));
    }
    if let Some(m) = metric_names
        .iter()
        .enumerate()
        .find_map(|(i, m)| metric_names[..i].iter().any(|n| n == m).then_some(m))
    {
        return Err(format!("--metric {m} is given twice (it names one column of the results)"));
    }
    let plan = plan_of(args)?;
    let metrics = metrics.for_system(&args.file).text()?;
    if args.plan_only {
        return super::write_file(&args.out.join("plan.csv"), |w| {
            w.write_all(plan.to_csv().as_bytes())
        });
    }
    let setup = Setup {
        system: args.file.clone(),
        options: args.sim.options(Vec::new())?,
        metrics: std::sync::Arc::new(metrics),
    };
    let jobs =
        args.jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    if jobs > MAX_JOBS {
        return Err(format!("--jobs {jobs}: more than the {MAX_JOBS} worker threads a sweep runs"));
    }
    let json = args.json || !args.rows.is_empty();
    if !json {
        check_outputs(args, &plan, &metric_names)?;
    }
    let mut bar = (!json && std::io::stderr().is_terminal()).then(|| Progress {
        total: plan.rows.len(),
        start: Instant::now(),
        last: None,
    });
    // A stop signal ends the sweep between two steps; the runs done are still written.
    let stop = signals::stop_on_signals();
    let wall = Instant::now();
    let mut outcomes = exec::run_plan_until(&setup, &plan, jobs, &stop, |done| {
        if let Some(b) = bar.as_mut() {
            b.show(done);
        }
    });
    // The run the signal stopped says which signal it was, as `inchworm run` does.
    if signals::stop_signal().is_some() {
        let stopped = Error::Stopped.to_string();
        for o in outcomes.iter_mut().filter(|o| o.error.as_deref() == Some(stopped.as_str())) {
            o.error = Some(signals::describe(Error::Stopped));
        }
    }
    let wall = wall.elapsed().as_secs_f64();
    if json {
        let mut out = std::io::stdout().lock();
        for o in &outcomes {
            writeln!(out, "{}", sw::json_line(&plan.names, &metric_names, o))
                .map_err(|e| format!("stdout: {e}"))?;
        }
        return signals::interrupted();
    }
    super::write_file(&args.out.join("plan.csv"), |w| w.write_all(plan.to_csv().as_bytes()))?;
    let table = sw::results_csv(&plan.names, &metric_names, &outcomes);
    super::write_file(&args.out.join("results.csv"), |w| w.write_all(table.as_bytes()))?;
    if let Err(e) = signals::interrupted() {
        return Err(format!(
            "{e} ({} holds the runs done)",
            args.out.join("results.csv").display()
        ));
    }
    let failed = outcomes.iter().filter(|o| o.error.is_some()).count();
    println!(
        "{} runs in {wall:.2} s on {jobs} thread(s) ({:.1} runs/s); {failed} failed",
        outcomes.len(),
        outcomes.len() as f64 / wall.max(1e-9)
    );
    if let Some(o) = outcomes.iter().find(|o| o.error.is_some()) {
        println!("  first failure, run {}: {}", o.run, o.error.as_deref().unwrap_or(""));
    }
    for (i, name) in metric_names.iter().enumerate() {
        let values: Vec<Option<f64>> = outcomes
            .iter()
            .filter(|o| o.error.is_none())
            .map(|o| o.metrics.get(i).copied().flatten())
            .collect();
        let s = sw::stats(&values);
        println!(
            "  {:<32} n {:>5}  none {:>4}  mean {:.6e}  sd {:.3e}  min {:.6e}  median {:.6e}  max {:.6e}",
            name, s.n, s.missing, s.mean, s.sd, s.min, s.median, s.max
        );
        if args.no_plots {
            continue;
        }
        let present: Vec<f64> =
            values.iter().flatten().copied().filter(|v| v.is_finite()).collect();
        let title = format!("{}: {} runs with a value, {} without", name, present.len(), s.missing);
        let png = args.out.join(format!("hist_{}.png", safe_name(name)));
        super::write_png(&png, |p| plots::histogram_png(&title, name, &present, args.bins, p))?;
        for (j, param) in plan.names.iter().enumerate() {
            let points: Vec<(f64, f64)> = outcomes
                .iter()
                .filter_map(|o| {
                    let y = o.metrics.get(i).copied().flatten().filter(|v| v.is_finite())?;
                    Some((o.values[j], y))
                })
                .collect();
            let png = args.out.join(format!("{}_vs_{}.png", safe_name(name), safe_name(param)));
            let title = format!("{} against {param}", name);
            super::write_png(&png, |p| plots::scatter_png(&title, param, name, &points, p))?;
        }
    }
    Ok(())
}
