//! The exact propagation of a piecewise linear system (`crate::linear`): the tables of
//! `e^{A 2^l tick}` per configuration, the watched functionals seen through them at every
//! scan point, and the rigorous bounds that let a step skip a scan.
//!
//! Durations are counted in ticks of 2⁻⁴⁰ s (0.91 ps); the propagators `e^{A 2^l tick}`
//! are tabulated per configuration, so any duration is a product of at most a few dozen
//! table entries, and bisection for an event walks down the same table, locating it to
//! the event-time resolution (`rel_tol`).

use nalgebra::{SMatrix, SVector};

#[cfg(target_arch = "x86_64")]
use super::kernels::dot4_avx;
use super::kernels::{dot_lanes, lanes, mul_mat, mul_vec, mul_vec_inline, Lanes};
use super::ticks::LEVELS;

/// The scan interval at the default tolerance: 2²⁴ ticks = 15.3 µs, a 16th of the period of
/// the fastest mode that moves node 3 appreciably (the ~4 kHz stack-on-flexure mode in
/// HOLD), so `ξ̇` changes sign at most once between two scan points.
pub const DEFAULT_SCAN_LEVEL: usize = 24;

/// Scan level for an event tolerance: each decade below 1 ns halves the scan interval (down
/// to 1.9 µs), so a tighter run also resolves faster turns of `ξ`.
pub fn scan_level(rel_tol: f64) -> usize {
    let decades = (1e-9 / rel_tol).log10().round().max(0.0) as usize;
    DEFAULT_SCAN_LEVEL - decades.min(3)
}

/// `e^{A 2^l tick}` for every level, and the watched functionals `c` seen through the
/// propagator at every scan point, `cᵀ e^{A k Δ}`: scanning a whole top-level piece for
/// events then costs one dot product per functional and point instead of a full
/// propagation per point.
#[derive(Clone, Debug)]
pub struct Propagators<const D: usize> {
    pub a: SMatrix<f64, D, D>,
    /// Boxed: 32 matrices are 50 KB for the mechanics, built in place and never moved.
    pub phi: Box<[SMatrix<f64, D, D>; LEVELS]>,
    pub watched: Vec<SVector<f64, D>>,
    /// The scan interval Δ is `2^scan_level` ticks; a top-level piece has `scan_points` of them.
    pub scan_level: usize,
    pub scan_points: usize,
    /// `scan[k * watched.len() + o]` = `watched[o]ᵀ e^{A (k+1) Δ}`.
    pub scan: Vec<SVector<f64, D>>,
    /// The scan rows four points at a time, point-minor: `scan_lanes[((g·w + o)·D + i)·4 + l]`
    /// is component `i` of `scan[(4g + l)·w + o]` (zero rows pad the last group), so one
    /// register holds one component of four points' rows. Only the x86-64 AVX scan reads it.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    scan_lanes: Vec<f64>,
    /// The watched functionals through each level's propagator, `level_rows[l·w + o]` =
    /// `watched[o]ᵀ e^{A 2^l tick}` (padded to 16 lanes): the bisection tests a candidate
    /// instant by dot products instead of propagating the state to it.
    level_rows: Vec<Lanes>,
    /// Bounds of every watched functional over all scan points of a piece, from the state
    /// alone (see [`ScanBound`]); `None` if the configuration's long-time propagator isn't finite.
    pub bound: Option<ScanBound<D>>,
}

/// Squarings of the top-level propagator (1.95 ms) that give the settling matrix
/// `P̂ = e^{A T}`, T = 2¹² · 1.95 ms = 8 s: every mode of the nominal devices has decayed
/// by e⁻²⁰⁰ or more by then, so `P̂` maps a state to its equilibrium for the held inputs.
/// (The bounds below are rigorous for any `P̂`; a good one only makes them tight.)
const SETTLE_SQUARINGS: usize = 12;

/// Relative slack that covers every floating-point rounding of the scan and of the bound
/// (each is a dot product or a sum of ≤ 14 terms, error ≤ 14 u ≈ 3.1e-15 of the sum of
/// the magnitudes; 1e-12 is 300× that).
pub(crate) const BOUND_SLACK: f64 = 1e-12;

/// Rigorous bounds of the watched functionals over every scan point of a piece, without
/// scanning: the rows `r_k = cᵀ e^{A k Δ}` (k = 0 … `scan_points`) change with `k` only on
/// the part of the state that hasn't settled. With `P̂` (≈ the projector onto the
/// equilibria) and `v = z − P̂ z`,
///
/// `r_k z = (r_k P̂) z + r_k v  ∈  [Σ_i min(lo_i z_i, hi_i z_i), Σ_i max(…)] ± ρ·|v|`,
///
/// with `lo`, `hi` the componentwise range of the tabulated `r_k P̂` over `k` and
/// `ρ = max_k |r_k|` componentwise, plus a rounding slack (`BOUND_SLACK`) over
/// `(ρ + ρ|P̂|)·|z|`. The bound holds for the *computed* values the scan would compare,
/// whatever `P̂` is; when the state has settled (`v` small) it is tight, and a quiet step
/// can skip the scan and still take exactly the decision the scan would have taken.
#[derive(Clone, Debug)]
pub struct ScanBound<const D: usize> {
    settle: SMatrix<f64, D, D>,
    functionals: Vec<FunctionalBound>,
}

/// One functional's bound as three weight vectors of the split state: with `mid` and
/// `rad` the centre and half-width of `[lo, hi]`, `Σ min(loᵢ zᵢ, hiᵢ zᵢ) = Σ midᵢ zᵢ −
/// Σ radᵢ |zᵢ|` (and `max` with `+`), so the value lies in
/// `mid·z ± ((rad + BOUND_SLACK (ρ + ρ|P̂| + α))·|z| + (1 + BOUND_SLACK) ρ·|v|)`. Rounding
/// `mid` and `rad` costs a few `u` of `(|lo| + |hi|)·|z| ≤ ρ|P̂|·|z|`, inside the slack.
#[derive(Clone, Debug)]
struct FunctionalBound {
    mid: Lanes,
    /// `rad + BOUND_SLACK (ρ + ρ|P̂| + α)`: the weights of `|z|`.
    spread: Lanes,
    /// `(1 + BOUND_SLACK) ρ`: the weights of `|v|`.
    moving: Lanes,
}

/// The functional of the quiet step's bound (`quiet`) that holds the difference of the row
/// of `ξ̇`'s sign (functional 1) between the two points of every turn test; a
/// configuration's bound (`Propagators::bound`) has only the watched functionals. Where `ξ̇` changes sign between two points,
/// `|ξ̇₀| + |ξ̇₁| = |ξ̇₁ − ξ̇₀|`: the reach of a turn is bounded by the change of `ξ̇` over one
/// scan interval, a fraction of its amplitude for a ring slower than the scan, where the
/// bound of `|ξ̇|` alone would take it twice at its peak.
pub(crate) const TURN_RATE: usize = 2;

/// A row whose value on the state a bound must hold.
pub(crate) struct BoundRow<const D: usize> {
    /// The value is this row of the state, in exact arithmetic.
    pub(crate) row: SVector<f64, D>,
    /// For a value computed through products (`c · (M_m ⋯ (M_1 z))`, `row` = `c M_m ⋯ M_1`):
    /// `|c| |M_m| ⋯ |M_1|`, which bounds the rounding of those products and of `row` itself
    /// (at most ~2(m + 1)·14 u of it, far inside `BOUND_SLACK`). `None` for a plain dot product.
    pub(crate) magnitude: Option<SVector<f64, D>>,
}

impl<const D: usize> BoundRow<D> {
    /// `a − b` for the difference of the two values computed on rows `a` and `b`, with the
    /// magnitudes (`None`: a plain dot product, `|row|`) of both: the difference of the two
    /// computed values is the exact one within the rounding of each and of the subtraction
    /// of the rows, all inside `BOUND_SLACK` of the sum of the magnitudes.
    pub(crate) fn difference(
        a: &SVector<f64, D>,
        a_magnitude: Option<&SVector<f64, D>>,
        b: &SVector<f64, D>,
        b_magnitude: Option<&SVector<f64, D>>,
    ) -> Self {
        let magnitude = a_magnitude.copied().unwrap_or_else(|| a.abs())
            + b_magnitude.copied().unwrap_or_else(|| b.abs());
        BoundRow { row: a - b, magnitude: Some(magnitude) }
    }
}

/// A state split against the settling matrix, ready for [`ScanBound::range`].
pub struct Split<const D: usize> {
    z: SVector<f64, D>,
    z_abs: SVector<f64, D>,
    v_abs: SVector<f64, D>,
}

impl<const D: usize> ScanBound<D> {
    fn new(
        top: &SMatrix<f64, D, D>,
        watched: &[SVector<f64, D>],
        scan: &[SVector<f64, D>],
        scan_points: usize,
    ) -> Option<Self> {
        let mut settle = *top;
        for _ in 0..SETTLE_SQUARINGS {
            settle = mul_mat(&settle, &settle);
        }
        let w = watched.len();
        let row = |k: usize, o: usize| if k == 0 { watched[o] } else { scan[(k - 1) * w + o] };
        let rows: Vec<Vec<BoundRow<D>>> = (0..w)
            .map(|o| {
                (0..=scan_points).map(|k| BoundRow { row: row(k, o), magnitude: None }).collect()
            })
            .collect();
        Self::from_rows(settle, &rows)
    }

    /// The bound of every functional `o` over its rows `rows[o]`, against the settling
    /// matrix `settle`; `None` if anything in it isn't finite.
    pub(crate) fn from_rows(settle: SMatrix<f64, D, D>, rows: &[Vec<BoundRow<D>>]) -> Option<Self> {
        assert!(D <= 16, "a bound is for at most 16 components");
        if !settle.iter().all(|x| x.is_finite()) {
            return None;
        }
        let settle_abs_t = settle.abs().transpose();
        // Transposed once, not per row: the same entries, so the same products.
        let settle_t = settle.transpose();
        let mut functionals = Vec::with_capacity(rows.len());
        for rows in rows {
            let mut lo = SVector::<f64, D>::repeat(f64::INFINITY);
            let mut hi = SVector::<f64, D>::repeat(f64::NEG_INFINITY);
            let mut rho = SVector::<f64, D>::zeros();
            let mut alpha = SVector::<f64, D>::zeros();
            for BoundRow { row: r, magnitude } in rows {
                // (r P̂) as a column.
                let t = mul_vec(&settle_t, r);
                for i in 0..D {
                    if !(t[i].is_finite() && r[i].is_finite()) {
                        return None;
                    }
                    lo[i] = lo[i].min(t[i]);
                    hi[i] = hi[i].max(t[i]);
                    rho[i] = rho[i].max(r[i].abs());
                    if let Some(a) = magnitude {
                        alpha[i] = alpha[i].max(a[i]);
                    }
                }
            }
            let slack = rho + mul_vec(&settle_abs_t, &rho) + alpha;
            if !slack.iter().all(|x| x.is_finite()) {
                return None;
            }
            let mid = (lo + hi) * 0.5;
            let rad = (hi - lo) * 0.5;
            functionals.push(FunctionalBound {
                mid: lanes(&mid),
                spread: lanes(&(rad + slack * BOUND_SLACK)),
                moving: lanes(&(rho * (1.0 + BOUND_SLACK))),
            });
        }
        Some(ScanBound { settle, functionals })
    }

    pub(crate) fn settle(&self) -> &SMatrix<f64, D, D> {
        &self.settle
    }

    /// Splits `z` for [`Self::range`].
    #[inline]
    pub fn split(&self, z: &SVector<f64, D>) -> Split<D> {
        let v = z - mul_vec(&self.settle, z);
        Split { z: *z, z_abs: z.abs(), v_abs: v.abs() }
    }

    /// [`Self::split`] in the caller's instruction set (see [`mul_vec_inline`]).
    #[inline(always)]
    pub fn split_inline<const AVX: bool>(&self, z: &SVector<f64, D>) -> Split<D> {
        let v = z - mul_vec_inline::<D, AVX>(&self.settle, z);
        Split { z: *z, z_abs: z.abs(), v_abs: v.abs() }
    }

    /// An interval that holds the computed value of every row of functional `o` on the
    /// split state; `None` if it isn't finite (then neither is the state).
    #[inline(always)]
    pub fn range<const AVX: bool>(&self, o: usize, s: &Split<D>) -> Option<(f64, f64)> {
        let f = &self.functionals[o];
        let centre = dot_lanes::<D, AVX>(&f.mid, &s.z);
        let weight = dot_lanes::<D, AVX>(&f.spread, &s.z_abs);
        let margin = weight + dot_lanes::<D, AVX>(&f.moving, &s.v_abs) + 1e-300;
        let (lo, hi) = (centre - margin, centre + margin);
        // A finite weight means a finite state: every weight of |z| is positive or 0·∞ = NaN.
        let finite = lo.is_finite() && hi.is_finite() && weight.is_finite();
        finite.then_some((lo, hi))
    }
}

impl<const D: usize> Propagators<D> {
    /// Every level has the bits of its own exponential (nalgebra's Padé scaling and
    /// squaring of `A 2^l tick`, shared between levels by `expm::dyadic`): squaring the
    /// finest one 31 times would double its rounding error at each level.
    pub fn new(a: SMatrix<f64, D, D>, watched: Vec<SVector<f64, D>>, scan_level: usize) -> Self
    where
        nalgebra::Const<D>: nalgebra::DimMin<nalgebra::Const<D>, Output = nalgebra::Const<D>>,
    {
        let mut phi: Box<[SMatrix<f64, D, D>; LEVELS]> =
            vec![SMatrix::zeros(); LEVELS].into_boxed_slice().try_into().expect("LEVELS matrices");
        super::expm::dyadic(&a, &mut phi);
        let step = phi[scan_level];
        let scan_points = 1 << (LEVELS - 1 - scan_level);
        let mut scan = Vec::with_capacity(scan_points * watched.len());
        let mut rows: Vec<SVector<f64, D>> = watched.clone();
        let step_t = step.transpose();
        for _ in 0..scan_points {
            for r in rows.iter_mut() {
                *r = mul_vec(&step_t, r);
                scan.push(*r);
            }
        }
        let bound = ScanBound::new(&phi[LEVELS - 1], &watched, &scan, scan_points);
        let w = watched.len();
        let groups = scan_points.div_ceil(4);
        let mut scan_lanes = vec![0.0; groups * w * D * 4];
        for (p, row) in scan.iter().enumerate() {
            let (k, o) = (p / w, p % w);
            for i in 0..D {
                scan_lanes[(((k / 4) * w + o) * D + i) * 4 + k % 4] = row[i];
            }
        }
        // `mᵀ c` by the same `gemv` as nalgebra's `m.transpose() * c`.
        let level_rows = phi
            .iter()
            .flat_map(|m| {
                let t = m.transpose();
                watched.iter().map(move |c| lanes(&mul_vec(&t, c)))
            })
            .collect();
        Propagators {
            a,
            phi,
            watched,
            scan_level,
            scan_points,
            scan,
            scan_lanes,
            level_rows,
            bound,
        }
    }

    /// Watched functional `o` after `2^level` ticks from `z`: `watched[o]ᵀ (e^{A 2^l tick} z)`
    /// but for rounding (the row is multiplied out first, and the sum's order is free), at the
    /// cost of one dot product.
    #[inline(always)]
    pub fn level_value<const AVX: bool>(&self, level: usize, o: usize, z: &SVector<f64, D>) -> f64 {
        dot_lanes::<D, AVX>(&self.level_rows[level * self.watched.len() + o], z)
    }

    /// Splits `z` for [`Self::range`]; `None` if this table has no bound.
    #[inline]
    pub fn split(&self, z: &SVector<f64, D>) -> Option<Split<D>> {
        Some(self.bound.as_ref()?.split(z))
    }

    /// An interval that holds the computed value of watched functional `o` at every scan
    /// point `k = 0 … scan_points` of a piece starting at the split state: `scanned(k, o, z)`
    /// for `k ≥ 1`, `watched[o].dot(z)` for `k = 0`. `None` if it isn't finite.
    #[inline]
    pub fn range(&self, o: usize, s: &Split<D>) -> Option<(f64, f64)> {
        let range = self.bound.as_ref()?.range::<false>(o, s);
        #[cfg(debug_assertions)]
        if let Some((lo, hi)) = range {
            let z = s.z;
            for k in 0..=self.scan_points {
                let v = if k == 0 { self.watched[o].dot(&z) } else { self.scanned(k, o, &z) };
                assert!(
                    lo <= v && v <= hi,
                    "scan bound: functional {o} at point {k} is {v}, outside [{lo}, {hi}]"
                );
            }
        }
        range
    }

    /// Exact propagation over `ticks`, plus the sub-tick remainder `rest` seconds (< 1 tick)
    /// by a second-order Taylor step, whose error there is below 1e-20 of the state.
    pub fn advance(&self, z: SVector<f64, D>, ticks: u64, rest: f64) -> SVector<f64, D> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU has AVX.
            return unsafe { self.advance_avx(z, ticks, rest) };
        }
        self.advance_inline::<false>(z, ticks, rest)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn advance_avx(&self, z: SVector<f64, D>, ticks: u64, rest: f64) -> SVector<f64, D> {
        self.advance_inline::<true>(z, ticks, rest)
    }

    /// [`Self::advance`] in the caller's instruction set (see [`mul_vec_inline`]): the same
    /// products, the same bits.
    #[inline(always)]
    pub fn advance_inline<const AVX: bool>(
        &self,
        mut z: SVector<f64, D>,
        mut ticks: u64,
        rest: f64,
    ) -> SVector<f64, D> {
        let top = 1u64 << (LEVELS - 1);
        while ticks >= 2 * top {
            z = mul_vec_inline::<D, AVX>(&self.phi[LEVELS - 1], &z);
            ticks -= top;
        }
        // The set bits in increasing order, as a loop over all levels would take them.
        while ticks != 0 {
            z = mul_vec_inline::<D, AVX>(&self.phi[ticks.trailing_zeros() as usize], &z);
            ticks &= ticks - 1;
        }
        if rest > 0.0 {
            let az = mul_vec_inline::<D, AVX>(&self.a, &z);
            z += az * rest + mul_vec_inline::<D, AVX>(&self.a, &az) * (0.5 * rest * rest);
        }
        z
    }

    /// Watched functional `o` at scan point `k` (1-based) from the state `z` at scan point 0.
    #[inline(always)]
    pub fn scanned(&self, k: usize, o: usize, z: &SVector<f64, D>) -> f64 {
        self.scan[(k - 1) * self.watched.len() + o].dot(z)
    }

    /// `scanned(k, o, z)` for the four points `k = 4g + 1 … 4g + 4`, bit for bit: with `AVX`
    /// (only in a caller that runs with AVX) each lane makes the multiplications and additions
    /// of nalgebra's `dot` for these sizes in its order, four points at once. Points past
    /// `scan_points` give 0.
    #[inline(always)]
    pub fn scanned4<const AVX: bool>(&self, g: usize, o: usize, z: &SVector<f64, D>) -> [f64; 4] {
        #[cfg(target_arch = "x86_64")]
        if AVX && (D == 4 || D >= 8) {
            let w = self.watched.len();
            let rows = &self.scan_lanes[(g * w + o) * D * 4..(g * w + o + 1) * D * 4];
            // SAFETY: `AVX` callers run with AVX.
            return unsafe { dot4_avx::<D>(rows, z) };
        }
        std::array::from_fn(|l| {
            let k = 4 * g + l + 1;
            if k <= self.scan_points {
                self.scanned(k, o, z)
            } else {
                0.0
            }
        })
    }
}
