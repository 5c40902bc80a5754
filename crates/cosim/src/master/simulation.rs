//! Phase 3 of a run: a [`Simulation`] stepping on its fixed communication grid, feeding
//! inputs, sampling rows, and reset in place for the next run of a sweep.

use super::component::Fmu;
use super::{Column, Coupling, Feed, InputTable, Options, Port, RunEnd, Simulation};
use crate::fmu::VarType;
use crate::model_exchange::MeStats;
use crate::{Error, StopFlag};

impl Simulation {
    /// The communication steps to the stop time: `stop / h`, a whole number.
    pub fn n_steps(&self) -> u64 {
        self.n_steps
    }

    /// The current communication point, `k h` (not accumulated, so the grid stays exact).
    pub fn time(&self) -> f64 {
        self.k as f64 * self.h
    }

    pub fn record_names(&self) -> &[String] {
        &self.record_names
    }

    /// Sets the inputs of component `only` (every component if `None`) from the latest
    /// outputs and the system inputs at the current time (the clocked inputs of clocked
    /// components wait for their ticks: `clocks`).
    fn feed(&mut self, only: Option<usize>) -> Result<(), Error> {
        let t = self.time();
        for i in 0..self.destinations.len() {
            let (dst, feed) = self.destinations[i];
            if only.is_none_or(|c| c == dst.component) {
                self.values[i] = self.input_value(dst, feed, t)?;
            }
        }
        self.destination_batches.write(&mut self.components, &self.values, only)
    }

    /// The value input `dst` gets from `feed` at `t`: the latest read of an output, or a
    /// system input at `t`.
    #[inline]
    pub(super) fn input_value(&mut self, dst: Port, feed: Feed, t: f64) -> Result<f64, Error> {
        Ok(match feed {
            Feed::Latest(j) => self.latest[j],
            Feed::SystemInput(j) => {
                let row = &mut self.input_rows[j];
                let v = system_input(&self.input_columns, self.input.as_ref(), j, t, row);
                // A CSV value for an Integer input: out of 32 bits, the cast would
                // saturate silently.
                let int = matches!(dst.ty, VarType::Integer | VarType::Enumeration);
                if int && !(f64::from(i32::MIN)..=f64::from(i32::MAX)).contains(&v) {
                    return Err(self.not_an_integer(j, v, t));
                }
                v
            }
        })
    }

    /// Why system input `j`'s value `v` at `t` cannot be set on an Integer input.
    #[cold]
    #[inline(never)]
    fn not_an_integer(&self, j: usize, v: f64, t: f64) -> Error {
        let name = match (self.input_columns[j], &self.input) {
            (Some(c), Some(table)) => table.names[c].as_str(),
            _ => "?",
        };
        Error::Config(format!(
            "input CSV column `{name}` = {v} at t = {t}: out of the Integer range {}..={}",
            i32::MIN,
            i32::MAX
        ))
    }

    /// The recorded variables now, in the order of [`Simulation::record_names`].
    pub fn sample(&mut self) -> Result<Vec<f64>, Error> {
        self.sample_row().map(<[f64]>::to_vec)
    }

    /// [`Simulation::sample`] into a buffer the simulation keeps: valid until the next call.
    pub fn sample_row(&mut self) -> Result<&[f64], Error> {
        if !self.rows_read {
            let recorded = &mut self.latest[self.sources..];
            self.record_batches.read(&mut self.components, recorded, None)?;
        }
        let t = self.time();
        for (out, column) in self.row.iter_mut().zip(&self.columns) {
            *out = match *column {
                Column::Latest(j) => self.latest[j],
                Column::SystemInput(i) => {
                    let row = &mut self.input_rows[i];
                    system_input(&self.input_columns, self.input.as_ref(), i, t, row)
                }
            };
        }
        Ok(&self.row)
    }

    /// One communication step from `k h` to `(k + 1) h`. The clocked components run
    /// their ticks' events as `clocks` says: those within the step as they step, those at
    /// its end after every component's step and read (Jacobi) or after their own
    /// (Gauss–Seidel), those at the start time at the start of the first step.
    ///
    /// Without clocks a component's outputs change only in its own step, so the step reads
    /// each component's recorded outputs with those that feed inputs, in the same call,
    /// and the row after it ([`Simulation::sample_row`]) calls no FMU.
    pub fn step(&mut self) -> Result<(), Error> {
        self.rows_read = false;
        let h = self.h;
        let t = self.time();
        let end = (self.k + 1) as f64 * h;
        let start = self.k == 0 && self.clocked;
        match self.coupling {
            Coupling::GaussSeidel => {
                for ci in 0..self.components.len() {
                    self.feed(Some(ci))?;
                    if self.components[ci].fmu.clocked() {
                        if start {
                            self.start_events(Some(ci))?;
                        }
                        self.advance_clocked(ci, t, end)?;
                    } else {
                        self.components[ci].fmu.advance(t, h)?;
                    }
                    self.read_outputs(Some(ci))?;
                    if self.clocked {
                        self.end_events(Some(ci), end)?;
                    }
                }
            }
            Coupling::Jacobi => {
                self.feed(None)?;
                if start {
                    self.start_events(None)?;
                }
                for ci in 0..self.components.len() {
                    if self.components[ci].fmu.clocked() {
                        self.advance_clocked(ci, t, end)?;
                    } else {
                        self.components[ci].fmu.advance(t, h)?;
                    }
                }
                self.read_outputs(None)?;
                if self.clocked {
                    self.end_events(None, end)?;
                }
            }
        }
        self.k += 1;
        self.rows_read = !self.clocked;
        Ok(())
    }

    /// Reads the outputs of component `only` (every component if `None`) after its step:
    /// with clocks, those that feed inputs (the clocks' events at the step's end may
    /// change the others before the row); without, the recorded ones too.
    fn read_outputs(&mut self, only: Option<usize>) -> Result<(), Error> {
        let batches = match self.clocked {
            true => &mut self.source_batches,
            false => &mut self.read_batches,
        };
        batches.read(&mut self.components, &mut self.latest, only)
    }

    /// What integrating each Model Exchange component cost so far, by component name.
    pub fn model_exchange_stats(&self) -> Vec<(String, MeStats)> {
        self.components
            .iter()
            .filter_map(|c| match &c.fmu {
                Fmu::Me(m) => Some((c.name.clone(), m.stats())),
                _ => None,
            })
            .collect()
    }

    pub fn terminate(mut self) -> Result<(), Error> {
        for c in self.components.iter_mut() {
            c.fmu.terminate()?;
        }
        Ok(())
    }

    /// Makes [`Simulation::run_into`] stop between two steps with [`Error::Stopped`] once
    /// `flag` is set, so the caller returns through its destructors (and the unpacked
    /// archives are removed) instead of being killed mid-step.
    pub fn stop_when(mut self, flag: StopFlag) -> Simulation {
        self.stop = Some(flag);
        self.components.iter_mut().for_each(|c| c.fmu.stop_when(self.stop.as_ref()));
        self
    }

    /// Steps to the stop time and hands every row to `sink` as soon as it is computed, t = 0
    /// first: nothing grows with the number of steps, so a run of any length runs in the
    /// same memory. The sink's own error type carries its failures (a full disk) as well
    /// as the engine's. What the run cost its Model Exchange components comes back, since
    /// the simulation is gone after it.
    pub fn run_into<E: From<Error>>(
        mut self,
        mut sink: impl FnMut(f64, &[f64]) -> Result<(), E>,
        mut progress: impl FnMut(f64),
    ) -> Result<RunEnd, E> {
        let n = self.n_steps;
        sink(0.0, self.sample_row()?)?;
        for k in 0..n {
            if let Some(flag) = &self.stop {
                flag.check()?;
            }
            self.step()?;
            let t = self.time();
            sink(t, self.sample_row()?)?;
            progress((k + 1) as f64 / n as f64);
        }
        let end = RunEnd { model_exchange: self.model_exchange_stats() };
        self.terminate()?;
        Ok(end)
    }
}

/// System input `i` at `t`: its column of the input table (near `row`, the row it was read
/// from last: [`InputTable::value_near`]), or 0 without one.
fn system_input(
    columns: &[Option<usize>],
    input: Option<&InputTable>,
    i: usize,
    t: f64,
    row: &mut usize,
) -> f64 {
    match (columns[i], input) {
        (Some(col), Some(table)) => table.value_near(col, t, row),
        _ => 0.0,
    }
}

// Sweeps (crate::sweep): one loaded system run many times, re-initialised in place between
// runs instead of unpacked and instantiated again.
impl Simulation {
    /// Back to t = 0 with `opts`, exactly as a fresh [`System::load`] and
    /// [`System::initialise`] would put it: `fmi2Reset` on every component, then the very
    /// same [`System::initialise`] on them, so the SSD's first bindings, the parameter set,
    /// the `--param` values, the input table, the wiring and the master's step counter
    /// and held connector values all come from the one code path a fresh run takes (a
    /// reset that re-applied only some of them gave rows that differ from `inchworm run`).
    /// After an error the simulation holds no components: drop it and load the system
    /// again.
    ///
    /// [`System::load`]: super::System::load
    /// [`System::initialise`]: super::System::initialise
    pub fn reset(&mut self, opts: &Options) -> Result<(), Error> {
        for c in self.components.iter_mut() {
            c.fmu.reset()?;
        }
        let mut system = self
            .loaded
            .take()
            .ok_or_else(|| Error::Config("a reset failed before: load the system again".into()))?;
        system.archive = self._archive.take();
        system.components = std::mem::take(&mut self.components);
        let stop = self.stop.take();
        *self = system.initialise(opts)?;
        self.components.iter_mut().for_each(|c| c.fmu.stop_when(stop.as_ref()));
        self.stop = stop;
        Ok(())
    }
}
