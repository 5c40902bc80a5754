//! What each run of a sweep reports. The engine's own metrics read any recorded variable
//! (`final:NAME`, `min:NAME`, `max:NAME`); a model's analysis adds its own through
//! [`Metrics`] (the actuator's settle time and holding RMS live with its scenarios, in
//! `inchworm-scenarios`).
//!
//! Every metric is a reducer fed one row at a time ([`Metrics::stream`], [`RowMetrics`]):
//! a sweep feeds it the rows as the master produces them, so a run of any length takes the
//! memory of one row (a whole trace of a long run would be gigabytes, and its allocation
//! aborts the process); the metrics of a whole trace ([`Metrics::compute`]) are the same
//! reducer fed the trace's rows, so both give the same values to the bit.

use std::fmt::Debug;

use crate::trace::Trace;
use crate::Error;

/// A boxed error of a [`Metrics`] implementation.
pub type BoxError = Box<dyn std::error::Error + Send + Sync>;

/// The metrics of a sweep: their column names, the variables a run must record for them,
/// and their reducer over one run's rows. Shared by every worker thread.
pub trait Metrics: Debug + Send + Sync {
    /// One column name per metric, in order.
    fn names(&self) -> Vec<String>;
    /// The variables a run must record, each once.
    fn recorded(&self) -> Vec<String>;
    /// The metrics of one run, to be fed its rows of the variables `names` (the run's
    /// recorded names), t = 0 first.
    fn stream<'a>(&'a self, names: &[String]) -> Result<Box<dyn RowMetrics + 'a>, BoxError>;

    /// Every metric on one run's whole trace, in the order of [`Metrics::names`]: the
    /// trace's rows fed to [`Metrics::stream`].
    fn compute(&self, trace: &Trace) -> Result<Vec<Option<f64>>, BoxError> {
        let mut metrics = self.stream(&trace.names)?;
        for (t, row) in &trace.rows {
            metrics.push(*t, row);
        }
        metrics.finish()
    }
}

/// One run's metrics, fed one row at a time ([`Metrics::stream`]).
pub trait RowMetrics {
    /// The row at time `t`, its values in the order of the names it was made for.
    fn push(&mut self, t: f64, row: &[f64]);
    /// Every metric's value, in the order of [`Metrics::names`]; `None` where it has none.
    fn finish(&mut self) -> Result<Vec<Option<f64>>, BoxError>;
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

    /// Its reducer on rows of the variables `names`; `metric` names it in the error if
    /// they lack its variable.
    pub fn stream(&self, metric: &str, names: &[String]) -> Result<ReduceStream, Error> {
        let n = self.variable();
        let column = names
            .iter()
            .position(|x| x == n)
            .ok_or_else(|| Error::Config(format!("metric {metric}: the trace has no `{n}`")))?;
        let how = match self {
            Reduce::Final(_) => How::Last,
            Reduce::Min(_) => How::Min,
            Reduce::Max(_) => How::Max,
        };
        Ok(ReduceStream { column, how, value: None })
    }
}

#[derive(Clone, Copy, Debug)]
enum How {
    Last,
    Min,
    Max,
}

/// A [`Reduce`] fed one row at a time ([`Reduce::stream`]).
#[derive(Clone, Debug)]
pub struct ReduceStream {
    column: usize,
    how: How,
    value: Option<f64>,
}

impl ReduceStream {
    /// The next row.
    pub fn push(&mut self, row: &[f64]) {
        let x = row[self.column];
        self.value = Some(match (self.how, self.value) {
            (How::Last, _) | (_, None) => x,
            (How::Min, Some(m)) => m.min(x),
            (How::Max, Some(m)) => m.max(x),
        });
    }

    /// Its value on the rows so far; `None` before the first.
    pub fn value(&self) -> Option<f64> {
        self.value
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

#[cfg(test)]
mod tests {
    use super::*;

    fn trace() -> Trace {
        let mut t = Trace::new(vec!["a.x".into(), "b.y".into()]);
        t.push(0.0, vec![2.0, -1.0]);
        t.push(0.5, vec![-3.5, 4.0]);
        t.push(1.0, vec![1.25, 0.5]);
        t
    }

    #[test]
    fn reductions_give_the_last_least_and_greatest_value() {
        let r = Reductions::parse(&["final:a.x", "min:a.x", "max:b.y", "min:b.y"]).unwrap();
        assert_eq!(r.recorded(), ["a.x", "b.y"]);
        let values = r.compute(&trace()).unwrap();
        assert_eq!(values, [Some(1.25), Some(-3.5), Some(4.0), Some(-1.0)]);
    }

    #[test]
    fn a_trace_without_rows_has_no_values_and_a_missing_variable_is_named() {
        let r = Reductions::parse(&["final:a.x", "max:b.y"]).unwrap();
        let empty = Trace::new(vec!["a.x".into(), "b.y".into()]);
        assert_eq!(r.compute(&empty).unwrap(), [None, None]);
        let e = Reductions::parse(&["max:c.z"]).unwrap().compute(&trace()).unwrap_err();
        assert_eq!(e.to_string(), "metric max:c.z: the trace has no `c.z`");
    }
}
