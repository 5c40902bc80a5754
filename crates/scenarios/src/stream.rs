//! The actuator's sweep metrics ([`LoopMetrics`]) computed row by row as the master
//! produces them, as `inchworm run` streams its rows to the CSV: nothing grows with the
//! number of steps, so a sweep run of any stop time runs in the memory of one row (a whole
//! trace of a long run would be gigabytes, and its allocation aborts the process).
//!
//! The definitions are those of [`Metric::compute`] on a whole trace and its
//! [`LoopView`](crate::closed_loop::LoopView), in the same order of floating-point
//! operations, so the values are the same to the bit (tests/sweep.rs holds every sweep row
//! to `master::run` + [`Metrics::compute`]).

use inchworm_cosim::sweep::metrics::{BoxError, Reduce, RowMetrics};
use inchworm_cosim::sweep::stream::ReduceStream;
use inchworm_cosim::Error;

use crate::closed_loop;
use crate::metrics::{Kind, LoopMetrics, Metric, DISTURBANCE, SLIP_EVENTS};

/// Where the closed-loop columns are in a row: by their position in
/// [`closed_loop::recorded`] (reference, counts, encoder position, runner position, the
/// three DAC outputs, …), looked up by name so that a reordering there cannot go unseen.
#[derive(Clone, Copy, Debug)]
struct LoopColumns {
    reference: usize,
    position: usize,
    dac: [usize; 3],
}

#[derive(Clone, Debug)]
enum State {
    /// `final:`, `min:`, `max:`, and the last value of `disturbance` and `slips`.
    Reduce(ReduceStream),
    /// The first parked time, whether a parked sample was out of the band, and the first
    /// parked time after the latest one that was.
    Settle { tol: f64, first: Option<f64>, bad: bool, after: Option<f64> },
    /// Σ e² and the count of the parked samples in `[from, to)`.
    Rms { from: f64, to: f64, sum: f64, n: usize },
}

/// The metrics of one run, fed one row at a time ([`Reducer::push`]), t = 0 first.
#[derive(Clone, Debug)]
pub struct Reducer {
    states: Vec<State>,
    columns: Option<LoopColumns>,
    /// Rows pushed so far.
    rows: usize,
    /// Consecutive rows, up to the previous one, whose three DAC outputs are all zero.
    zeros: usize,
}

impl Reducer {
    /// For `metrics` on rows of the variables `names` (the run's recorded names).
    pub fn new(metrics: &[Metric], names: &[String]) -> Result<Reducer, Error> {
        let last = |m: &Metric, n: &str| Reduce::Final(n.to_string()).stream(&m.name, names);
        let needs_loop =
            metrics.iter().any(|m| matches!(m.kind, Kind::Settle { .. } | Kind::ParkedRms { .. }));
        let columns = if needs_loop {
            let recorded = closed_loop::recorded();
            let at = |i: usize| -> Result<usize, Error> {
                names
                    .iter()
                    .position(|x| *x == recorded[i])
                    .ok_or_else(|| Error::Config(format!("the trace has no `{}`", recorded[i])))
            };
            // The reference under either of its names, as LoopView reads it.
            let reference = closed_loop::reference_index(names)
                .ok_or_else(|| Error::Config(format!("the trace has no `{}`", recorded[0])))?;
            Some(LoopColumns { reference, position: at(2)?, dac: [at(4)?, at(5)?, at(6)?] })
        } else {
            None
        };
        let states = metrics
            .iter()
            .map(|m| {
                Ok(match &m.kind {
                    Kind::Settle { tol } => {
                        State::Settle { tol: *tol, first: None, bad: false, after: None }
                    }
                    Kind::ParkedRms { from, to } => {
                        State::Rms { from: *from, to: *to, sum: 0.0, n: 0 }
                    }
                    Kind::Disturbance => State::Reduce(last(m, DISTURBANCE)?),
                    Kind::Slips => State::Reduce(last(m, SLIP_EVENTS)?),
                    Kind::Reduce(r) => State::Reduce(r.stream(&m.name, names)?),
                })
            })
            .collect::<Result<_, Error>>()?;
        Ok(Reducer { states, columns, rows: 0, zeros: 0 })
    }

    /// The row at time `t`.
    pub fn push(&mut self, t: f64, row: &[f64]) {
        // LoopView's sample k ≥ 1 is this row; it is parked when the DAC outputs of the
        // 8 rows before it (what was held up to it) are all zero, and it is at least its
        // 9th sample (index 8).
        let parked = self.rows >= 9 && self.zeros >= 8;
        let error = self.columns.map(|c| row[c.reference] - row[c.position]);
        for s in &mut self.states {
            match s {
                State::Reduce(r) => r.push(row),
                State::Settle { tol, first, bad, after } if parked => {
                    let e = error.unwrap_or(f64::NAN);
                    first.get_or_insert(t);
                    if e.abs() > *tol {
                        *bad = true;
                        *after = None;
                    } else if *bad && after.is_none() {
                        *after = Some(t);
                    }
                }
                State::Rms { from, to, sum, n } if parked && t >= *from && t < *to => {
                    let e = error.unwrap_or(f64::NAN);
                    *sum += e * e;
                    *n += 1;
                }
                _ => {}
            }
        }
        if let Some(c) = self.columns {
            let zero = c.dac.iter().all(|&i| row[i] == 0.0);
            self.zeros = if zero { self.zeros + 1 } else { 0 };
        }
        self.rows += 1;
    }

    /// Every metric's value, in order; `None` where it has none.
    pub fn finish(&self) -> Vec<Option<f64>> {
        self.states
            .iter()
            .map(|s| match s {
                State::Reduce(r) => r.value(),
                State::Settle { first, bad, after, .. } => {
                    if *bad {
                        *after
                    } else {
                        *first
                    }
                }
                State::Rms { sum, n, .. } => (*n > 0).then(|| (sum / *n as f64).sqrt()),
            })
            .collect()
    }
}

impl RowMetrics for Reducer {
    fn push(&mut self, t: f64, row: &[f64]) {
        Reducer::push(self, t, row);
    }

    fn finish(&mut self) -> Result<Vec<Option<f64>>, BoxError> {
        Ok(Reducer::finish(self))
    }
}

impl LoopMetrics {
    /// [`Metrics::stream`]: a [`Reducer`] of these metrics.
    pub fn reducer(&self, names: &[String]) -> Result<Reducer, Error> {
        Reducer::new(&self.metrics, names)
    }
}

/// Used by [`LoopMetrics`]' [`Metrics::stream`].
pub(crate) fn stream<'a>(
    metrics: &'a LoopMetrics,
    names: &[String],
) -> Result<Box<dyn RowMetrics + 'a>, BoxError> {
    Ok(Box::new(metrics.reducer(names)?))
}
