//! `inchworm delay-line`: an interferometer's delay line on the inchworm
//! (docs/delay-line.md), one run (`--param NAME=VALUE` on its declared parameters) or the
//! designer's survey (`--survey`): CSV, PNG and the figures.

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;

use inchworm_delay_line::geometry::EARTH_ROTATION_RATE;
use inchworm_delay_line::system::{self, DelayLineParams};
use inchworm_plant::PlantParams;
use inchworm_scenarios::delay_line::{self as dl, Following, MODES};
use inchworm_scenarios::plot;

use super::Text;

#[derive(Args)]
pub struct DelayLineArgs {
    /// A delay-line parameter as NAME=VALUE (repeatable; docs/delay-line.md lists them).
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// The inchworm's controller: stepping, deadband or analog.
    #[arg(long, default_value = "stepping")]
    pub controller: String,
    /// Simulated time (s).
    #[arg(long, default_value_t = 20.0)]
    pub duration: f64,
    /// Run the survey (ground 10 m and 100 m, space; every controller; with and without the
    /// fine stage) and the largest rate each gait follows, instead of one run.
    #[arg(long)]
    pub survey: bool,
    /// Output folder.
    #[arg(long, default_value = "out/delay-line")]
    pub out: PathBuf,
    #[arg(long, default_value = plot::DEFAULT_FONT)]
    pub font: PathBuf,
}

pub fn run(args: &DelayLineArgs) -> Result<(), String> {
    let controller = dl::controller(&args.controller).ok_or_else(|| {
        format!("unknown controller `{}`; known: {}", args.controller, MODES.join(", "))
    })?;
    let mut p = DelayLineParams::default();
    for (name, value) in super::parse_params(&args.params)? {
        inchworm_declare::set_named(&mut p, &name, &value)?;
    }
    plot::load_font(&args.font).text()?;
    super::create_dir(&args.out)?;
    if args.survey {
        return survey(args);
    }
    let wall = Instant::now();
    let run = system::run(&p, PlantParams::fia20(), controller, args.duration).text()?;
    let f = run.figures();
    println!(
        "{} s in {:.2} s of wall time; sidereal rate up to {:.3e} m/s",
        run.time.last().copied().unwrap_or(0.0),
        wall.elapsed().as_secs_f64(),
        run.sidereal_rate
    );
    println!(
        "residual RMS {:.2} nm (tracker, 2 ms), {:.2} nm within {} s frames, frame offsets {:.2} nm",
        f.tracker_rms * 1e9,
        f.science_jitter * 1e9,
        p.science_frame,
        f.science_offset * 1e9
    );
    println!(
        "visibility {:.4} at 1.65 µm, {:.5} at 10 µm; null depth {:.2e} at 10 µm",
        f.visibility_h, f.visibility_n, f.null_n
    );
    match (f.first_lost, run.end_of_stroke) {
        (_, Some(t)) => println!("LOST: the runner reached the end of its stroke at {t} s"),
        (Some(t), None) => println!("LOST: {} samples without fringes, the first at {t} s", f.lost),
        (None, None) => println!("locked throughout (after {} s)", p.settle_time),
    }
    let trace = dl::trace(&run);
    super::write_file(&args.out.join("delay-line.csv"), |w| trace.write_csv(w))?;
    super::write_png(&args.out.join("delay-line.png"), |path| {
        plot::trace_png("Delay line: optical paths and residual (m)", &dl::plot_trace(&run), path)
    })
}

fn survey(args: &DelayLineArgs) -> Result<(), String> {
    let wall = Instant::now();
    let rows = dl::survey(args.duration).text()?;
    print!("{}", dl::survey_table(&rows));
    super::write_file(&args.out.join("survey.csv"), |w| dl::write_survey_csv(&rows, w))?;
    println!("\nthe largest path rate the inchworm alone follows (fia20, ideal tracker, no cart):");
    for (name, c) in dl::gaits() {
        let up = dl::max_rate(&c, 10.0, Following::KeepsUp).text()?;
        let fringes = dl::max_rate(&c, 10.0, Following::Fringes).text()?;
        println!(
            "  {name}: keeps up to {:.3} mm/s ({:.1} m of baseline), keeps the fringes between steps to {:.3} mm/s ({:.1} m)",
            up * 1e3,
            up / EARTH_ROTATION_RATE,
            fringes * 1e3,
            fringes / EARTH_ROTATION_RATE
        );
    }
    let sweep = dl::baseline_sweep(args.duration).text()?;
    super::write_file(&args.out.join("baselines.csv"), |w| dl::write_survey_csv(&sweep, w))?;
    let series = dl::visibility_series(&sweep);
    super::write_png(&args.out.join("visibility.png"), |path| {
        plot::visibility_png(
            "Delay line on the ground, fine stage on: visibility and null against baseline",
            &series,
            path,
        )
    })?;
    println!(
        "\nvisibility at 1.65 µm on baselines of {:?} m (fine stage on; 0: the end of the stroke):",
        dl::BASELINES
    );
    for (name, points) in &series {
        let v: Vec<String> = points.iter().map(|p| format!("{:.3}", p[1])).collect();
        println!("  {name}: {}", v.join(" "));
    }
    println!("survey in {:.1} s of wall time", wall.elapsed().as_secs_f64());
    Ok(())
}
