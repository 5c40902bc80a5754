//! The scan: the watched functionals at the scan points of a piece, from the tabulated rows
//! (`Propagators::scanned4`), four points at a time; and the scan bound, which proves a
//! whole scan clear (or its brakes) from the state alone (`propagators::ScanBound`).

use super::configs::table;
use super::propagators::{Propagators, BOUND_SLACK};
use super::solver::Watch;
use super::ticks::TICK;
use crate::linear::{self, ix, Chain};
use crate::Plant;

/// A scan of fewer points than this is cheaper than the bound that could skip it.
pub(crate) const MIN_BOUND_POINTS: usize = 16;

/// What the scan bound proved of a scan (`Plant::provably_clear`).
enum Proof {
    /// Nothing: the scan looks at every test.
    Nothing,
    /// No brake switches at any scan point: the scan looks at the mechanics alone.
    Brakes,
    /// Every scan point is clear: no scan.
    All,
}

/// The brakes' part of `Plant::clear_on`: on intervals of the earth and the non-earth
/// brake volts that hold every value the event loop will compare, neither brake switches.
#[inline(always)]
fn brakes_clear_on(watch: &Watch, earth: Option<(f64, f64)>, nonearth: Option<(f64, f64)>) -> bool {
    let clear = |range: Option<(f64, f64)>, closed_below: bool| -> bool {
        let Some((lo, hi)) = range else {
            return false;
        };
        if closed_below {
            hi < watch.vth
        } else {
            lo >= watch.vth
        }
    };
    // Earth closed ⇔ V_E < V_th; non-earth closed ⇔ V_N ≥ V_th: no switch means V_E stays
    // on its side of V_th, as does V_N.
    clear(earth, watch.earth_closed) && clear(nonearth, !watch.nonearth_closed)
}

/// Whether any of four consecutive scan points may stop the scan: the point-by-point test of
/// `full_scan_inline` on four lanes at once (the same IEEE comparisons, products and sums,
/// so the same decisions; `maxpd` and `f64::max` differ only on a NaN or a zero's sign, and a
/// lane with a NaN counts as a stop). `false` means every point is clear; on `true` the
/// caller decides the points one by one. Without `BRAKES` the brake volts are not looked
/// at (a bound has proved that neither brake switches at any scan point).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn group_may_stop<const BRAKES: bool>(
    w: &Watch,
    [ve, vn, xi, rate]: [&[f64; 4]; 4],
    xi_prev: f64,
    rate_prev: f64,
    dt: f64,
) -> bool {
    use std::arch::x86_64::*;
    // SAFETY: every load is of a whole `[f64; 4]`.
    unsafe {
        let (x, r) = (_mm256_loadu_pd(xi.as_ptr()), _mm256_loadu_pd(rate.as_ptr()));
        let nan =
            _mm256_or_pd(_mm256_cmp_pd::<_CMP_UNORD_Q>(x, x), _mm256_cmp_pd::<_CMP_UNORD_Q>(r, r));
        let brakes = if BRAKES {
            let (ve, vn) = (_mm256_loadu_pd(ve.as_ptr()), _mm256_loadu_pd(vn.as_ptr()));
            let vth = _mm256_set1_pd(w.vth);
            let nan = _mm256_or_pd(
                _mm256_cmp_pd::<_CMP_UNORD_Q>(ve, ve),
                _mm256_cmp_pd::<_CMP_UNORD_Q>(vn, vn),
            );
            // Earth closed ⇔ V_E < V_th, non-earth closed ⇔ V_N ≥ V_th: a stop is the other
            // side.
            let earth = if w.earth_closed {
                _mm256_cmp_pd::<_CMP_GE_OQ>(ve, vth)
            } else {
                _mm256_cmp_pd::<_CMP_LT_OQ>(ve, vth)
            };
            let nonearth = if w.nonearth_closed {
                _mm256_cmp_pd::<_CMP_LT_OQ>(vn, vth)
            } else {
                _mm256_cmp_pd::<_CMP_GE_OQ>(vn, vth)
            };
            _mm256_or_pd(nan, _mm256_or_pd(earth, nonearth))
        } else {
            _mm256_setzero_pd()
        };
        let (up, down) = (_mm256_set1_pd(w.up), _mm256_set1_pd(w.down));
        let play = if w.direction != 0.0 {
            let reversal = _mm256_cmp_pd::<_CMP_LE_OQ>(
                _mm256_mul_pd(_mm256_set1_pd(w.direction), r),
                _mm256_setzero_pd(),
            );
            let onset = if w.direction > 0.0 {
                _mm256_cmp_pd::<_CMP_GE_OQ>(x, up)
            } else {
                _mm256_cmp_pd::<_CMP_LE_OQ>(x, down)
            };
            _mm256_or_pd(reversal, onset)
        } else {
            let onset = _mm256_or_pd(
                _mm256_cmp_pd::<_CMP_GE_OQ>(x, up),
                _mm256_cmp_pd::<_CMP_LE_OQ>(x, down),
            );
            // Each point against the one before it: the previous group's last, then these.
            let xp = _mm256_set_pd(xi[2], xi[1], xi[0], xi_prev);
            let rp = _mm256_set_pd(rate[2], rate[1], rate[0], rate_prev);
            let turn = _mm256_cmp_pd::<_CMP_LT_OQ>(_mm256_mul_pd(r, rp), _mm256_setzero_pd());
            let abs = _mm256_castsi256_pd(_mm256_set1_epi64x(i64::MAX));
            let reach = _mm256_mul_pd(
                _mm256_mul_pd(
                    _mm256_set1_pd(dt),
                    _mm256_add_pd(_mm256_and_pd(rp, abs), _mm256_and_pd(r, abs)),
                ),
                _mm256_set1_pd(w.xi_row[ix::VX]),
            );
            let cross = _mm256_or_pd(
                _mm256_cmp_pd::<_CMP_GE_OQ>(_mm256_add_pd(_mm256_max_pd(xp, x), reach), up),
                _mm256_cmp_pd::<_CMP_LE_OQ>(_mm256_sub_pd(_mm256_min_pd(xp, x), reach), down),
            );
            _mm256_or_pd(onset, _mm256_and_pd(turn, cross))
        };
        let any = _mm256_or_pd(_mm256_or_pd(nan, play), brakes);
        _mm256_movemask_pd(any) != 0
    }
}

impl Plant {
    /// Scans up to `points` scan intervals ahead for anything the event loop must stop at,
    /// using only the tabulated functionals. Returns how many intervals are clear.
    pub(crate) fn scan(&mut self, points: usize) -> usize {
        let key = self.config();
        let cfg = table(&self.solver.configs, key);
        let watch = self.watch(cfg);
        let mut brakes = true;
        if points >= MIN_BOUND_POINTS && !self.solver.scan_always {
            match self.provably_clear(cfg, &watch) {
                Proof::All => {
                    debug_assert_eq!(
                        self.full_scan(cfg, &watch, points, true),
                        points,
                        "the scan bound missed an event"
                    );
                    self.solver.scan_stats.skipped += 1;
                    return points;
                }
                Proof::Brakes => brakes = false,
                Proof::Nothing => {}
            }
            self.solver.scan_stats.scanned += 1;
        }
        let clear = self.full_scan(cfg, &watch, points, brakes);
        debug_assert!(
            brakes || clear == self.full_scan(cfg, &watch, points, true),
            "the brakes' bound missed a switch"
        );
        clear
    }

    /// `scan` looking at every point; without `brakes` at the mechanics alone (a bound
    /// has proved that neither brake switches at any scan point, so their tests would all
    /// be false and they decide nothing).
    fn full_scan(
        &self,
        cfg: &Propagators<{ linear::N }>,
        watch: &Watch,
        points: usize,
        brakes: bool,
    ) -> usize {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU has AVX.
            return unsafe {
                if brakes {
                    self.full_scan_avx::<true>(cfg, watch, points)
                } else {
                    self.full_scan_avx::<false>(cfg, watch, points)
                }
            };
        }
        if brakes {
            self.full_scan_inline::<false, true>(cfg, watch, points)
        } else {
            self.full_scan_inline::<false, false>(cfg, watch, points)
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn full_scan_avx<const BRAKES: bool>(
        &self,
        cfg: &Propagators<{ linear::N }>,
        watch: &Watch,
        points: usize,
    ) -> usize {
        self.full_scan_inline::<true, BRAKES>(cfg, watch, points)
    }

    /// The scan, four points' values at a time (`Propagators::scanned4`: the same bits as
    /// one at a time), each point then decided in order as before; the brake volts only
    /// with `BRAKES`.
    #[inline(always)]
    fn full_scan_inline<const AVX: bool, const BRAKES: bool>(
        &self,
        cfg: &Propagators<{ linear::N }>,
        watch: &Watch,
        points: usize,
    ) -> usize {
        let chain = &self.solver.chain;
        let (z, e, n) = (&self.state.z, &self.state.earth, &self.state.nonearth);
        let dt = TICK * (1u64 << chain.scan_level) as f64;
        let mut xi_prev = watch.xi(z);
        let mut rate_prev = watch.rate(z);
        for g in 0..points.div_ceil(4) {
            let (ve, vn) = if BRAKES {
                (chain.scanned4::<AVX>(g, 0, e), chain.scanned4::<AVX>(g, 0, n))
            } else {
                ([0.0; 4], [0.0; 4])
            };
            let xi = cfg.scanned4::<AVX>(g, 0, z);
            let rate = cfg.scanned4::<AVX>(g, 1, z);
            #[cfg(target_arch = "x86_64")]
            if AVX && 4 * g + 4 <= points {
                // SAFETY: `AVX` callers run with AVX.
                let may_stop = unsafe {
                    group_may_stop::<BRAKES>(watch, [&ve, &vn, &xi, &rate], xi_prev, rate_prev, dt)
                };
                if !may_stop {
                    (xi_prev, rate_prev) = (xi[3], rate[3]);
                    continue;
                }
            }
            for l in 0..4 {
                let k = 4 * g + l + 1;
                if k > points {
                    break;
                }
                let (xi, rate) = (xi[l], rate[l]);
                let stop = (BRAKES
                    && ((ve[l] < watch.vth) != watch.earth_closed
                        || (vn[l] >= watch.vth) != watch.nonearth_closed))
                    || watch.play_event_at(xi, rate)
                    || (watch.direction == 0.0
                        && rate * rate_prev < 0.0
                        && watch.extremum_may_cross(xi_prev, xi, rate_prev, rate, dt));
                if stop {
                    return k - 1;
                }
                xi_prev = xi;
                rate_prev = rate;
            }
        }
        points
    }

    /// Whether the scan of any number of points (up to a whole top-level piece) from the
    /// current state is certain to find every point clear, from the bounds of the watched
    /// functionals over all scan points (`propagators::ScanBound`). The test mirrors every
    /// condition of `scan` on intervals that hold the very values `scan` would compute,
    /// so `Proof::All` means `scan` would return all points, and `Proof::Brakes` that no
    /// brake test of the scan can fire; in doubt it proves less.
    fn provably_clear(&self, cfg: &Propagators<{ linear::N }>, watch: &Watch) -> Proof {
        let chain = &self.solver.chain;
        debug_assert!(cfg.watched[0] == *watch.xi_row && cfg.watched[1] == *watch.rate_row);
        let brake = |state: &Chain| chain.split(state).and_then(|s| chain.range(0, &s));
        if !brakes_clear_on(watch, brake(&self.state.earth), brake(&self.state.nonearth)) {
            return Proof::Nothing;
        }
        let Some(s) = cfg.split(&self.state.z) else {
            return Proof::Brakes;
        };
        let mechanics = || Some((cfg.range(0, &s)?, cfg.range(1, &s)?));
        // A configuration's bound has no functional of the turn test (`propagators::TURN_RATE`):
        // a turn that the interval of `ξ̇` leaves open is left to the scan.
        if self.mechanics_clear_on(watch, mechanics(), || None) {
            Proof::All
        } else {
            Proof::Brakes
        }
    }

    /// The decision of `provably_clear` on intervals of the brake volts of the earth and
    /// the non-earth chain, of `ξ` and of the sign of `ξ̇` (`mechanics`), and of the change
    /// of the sign of `ξ̇` between the two points of a turn test (`turn`, asked for only
    /// where the interval of `ξ̇` cannot decide), that hold every value the event loop will
    /// compare: `true` means no point of them can stop it.
    #[inline(always)]
    pub(crate) fn clear_on(
        &self,
        watch: &Watch,
        earth: impl FnOnce() -> Option<(f64, f64)>,
        nonearth: impl FnOnce() -> Option<(f64, f64)>,
        mechanics: impl FnOnce() -> Option<((f64, f64), (f64, f64))>,
        turn: impl FnOnce() -> Option<(f64, f64)>,
    ) -> bool {
        brakes_clear_on(watch, earth(), nonearth())
            && self.mechanics_clear_on(watch, mechanics(), turn)
    }

    /// The mechanics' part of [`Self::clear_on`]: on intervals of `ξ` and of the sign of
    /// `ξ̇`, no slip onset, no reversal of a slipping `ξ`, no turn that could reach an onset.
    #[inline(always)]
    fn mechanics_clear_on(
        &self,
        watch: &Watch,
        mechanics: Option<((f64, f64), (f64, f64))>,
        turn: impl FnOnce() -> Option<(f64, f64)>,
    ) -> bool {
        let Some(((xi_lo, xi_hi), (rate_lo, rate_hi))) = mechanics else {
            return false;
        };
        if watch.direction > 0.0 {
            // Sliding up: ξ̇ stays positive and ξ below the next onset.
            rate_lo > 0.0 && xi_hi < watch.up
        } else if watch.direction < 0.0 {
            rate_hi < 0.0 && xi_lo > watch.down
        } else {
            // Nothing slides: ξ stays between the onsets, and so does any turn of ξ between
            // two points. The same floating-point operations as `extremum_may_cross` on
            // bounds of its arguments: rounding is monotone, so these bound its results
            // (for the tail of a step too, whose interval is shorter than a scan interval).
            let gain = watch.xi_row[ix::VX];
            if gain.is_nan() || gain < 0.0 {
                return false;
            }
            let dt = TICK * (1u64 << self.solver.chain.scan_level) as f64;
            // `|ξ̇₀| + |ξ̇₁|` bounded by `sum`.
            let inside = |sum: f64| {
                let reach = dt * sum * watch.xi_row[ix::VX];
                xi_hi + reach < watch.up && xi_lo - reach > watch.down
            };
            let rate_max = rate_lo.abs().max(rate_hi.abs());
            if inside(rate_max + rate_max) {
                return true;
            }
            // The turn test fires only where `ξ̇₀ ξ̇₁ < 0`, and there `|ξ̇₀| + |ξ̇₁|` is
            // `|ξ̇₁ − ξ̇₀|` (`propagators::TURN_RATE`), which the interval `turn` holds; the
            // computed sum of the two magnitudes rounds to at most its bound times
            // `1 + BOUND_SLACK`, and the rest is monotone as above. A NaN decides nothing.
            let Some((lo, hi)) = turn() else {
                return false;
            };
            inside(lo.abs().max(hi.abs()) * (1.0 + BOUND_SLACK))
        }
    }
}
