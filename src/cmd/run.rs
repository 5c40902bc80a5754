//! `inchworm run`: the master on any flat SSP or single FMI 2.0 or 3.0 CS FMU, its recorded
//! variables written as CSV (and a plot).

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;

use inchworm_cosim::limits;
use inchworm_cosim::master::{self, Coupling, Options};
use inchworm_cosim::trace::{self, Decimated};
use inchworm_scenarios::plot;
use inchworm_scenarios::poses::Poses;

use super::signals;
use super::Text;

/// Rows a plot is drawn from, whatever the run's length: 2000 to 4000 points a line
/// resolve a 1400-pixel-wide panel, and a 10^6 s run would have 5 · 10^8.
const PLOT_POINTS: usize = 2000;

#[derive(Args)]
pub struct RunArgs {
    /// The system (.ssp) or FMU (.fmu).
    pub file: PathBuf,
    #[command(flatten)]
    pub sim: SimArgs,
    /// A variable to record (component.variable, or a system output); repeatable;
    /// default: the system's outputs.
    #[arg(long = "output", value_name = "NAME")]
    pub outputs: Vec<String>,
    /// Where to write the results.
    #[arg(long, default_value = "out/run.csv")]
    pub out: PathBuf,
    /// Also draw the recorded variables (the first six) into this PNG.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    #[arg(long, default_value = plot::DEFAULT_FONT)]
    pub font: PathBuf,
    /// Integrate this component's Model Exchange interface in the master instead of
    /// stepping its Co-Simulation: COMPONENT=me (`fmu=me` for a single FMU), or `me` for
    /// every component whose FMU offers it; COMPONENT=cs keeps a component's
    /// Co-Simulation (under `me` too); COMPONENT=cs-events runs an FMI 3.0 component's
    /// Co-Simulation with event mode, stepped from clock tick to clock tick, and
    /// COMPONENT=se in Scheduled Execution, its partitions activated at their ticks;
    /// repeatable. A name the run does not have is refused. A component whose FMU has only
    /// Model Exchange is integrated either way.
    #[arg(long = "interface", value_name = "COMPONENT=me|cs|cs-events|se")]
    pub interface: Vec<String>,
    /// Relative tolerance of the Model Exchange integrator (1e-14 to 0.5).
    #[arg(long, default_value_t = inchworm_cosim::model_exchange::Tolerance::default().rtol)]
    pub me_rtol: f64,
    /// Absolute tolerance of the Model Exchange integrator, times each state's nominal
    /// (1e-30 to 0.5).
    #[arg(long, default_value_t = inchworm_cosim::model_exchange::Tolerance::default().atol)]
    pub me_atol: f64,
    /// Threads: an SSP's independent subsystems (the connected components of its
    /// connections) in up to this many parts, each stepped on a thread of its own; the
    /// rows are the one-thread run's, bit for bit. Default 1: runs are often many at once
    /// (sweeps, tests, a cluster's workers), which already fill the cores.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..=256))]
    pub jobs: u64,
    /// Run part K (1 to N) alone of the parts `--jobs N` splits the SSP into, recording the
    /// columns it owns, for a run spread over processes or machines
    /// (python/inchworm_dask); `--show-split` says which columns each part records.
    #[arg(long, value_name = "K/N", conflicts_with = "jobs")]
    pub part: Option<String>,
    /// Print the split of `--jobs N` (or `--part K/N`) and run nothing: each recorded
    /// column of the whole run, in order, as `part<TAB>name` (parts from 1).
    #[arg(long)]
    pub show_split: bool,
    /// Reduce every actuator of the run to the sweep's metrics (an actuator: a plant
    /// `{a}plant{b}` recorded with its encoder position, its controller `{a}controller{b}`
    /// and reference `{a}reference{b}`, as `fmu-build segmented` names them), and write
    /// DIR/actuators.csv (one row an actuator) and DIR/spread.png (a histogram a metric).
    #[arg(long, value_name = "DIR")]
    pub spread: Option<PathBuf>,
    /// A metric of --spread, as `inchworm sweep --metric` takes it; repeatable; default:
    /// settle:1e-6, rms:6:10 and disturbance.
    #[arg(long = "spread-metric", value_name = "METRIC", requires = "spread")]
    pub spread_metrics: Vec<String>,
    /// Also write every mirror mount's pose as the poses CSV of python/inchworm_segments
    /// (docs/segments.md): `{prefix}piston_m`, `{prefix}tip_rad`, `{prefix}tilt_rad` of each
    /// `{prefix}mount`, then `parked`, 1 where every controller `{prefix}controller…`
    /// recorded with its DAC outputs holds its runner.
    #[arg(long, value_name = "FILE")]
    pub poses: Option<PathBuf>,
}

impl RunArgs {
    /// `--part K/N` as (K - 1, N), or none.
    fn part(&self) -> Result<Option<(usize, usize)>, String> {
        let Some(text) = &self.part else { return Ok(None) };
        let bad = || format!("--part {text}: give K/N with 1 <= K <= N <= 256, e.g. 1/2");
        let (k, n) = text.split_once('/').ok_or_else(bad)?;
        let (k, n): (usize, usize) =
            (k.trim().parse().map_err(|_| bad())?, n.trim().parse().map_err(|_| bad())?);
        if !(1 <= k && k <= n && n <= 256) {
            return Err(bad());
        }
        Ok(Some((k - 1, n)))
    }
}

impl RunArgs {
    /// The components to integrate as Model Exchange, from `--interface`, and the
    /// tolerances, each checked against its range (`inchworm_cosim::limits`) under the
    /// option's name. The names are checked against the run's components when it loads.
    pub fn interfaces(&self) -> Result<master::Interfaces, String> {
        let (mut model_exchange, mut co_simulation) = (Vec::new(), Vec::new());
        let (mut event_mode, mut scheduled_execution) = (Vec::new(), Vec::new());
        let mut all_cs = false;
        for a in &self.interface {
            let (component, kind) = match a.split_once('=') {
                Some((c, k)) => (Some(c.trim()), k.trim()),
                None => (None, a.trim()),
            };
            match (component, kind) {
                (Some(c), "me") => model_exchange.push(c.to_owned()),
                (None, "me") => model_exchange.push("*".to_owned()),
                (Some(c), "cs") => co_simulation.push(c.to_owned()),
                (Some(c), "cs-events") => event_mode.push(c.to_owned()),
                (Some(c), "se") => scheduled_execution.push(c.to_owned()),
                (None, k @ ("cs-events" | "se")) => {
                    return Err(format!(
                        "--interface {a}: name the component to run as `{k}`: COMPONENT={k}"
                    ))
                }
                // Every component's Co-Simulation: the default, unless `me` says otherwise.
                (None, "cs") => all_cs = true,
                (_, k) => {
                    return Err(format!(
                        "--interface {a}: `{k}` is not an interface (me, cs, cs-events or se)"
                    ))
                }
            }
        }
        if all_cs && model_exchange.iter().any(|n| n == "*") {
            return Err("--interface me and --interface cs: every component cannot run both".into());
        }
        let option = |name: &str, range: limits::Range, v: f64| {
            range.check(name, v).map_err(|e| e.to_string())
        };
        let tolerance = inchworm_cosim::model_exchange::Tolerance {
            rtol: option("--me-rtol", limits::RTOL, self.me_rtol)?,
            atol: option("--me-atol", limits::ATOL, self.me_atol)?,
        };
        Ok(master::Interfaces {
            model_exchange,
            co_simulation,
            event_mode,
            scheduled_execution,
            tolerance,
        })
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum CouplingArg {
    Jacobi,
    GaussSeidel,
}

/// How a system is simulated: the options `inchworm run` and `inchworm sweep` share.
#[derive(Args)]
pub struct SimArgs {
    /// Stop time (s); default: the file's default experiment, else 1 s.
    #[arg(long)]
    pub stop_time: Option<f64>,
    /// Communication step (s); default: the file's, else stop time / 500.
    #[arg(long)]
    pub step_size: Option<f64>,
    #[arg(long, value_enum, default_value = "jacobi")]
    pub coupling: CouplingArg,
    /// A start value or parameter: component.variable=value (variable=value for an FMU);
    /// repeatable (in a sweep: fixed for every run).
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// A parameter set of the SSP, by name: every ParameterBinding of the SSD whose
    /// ssv:ParameterSet has this name (an SSP without bindings: resources/<name>.ssv).
    #[arg(long)]
    pub parameter_set: Option<String>,
    /// CSV `time,<input>,…` for the system's (or FMU's) unconnected inputs, held
    /// piecewise constant.
    #[arg(long)]
    pub input: Option<PathBuf>,
}

impl SimArgs {
    /// The master's options for these arguments, recording `outputs`.
    pub fn options(&self, outputs: Vec<String>) -> Result<Options, String> {
        Ok(Options {
            stop_time: self.stop_time,
            step_size: self.step_size,
            coupling: match self.coupling {
                CouplingArg::Jacobi => Coupling::Jacobi,
                CouplingArg::GaussSeidel => Coupling::GaussSeidel,
            },
            params: super::parse_params(&self.params)?,
            parameter_set: self.parameter_set.clone(),
            input: self.input.as_deref().map(super::read_input).transpose()?,
            outputs,
        })
    }
}

/// Why a run ended early: the engine's error, or the CSV could not be written.
enum Stopped {
    Engine(inchworm_cosim::Error),
    Write(String),
}

impl From<inchworm_cosim::Error> for Stopped {
    fn from(e: inchworm_cosim::Error) -> Stopped {
        Stopped::Engine(e)
    }
}

pub fn run(args: &RunArgs) -> Result<(), String> {
    let opts = args.sim.options(args.outputs.clone())?;
    // Before any work: a bad font or output path fails before the run, not after it.
    if args.plot.is_some() || args.spread.is_some() {
        plot::load_font(&args.font).text()?;
    }
    let mut outputs: Vec<(&str, &Path)> = vec![("--out", &args.out)];
    outputs.extend(args.poses.as_deref().map(|p| ("--poses", p)));
    outputs.extend(args.plot.as_deref().map(|p| ("--plot", p)));
    let mut inputs: Vec<&Path> = vec![&args.file];
    inputs.extend(args.sim.input.as_deref());
    super::check_outputs(&outputs, &inputs)?;
    let stop = signals::stop_on_signals();
    let interfaces = args.interfaces()?;
    let load = Instant::now();
    let part = args.part()?;
    let is_ssp = args.file.extension().is_some_and(|e| e.eq_ignore_ascii_case("ssp"));
    let jobs = part.map_or(args.jobs as usize, |(_, n)| n);
    if args.show_split || part.is_some() || (jobs > 1 && is_ssp) {
        if !is_ssp {
            return Err(format!("{}: --part and --show-split split an .ssp", args.file.display()));
        }
        let parallel = master::Parallel::new(&args.file, &interfaces, &opts, jobs).text()?;
        if args.show_split {
            let split = parallel.split();
            for (name, (p, _)) in split.record_names.iter().zip(&split.columns) {
                println!("{}\t{name}", p + 1);
            }
            return Ok(());
        }
        return match part {
            Some((k, _)) => {
                let sim = parallel.load(k).text()?;
                signals::interrupted()?;
                let sim = sim.stop_when(stop);
                let names = sim.record_names().to_vec();
                let load_s = load.elapsed().as_secs_f64();
                write_run(args, names, load_s, |sink, progress| sim.run_into(sink, progress))
            }
            None => {
                let names = parallel.record_names().to_vec();
                let load_s = load.elapsed().as_secs_f64();
                write_run(args, names, load_s, |sink, progress| {
                    parallel.run_into(&stop, sink, progress)
                })
            }
        };
    }
    let sim = master::System::load_as(&args.file, &interfaces).text()?;
    signals::interrupted()?;
    let sim = sim.initialise(&opts).text()?.stop_when(stop);
    let load_s = load.elapsed().as_secs_f64();
    let names = sim.record_names().to_vec();
    write_run(args, names, load_s, |sink, progress| sim.run_into(sink, progress))
}

/// The rows of a run, through `run(sink, progress)`, written to `--out` as CSV of `names`
/// (and the plot), and the run's summary printed with its load time `load_s`.
fn write_run(
    args: &RunArgs,
    names: Vec<String>,
    load_s: f64,
    run: impl FnOnce(
        &mut dyn FnMut(f64, &[f64]) -> Result<(), Stopped>,
        &mut dyn FnMut(f64),
    ) -> Result<master::RunEnd, Stopped>,
) -> Result<(), String> {
    let mut spread = args
        .spread
        .as_ref()
        .map(|_| super::spread::spread(&args.spread_metrics, &names))
        .transpose()?;
    let mut poses = match &args.poses {
        Some(path) => {
            let p = Poses::new(&names).map_err(|e| e.to_string())?;
            let mut w = super::create_file(path)?;
            p.write_header(&mut w).map_err(|e| format!("{}: {e}", path.display()))?;
            Some((p, w, path))
        }
        None => None,
    };
    let out = &args.out;
    let io = |e: std::io::Error| format!("{}: {e}", out.display());
    let mut csv = super::create_file(out)?;
    trace::write_header(&mut csv, &names).map_err(io)?;
    let mut sample = args.plot.as_ref().map(|_| Decimated::new(names.clone(), PLOT_POINTS));
    let show = std::io::stderr().is_terminal();
    let mut shown = 0;
    let mut rows_text = trace::RowWriter::new();
    let (mut rows, mut end) = (0u64, 0.0);
    let wall = Instant::now();
    let ran = run(
        &mut |t, row| {
            rows_text.write(&mut csv, t, row).map_err(|e| Stopped::Write(io(e)))?;
            if let Some(s) = &mut sample {
                s.push(t, row);
            }
            if let Some(s) = &mut spread {
                s.push(t, row);
            }
            if let Some((p, w, path)) = &mut poses {
                p.write_row(w, t, row)
                    .map_err(|e| Stopped::Write(format!("{}: {e}", path.display())))?;
            }
            rows += 1;
            end = t;
            Ok(())
        },
        &mut |f| {
            let pct = (f * 100.0) as u32;
            if show && pct >= shown + 5 {
                shown = pct;
                eprint!("\r{pct:>3} %");
            }
        },
    );
    if show {
        eprintln!();
    }
    let ran = ran.map_err(|e| match e {
        Stopped::Engine(e) => signals::describe(e),
        Stopped::Write(e) => e,
    });
    let flushed = csv.flush().map_err(io);
    let ran = match ran {
        Ok(ran) => ran,
        Err(e) => {
            // A run that fails keeps the rows it made where that destroys nothing: in a
            // new file; an existing `--out` (and `--poses`) stays as it was.
            if rows == 0 {
                return Err(e);
            }
            if out.exists() || flushed.is_err() {
                return Err(format!(
                    "{e} ({} is as it was: the rows to t = {end} s are not written over it)",
                    out.display()
                ));
            }
            super::commit(csv)?;
            return Err(format!("{e} ({} holds the rows to t = {end} s)", out.display()));
        }
    };
    flushed?;
    super::commit(csv)?;
    if let Some((p, w, path)) = poses {
        super::commit(w)?;
        println!("wrote {} ({} mounts)", path.display(), p.mounts());
    }
    let loop_s = wall.elapsed().as_secs_f64();
    println!("wrote {}", out.display());
    if let (Some(png), Some(sample)) = (&args.plot, sample) {
        let title = format!("inchworm run {}", args.file.display());
        super::write_png(png, |p| plot::trace_png(&title, &sample.finish(), p))?;
    }
    if let (Some(dir), Some(spread)) = (&args.spread, &spread) {
        super::spread::write(dir, spread)?;
    }
    let timing = master::Timing { load_s, loop_s, simulated_s: end };
    println!("{timing}; {} variables, {rows} rows", names.len());
    for (component, stats) in &ran.model_exchange {
        println!("{component} (Model Exchange): {stats}");
    }
    Ok(())
}
