//! The sweep metrics of the actuator's closed loop, computed from each run's trace; chosen
//! by `inchworm sweep --metric`.
//!
//! * `settle[:TOL]`: the settle time (s) within ±TOL m (default 1e-6) of the reference,
//!   as [`LoopView::settle_time`] defines it (the first time after which every parked
//!   sample is in the band); empty if the run never settles;
//! * `rms:FROM:TO`: RMS error (m) of the parked samples in [FROM, TO) s;
//! * `disturbance`: the controller's final disturbance estimate (m);
//! * `slips`: the plant's slip events (entries into FREE) over the run;
//! * `final:NAME`, `min:NAME`, `max:NAME`: any recorded variable's last, least or greatest
//!   value (`component.variable`, or a system output): the engine's [`Reduce`].
//!
//! The column of a metric in the results is its flag text, as given.

use inchworm_cosim::sweep::metrics::{check_column_name, BoxError, Metrics, Reduce, RowMetrics};
use inchworm_cosim::{Error, Trace};

use crate::closed_loop::{self, LoopView};

pub(crate) const SLIP_EVENTS: &str = "plant.slip_events";
pub(crate) const DISTURBANCE: &str = "controller.disturbance_estimate";

#[derive(Clone, Debug, PartialEq)]
pub enum Kind {
    Settle {
        tol: f64,
    },
    ParkedRms {
        from: f64,
        to: f64,
    },
    Disturbance,
    Slips,
    /// `final:`, `min:` or `max:` of any recorded variable.
    Reduce(Reduce),
}

#[derive(Clone, Debug, PartialEq)]
pub struct Metric {
    /// The flag text, which names the column.
    pub name: String,
    pub kind: Kind,
}

/// What `inchworm sweep` reports without `--metric`.
pub const DEFAULT: [&str; 4] =
    ["settle:1e-6", "disturbance", "slips", "final:plant.encoder_position"];

fn num(text: &str, what: &str) -> Result<f64, Error> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| Error::Config(format!("--metric {what}: `{text}` is not a finite number")))
}

impl Metric {
    pub fn parse(text: &str) -> Result<Metric, Error> {
        let text = text.trim();
        check_column_name(text)?;
        let (head, rest) = match text.split_once(':') {
            Some((h, r)) => (h, Some(r)),
            None => (text, None),
        };
        let kind = match (head, rest) {
            ("settle", None) => Kind::Settle { tol: 1e-6 },
            ("settle", Some(t)) => Kind::Settle { tol: num(t, text)? },
            ("rms", Some(r)) => {
                let (a, b) = r
                    .split_once(':')
                    .ok_or_else(|| Error::Config(format!("--metric {text}: expected rms:FROM:TO")))?;
                let (from, to) = (num(a, text)?, num(b, text)?);
                if from >= to {
                    return Err(Error::Config(format!(
                        "--metric {text}: the window must have FROM < TO"
                    )));
                }
                Kind::ParkedRms { from, to }
            }
            ("disturbance", None) => Kind::Disturbance,
            ("slips", None) => Kind::Slips,
            _ => match Reduce::parse(text) {
                Some(r) => Kind::Reduce(r),
                None => {
                    return Err(Error::Config(format!(
                        "--metric {text}: expected settle[:TOL], rms:FROM:TO, disturbance, slips, final:NAME, min:NAME or max:NAME"
                    )))
                }
            },
        };
        if let Kind::Settle { tol } = kind {
            if tol <= 0.0 {
                return Err(Error::Config(format!("--metric {text}: the band must be > 0")));
            }
        }
        Ok(Metric { name: text.to_string(), kind })
    }

    fn needs_loop(&self) -> bool {
        matches!(self.kind, Kind::Settle { .. } | Kind::ParkedRms { .. })
    }

    /// The value of this metric on one run; `None` where it has none (a run that does not
    /// settle).
    pub fn compute(&self, trace: &Trace, view: Option<&LoopView>) -> Result<Option<f64>, BoxError> {
        let last = |name: &str| Reduce::Final(name.to_string()).compute(&self.name, trace);
        Ok(match &self.kind {
            Kind::Settle { tol } => view.ok_or("no closed-loop view")?.settle_time(*tol),
            Kind::ParkedRms { from, to } => {
                let v = view.ok_or("no closed-loop view")?;
                let any = v.parked().iter().any(|&i| v.time[i] >= *from && v.time[i] < *to);
                any.then(|| v.parked_rms(*from, *to))
            }
            Kind::Disturbance => last(DISTURBANCE)?,
            Kind::Slips => last(SLIP_EVENTS)?,
            Kind::Reduce(r) => r.compute(&self.name, trace)?,
        })
    }
}

/// A sweep's metrics, in order: what [`inchworm_cosim::sweep::exec::Setup`] takes.
#[derive(Clone, Debug, PartialEq)]
pub struct LoopMetrics {
    pub metrics: Vec<Metric>,
    /// The name the swept system records the reference under ([`closed_loop::reference_name`]).
    pub reference: &'static str,
}

impl LoopMetrics {
    /// These metrics, on a system that records the reference as `reference`
    /// (`InchwormSystemOpen.ssp`; [`LoopMetrics::for_system`] says which).
    pub fn new(metrics: Vec<Metric>) -> LoopMetrics {
        LoopMetrics { metrics, reference: closed_loop::REFERENCE }
    }

    /// Each text through [`Metric::parse`].
    pub fn parse<S: AsRef<str>>(texts: &[S]) -> Result<LoopMetrics, Error> {
        texts
            .iter()
            .map(|t| Metric::parse(t.as_ref()))
            .collect::<Result<_, _>>()
            .map(LoopMetrics::new)
    }

    /// The same metrics, recording the reference under the name `system` gives it.
    pub fn for_system(self, system: &std::path::Path) -> Result<LoopMetrics, Error> {
        Ok(LoopMetrics { reference: closed_loop::reference_name(system)?, ..self })
    }
}

impl Metrics for LoopMetrics {
    fn names(&self) -> Vec<String> {
        self.metrics.iter().map(|m| m.name.clone()).collect()
    }

    /// The closed loop's variables first if any metric reads the loop, then each metric's.
    fn recorded(&self) -> Vec<String> {
        let mut names: Vec<String> = Vec::new();
        let mut add = |n: &str| {
            if !names.iter().any(|m| m == n) {
                names.push(n.to_string());
            }
        };
        if self.metrics.iter().any(Metric::needs_loop) {
            closed_loop::recorded_as(self.reference).iter().for_each(|n| add(n));
        }
        for m in &self.metrics {
            match &m.kind {
                Kind::Disturbance => add(DISTURBANCE),
                Kind::Slips => add(SLIP_EVENTS),
                Kind::Reduce(r) => add(r.variable()),
                _ => {}
            }
        }
        names
    }

    /// The closed-loop view is built once per run, for every metric that reads it.
    fn compute(&self, trace: &Trace) -> Result<Vec<Option<f64>>, BoxError> {
        let view = if self.metrics.iter().any(Metric::needs_loop) {
            Some(LoopView::new(trace)?)
        } else {
            None
        };
        self.metrics.iter().map(|m| m.compute(trace, view.as_ref())).collect()
    }

    /// Row by row ([`crate::stream::Reducer`]), to the bit what [`Metrics::compute`] gives.
    fn stream<'a>(&'a self, names: &[String]) -> Result<Box<dyn RowMetrics + 'a>, BoxError> {
        crate::stream::stream(self, names)
    }
}
