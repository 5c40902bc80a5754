//! One SSP system on several threads: its independent subsystems ([`partition`]) grouped
//! into parts, each part loaded, initialised and stepped by a thread of its own exactly as
//! a whole run steps it, the parts' rows merged into the whole run's columns in its
//! order. The result is the one-thread run's, bit for bit, by construction: no value
//! crosses between parts, and each part's components take the same calls in the same
//! order as in the whole system.
//!
//! The threads do not wait for each other at every step: each runs ahead by blocks of
//! [`BLOCK_ROWS`] rows, a bounded channel holding at most [`BLOCKS_AHEAD`] blocks, so
//! memory stays that of a few blocks whatever the stop time, and the main thread hands
//! the merged rows to the caller's sink in order as they come.

use std::path::{Path, PathBuf};
use std::sync::mpsc;

use super::partition::Split;
use super::{Interfaces, Options, RunEnd, Simulation, System};
use crate::model_exchange::MeStats;
use crate::ssp::Archive;
use crate::{Error, StopFlag};

/// Rows a part computes before handing them over: 0.1 s of a 2 ms run, so the
/// hand-over costs little against the steps, and the rows come out often.
pub const BLOCK_ROWS: usize = 50;

/// Blocks a part may compute ahead of the slowest part's merged rows.
pub const BLOCKS_AHEAD: usize = 4;

/// What a part's thread sends: a block of rows (their times, and their values row after
/// row), the part's Model Exchange costs at its end, or why it stopped.
enum Message {
    Rows(Vec<f64>, Vec<f64>),
    End(Vec<(String, MeStats)>),
    Failed(Error),
}

/// An SSP system split for `jobs` threads, not yet loaded.
pub struct Parallel {
    path: PathBuf,
    /// The SSP unpacked once, its folder shared by every part.
    archive: Archive,
    interfaces: Interfaces,
    opts: Options,
    split: Split,
    /// The SSD's components in order, to order the Model Exchange costs as a whole run.
    order: Vec<String>,
    /// The run's steps as the parts will count them, for the progress (0: the parts
    /// refuse the stop time, and say why).
    n_steps: u64,
}

impl Parallel {
    /// Reads the SSP `path` and splits it into at most `jobs` parts of whole subsystems
    /// (fewer when it has fewer subsystems: a system of one connected subsystem runs on one
    /// thread).
    pub fn new(
        path: &Path,
        interfaces: &Interfaces,
        opts: &Options,
        jobs: usize,
    ) -> Result<Parallel, Error> {
        let archive = Archive::open(path)?;
        let split = Split::new(&archive, &opts.outputs, jobs)?;
        let order = archive.system.components.iter().map(|c| c.name.clone()).collect();
        let stop_time = opts.stop_time.or(archive.system.stop_time).unwrap_or(1.0);
        let h = opts.step_size.or(archive.system.step_size).unwrap_or(stop_time / 500.0);
        let n_steps = super::system::step_count(stop_time, h).unwrap_or(0);
        Ok(Parallel {
            n_steps,
            path: path.to_path_buf(),
            archive,
            interfaces: interfaces.clone(),
            opts: opts.clone(),
            split,
            order,
        })
    }

    /// The parts and what each records.
    pub fn split(&self) -> &Split {
        &self.split
    }

    /// What every row holds, in order: the whole run's recorded names.
    pub fn record_names(&self) -> &[String] {
        &self.split.record_names
    }

    /// Loads, initialises and runs every part on a thread of its own, handing every merged
    /// row to `sink` as [`Simulation::run_into`] does, t = 0 first, and `progress` the
    /// fraction done, both on the calling thread. `stop` ends every part between two steps
    /// with [`Error::Stopped`]. The first error in the order of the rows (a part's, or the
    /// sink's) ends the run; the other parts stop at their next block.
    ///
    /// [`Simulation::run_into`]: super::Simulation::run_into
    pub fn run_into<E: From<Error>>(
        self,
        stop: &StopFlag,
        mut sink: impl FnMut(f64, &[f64]) -> Result<(), E>,
        mut progress: impl FnMut(f64),
    ) -> Result<RunEnd, E> {
        let split = &self.split;
        // Set when the calling thread gives up (an error), so the parts stop too.
        let abandon = StopFlag::new();
        std::thread::scope(|scope| {
            let mut receivers = Vec::new();
            for k in 0..split.parts.len() {
                let (tx, rx) = mpsc::sync_channel::<Message>(BLOCKS_AHEAD);
                receivers.push(rx);
                let (this, abandon) = (&self, &abandon);
                scope.spawn(move || {
                    let failed = match this.run_part(k, stop, abandon, &tx) {
                        Ok(()) => return,
                        Err(e) => e,
                    };
                    let _ = tx.send(Message::Failed(failed));
                });
            }
            let merged = self.merge(&receivers, &mut sink, &mut progress);
            if merged.is_err() {
                abandon.set();
            }
            // The parts' threads end once their receivers are gone, and the scope joins them.
            drop(receivers);
            merged
        })
    }

    /// Part `k` (from 0) alone, loaded and initialised: it records the columns of
    /// [`Split::part_records`]`[k]`, which are the whole run's bit for bit. For a part run
    /// elsewhere (another process, another machine), its rows merged afterwards by
    /// [`Split::columns`].
    pub fn load(&self, k: usize) -> Result<Simulation, Error> {
        let parts = self.split.parts.len();
        if k >= parts {
            return Err(Error::Config(format!(
                "part {} of {parts}: the system splits into {parts} part(s)",
                k + 1
            )));
        }
        let elsewhere = self.split.elsewhere(k);
        let records = &self.split.part_records[k];
        let archive = self.archive.clone();
        let system = System::load_part(&self.path, archive, &self.interfaces, &elsewhere, records)?;
        system.initialise(&Options { outputs: Vec::new(), ..self.opts.clone() })
    }

    /// Part `k` on this thread: loaded, initialised, stepped to the stop time, its rows
    /// sent in blocks.
    fn run_part(
        &self,
        k: usize,
        stop: &StopFlag,
        abandon: &StopFlag,
        tx: &mpsc::SyncSender<Message>,
    ) -> Result<(), Error> {
        let mut sim = self.load(k)?.stop_when(stop.clone());
        let n = sim.n_steps();
        let mut block = (Vec::with_capacity(BLOCK_ROWS), Vec::new());
        let row = sim.sample_row()?;
        block.0.push(0.0);
        block.1.extend_from_slice(row);
        for _ in 0..n {
            stop.check()?;
            if block.0.len() == BLOCK_ROWS {
                let full = std::mem::replace(&mut block, (Vec::with_capacity(BLOCK_ROWS), vec![]));
                if abandon.is_set() || tx.send(Message::Rows(full.0, full.1)).is_err() {
                    return Ok(());
                }
            }
            sim.step()?;
            let t = sim.time();
            let row = sim.sample_row()?;
            block.0.push(t);
            block.1.extend_from_slice(row);
        }
        let stats = sim.model_exchange_stats();
        sim.terminate()?;
        if tx.send(Message::Rows(block.0, block.1)).is_ok() {
            let _ = tx.send(Message::End(stats));
        }
        Ok(())
    }

    /// Takes the parts' blocks in turn and hands their rows, merged, to `sink`.
    fn merge<E: From<Error>>(
        &self,
        receivers: &[mpsc::Receiver<Message>],
        sink: &mut impl FnMut(f64, &[f64]) -> Result<(), E>,
        progress: &mut impl FnMut(f64),
    ) -> Result<RunEnd, E> {
        let split = &self.split;
        let widths: Vec<usize> = split.part_records.iter().map(Vec::len).collect();
        let mut row = vec![0.0; split.record_names.len()];
        let mut stats: Vec<(String, MeStats)> = Vec::new();
        let mut blocks: Vec<(Vec<f64>, Vec<f64>)> = vec![(vec![], vec![]); receivers.len()];
        let mut rows_done = 0u64;
        let total = self.n_steps.max(1) as f64;
        loop {
            let mut ended = 0;
            for (k, rx) in receivers.iter().enumerate() {
                match rx.recv() {
                    Ok(Message::Rows(times, values)) => blocks[k] = (times, values),
                    Ok(Message::End(s)) => {
                        stats.extend(s);
                        ended += 1;
                    }
                    Ok(Message::Failed(e)) => return Err(e.into()),
                    Err(_) => {
                        return Err(Error::Config(format!(
                        "part {k} of the system stopped without a word (a bug: please report it)"
                    ))
                        .into())
                    }
                }
            }
            if ended == receivers.len() {
                break;
            }
            if ended > 0 {
                return Err(Error::Config(
                    "the parts of the system ended at different times (a bug: please report it)"
                        .into(),
                )
                .into());
            }
            let times = &blocks[0].0;
            for (r, &t) in times.iter().enumerate() {
                for (out, &(p, i)) in row.iter_mut().zip(&split.columns) {
                    *out = blocks[p].1[r * widths[p] + i];
                }
                sink(t, &row)?;
                rows_done += 1;
                if rows_done > 1 {
                    progress((rows_done - 1) as f64 / total);
                }
            }
        }
        let position = |n: &String| self.order.iter().position(|c| c == n);
        stats.sort_by_key(|(n, _)| position(n));
        Ok(RunEnd { model_exchange: stats })
    }
}
