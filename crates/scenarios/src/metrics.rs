//! The sweep metrics of the actuator's closed loop, chosen by `inchworm sweep --metric`,
//! each reduced row by row as a run goes ([`Reducer`]).
//!
//! * `settle[:TOL]`: the settle time (s) within ±TOL m (default 1e-6) of the reference:
//!   the first time after which every parked sample is in the band ([`Settle`] over the
//!   [`Parked`] samples, as [`LoopView::settle_time`](crate::closed_loop::LoopView::settle_time)
//!   reads a whole run); empty if the run never settles;
//! * `rms:FROM:TO`: the holding RMS error (m) of the parked samples in [FROM, TO) s
//!   ([`HoldingRms`]); empty if none is in the window;
//! * `disturbance`: the controller's final disturbance estimate (m);
//! * `slips`: the plant's slip events (entries into FREE) over the run;
//! * `final:NAME`, `min:NAME`, `max:NAME`: any recorded variable's last, least or greatest
//!   value (`component.variable`, or a system output): the engine's [`Reduce`].
//!
//! The column of a metric in the results is its flag text, as given.

use inchworm_cosim::sweep::metrics::{
    check_column_name, BoxError, Metrics, Reduce, ReduceStream, RowMetrics,
};
use inchworm_cosim::Error;

use crate::closed_loop::{
    self, recorded_name, DAC, DISTURBANCE_ESTIMATE, ENCODER_POSITION, SLIP_EVENTS,
};
use crate::holding::{HoldingRms, Parked, Settle};

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
    ["settle:1e-6", "disturbance", "slips", recorded_name!("final", ":", ENCODER_POSITION)];

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

    /// These metrics on rows of the variables `names` (the run's recorded names).
    pub fn reducer(&self, names: &[String]) -> Result<Reducer, Error> {
        Reducer::new(&self.metrics, names)
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
                Kind::Disturbance => add(DISTURBANCE_ESTIMATE),
                Kind::Slips => add(SLIP_EVENTS),
                Kind::Reduce(r) => add(r.variable()),
                _ => {}
            }
        }
        names
    }

    /// Row by row: a [`Reducer`] of these metrics.
    fn stream<'a>(&'a self, names: &[String]) -> Result<Box<dyn RowMetrics + 'a>, BoxError> {
        Ok(Box::new(self.reducer(names)?))
    }
}

/// Where the closed loop's columns are in a row.
#[derive(Clone, Copy, Debug)]
struct LoopColumns {
    reference: usize,
    position: usize,
    dac: [usize; 3],
}

impl LoopColumns {
    fn find(names: &[String]) -> Result<LoopColumns, Error> {
        let missing = |name: &str| Error::Config(format!("the trace has no `{name}`"));
        let at = |name: &str| names.iter().position(|x| x == name).ok_or_else(|| missing(name));
        Ok(LoopColumns {
            // The reference under either of its names, as the closed-loop view reads it.
            reference: closed_loop::reference_index(names)
                .ok_or_else(|| missing(closed_loop::REFERENCE))?,
            position: at(ENCODER_POSITION)?,
            dac: [at(DAC[0])?, at(DAC[1])?, at(DAC[2])?],
        })
    }
}

/// The closed loop's samples read row by row, as the closed-loop view reads a whole trace:
/// row k ≥ 1 completes sample k, with that row's position error and the DAC volts of row
/// k − 1 (what was held during `[t_{k-1}, t_k)`).
#[derive(Clone, Debug)]
struct LoopSamples {
    columns: LoopColumns,
    /// The previous row's DAC volts; none before the first row.
    held: Option<[f64; 3]>,
    parked: Parked,
}

impl LoopSamples {
    /// The position error of the sample that `row` completes, if that sample is parked.
    fn next(&mut self, row: &[f64]) -> Option<f64> {
        let c = self.columns;
        let held = self.held.replace(c.dac.map(|i| row[i]));
        // The t = 0 row completes no sample.
        let parked = held.is_some_and(|dac| self.parked.next(&dac));
        parked.then(|| row[c.reference] - row[c.position])
    }
}

#[derive(Clone, Debug)]
enum State {
    /// `final:`, `min:`, `max:`, and the last value of `disturbance` and `slips`.
    Reduce(ReduceStream),
    Settle {
        tol: f64,
        settle: Settle,
    },
    Rms(HoldingRms),
}

/// The metrics of one run, fed one row at a time ([`Reducer::push`]), t = 0 first.
#[derive(Clone, Debug)]
pub struct Reducer {
    states: Vec<State>,
    /// The closed loop's samples, where a metric reads them.
    samples: Option<LoopSamples>,
}

impl Reducer {
    /// For `metrics` on rows of the variables `names` (the run's recorded names).
    pub fn new(metrics: &[Metric], names: &[String]) -> Result<Reducer, Error> {
        let samples = if metrics.iter().any(Metric::needs_loop) {
            Some(LoopSamples {
                columns: LoopColumns::find(names)?,
                held: None,
                parked: Parked::default(),
            })
        } else {
            None
        };
        let last = |m: &Metric, n: &str| Reduce::Final(n.to_string()).stream(&m.name, names);
        let states = metrics
            .iter()
            .map(|m| {
                Ok(match &m.kind {
                    Kind::Settle { tol } => State::Settle { tol: *tol, settle: Settle::default() },
                    Kind::ParkedRms { from, to } => State::Rms(HoldingRms::new(*from, *to)),
                    Kind::Disturbance => State::Reduce(last(m, DISTURBANCE_ESTIMATE)?),
                    Kind::Slips => State::Reduce(last(m, SLIP_EVENTS)?),
                    Kind::Reduce(r) => State::Reduce(r.stream(&m.name, names)?),
                })
            })
            .collect::<Result<_, Error>>()?;
        Ok(Reducer { states, samples })
    }

    /// The row at time `t`.
    pub fn push(&mut self, t: f64, row: &[f64]) {
        let parked_error = self.samples.as_mut().and_then(|s| s.next(row));
        for s in &mut self.states {
            match (s, parked_error) {
                (State::Reduce(r), _) => r.push(row),
                (State::Settle { tol, settle }, Some(e)) => settle.push(t, e.abs() > *tol),
                (State::Rms(rms), Some(e)) => rms.push(t, e),
                _ => {}
            }
        }
    }

    /// Every metric's value, in order; `None` where it has none.
    pub fn finish(&self) -> Vec<Option<f64>> {
        self.states
            .iter()
            .map(|s| match s {
                State::Reduce(r) => r.value(),
                State::Settle { settle, .. } => settle.time(),
                State::Rms(rms) => rms.value(),
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

#[cfg(test)]
mod tests {
    use inchworm_controller::Params;
    use inchworm_plant::PlantParams;

    use super::*;
    use crate::closed_loop::LoopView;

    /// Fig. 5, full control, the crates coupled directly: the metrics of its rows are what
    /// the closed-loop view of the whole trace reads, to the bit, and the scenario's figures.
    #[test]
    fn fig5_row_metrics_are_the_closed_loop_views_figures() {
        let trace = closed_loop::run(PlantParams::fia20(), Params::default(), |_| 100e-6, 10.0)
            .expect("the loop runs");
        let texts = ["settle:1e-6", "rms:6:10", "disturbance", "settle:1e-12", "rms:0:0.01"];
        let values = LoopMetrics::parse(&texts).unwrap().compute(&trace).unwrap();
        let view = LoopView::new(&trace).unwrap();
        let bits = |v: Option<f64>| v.map(f64::to_bits);
        assert_eq!(bits(values[0]), bits(view.settle_time(1e-6)));
        assert_eq!(bits(values[1]), bits(Some(view.parked_rms(6.0, 10.0))));
        assert_eq!(bits(values[2]), bits(view.disturbance_estimate.last().copied()));
        // `inchworm scenario fig5`: settles within 1 µm at 0.788 s, parked RMS 3.027 nm in
        // [6, 10) s, final disturbance estimate 4.658 µm.
        let settle = values[0].unwrap();
        assert!((settle - 0.788).abs() < 1e-9, "settle {settle}");
        let rms = values[1].unwrap();
        assert!((rms * 1e9 - 3.027).abs() < 5e-4, "rms {rms}");
        let disturbance = values[2].unwrap();
        assert!((disturbance * 1e6 - 4.658).abs() < 5e-4, "disturbance {disturbance}");
        // Never within a picometre; no parked sample in the first 10 ms.
        assert_eq!((values[3], view.settle_time(1e-12)), (None, None));
        assert_eq!((values[4], view.parked_rms(0.0, 0.01)), (None, 0.0));
    }

    #[test]
    fn a_row_completes_the_sample_before_it_with_the_previous_rows_dac_volts() {
        let m = LoopMetrics::parse(&["settle:1e-6", "rms:0:1"]).unwrap();
        let names = m.recorded();
        let mut reducer = m.reducer(&names).unwrap();
        let row = |error: f64, dac: f64| {
            // Reference 0: the error is minus the encoder position.
            let mut v = vec![0.0; names.len()];
            v[2] = -error;
            v[4] = dac;
            v
        };
        // Rows 0..=8 hold zero volts; row 9 completes sample 8, the first that may be
        // parked, with row 8's volts. Row 9 commands a step: row 10's sample is not parked.
        for k in 0..9 {
            reducer.push(k as f64 * 0.002, &row(5e-6, 0.0));
        }
        reducer.push(0.018, &row(2e-9, 10.0));
        reducer.push(0.020, &row(7e-6, 0.0));
        let values = reducer.finish();
        assert_eq!(values, [Some(0.018), Some(2e-9)]);
    }
}
