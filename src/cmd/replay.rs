//! `inchworm replay`: the controller FMU re-run on a controller-side bridge log.

use super::Text;
use std::path::PathBuf;

use clap::Args;

use inchworm_bridge::replay::{controller_samples, replay};
use inchworm_bridge::runlog::{read_log, Record};
use inchworm_scenarios::bridge::FmuController;

#[derive(Args)]
pub struct ReplayArgs {
    /// A controller-side log written by `inchworm bridge --role controller --log`. Exit
    /// status: 0 the whole run, no divergence; 1 a divergence or an unreadable log; 3 no
    /// divergence, but the log does not hold the whole run (no end record).
    pub log: PathBuf,
    #[arg(long, default_value = "dist/InchwormController.fmu")]
    pub fmu: PathBuf,
    /// How the controller FMU is driven, as for `inchworm bridge`: auto (Scheduled
    /// Execution when the FMU offers it, else Co-Simulation), se or cs. Either replays a
    /// log of either: the codes are the same.
    #[arg(long, value_enum, default_value = "auto")]
    pub interface: super::bridge::InterfaceArg,
}

/// Exit status of a replay without divergence of a log that does not hold the whole run
/// (no end record, or a record cut short): what is there agrees, but it is not everything.
pub const EXIT_INCOMPLETE: u8 = 3;

pub fn run(args: &ReplayArgs) -> Result<(), String> {
    let log = read_log(&args.log).text()?;
    let meta = log
        .records
        .iter()
        .find_map(|r| if let Record::Meta(m) = r { Some(m.clone()) } else { None })
        .unwrap_or_default();
    if !meta.contains("role=controller") {
        return Err(format!(
            "{}: not a controller-side log (its meta says: {})",
            args.log.display(),
            meta.lines().next().unwrap_or("nothing")
        ));
    }
    let samples = controller_samples(&log.records);
    let events = log.records.iter().filter(|r| matches!(r, Record::Event { .. })).count();
    // What the file holds, said first: a killed run's log reads back whole up to the kill,
    // and only the missing end record tells it from a finished one.
    let found = format!(
        "{}: {} complete records ({} controller samples, {events} events)",
        args.log.display(),
        log.records.len(),
        samples.len()
    );
    let incomplete = match (log.end(), log.truncated_at) {
        (Some((_, end)), None) => {
            println!("{found}; end record: {end}");
            false
        }
        (_, Some(at)) => {
            println!("{found}, then a record cut short at byte {at} (the writer stopped mid-write); no end record: the run did not finish cleanly");
            true
        }
        (None, None) => {
            println!("{found}; no end record: the run did not finish cleanly (killed, or the machine stopped)");
            true
        }
    };
    if samples.is_empty() {
        return Err(format!("{}: no controller samples", args.log.display()));
    }
    let params = inchworm_scenarios::bridge::params_from_meta(&meta);
    let mut comp = FmuController::load(&args.fmu, &params, args.interface.into()).text()?;
    let interface = comp.interface();
    let r = replay(&mut comp, &samples).text()?;
    drop(comp);
    println!(
        "replayed {} samples ({} events, {} discontinuities) with {} ({interface})",
        r.samples,
        events,
        r.discontinuities,
        args.fmu.display()
    );
    match r.first {
        None if incomplete => {
            println!("no divergence in the samples there are; exit status {EXIT_INCOMPLETE}: the log is incomplete");
            // main maps every error to 1; an incomplete log that agrees is neither a
            // success nor a divergence, so it gets its own status.
            std::process::exit(i32::from(EXIT_INCOMPLETE));
        }
        None => {
            println!("no divergence: every tick's DAC codes are the logged ones");
            Ok(())
        }
        Some((tick, logged, replayed)) => Err(format!(
            "{} of {} samples diverge; first at tick {tick}: logged codes {logged:?}, replayed {replayed:?}",
            r.divergent, r.samples
        )),
    }
}
