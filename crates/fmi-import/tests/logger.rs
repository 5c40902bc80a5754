//! The FMU's logger messages arrive intact as `log` records: the FMU formats its text
//! through "%s" (the C-variadic logger), the record's target is the instance name, the
//! level follows the status and the text carries the log category.

mod common;

use std::sync::Mutex;

use common::dist;
use inchworm_fmi_import::{CsFmu, VarType};
use inchworm_fmu_models::Dac;

struct Capture(Mutex<Vec<(log::Level, String, String)>>);

impl log::Log for Capture {
    fn enabled(&self, _: &log::Metadata) -> bool {
        true
    }
    fn log(&self, r: &log::Record) {
        self.0.lock().unwrap().push((r.level(), r.target().to_owned(), r.args().to_string()));
    }
    fn flush(&self) {}
}

static CAPTURE: Capture = Capture(Mutex::new(Vec::new()));

fn records(target: &str) -> Vec<(log::Level, String)> {
    CAPTURE.0.lock().unwrap().iter().filter(|r| r.1 == target).map(|r| (r.0, r.2.clone())).collect()
}

#[test]
fn the_fmus_messages_arrive_formatted() {
    log::set_logger(&CAPTURE).unwrap();
    log::set_max_level(log::LevelFilter::Trace);

    let mut fmu = CsFmu::load(&dist("InchwormPlant.fmu"), "logged plant", true).unwrap();
    fmu.enter_initialization(None, 0.0, None).unwrap();
    let earth = fmu.var_of(Dac::EARTH.name(), VarType::Real).unwrap().vr;
    assert!(fmu.set_real(&[earth], &[f64::NAN]).is_err());
    let log = records("logged plant");
    let refused = log
        .iter()
        .find(|(_, m)| m.contains("dac_earth = NaN refused: DAC volts must be finite; keeping 0 V"))
        .unwrap_or_else(|| panic!("the refusal did not arrive: {log:#?}"));
    assert_eq!(refused.0, log::Level::Error);
    assert!(refused.1.starts_with("logStatusError: "), "{}", refused.1);
    // With loggingOn, the FMU's info messages (one per call under logAll) come through too.
    assert!(
        log.iter()
            .any(|(l, m)| *l == log::Level::Info && m.contains("fmi2EnterInitializationMode")),
        "{log:#?}"
    );

    // fmi2Warning: the call succeeds, the FMU's warning and the layer's own are logged.
    fmu.set_real(&[earth], &[12.0]).unwrap();
    let log = records("logged plant");
    assert!(
        log.iter().any(|(l, m)| *l == log::Level::Warn
            && m.contains("outside the DAC range 0-10 V, clamped to 10 V")),
        "{log:#?}"
    );
    assert!(
        log.iter().any(|(l, m)| *l == log::Level::Warn
            && m.contains("fmi2SetReal returned fmi2Warning at t = 0 s")),
        "{log:#?}"
    );

    // Without loggingOn errors still arrive, info messages do not.
    let mut quiet = CsFmu::load(&dist("InchwormPlant.fmu"), "quiet plant", false).unwrap();
    quiet.enter_initialization(None, 0.0, None).unwrap();
    assert!(quiet.set_real(&[earth], &[f64::INFINITY]).is_err());
    let log = records("quiet plant");
    assert!(log.iter().all(|(l, _)| *l != log::Level::Info), "{log:#?}");
    assert!(
        log.iter().any(|(l, m)| *l == log::Level::Error && m.contains("dac_earth = inf refused")),
        "{log:#?}"
    );
}
