//! Running a plan: `jobs` worker threads, each loading the system once and resetting it
//! between runs ([`Simulation::reset`]); a run that fails is a row with its error.

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{mpsc, Arc};

use crate::master::{Options, Simulation, System};
use crate::sweep::metrics::Metrics;
use crate::sweep::metrics::RowMetrics;
use crate::sweep::plan::{Plan, Row};
use crate::sweep::ranges::Ranges;
use crate::{Error, StopFlag};

/// What every run of a sweep shares.
#[derive(Clone, Debug)]
pub struct Setup {
    pub system: PathBuf,
    /// The options of every run; the swept values are set after its `params`. Its `outputs`
    /// are not read: a run records what the metrics read ([`Metrics::recorded`]).
    pub options: Options,
    pub metrics: Arc<dyn Metrics>,
}

/// One run's outcome.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    pub run: usize,
    pub sample: usize,
    pub values: Vec<f64>,
    /// One per metric; empty if the run failed.
    pub metrics: Vec<Option<f64>>,
    pub error: Option<String>,
}

impl Setup {
    fn options(&self, names: &[String], row: &Row) -> Options {
        let mut options = self.options.clone();
        let swept = names.iter().zip(&row.values).map(|(n, v)| (n.clone(), format!("{v}")));
        options.params.extend(swept);
        options.outputs = self.metrics.recorded();
        options
    }
}

/// A loaded system kept across runs.
pub struct Worker<'a> {
    setup: &'a Setup,
    sim: Option<Simulation>,
    /// The declared ranges; empty if the model descriptions could not be read (then only
    /// the FMUs themselves refuse a value).
    ranges: Ranges,
    /// Loads (unpack + instantiate) done so far: 1 unless a run failed.
    pub loads: usize,
    /// Ends a run between two steps once set ([`Worker::stop_when`]).
    stop: StopFlag,
}

/// Steps `sim` to the stop time, each row reduced to the metrics as it comes (as
/// `inchworm run` streams its rows): a run of any length takes the memory of one row
/// (with metrics that stream, [`Metrics::stream`]). `stop` ends it between two steps with
/// [`Error::Stopped`].
fn simulate(
    sim: &mut Simulation,
    metrics: &dyn Metrics,
    stop: &StopFlag,
) -> Result<Vec<Option<f64>>, String> {
    let text = |e: Error| e.to_string();
    let mut reducer: Box<dyn RowMetrics + '_> =
        metrics.stream(sim.record_names()).map_err(|e| e.to_string())?;
    reducer.push(0.0, sim.sample_row().map_err(text)?);
    for _ in 0..sim.n_steps() {
        // A stop (SIGINT/SIGTERM in the binary) ends the run between two steps, as in
        // `inchworm run`, so the unpacked FMUs are removed on the way out.
        stop.check().map_err(text)?;
        sim.step().map_err(text)?;
        let t = sim.time();
        reducer.push(t, sim.sample_row().map_err(text)?);
    }
    reducer.finish().map_err(|e| e.to_string())
}

impl<'a> Worker<'a> {
    pub fn new(setup: &'a Setup) -> Worker<'a> {
        let ranges = Ranges::read(&setup.system).unwrap_or_default();
        Worker { setup, sim: None, ranges, loads: 0, stop: StopFlag::new() }
    }

    /// Makes a run stop between two steps, failing its row with [`Error::Stopped`], once
    /// `flag` is set.
    pub fn stop_when(mut self, flag: StopFlag) -> Worker<'a> {
        self.stop = flag;
        self
    }

    fn fresh(&mut self, opts: &Options) -> Result<(), Error> {
        self.sim = None;
        self.loads += 1;
        self.sim = Some(System::load(&self.setup.system)?.initialise(opts)?);
        Ok(())
    }

    /// The system at t = 0 with `opts`' parameters: the loaded one reset, or, the first
    /// time or after a failure, loaded anew.
    fn ready(&mut self, opts: &Options) -> Result<&mut Simulation, Error> {
        let reset = self.sim.as_mut().map(|sim| sim.reset(opts));
        if !matches!(reset, Some(Ok(()))) {
            // First run, or a reset refused (which may be the previous run's trouble):
            // start clean, and let a load or initialisation error be this row's.
            self.fresh(opts)?;
        }
        self.sim.as_mut().ok_or_else(|| Error::Config("the system is not loaded".into()))
    }

    /// Runs one row; never fails: an error is the outcome's.
    pub fn run(&mut self, names: &[String], row: &Row) -> Outcome {
        let outcome = |metrics, error| Outcome {
            run: row.run,
            sample: row.sample,
            values: row.values.clone(),
            metrics,
            error,
        };
        // Out of its declared range: refused before the FMUs see it, which stay as they are.
        if let Some(e) =
            names.iter().zip(&row.values).find_map(|(n, v)| self.ranges.check(n, *v).err())
        {
            return outcome(vec![], Some(e.to_string()));
        }
        let opts = self.setup.options(names, row);
        let setup = self.setup;
        let metrics = &*setup.metrics;
        let stop = self.stop.clone();
        let result = self
            .ready(&opts)
            .map_err(|e| e.to_string())
            .and_then(|sim| simulate(sim, metrics, &stop));
        let (metrics, error) = match result {
            Ok(m) => (m, None),
            Err(e) => {
                // The FMUs may be in an error state: the next run loads them anew.
                self.sim = None;
                (vec![], Some(e))
            }
        };
        outcome(metrics, error)
    }
}

fn failed(row: &Row, error: &str) -> Outcome {
    Outcome {
        run: row.run,
        sample: row.sample,
        values: row.values.clone(),
        metrics: vec![],
        error: Some(error.to_string()),
    }
}

/// Runs every row of `plan` on `jobs` threads (at least 1), calling `progress(done)` on
/// the calling thread after each run; outcomes in plan order.
pub fn run_plan(
    setup: &Setup,
    plan: &Plan,
    jobs: usize,
    progress: impl FnMut(usize),
) -> Vec<Outcome> {
    run_plan_until(setup, plan, jobs, &StopFlag::new(), progress)
}

/// [`run_plan`] that `stop` ends between two steps: the run under way fails with
/// [`Error::Stopped`], no new run starts, and the rows not run fail with "the worker
/// thread stopped before this run"; the runs done keep their outcomes.
pub fn run_plan_until(
    setup: &Setup,
    plan: &Plan,
    jobs: usize,
    stop: &StopFlag,
    mut progress: impl FnMut(usize),
) -> Vec<Outcome> {
    let jobs = jobs.clamp(1, plan.rows.len().max(1));
    let next = AtomicUsize::new(0);
    let mut out: Vec<Option<Outcome>> = vec![None; plan.rows.len()];
    std::thread::scope(|scope| {
        let (tx, rx) = mpsc::channel::<(usize, Outcome)>();
        for _ in 0..jobs {
            let tx = tx.clone();
            let next = &next;
            scope.spawn(move || {
                let mut w = Worker::new(setup).stop_when(stop.clone());
                loop {
                    // After a stop no new run starts; the rows not run say so.
                    if stop.is_set() {
                        break;
                    }
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(row) = plan.rows.get(i) else { break };
                    // A panic (a bug) fails its row, not the sweep; the system is loaded anew.
                    let o = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                        w.run(&plan.names, row)
                    }))
                    .unwrap_or_else(|_| {
                        w.sim = None;
                        failed(row, "the run panicked (a bug: please report it)")
                    });
                    if tx.send((i, o)).is_err() {
                        break;
                    }
                }
            });
        }
        drop(tx);
        let mut done = 0;
        for (i, o) in rx {
            out[i] = Some(o);
            done += 1;
            progress(done);
        }
    });
    out.into_iter()
        .zip(&plan.rows)
        .map(|(o, row)| {
            o.unwrap_or_else(|| failed(row, "the worker thread stopped before this run"))
        })
        .collect()
}
