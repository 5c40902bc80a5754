//! What each run of a sweep reports, computed from its trace. The engine's own metrics
//! read any recorded variable (`final:NAME`, `min:NAME`, `max:NAME`); a model's analysis
//! adds its own through [`Metrics`] (the actuator's settle time and parked RMS live with
//! its scenarios, in `inchworm-scenarios`).

use std::fmt::Debug;

use crate::trace::Trace;
use crate::Error;

/// A boxed error of a [`Metrics`] implementation.
pub type BoxError = Box<dyn std::error::Error + Send + Sync>;

/// The metrics of a sweep: their column names, the variables a run must record for them,
/// and their values on one run's trace. Shared by every worker thread.
pub trait Metrics: Debug + Send + Sync {
    /// One column name per metric, in order.
    fn names(&self) -> Vec<String>;
    /// The variables a run must record, each once.
    fn recorded(&self) -> Vec<String>;
    /// Every metric on one run's trace, in the order of [`Metrics::names`]; `None` where a
    /// metric has no value on this run.
    fn compute(&self, trace: &Trace) -> Result<Vec<Option<f64>>, BoxError>;
}

/// A recorded variable reduced to one number.
#[derive(Clone, Debug, PartialEq)]
pub enum Reduce {
    Final(String),
    Min(String),
    Max(String),
}

impl Reduce {
    /// `final:NAME`, `min:NAME` or `max:NAME`; `None` for any other text.
    pub fn parse(text: &str) -> Option<Reduce> {
        let (head, name) = text.split_once(':')?;
        if name.is_empty() {
            return None;
        }
        let name = name.to_string();
        match head {
            "final" => Some(Reduce::Final(name)),
            "min" => Some(Reduce::Min(name)),
            "max" => Some(Reduce::Max(name)),
            _ => None,
        }
    }

    /// The variable it reads.
    pub fn variable(&self) -> &str {
        match self {
            Reduce::Final(n) | Reduce::Min(n) | Reduce::Max(n) => n,
        }
    }

    /// Its value on `trace`; `metric` names it in the error if the trace lacks the variable.
    pub fn compute(&self, metric: &str, trace: &Trace) -> Result<Option<f64>, Error> {
        let n = self.variable();
        let column = trace
            .column(n)
            .ok_or_else(|| Error::Config(format!("metric {metric}: the trace has no `{n}`")))?;
        Ok(match self {
            Reduce::Final(_) => column.last().copied(),
            Reduce::Min(_) => column.into_iter().reduce(f64::min),
            Reduce::Max(_) => column.into_iter().reduce(f64::max),
        })
    }
}

/// A metric's text as a CSV column name: no commas or quotes.
pub fn check_column_name(text: &str) -> Result<(), Error> {
    if text.contains(',') || text.contains('"') {
        return Err(Error::Config(format!(
            "--metric {text}: no commas or quotes (it names a CSV column)"
        )));
    }
    Ok(())
}

/// Metrics of any system: each a [`Reduce`] of a recorded variable, named by its text.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Reductions(pub Vec<(String, Reduce)>);

impl Reductions {
    /// `final:NAME`, `min:NAME`, `max:NAME` texts.
    pub fn parse<S: AsRef<str>>(texts: &[S]) -> Result<Reductions, Error> {
        let mut out = Vec::new();
        for t in texts {
            let t = t.as_ref().trim();
            check_column_name(t)?;
            let r = Reduce::parse(t).ok_or_else(|| {
                Error::Config(format!("--metric {t}: expected final:NAME, min:NAME or max:NAME"))
            })?;
            out.push((t.to_string(), r));
        }
        Ok(Reductions(out))
    }
}

impl Metrics for Reductions {
    fn names(&self) -> Vec<String> {
        self.0.iter().map(|(n, _)| n.clone()).collect()
    }

    fn recorded(&self) -> Vec<String> {
        let mut names: Vec<String> = Vec::new();
        for (_, r) in &self.0 {
            if !names.iter().any(|m| m == r.variable()) {
                names.push(r.variable().to_string());
            }
        }
        names
    }

    fn compute(&self, trace: &Trace) -> Result<Vec<Option<f64>>, BoxError> {
        Ok(self.0.iter().map(|(n, r)| r.compute(n, trace)).collect::<Result<_, _>>()?)
    }
}
