//! The quiet step: one bound, taken at the start of a step, that proves nothing the event
//! loop watches can stop it anywhere in the step, then the step's one propagation product.
//!
//! Without an event, the event loop of `solver` makes a sequence of products that depends on
//! `h` alone: the scan segments (each up to a top-level piece, by the set bits of its
//! ticks), the cached tail below one scan interval, the sub-tick Taylor step. Every value
//! it compares on the way is a watched row applied to a state that is a product of those
//! matrices with the step's first state, so a [`ScanBound`] over those composed rows holds
//! all of them; when it proves them clear, the loop would stop nowhere. A step that stops
//! nowhere ends, in the event loop as here, at the whole-step propagator
//! (`configs::whole_step`, those products multiplied out) times its first state, so the
//! quiet step makes that one product and gets the event loop's bits.
//! Nothing is written until the step is known finite, so there is nothing to undo.

use std::sync::Arc;

use nalgebra::{SMatrix, SVector};

use super::configs::{product, table, whole_step};
use super::kernels::mul_vec_inline;
use super::propagators::{BoundRow, Propagators, ScanBound, TURN_RATE};
use super::scan::MIN_BOUND_POINTS;
use super::ticks::{ticks_of, LEVELS};
use crate::linear::{self, ix, Chain, ChainMatrix, Matrix, Vector};
use crate::{Dac, Mode, Plant, StepReport, N_PLAYS};

/// Most scan segments a planned step may have: a 2 ms step has two (128 points and 3 at
/// the default tolerance), longer steps take the general path.
const MAX_SEGMENTS: usize = 2;

/// What a quiet step of one length makes in one mode with nothing slipping.
#[derive(Debug)]
pub(crate) struct QuietPlan {
    /// The step length it is for (bits of `h`).
    h: u64,
    /// `None` where the step is too long or the bound isn't finite.
    body: Option<Body>,
}

#[derive(Debug)]
struct Body {
    /// Segments long enough for the general path to try its bound (for `ScanStats`).
    long_segments: u64,
    /// The whole step's propagators (`configs::whole_step`, the event loop's for a step
    /// without a stop): of the mechanics and of either analog chain.
    whole: (Matrix, ChainMatrix),
    mechanics: ScanBound<{ linear::N }>,
    chain: ScanBound<4>,
}

/// A factor of [`compose`]: `mᵀ` and `|m|ᵀ` of a product `m`, formed once for every row
/// composed through it (the same entries, so the same products).
struct Factor<const D: usize> {
    t: SMatrix<f64, D, D>,
    abs_t: SMatrix<f64, D, D>,
}

impl<const D: usize> Factor<D> {
    fn of(m: &SMatrix<f64, D, D>) -> Self {
        Factor { t: m.transpose(), abs_t: m.abs().transpose() }
    }
}

/// `c` seen through the products `pre` (applied in order) as a bound row.
fn compose<const D: usize>(c: &SVector<f64, D>, pre: &[Factor<D>]) -> BoundRow<D> {
    if pre.is_empty() {
        return BoundRow { row: *c, magnitude: None };
    }
    let (mut row, mut magnitude) = (*c, c.abs());
    for m in pre.iter().rev() {
        row = m.t * row;
        magnitude = m.abs_t * magnitude;
    }
    BoundRow { row, magnitude: Some(magnitude) }
}

/// The matrices `Propagators::advance` applies over `ticks`, in its order.
fn advance_factors<const D: usize>(t: &Propagators<D>, mut ticks: u64, out: &mut Vec<Factor<D>>) {
    let top = 1u64 << (LEVELS - 1);
    while ticks >= 2 * top {
        out.push(Factor::of(&t.phi[LEVELS - 1]));
        ticks -= top;
    }
    while ticks != 0 {
        out.push(Factor::of(&t.phi[ticks.trailing_zeros() as usize]));
        ticks &= ticks - 1;
    }
}

/// Every row functional `o` of `t` is compared on during a step of these segments and
/// tail: each segment's scan points from its first state, the tail's end.
fn step_rows<const D: usize>(
    t: &Propagators<D>,
    o: usize,
    segments: &[u64],
    remainder: Option<&SMatrix<f64, D, D>>,
) -> Vec<BoundRow<D>> {
    let w = t.watched.len();
    let mut pre = Vec::new();
    // The step's first state: the tail's start when there is no segment.
    let mut rows = vec![compose(&t.watched[o], &pre)];
    for &ticks in segments {
        let points = (ticks >> t.scan_level) as usize;
        for k in 0..=points {
            let c = if k == 0 { t.watched[o] } else { t.scan[(k - 1) * w + o] };
            rows.push(compose(&c, &pre));
        }
        advance_factors(t, ticks, &mut pre);
    }
    if let Some(r) = remainder {
        pre.push(Factor::of(r));
        rows.push(compose(&t.watched[o], &pre));
    }
    rows
}

/// The differences of functional `o` of `t` between the two points of every turn test of a
/// step of these segments and tail (`propagators::TURN_RATE`): each segment's consecutive scan
/// points, and the tail's start and end.
fn step_differences<const D: usize>(
    t: &Propagators<D>,
    o: usize,
    segments: &[u64],
    remainder: Option<&SMatrix<f64, D, D>>,
) -> Vec<BoundRow<D>> {
    let w = t.watched.len();
    let row = |k: usize| if k == 0 { t.watched[o] } else { t.scan[(k - 1) * w + o] };
    let difference = |a: BoundRow<D>, b: BoundRow<D>| {
        BoundRow::difference(&a.row, a.magnitude.as_ref(), &b.row, b.magnitude.as_ref())
    };
    let mut pre = Vec::new();
    let mut rows = Vec::new();
    for &ticks in segments {
        let points = (ticks >> t.scan_level) as usize;
        for k in 0..points {
            rows.push(difference(compose(&row(k + 1), &pre), compose(&row(k), &pre)));
        }
        advance_factors(t, ticks, &mut pre);
    }
    if let Some(r) = remainder {
        let start = compose(&t.watched[o], &pre);
        pre.push(Factor::of(r));
        rows.push(difference(compose(&t.watched[o], &pre), start));
    }
    rows
}

impl QuietPlan {
    fn new(h: f64, cfg: &Propagators<{ linear::N }>, chain: &Propagators<4>) -> QuietPlan {
        QuietPlan { h: h.to_bits(), body: Body::new(h, cfg, chain) }
    }
}

impl Body {
    fn new(h: f64, cfg: &Propagators<{ linear::N }>, chain: &Propagators<4>) -> Option<Body> {
        let (mut left, _) = ticks_of(h);
        let fine = 1u64 << chain.scan_level;
        let mut segments = Vec::new();
        // As `advance_held` cuts a step that has no event.
        while left >= fine {
            let points = ((left >> chain.scan_level) as usize).min(chain.scan_points);
            let ticks = (points as u64) << chain.scan_level;
            segments.push(ticks);
            left -= ticks;
            if segments.len() > MAX_SEGMENTS {
                return None;
            }
        }
        let long_segments = segments
            .iter()
            .filter(|&&t| (t >> chain.scan_level) as usize >= MIN_BOUND_POINTS)
            .count() as u64;
        let remainder = (left > 0).then(|| (product(&cfg.phi, left), product(&chain.phi, left)));
        let rows = |o| step_rows(cfg, o, &segments, remainder.as_ref().map(|r| &r.0));
        let turns = step_differences(cfg, 1, &segments, remainder.as_ref().map(|r| &r.0));
        let mechanics =
            ScanBound::from_rows(*cfg.bound.as_ref()?.settle(), &[rows(0), rows(1), turns])?;
        let chain_rows = step_rows(chain, 0, &segments, remainder.as_ref().map(|r| &r.1));
        let whole = (whole_step(cfg, h)?, whole_step(chain, h)?);
        let chain = ScanBound::from_rows(*chain.bound.as_ref()?.settle(), &[chain_rows])?;
        Some(Body { long_segments, whole, mechanics, chain })
    }
}

/// The state a quiet step ends in, before it is committed.
struct Quiet {
    z: Vector,
    earth: Chain,
    nonearth: Chain,
    direction: i8,
    long_segments: u64,
}

impl Plant {
    /// The step when a bound proves it quiet (no brake switch, no slip onset or reversal,
    /// no turn of `ξ` that could reach an onset) and its state stays finite: the same bits as
    /// the event loop, at the cost of one bound and the products. `None` (and the plant
    /// unchanged) otherwise, and then the event loop takes the step.
    pub(crate) fn quiet_step(&mut self, dac: Dac, h: f64) -> Option<StepReport> {
        let repeated = std::mem::replace(&mut self.solver.last_h, h.to_bits()) == h.to_bits();
        if self.solver.scan_always || self.state.hysteresis.sliding != 0 {
            return None;
        }
        let mode = self.state.mode.index();
        let key = mode << N_PLAYS;
        if self.solver.quiet[mode].as_ref().is_none_or(|p| p.h != h.to_bits()) {
            // Plans are for the steps a master repeats; the first step of a length and the
            // first entry into a configuration take the general path.
            self.solver.configs[key].as_ref()?;
            if !repeated {
                return None;
            }
            self.build_quiet(mode, h);
        }
        let q = self.quiet_state(dac, h, key)?;
        #[cfg(debug_assertions)]
        let reference = {
            let mut p = self.clone();
            p.solver.scan_always = true;
            p.step(dac, h).expect("the quiet step is finite");
            p
        };
        self.state.z = q.z;
        self.state.earth = q.earth;
        self.state.nonearth = q.nonearth;
        self.state.hysteresis.direction = q.direction;
        self.state.armed.sync_direction(&self.state.hysteresis);
        self.solver.scan_stats.skipped += q.long_segments;
        self.solver.scan_stats.quiet += 1;
        self.state.time += h;
        self.sample_encoder();
        #[cfg(debug_assertions)]
        {
            let (mut a, mut b) = (Vec::new(), Vec::new());
            self.save_state(&mut a);
            reference.save_state(&mut b);
            assert!(a == b, "the quiet step and the event loop differ");
        }
        Some(StepReport::default())
    }

    #[cold]
    #[inline(never)]
    fn build_quiet(&mut self, mode: usize, h: f64) {
        let cfg = table(&self.solver.configs, mode << N_PLAYS);
        self.solver.quiet[mode] = Some(Arc::new(QuietPlan::new(h, cfg, &self.solver.chain)));
    }

    /// The end of the step if it is quiet and finite, from the plan of this mode and `h`.
    fn quiet_state(&self, dac: Dac, h: f64, key: usize) -> Option<Quiet> {
        // One dispatch on the CPU for the whole step, so every product inlines.
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU has AVX.
            return unsafe { self.quiet_state_avx(dac, h, key) };
        }
        self.quiet_state_inline::<false>(dac, h, key)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn quiet_state_avx(&self, dac: Dac, h: f64, key: usize) -> Option<Quiet> {
        self.quiet_state_inline::<true>(dac, h, key)
    }

    #[inline(always)]
    fn quiet_state_inline<const AVX: bool>(&self, dac: Dac, h: f64, key: usize) -> Option<Quiet> {
        let plan = self.solver.quiet[key >> N_PLAYS].as_deref()?.body.as_ref()?;
        let cfg = table(&self.solver.configs, key);
        let (mut z, mut e, mut n) = (self.state.z, self.state.earth, self.state.nonearth);
        let volts = super::solver::held_volts;
        z[ix::UX] = volts(dac.extension);
        e[3] = volts(dac.earth);
        n[3] = volts(dac.nonearth);
        let watch = self.watch(cfg);
        // What `sync_hysteresis` would do; a quiet step leaves the memories as they are.
        let rate = watch.rate(&z);
        let direction = super::solver::rate_sign(rate);
        let xi = watch.xi(&z);
        debug_assert!(
            !self.state.armed.keeps(xi) || self.state.hysteresis.sync_keeps(xi, direction)
        );
        if !self.state.armed.keeps(xi) && !self.state.hysteresis.sync_keeps(xi, direction) {
            return None;
        }
        z[ix::C0] = self.state.armed.c0();
        let split = plan.mechanics.split_inline::<AVX>(&z);
        let ranges = [
            plan.chain.range::<AVX>(0, &plan.chain.split_inline::<AVX>(&e)),
            plan.chain.range::<AVX>(0, &plan.chain.split_inline::<AVX>(&n)),
            plan.mechanics.range::<AVX>(0, &split),
            plan.mechanics.range::<AVX>(1, &split),
        ];
        // All four at once, no early exit: on a quiet step every one of them is needed; the
        // bound of a turn's reach only where the one of `ξ̇` does not do.
        let clear = self.clear_on(
            &watch,
            || ranges[0],
            || ranges[1],
            || Some((ranges[2]?, ranges[3]?)),
            || plan.mechanics.range::<AVX>(TURN_RATE, &split),
        );
        if !clear {
            return None;
        }
        let (phi, chain_phi) = &plan.whole;
        (z, e, n) = (
            mul_vec_inline::<{ linear::N }, AVX>(phi, &z),
            mul_vec_inline::<4, AVX>(chain_phi, &e),
            mul_vec_inline::<4, AVX>(chain_phi, &n),
        );
        if self.state.mode == Mode::Drive {
            z[ix::Y4] = z[ix::Y3] + self.state.drive_offset;
            z[ix::V4] = z[ix::V3];
        }
        // `0·x` is ±0 for a finite `x` and NaN otherwise.
        let finite = (self.state.time + h).is_finite()
            && (z * 0.0).sum() + (e * 0.0).sum() + (n * 0.0).sum() == 0.0;
        finite.then_some(Quiet {
            z,
            earth: e,
            nonearth: n,
            direction,
            long_segments: plan.long_segments,
        })
    }
}
