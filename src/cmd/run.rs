//! `inchworm run`: the master on any flat SSP or single FMI 2.0 CS FMU, its recorded
//! variables written as CSV (and a plot).

use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::Instant;

use clap::Args;

use inchworm::master::{self, Coupling, Options};
use inchworm::plot;

#[derive(Args)]
pub struct RunArgs {
    /// The system (.ssp) or FMU (.fmu).
    pub file: PathBuf,
    /// Stop time (s); default: the file's default experiment, else 1 s.
    #[arg(long)]
    pub stop_time: Option<f64>,
    /// Communication step (s); default: the file's, else stop time / 500.
    #[arg(long)]
    pub step_size: Option<f64>,
    #[arg(long, value_enum, default_value = "jacobi")]
    pub coupling: CouplingArg,
    /// A start value or parameter: component.variable=value (variable=value for an FMU).
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
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum CouplingArg {
    Jacobi,
    GaussSeidel,
}

pub fn run(args: &RunArgs) -> Result<(), String> {
    let opts = Options {
        stop_time: args.stop_time,
        step_size: args.step_size,
        coupling: match args.coupling {
            CouplingArg::Jacobi => Coupling::Jacobi,
            CouplingArg::GaussSeidel => Coupling::GaussSeidel,
        },
        params: super::parse_params(&args.params)?,
        parameter_set: args.parameter_set.clone(),
        input: args.input.as_deref().map(super::read_input).transpose()?,
        outputs: args.outputs.clone(),
    };
    let show = std::io::stderr().is_terminal();
    let mut shown = 0;
    let wall = Instant::now();
    let trace = master::run(&args.file, &opts, |f| {
        let pct = (f * 100.0) as u32;
        if show && pct >= shown + 5 {
            shown = pct;
            eprint!("\r{pct:>3} %");
        }
    })?;
    if show {
        eprintln!();
    }
    let wall = wall.elapsed().as_secs_f64();
    super::write_file(&args.out, |w| trace.write_csv(w))?;
    if let Some(png) = &args.plot {
        plot::load_font(&args.font)?;
        let title = format!("inchworm run {}", args.file.display());
        super::write_png(png, |p| plot::trace_png(&title, &trace, p))?;
    }
    let end = trace.rows.last().map_or(0.0, |r| r.0);
    println!(
        "{end} s simulated in {wall:.3} s ({:.0}x real time); {} variables, {} rows",
        end / wall,
        trace.names.len(),
        trace.rows.len()
    );
    Ok(())
}
