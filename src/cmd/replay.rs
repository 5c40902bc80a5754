//! `inchworm replay`: the controller FMU re-run on a controller-side bridge log.

use std::path::PathBuf;

use clap::Args;

use inchworm_bridge::replay::{controller_samples, replay};
use inchworm_bridge::runlog::{read_log, Record};

#[derive(Args)]
pub struct ReplayArgs {
    /// A controller-side log written by `inchworm bridge --role controller --log`.
    pub log: PathBuf,
    #[arg(long, default_value = "dist/InchwormController.fmu")]
    pub fmu: PathBuf,
}

pub fn run(args: &ReplayArgs) -> Result<(), String> {
    let log = read_log(&args.log)?;
    if let Some(at) = log.truncated_at {
        eprintln!("warning: {}: the log ends inside a record at byte {at} (the writer stopped mid-write); replaying what is whole", args.log.display());
    }
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
    if samples.is_empty() {
        return Err(format!("{}: no controller samples", args.log.display()));
    }
    let params = inchworm::bridge::params_from_meta(&meta);
    let mut comp = inchworm::bridge::FmuCompensator::load(&args.fmu, &params)?;
    let r = replay(&mut comp, &samples)?;
    let events = log.records.iter().filter(|r| matches!(r, Record::Event { .. })).count();
    println!(
        "replayed {} samples ({} events, {} discontinuities) with {}",
        r.samples,
        events,
        r.discontinuities,
        args.fmu.display()
    );
    match r.first {
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
