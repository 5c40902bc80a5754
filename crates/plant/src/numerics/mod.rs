//! The plant's numerics, apart from its physics: the exact propagation of the piecewise
//! linear system of `crate::linear` between located events. The event-driven step is in
//! `solver` (its scan in `scan`, its pieces and their bisection in `pieces`, the quiet step
//! in `quiet`); the per-configuration propagator tables in `propagators` and `configs`
//! (their exponentials in `expm`, the time grid in `ticks`); the AVX kernels they run on
//! in `kernels` and `lu`. Every `unsafe` block of the crate is here, each an AVX path
//! taken only where the CPU has it, beside the portable path it equals bit for bit.
//!
//! [`Solver`] is what the numerics keep between steps: tables derived from the parameters,
//! never part of the plant's state (`crate::Dynamics`), so a state saved and restored or a
//! clone gives the same bits whatever the cache held.

pub(crate) mod configs;
mod expm;
pub(crate) mod kernels;
mod lu;
mod pieces;
pub(crate) mod propagators;
pub(crate) mod quiet;
mod scan;
pub(crate) mod solver;
mod ticks;

use std::sync::Arc;

use configs::{ChainRemainder, ConfigTable, Remainder, Whole};
use propagators::Propagators;
use quiet::QuietPlan;

use crate::{linear, PlantParams, ScanStats, N_PLAYS};

/// The propagators a plant's steps use, built lazily and kept between steps.
#[derive(Clone, Debug)]
pub(crate) struct Solver {
    /// The analog channels' propagators (one configuration: they have no events).
    pub chain: Arc<Propagators<4>>,
    /// Lazily built propagators, indexed by mode and sliding set.
    pub configs: Vec<Option<ConfigTable>>,
    /// Propagators over the last sub-scan tail of a step, per configuration: a master's
    /// steps repeat, so their tails do too.
    /// Boxed: most are empty, and a clone (`load_state` makes one) copies only the others.
    pub remainders: Vec<Option<Box<Remainder>>>,
    pub chain_remainder: Option<ChainRemainder>,
    /// Propagators of a whole step that stops nowhere (`configs::whole_step`), per
    /// configuration, for the last step length each (boxed as `remainders`).
    pub wholes: Vec<Option<Box<Whole<{ linear::N }>>>>,
    pub chain_whole: Option<Whole<4>>,
    /// The quiet-step plans of each mode with nothing slipping, for one step length each.
    pub quiet: [Option<Arc<QuietPlan>>; 4],
    /// The length of the last step (bits of `h`): a plan is built when a length repeats.
    pub last_h: u64,
    /// Always take the event loop and scan every point (the solver before the quiet step
    /// and the quiet-step bound); results are bit-identical either way. For benchmarks and
    /// tests.
    pub scan_always: bool,
    /// Scans of `MIN_BOUND_POINTS` or more points: how many were run, how many the bound
    /// proved clear.
    pub scan_stats: ScanStats,
}

impl Solver {
    /// Empty caches and the analog channels' table, for validated parameters.
    pub fn new(params: &PlantParams) -> Solver {
        let mut volts = linear::Chain::zeros();
        volts[2] = 1.0;
        let scan_level = propagators::scan_level(params.rel_tol);
        let chain =
            Arc::new(Propagators::new(linear::chain_matrix(params), vec![volts], scan_level));
        Solver {
            chain,
            configs: vec![None; 4 << N_PLAYS],
            remainders: vec![None; 4 << N_PLAYS],
            chain_remainder: None,
            wholes: vec![None; 4 << N_PLAYS],
            chain_whole: None,
            quiet: Default::default(),
            last_h: 0,
            scan_always: false,
            scan_stats: ScanStats::default(),
        }
    }
}
