//! The `min`/`max` a model description declares for each variable, so that a swept value
//! out of range fails its run with a message naming the parameter and its range (an FMU
//! that refuses the value itself says why only in its log).

use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;

use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

use crate::Error;

/// Qualified name (`component.variable`, or the bare name for a single FMU) → (min, max).
#[derive(Clone, Debug, Default)]
pub struct Ranges(BTreeMap<String, (Option<f64>, Option<f64>)>);

fn attr(e: &BytesStart, name: &str) -> Option<String> {
    e.attributes().flatten().find(|a| a.key.local_name().into_inner() == name).and_then(|a| {
        a.normalized_value(quick_xml::XmlVersion::Implicit1_0).ok().map(|v| v.into_owned())
    })
}

fn model_description(fmu: &Path) -> Result<String, Error> {
    let f =
        std::fs::File::open(fmu).map_err(|e| Error::Config(format!("{}: {e}", fmu.display())))?;
    let mut zip =
        zip::ZipArchive::new(f).map_err(|e| Error::Config(format!("{}: {e}", fmu.display())))?;
    let mut entry = zip
        .by_name("modelDescription.xml")
        .map_err(|e| Error::Config(format!("{}: {e}", fmu.display())))?;
    let mut text = String::new();
    entry
        .read_to_string(&mut text)
        .map_err(|e| Error::Config(format!("{}: {e}", fmu.display())))?;
    Ok(text)
}

fn scan(xml: &str, prefix: &str, out: &mut BTreeMap<String, (Option<f64>, Option<f64>)>) {
    let mut reader = Reader::from_str(xml);
    let mut current: Option<String> = None;
    while let Ok(ev) = reader.read_event() {
        match ev {
            Event::Start(e) | Event::Empty(e) => match e.local_name().into_inner() {
                "ScalarVariable" => current = attr(&e, "name"),
                "Real" | "Integer" => {
                    if let Some(n) = current.take() {
                        let num = |k: &str| attr(&e, k).and_then(|v| v.trim().parse::<f64>().ok());
                        let (lo, hi) = (num("min"), num("max"));
                        if lo.is_some() || hi.is_some() {
                            out.insert(format!("{prefix}{n}"), (lo, hi));
                        }
                    }
                }
                _ => {}
            },
            Event::Eof => break,
            _ => {}
        }
    }
}

impl Ranges {
    /// The ranges of every component of an `.ssp`, or of a single `.fmu`.
    pub fn read(system: &Path) -> Result<Ranges, Error> {
        let mut out = BTreeMap::new();
        if system.extension().is_some_and(|e| e.eq_ignore_ascii_case("ssp")) {
            let a = crate::ssp::Archive::open(system)?;
            for c in &a.system.components {
                scan(
                    &model_description(&a.dir.join(&c.source))?,
                    &format!("{}.", c.name),
                    &mut out,
                );
            }
        } else {
            scan(&model_description(system)?, "", &mut out);
        }
        Ok(Ranges(out))
    }

    /// `Err` naming the variable and its range if `value` is outside it.
    pub fn check(&self, name: &str, value: f64) -> Result<(), Error> {
        match self.0.get(name) {
            Some(&(lo, hi)) if lo.is_some_and(|l| value < l) || hi.is_some_and(|h| value > h) => {
                let show = |b: Option<f64>| b.map_or("-inf".to_string(), |v| v.to_string());
                Err(Error::Config(format!(
                    "parameter {name} = {value} is outside its range [{}, {}]",
                    show(lo),
                    show(hi).replace("-inf", "inf")
                )))
            }
            _ => Ok(()),
        }
    }
}
