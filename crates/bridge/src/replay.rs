//! Replay: the controller re-run on the samples a run logged. Each logged tick gives the
//! encoder count and reference the controller used; its codes must come out as logged. A
//! divergence means the controller (or its parameters) is not the one that ran, or that
//! the run itself was not deterministic.

use std::convert::Infallible;
use std::ops::ControlFlow;

use crate::runlog::{ControllerSample, Record};
use crate::{Compensator, ModelError};

#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReplayReport {
    pub samples: u64,
    pub divergent: u64,
    /// The first divergent sample: its tick, the logged codes and the replayed ones.
    pub first: Option<(u32, [u16; 3], [u16; 3])>,
    /// Ticks that do not follow their predecessor (a fault and a re-arm in the run).
    pub discontinuities: u64,
}

/// The controller samples of a log, in order.
pub fn controller_samples(records: &[Record]) -> Vec<ControllerSample> {
    records
        .iter()
        .filter_map(|r| if let Record::Controller(s) = r { Some(*s) } else { None })
        .collect()
}

pub fn replay<C: Compensator>(
    comp: &mut C,
    samples: &[ControllerSample],
) -> Result<ReplayReport, ModelError> {
    let mut report = ReplayReport::default();
    let mut previous: Option<u32> = None;
    for s in samples {
        if previous.is_some_and(|p| p.wrapping_add(1) != s.tick) {
            report.discontinuities += 1;
        }
        previous = Some(s.tick);
        let ticked = crate::tick(comp, s.counts, s.reference, |codes| {
            Ok::<_, ModelError>(ControlFlow::<Infallible, _>::Continue(codes))
        })?;
        let codes = match ticked {
            ControlFlow::Continue((codes, _)) => codes,
            ControlFlow::Break(never) => match never {},
        };
        if codes != s.codes {
            report.divergent += 1;
            if report.first.is_none() {
                report.first = Some((s.tick, s.codes, codes));
            }
        }
        report.samples += 1;
    }
    Ok(report)
}
