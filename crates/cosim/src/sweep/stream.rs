//! A run's metrics computed row by row as the master produces them, as `inchworm run`
//! streams its rows to the CSV: nothing grows with the number of steps, so a sweep run of
//! any stop time runs in the memory of one row (a whole trace of a long run would be
//! gigabytes, and its allocation aborts the process).
//!
//! Here the engine's own reductions ([`Reduce`]); a model's metrics stream through
//! [`Metrics::stream`](super::metrics::Metrics::stream) (the actuator's settle time and
//! parked RMS in `inchworm-scenarios`). The definitions are those of [`Reduce::compute`] on
//! a whole trace, in the same order of floating-point operations, so the values are the
//! same to the bit (tests/sweep.rs holds every sweep row to `master::run` +
//! [`Metrics::compute`](super::metrics::Metrics::compute)).

use crate::sweep::metrics::Reduce;
use crate::Error;

#[derive(Clone, Copy, Debug)]
enum How {
    Last,
    Min,
    Max,
}

/// A [`Reduce`] fed one row at a time.
#[derive(Clone, Debug)]
pub struct ReduceStream {
    column: usize,
    how: How,
    value: Option<f64>,
}

impl ReduceStream {
    /// For `reduce` on rows of the variables `names`; `metric` names it in the error if
    /// they lack its variable.
    pub fn new(reduce: &Reduce, metric: &str, names: &[String]) -> Result<ReduceStream, Error> {
        let n = reduce.variable();
        let column = names
            .iter()
            .position(|x| x == n)
            .ok_or_else(|| Error::Config(format!("metric {metric}: the trace has no `{n}`")))?;
        let how = match reduce {
            Reduce::Final(_) => How::Last,
            Reduce::Min(_) => How::Min,
            Reduce::Max(_) => How::Max,
        };
        Ok(ReduceStream { column, how, value: None })
    }

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
