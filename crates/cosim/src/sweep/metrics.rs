//! What each run of a sweep reports, computed from its trace. The engine's own metrics
//! read any recorded variable (`final:NAME`, `min:NAME`, `max:NAME`); a model's analysis
//! adds its own through [`Metrics`] (the actuator's settle time and parked RMS live with
//! its scenarios, in `inchworm-scenarios`). A sweep computes them row by row as the master
//! produces the rows ([`Metrics::stream`], [`RowMetrics`]), so a run of any length takes
//! the memory of one row.

use std::fmt::Debug;

use crate::sweep::stream::ReduceStream;
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

    /// The metrics of one run fed row by row, for rows of the variables `names` (the run's
    /// recorded names, t = 0 first); at the end the values [`Metrics::compute`] gives on
    /// the whole trace, to the bit. The default keeps the rows and computes on the trace,
    /// in memory that grows with the run: an implementation that can reduce each row as it
    /// comes should (the sweep runs in the memory of one row then).
    fn stream<'a>(&'a self, names: &[String]) -> Result<Box<dyn RowMetrics + 'a>, BoxError> {
        Ok(Box::new(Buffered { metrics: self, trace: Trace::new(names.to_vec()) }))
    }
}

/// One run's metrics, fed one row at a time ([`Metrics::stream`]).
pub trait RowMetrics {
    /// The row at time `t`, its values in the order of the names it was made for.
    fn push(&mut self, t: f64, row: &[f64]);
    /// Every metric's value, in the order of [`Metrics::names`]; `None` where it has none.
    fn finish(&mut self) -> Result<Vec<Option<f64>>, BoxError>;
}

/// [`Metrics::stream`] for metrics that only compute on a whole trace.
struct Buffered<'a, M: ?Sized> {
    metrics: &'a M,
    trace: Trace,
}

impl<M: Metrics + ?Sized> RowMetrics for Buffered<'_, M> {
    fn push(&mut self, t: f64, row: &[f64]) {
        self.trace.push(t, row.to_vec());
    }

    fn finish(&mut self) -> Result<Vec<Option<f64>>, BoxError> {
        self.metrics.compute(&self.trace)
    }
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

    /// [`Reduce::compute`] row by row, on rows of the variables `names`; `metric` names
    /// it in the error if they lack the variable (the same error).
    pub fn stream(&self, metric: &str, names: &[String]) -> Result<ReduceStream, Error> {
        ReduceStream::new(self, metric, names)
    }
}

/// A metric's text as a CSV column name: no commas, quotes or control characters.
pub fn check_column_name(text: &str) -> Result<(), Error> {
    if text.contains(',') || text.contains('"') {
        return Err(Error::Config(format!(
            "--metric {text}: no commas or quotes (it names a CSV column)"
        )));
    }
    // It names a column of the results and a line of the summary: a control character
    // would break the header or reach the terminal.
    if let Some(c) = text.chars().find(|c| c.is_control()) {
        return Err(Error::Config(format!(
            "--metric {}: the control character U+{:04X} is refused (it names a CSV column)",
            text.escape_debug(),
            c as u32
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

    fn stream<'a>(&'a self, names: &[String]) -> Result<Box<dyn RowMetrics + 'a>, BoxError> {
        let streams = self.0.iter().map(|(n, r)| r.stream(n, names)).collect::<Result<_, _>>()?;
        Ok(Box::new(ReductionStreams(streams)))
    }
}

/// [`Reductions`] row by row.
struct ReductionStreams(Vec<ReduceStream>);

impl RowMetrics for ReductionStreams {
    fn push(&mut self, _t: f64, row: &[f64]) {
        self.0.iter_mut().for_each(|s| s.push(row));
    }

    fn finish(&mut self) -> Result<Vec<Option<f64>>, BoxError> {
        Ok(self.0.iter().map(ReduceStream::value).collect())
    }
}
