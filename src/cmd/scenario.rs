//! `inchworm scenario`: a named scenario of the paper, through the master on the SSP (or
//! the crates with `--direct`), each variant as CSV, all of them in one PNG.

use std::path::PathBuf;
use std::sync::OnceLock;

use clap::Args;

use inchworm_scenarios::closed_loop::{LoopView, SlewView};
use inchworm_scenarios::plot;
use inchworm_scenarios::scenario::{self, Via};

use super::Text;

#[derive(Args)]
pub struct ScenarioArgs {
    #[arg(help = scenario_help().as_str())]
    pub name: String,
    /// Folder holding InchwormSystem.ssp (built by `cargo run --release -p fmu-build`).
    #[arg(long, default_value = "dist")]
    pub dist: PathBuf,
    /// Couple the plant and controller crates directly instead of loading the FMUs.
    #[arg(long)]
    pub direct: bool,
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    #[arg(long, default_value = plot::DEFAULT_FONT)]
    pub font: PathBuf,
}

/// The scenario argument's help: every name of the scenarios' table and what it runs.
fn scenario_help() -> &'static String {
    static HELP: OnceLock<String> = OnceLock::new();
    HELP.get_or_init(|| {
        let lines: Vec<String> =
            scenario::SCENARIOS.iter().map(|(n, what)| format!("  {n}: {what}")).collect();
        format!("The scenario:\n{}", lines.join("\n"))
    })
}

pub fn run(args: &ScenarioArgs) -> Result<(), String> {
    if args.name == "mirror" {
        return scenario::mirror(&args.dist, &args.out, &args.font).text();
    }
    let s = scenario::by_name(&args.name).ok_or_else(|| {
        format!("unknown scenario `{}`; known: {}", args.name, scenario::names().join(", "))
    })?;
    plot::load_font(&args.font).text()?;
    super::create_dir(&args.out)?;
    let ssp = args.dist.join("InchwormSystem.ssp");
    let via = if args.direct { Via::Direct } else { Via::System(&ssp) };
    let (traces, timing) = s.run_timed(via).text()?;
    let views = traces.iter().map(LoopView::new).collect::<Result<Vec<_>, _>>().text()?;
    println!("{} ({})", s.title, s.via_text(via));
    for (v, r) in s.variants.iter().zip(&views) {
        println!("  {}", s.summary(v, r));
    }
    println!("{timing}");
    let slug = |name: &str| -> String {
        name.split(|c: char| !c.is_alphanumeric())
            .filter(|w| !w.is_empty())
            .collect::<Vec<_>>()
            .join("_")
    };
    let names: Vec<&str> = s.variants.iter().map(|v| v.name.as_str()).collect();
    if s.open_loop() {
        // A slew is read gait by gait: one row per gait, and Fig. 11's two panels.
        let slews: Vec<SlewView> =
            views.iter().map(|r| SlewView::new(r, scenario::SAMPLES_PER_GAIT)).collect();
        for (v, g) in s.variants.iter().zip(&slews) {
            let path = args.out.join(format!("{}_{}_gaits.csv", s.name, slug(&v.name)));
            super::write_file(&path, |w| g.write_csv(w))?;
        }
        return super::write_png(&args.out.join(format!("{}.png", s.name)), |p| {
            plot::slew_png(s.title, &names, &slews, p)
        });
    }
    for (v, r) in s.variants.iter().zip(&views) {
        super::write_file(&args.out.join(format!("{}_{}.csv", s.name, slug(&v.name))), |w| {
            r.write_csv(w)
        })?;
    }
    if scenario::is_controller_option(s.name) {
        super::write_png(&args.out.join(format!("{}.png", s.name)), |p| {
            scenario::options_png(s.title, &names, &views, p)
        })?;
        return scenario::write_extras(s.name, &args.out).text();
    }
    super::write_png(&args.out.join(format!("{}.png", s.name)), |p| {
        plot::closed_loop_png(s.title, &names, &views, p)
    })
}
