//! The pieces of a step: one piece of `2^level` ticks propagated to its end or, where the
//! watched functionals say it stops, bisected down the table to the first resolution
//! interval at whose end a stop condition holds.

use super::configs::table;
use super::kernels::{mul_vec, mul_vec_inline};
use super::ticks::TICK;
use crate::linear::{self, Chain, Vector};
use crate::{Plant, StepReport};

impl Plant {
    /// Propagates one piece of `2^level` ticks, stopping at the first event inside it.
    /// Returns the ticks consumed and whether an event was handled.
    pub(crate) fn piece(&mut self, level: usize, report: &mut StepReport) -> (u64, bool) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU has AVX.
            return unsafe { self.piece_avx(level, report) };
        }
        self.piece_inline::<false>(level, report)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn piece_avx(&mut self, level: usize, report: &mut StepReport) -> (u64, bool) {
        self.piece_inline::<true>(level, report)
    }

    /// The pieces of `left` ticks (below one scan interval) by its set bits from the top, as
    /// `advance_held` would take them one `piece` at a time, up to and with the first one that
    /// stops: the ticks consumed, whether an event was handled, and whether a piece stopped
    /// before its end. A piece that runs clear is `piece`'s test and product, made here
    /// without its set-up (one configuration and watch for them all: nothing changes them
    /// until a stop); a piece that may stop goes to `piece`, which makes the same test again
    /// from the same state, and so the same decision.
    pub(crate) fn pieces(&mut self, left: u64, report: &mut StepReport) -> (u64, bool, bool) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU has AVX.
            return unsafe { self.pieces_avx(left, report) };
        }
        self.pieces_inline::<false>(left, report)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn pieces_avx(&mut self, left: u64, report: &mut StepReport) -> (u64, bool, bool) {
        self.pieces_inline::<true>(left, report)
    }

    #[inline(always)]
    fn pieces_inline<const AVX: bool>(
        &mut self,
        left: u64,
        report: &mut StepReport,
    ) -> (u64, bool, bool) {
        let key = self.config();
        let mut consumed = 0u64;
        while consumed < left {
            let stop_level = {
                let cfg = table(&self.solver.configs, key);
                let chain = &*self.solver.chain;
                let watch = self.watch(cfg);
                let (mut z, mut e, mut n) = (self.state.z, self.state.earth, self.state.nonearth);
                let mut stop_level = None;
                while consumed < left {
                    let level = 63 - (left - consumed).leading_zeros() as usize;
                    // `piece_inline`'s test of the piece's end, and its test for a turn of ξ.
                    let (xi1, rate1) = (
                        cfg.level_value::<AVX>(level, 0, &z),
                        cfg.level_value::<AVX>(level, 1, &z),
                    );
                    let hit = watch.brakes_changed_at(
                        chain.level_value::<AVX>(level, 0, &e),
                        chain.level_value::<AVX>(level, 0, &n),
                    ) || watch.play_event_at(xi1, rate1);
                    if hit || (watch.direction == 0.0 && watch.rate(&z) * rate1 < 0.0) {
                        stop_level = Some(level);
                        break;
                    }
                    z = mul_vec_inline::<{ linear::N }, AVX>(&cfg.phi[level], &z);
                    e = mul_vec_inline::<4, AVX>(&chain.phi[level], &e);
                    n = mul_vec_inline::<4, AVX>(&chain.phi[level], &n);
                    consumed += 1 << level;
                }
                (self.state.z, self.state.earth, self.state.nonearth) = (z, e, n);
                stop_level
            };
            let Some(level) = stop_level else {
                break;
            };
            // A piece that may stop: `piece` decides it. One that runs clear after all (a
            // sign change of `ξ̇` that is no turn, or whose turn cannot reach an onset)
            // leaves the configuration as it was, and the loop goes on.
            let (ticks, event) = self.piece_inline::<AVX>(level, report);
            consumed += ticks;
            if event || ticks < 1 << level {
                return (consumed, event, true);
            }
        }
        (consumed, false, false)
    }

    /// `piece` with its products inlined (one CPU dispatch per piece, not per product).
    ///
    /// Every instant it tests is tested on the watched functionals through that level's
    /// propagator (`Propagators::level_value`: four dot products), and the state is
    /// propagated only where it moves on: to the piece's end when nothing stops it, and in
    /// the bisection to each candidate found clear, then over the last resolution interval.
    #[inline(always)]
    fn piece_inline<const AVX: bool>(
        &mut self,
        level: usize,
        report: &mut StepReport,
    ) -> (u64, bool) {
        let key = self.config();
        let cfg = table(&self.solver.configs, key);
        let chain = &*self.solver.chain;
        let (z0, e0, n0) = (self.state.z, self.state.earth, self.state.nonearth);
        let watch = self.watch(cfg);
        let (xi1, rate1) =
            (cfg.level_value::<AVX>(level, 0, &z0), cfg.level_value::<AVX>(level, 1, &z0));
        let hit = watch.brakes_changed_at(
            chain.level_value::<AVX>(level, 0, &e0),
            chain.level_value::<AVX>(level, 0, &n0),
        ) || watch.play_event_at(xi1, rate1);
        let propagate = |z: &Vector, e: &Chain, n: &Chain, l: usize| {
            (
                mul_vec_inline::<{ linear::N }, AVX>(&cfg.phi[l], z),
                mul_vec_inline::<4, AVX>(&chain.phi[l], e),
                mul_vec_inline::<4, AVX>(&chain.phi[l], n),
            )
        };
        // With no play sliding, ξ may cross a threshold and come back inside the piece:
        // stop at its extremum (ξ̇ = 0) too, when the excursion could reach a threshold.
        let rate0 = watch.rate(&z0);
        let mut end = None;
        let mut extremum = false;
        if !hit && watch.direction == 0.0 && rate0 * rate1 < 0.0 {
            let (z1, e1, n1) = propagate(&z0, &e0, &n0, level);
            if watch.turns(&z0, &z1, rate0, rate1) {
                let dt = TICK * (1u64 << level) as f64;
                extremum = watch.extremum_may_cross(watch.xi(&z0), xi1, rate0, rate1, dt);
            }
            end = Some((z1, e1, n1));
        }
        if !hit && !extremum {
            (self.state.z, self.state.earth, self.state.nonearth) =
                end.unwrap_or_else(|| propagate(&z0, &e0, &n0, level));
            return (1 << level, false);
        }
        let (mut z, mut e, mut n) = (z0, e0, n0);
        let mut offset = 0u64;
        for l in (self.resolution_level()..level).rev() {
            let (xi, rate) = (cfg.level_value::<AVX>(l, 0, &z), cfg.level_value::<AVX>(l, 1, &z));
            let stop = watch.brakes_changed_at(
                chain.level_value::<AVX>(l, 0, &e),
                chain.level_value::<AVX>(l, 0, &n),
            ) || watch.play_event_at(xi, rate)
                || (extremum && rate * rate0 <= 0.0);
            if !stop {
                (z, e, n) = propagate(&z, &e, &n, l);
                offset += 1 << l;
            }
        }
        // The first resolution interval at whose end the stop condition holds.
        let r = self.resolution_level().min(level);
        (self.state.z, self.state.earth, self.state.nonearth) = propagate(&z, &e, &n, r);
        let event = watch.event(&self.state.z, &self.state.earth, &self.state.nonearth);
        if event {
            self.handle_event(report);
        }
        (offset + (1 << r), event)
    }

    /// Propagates `2^level` ticks without looking for events (event budget exhausted).
    pub(crate) fn blind(&mut self, level: usize) -> (u64, bool) {
        let key = self.config();
        let cfg = table(&self.solver.configs, key);
        self.state.z = mul_vec(&cfg.phi[level], &self.state.z);
        self.state.earth = mul_vec(&self.solver.chain.phi[level], &self.state.earth);
        self.state.nonearth = mul_vec(&self.solver.chain.phi[level], &self.state.nonearth);
        (1 << level, false)
    }

    /// What `pieces` does, one `piece` at a time on a clone, as the loop of `advance_held`
    /// takes them: for the debug build's check of `pieces`.
    #[cfg(debug_assertions)]
    pub(crate) fn pieces_one_by_one(
        &self,
        left: u64,
        mut report: StepReport,
    ) -> (Plant, StepReport, (u64, bool, bool)) {
        let mut plant = self.clone();
        let mut consumed = 0;
        while consumed < left {
            let level = 63 - (left - consumed).leading_zeros() as usize;
            let (ticks, event) = plant.piece(level, &mut report);
            consumed += ticks;
            if event || ticks < 1 << level {
                return (plant, report, (consumed, event, true));
            }
        }
        (plant, report, (consumed, false, false))
    }
}
