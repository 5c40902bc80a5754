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
use inchworm_scenarios::metrics::{self, LoopMetrics};
use inchworm_scenarios::{plot, sweep_plots as plots};

use super::Text;

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
    /// min:NAME, max:NAME; repeatable; default (for InchwormSystem.ssp): settle:1e-6,
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
        let text = std::fs::read_to_string(p).map_err(|e| format!("{}: {e}", p.display()))?;
        let plan = Plan::parse(&text).map_err(|e| format!("{}: {e}", p.display()))?;
        if args.rows.is_empty() {
            return Ok(plan);
        }
        let mut rows = Vec::new();
        for k in &args.rows {
            let r = plan
                .rows
                .iter()
                .find(|r| r.run == *k)
                .ok_or_else(|| format!("{}: no row with run index {k}", p.display()))?;
            rows.push(r.clone());
        }
        return Ok(Plan { names: plan.names, rows });
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

pub fn run(args: &SweepArgs) -> Result<(), String> {
    let metrics = if args.metrics.is_empty() {
        LoopMetrics::parse(&metrics::DEFAULT)
    } else {
        LoopMetrics::parse(&args.metrics)
    }
    .text()?;
    let metric_names = metrics.names();
    let plan = plan_of(args)?;
    if args.plan_only {
        return super::write_file(&args.out.join("plan.csv"), |w| {
            w.write_all(plan.to_csv().as_bytes())
        });
    }
    let opts = args.sim.options(Vec::new())?;
    let setup = Setup {
        system: args.file.clone(),
        stop_time: opts.stop_time,
        step_size: opts.step_size,
        coupling: opts.coupling,
        params: opts.params,
        parameter_set: opts.parameter_set,
        input: opts.input,
        metrics: std::sync::Arc::new(metrics),
    };
    let jobs =
        args.jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let json = args.json || !args.rows.is_empty();
    let mut bar = (!json && std::io::stderr().is_terminal()).then(|| Progress {
        total: plan.rows.len(),
        start: Instant::now(),
        last: None,
    });
    let wall = Instant::now();
    let outcomes = exec::run_plan(&setup, &plan, jobs, |done| {
        if let Some(b) = bar.as_mut() {
            b.show(done);
        }
    });
    let wall = wall.elapsed().as_secs_f64();
    if json {
        let mut out = std::io::stdout().lock();
        for o in &outcomes {
            writeln!(out, "{}", sw::json_line(&plan.names, &metric_names, o))
                .map_err(|e| format!("stdout: {e}"))?;
        }
        return Ok(());
    }
    if !args.no_plots {
        plot::load_font(&args.font)?;
    }
    super::write_file(&args.out.join("plan.csv"), |w| w.write_all(plan.to_csv().as_bytes()))?;
    let table = sw::results_csv(&plan.names, &metric_names, &outcomes);
    super::write_file(&args.out.join("results.csv"), |w| w.write_all(table.as_bytes()))?;
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
