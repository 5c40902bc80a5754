//! What each run of a sweep reports, computed from its trace; chosen by `--metric`.
//!
//! * `settle[:TOL]`: the settle time (s) within ±TOL m (default 1e-6) of the reference,
//!   as [`LoopView::settle_time`] defines it (the first time after which every parked
//!   sample is in the band); empty if the run never settles;
//! * `rms:FROM:TO`: RMS error (m) of the parked samples in [FROM, TO) s;
//! * `disturbance`: the controller's final disturbance estimate (m);
//! * `slips`: the plant's slip events (entries into FREE) over the run;
//! * `final:NAME`, `min:NAME`, `max:NAME`: any recorded variable's last, least or greatest
//!   value (`component.variable`, or a system output).
//!
//! The column of a metric in the results is its flag text, as given.

use crate::closed_loop::{self, LoopView};
use crate::trace::Trace;

pub(crate) const SLIP_EVENTS: &str = "plant.slip_events";
pub(crate) const DISTURBANCE: &str = "controller.disturbance_estimate";

#[derive(Clone, Debug, PartialEq)]
pub enum Kind {
    Settle { tol: f64 },
    ParkedRms { from: f64, to: f64 },
    Disturbance,
    Slips,
    Final(String),
    Min(String),
    Max(String),
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

fn num(text: &str, what: &str) -> Result<f64, String> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| format!("--metric {what}: `{text}` is not a finite number"))
}

impl Metric {
    pub fn parse(text: &str) -> Result<Metric, String> {
        let text = text.trim();
        if text.contains(',') || text.contains('"') {
            return Err(format!("--metric {text}: no commas or quotes (it names a CSV column)"));
        }
        // It names a column of the results and a line of the summary: a control character
        // would break the header or reach the terminal.
        if let Some(c) = text.chars().find(|c| c.is_control()) {
            return Err(format!(
                "--metric {}: the control character U+{:04X} is refused (it names a CSV column)",
                text.escape_debug(),
                c as u32
            ));
        }
        let (head, rest) = match text.split_once(':') {
            Some((h, r)) => (h, Some(r)),
            None => (text, None),
        };
        let kind = match (head, rest) {
            ("settle", None) => Kind::Settle { tol: 1e-6 },
            ("settle", Some(t)) => Kind::Settle { tol: num(t, text)? },
            ("rms", Some(r)) => {
                let (a, b) = r.split_once(':').ok_or(format!("--metric {text}: expected rms:FROM:TO"))?;
                let (from, to) = (num(a, text)?, num(b, text)?);
                if from >= to {
                    return Err(format!("--metric {text}: the window must have FROM < TO"));
                }
                Kind::ParkedRms { from, to }
            }
            ("disturbance", None) => Kind::Disturbance,
            ("slips", None) => Kind::Slips,
            ("final", Some(n)) if !n.is_empty() => Kind::Final(n.to_string()),
            ("min", Some(n)) if !n.is_empty() => Kind::Min(n.to_string()),
            ("max", Some(n)) if !n.is_empty() => Kind::Max(n.to_string()),
            _ => {
                return Err(format!(
                    "--metric {text}: expected settle[:TOL], rms:FROM:TO, disturbance, slips, final:NAME, min:NAME or max:NAME"
                ))
            }
        };
        if let Kind::Settle { tol } = kind {
            if tol <= 0.0 {
                return Err(format!("--metric {text}: the band must be > 0"));
            }
        }
        Ok(Metric { name: text.to_string(), kind })
    }

    fn needs_loop(&self) -> bool {
        matches!(self.kind, Kind::Settle { .. } | Kind::ParkedRms { .. })
    }

    /// The value of this metric on one run; `None` where it has none (a run that does not
    /// settle).
    pub fn compute(&self, trace: &Trace, view: Option<&LoopView>) -> Result<Option<f64>, String> {
        let column = |name: &str| -> Result<Vec<f64>, String> {
            trace
                .column(name)
                .ok_or_else(|| format!("metric {}: the trace has no `{name}`", self.name))
        };
        let last =
            |name: &str| -> Result<Option<f64>, String> { Ok(column(name)?.last().copied()) };
        Ok(match &self.kind {
            Kind::Settle { tol } => view.ok_or("no closed-loop view")?.settle_time(*tol),
            Kind::ParkedRms { from, to } => {
                let v = view.ok_or("no closed-loop view")?;
                let any = v.parked().iter().any(|&i| v.time[i] >= *from && v.time[i] < *to);
                any.then(|| v.parked_rms(*from, *to))
            }
            Kind::Disturbance => last(DISTURBANCE)?,
            Kind::Slips => last(SLIP_EVENTS)?,
            Kind::Final(n) => last(n)?,
            Kind::Min(n) => column(n)?.into_iter().reduce(f64::min),
            Kind::Max(n) => column(n)?.into_iter().reduce(f64::max),
        })
    }
}

/// The variables a run must record for `metrics`, each once.
pub fn recorded(metrics: &[Metric]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    let mut add = |n: &str| {
        if !names.iter().any(|m| m == n) {
            names.push(n.to_string());
        }
    };
    if metrics.iter().any(Metric::needs_loop) {
        closed_loop::recorded().iter().for_each(|n| add(n));
    }
    for m in metrics {
        match &m.kind {
            Kind::Disturbance => add(DISTURBANCE),
            Kind::Slips => add(SLIP_EVENTS),
            Kind::Final(n) | Kind::Min(n) | Kind::Max(n) => add(n),
            _ => {}
        }
    }
    names
}

/// Every metric of one run's trace, in order.
pub fn compute_all(metrics: &[Metric], trace: &Trace) -> Result<Vec<Option<f64>>, String> {
    let view =
        if metrics.iter().any(Metric::needs_loop) { Some(LoopView::new(trace)?) } else { None };
    metrics.iter().map(|m| m.compute(trace, view.as_ref())).collect()
}
