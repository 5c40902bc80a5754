//! The table's exponentials `e^{A 2^l tick}`, `l = 0 … LEVELS − 1`, with the bits of
//! nalgebra's `exp` of each level's matrix, at a fraction of 32 separate calls' cost.
//!
//! nalgebra's `exp` is Higham's scaling and squaring (Higham 2005, "The scaling and
//! squaring method for the matrix exponential revisited", Algorithm 2.3, as scipy's `expm`):
//! from the one-norms of `A⁴, A⁶, A⁸, A¹⁰` and a rounding-error estimate (`ell`) it picks a
//! Padé approximant of degree 3, 5, 7, 9, or of degree 13 of `A / 2^s` squared `s` times.
//! Every level here takes the same decision on the same numbers and makes the same
//! floating-point operations in the same order, with two savings that change no bit:
//!
//! * **Powers by scaling.** `A_l = A_0 · 2^l` exactly (a product by a power of two rounds
//!   as its factor does), and so are the products that make its powers, `A_l^k = A_0^k ·
//!   2^{kl}`, as long as no product of two entries underflows below the normal range or
//!   overflows: [`Powers::new`] checks that and otherwise declines, and every level then
//!   comes from its own `exp`. The powers are formed once, not once per level.
//! * **Levels by squaring.** Of two consecutive levels that both take degree 13, with
//!   `s_{l+1} = s_l + 1`, the Padé approximant is made of the same scaled matrix
//!   (`A_l / 2^{s_l}` is `A_{l+1} / 2^{s_{l+1}}` exactly), so level `l + 1` is level `l`
//!   squared once more: the very product its own `exp` would end with.
//!
//! A matrix [`Powers::new`] declines has every level from nalgebra's `exp`. Debug builds
//! compare every level with it.

use nalgebra::{Const, DimMin, SMatrix, SVector};

use crate::numerics::kernels::{mul_mat, mul_vec};
use crate::numerics::ticks::{LEVELS, TICK};

/// Writes `e^{a 2^l tick}` for every level `l` into `phi[l]`, each with the bits of
/// `exp(a * (TICK * 2^l))`.
pub(crate) fn dyadic<const D: usize>(a: &SMatrix<f64, D, D>, phi: &mut [SMatrix<f64, D, D>; LEVELS])
where
    Const<D>: DimMin<Const<D>, Output = Const<D>>,
{
    let Some(powers) = Powers::new(a) else {
        for (l, p) in phi.iter_mut().enumerate() {
            *p = level_matrix(a, l).exp();
        }
        return;
    };
    let mut previous = None;
    for l in 0..LEVELS {
        let choice = powers.choice(l);
        phi[l] = match (previous, choice) {
            (Some(Choice::Pade13 { s: before }), Choice::Pade13 { s }) if s == before + 1 => {
                mul_mat(&phi[l - 1], &phi[l - 1])
            }
            _ => powers.exp(l, choice),
        };
        debug_assert!(
            same_bits(&phi[l], &level_matrix(a, l).exp()),
            "level {l}: the shared exponential differs from nalgebra's"
        );
        previous = Some(choice);
    }
}

/// Level `l`'s matrix `a · (tick 2^l)`, as the table's callers form it.
fn level_matrix<const D: usize>(a: &SMatrix<f64, D, D>, l: usize) -> SMatrix<f64, D, D> {
    a * (TICK * (1u64 << l) as f64)
}

/// Whether two matrices hold the same bits (NaN, −0 and all).
pub(crate) fn same_bits<const D: usize>(a: &SMatrix<f64, D, D>, b: &SMatrix<f64, D, D>) -> bool {
    a.iter().zip(b.iter()).all(|(x, y)| x.to_bits() == y.to_bits())
}

/// The approximant `exp` picks for a matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Choice {
    Pade3,
    Pade5,
    Pade7,
    Pade9,
    /// Degree 13 of `A / 2^s`, squared `s` times.
    Pade13 {
        s: u64,
    },
}

/// The powers of `A_0 = a · tick` that `exp` forms (`A², A⁴ = A²·A², A⁶ = A⁴·A²,
/// A⁸ = A⁶·A², A¹⁰ = A⁶·A⁴`), valid for every level by scaling, with their one-norms and
/// the iterates of Higham's `ℓ`.
struct Powers<const D: usize> {
    a: SMatrix<f64, D, D>,
    /// `[A², A⁴, A⁶, A⁸, A¹⁰]` of level 0.
    even: [SMatrix<f64, D, D>; 5],
    /// The one-norms of `A⁴, A⁶, A⁸, A¹⁰` of level 0. Level `l`'s powers are these
    /// matrices times `2^{kl}` entry by entry, exactly, so their column sums are too (sums
    /// of terms scaled by one power of two round as the unscaled ones do, and past the
    /// largest finite number both are infinite).
    norms: [f64; 4],
    abs: AbsPowers,
}

/// Entries at least this large (or zero) at level 0, and at most [`HUGE`] at the top level,
/// make every product of two of them a normal number at every level: `2^-500`.
const TINY: f64 = f64::from_bits((1023 - 500) << 52);
/// See [`TINY`]: `2^400`.
const HUGE: f64 = f64::from_bits((1023 + 400) << 52);

impl<const D: usize> Powers<D>
where
    Const<D>: DimMin<Const<D>, Output = Const<D>>,
{
    /// The powers of level 0, or `None` if some level's products could leave the normal
    /// range (then scaling would not give that level's bits).
    fn new(a: &SMatrix<f64, D, D>) -> Option<Self> {
        let a0 = a * TICK;
        let a2 = mul_mat(&a0, &a0);
        let a4 = mul_mat(&a2, &a2);
        let a6 = mul_mat(&a4, &a2);
        let a8 = mul_mat(&a6, &a2);
        let a10 = mul_mat(&a6, &a4);
        // The factors of every product: A_l, A_l², A_l⁴, A_l⁶ at every level.
        let top = (1u64 << (LEVELS - 1)) as f64;
        let normal = [(&a0, 1), (&a2, 2), (&a4, 4), (&a6, 6)].into_iter().all(|(m, k)| {
            m.iter().all(|&x| {
                let x = x.abs();
                x == 0.0 || (x >= TINY && x * top.powi(k) <= HUGE)
            })
        });
        let finite =
            [&a8, &a10].into_iter().all(|m| m.iter().all(|x| (x * top.powi(10)).is_finite()));
        (normal && finite).then(|| Powers {
            a: *a,
            norms: [a4.one_norm(), a6.one_norm(), a8.one_norm(), a10.one_norm()],
            abs: AbsPowers::new(&a0),
            even: [a2, a4, a6, a8, a10],
        })
    }

    /// The approximant `exp` takes for level `l`, decided on the same numbers in the same
    /// order.
    fn choice(&self, l: usize) -> Choice {
        let two_l = (1u64 << l) as f64;
        let norm = |k: usize, p: i32| self.norms[k] * two_l.powi(p);
        let d4 = norm(0, 4).powf(0.25);
        let d6 = norm(1, 6).powf(1.0 / 6.0);
        let d8 = || norm(2, 8).powf(1.0 / 8.0);
        let d10 = || norm(3, 10).powf(1.0 / 10.0);
        let ell = |m: u32| self.ell(l as i32, m, || level_matrix(&self.a, l));
        let eta_1 = d4.max(d6);
        if eta_1 < 1.495_585_217_958_292e-2 && ell(3) == 0 {
            return Choice::Pade3;
        }
        if eta_1 < 2.539_398_330_063_23e-1 && ell(5) == 0 {
            return Choice::Pade5;
        }
        let eta_3 = d6.max(d8());
        if eta_3 < 9.504_178_996_162_932e-1 && ell(7) == 0 {
            return Choice::Pade7;
        }
        if eta_3 < 2.097_847_961_257_068e0 && ell(9) == 0 {
            return Choice::Pade9;
        }
        let eta_5 = eta_3.min(d8().max(d10()));
        let mut s = if eta_5 == 0.0 {
            0
        } else {
            let l2 = (eta_5 / 4.25).log2().ceil();
            if l2 < 0.0 {
                0
            } else {
                l2 as u64
            }
        };
        // `A_l / 2^s` is `A_0 2^{l − s}`.
        let e = i32::try_from(s).map_or(i32::MIN, |s| l as i32 - s);
        s += self.ell(e, 13, || level_matrix(&self.a, l) * 2.0_f64.powf(-(s as f64)));
        Choice::Pade13 { s }
    }

    /// `ℓ(A_0 2^e, m)` from level 0's iterates where they scale exactly, else from
    /// `matrix()`, the matrix `exp` hands to `ℓ`.
    fn ell(&self, e: i32, m: u32, matrix: impl FnOnce() -> SMatrix<f64, D, D>) -> u64 {
        self.abs.ell(e, m).unwrap_or_else(|| ell(&matrix(), m))
    }

    /// Level `l`'s exponential by the approximant chosen: `exp`'s sums and products of the
    /// powers `A_l^k = A_0^k · 2^{kl}`, each power scaled as `exp` has it (the scaling
    /// folded into the sums, factor by factor in `exp`'s order).
    fn exp(&self, l: usize, choice: Choice) -> SMatrix<f64, D, D> {
        let two_l = (1u64 << l) as f64;
        let t: [f64; 5] = std::array::from_fn(|k| two_l.powi(2 * k as i32 + 2));
        let [a2, a4, a6, a8, _] = &self.even;
        let a = level_matrix(&self.a, l);
        let (u, v) = match choice {
            Choice::Pade3 => {
                let b = [120.0, 60.0, 12.0, 1.0];
                (
                    mul_mat(&a, &sum(&[(a2, &[t[0], b[3]])], Some(b[1]))),
                    sum(&[(a2, &[t[0], b[2]])], Some(b[0])),
                )
            }
            Choice::Pade5 => {
                let b = [30240.0, 15120.0, 3360.0, 420.0, 30.0, 1.0];
                (
                    mul_mat(&a, &sum(&[(a4, &[t[1], b[5]]), (a2, &[t[0], b[3]])], Some(b[1]))),
                    sum(&[(a4, &[t[1], b[4]]), (a2, &[t[0], b[2]])], Some(b[0])),
                )
            }
            Choice::Pade7 => {
                let b = [
                    17_297_280.0,
                    8_648_640.0,
                    1_995_840.0,
                    277_200.0,
                    25_200.0,
                    1_512.0,
                    56.0,
                    1.0,
                ];
                let odd = [(a6, &[t[2], b[7]][..]), (a4, &[t[1], b[5]]), (a2, &[t[0], b[3]])];
                let even = [(a6, &[t[2], b[6]][..]), (a4, &[t[1], b[4]]), (a2, &[t[0], b[2]])];
                (mul_mat(&a, &sum(&odd, Some(b[1]))), sum(&even, Some(b[0])))
            }
            Choice::Pade9 => {
                let b = [
                    17_643_225_600.0,
                    8_821_612_800.0,
                    2_075_673_600.0,
                    302_702_400.0,
                    30_270_240.0,
                    2_162_160.0,
                    110_880.0,
                    3_960.0,
                    90.0,
                    1.0,
                ];
                let odd = [
                    (a8, &[t[3], b[9]][..]),
                    (a6, &[t[2], b[7]]),
                    (a4, &[t[1], b[5]]),
                    (a2, &[t[0], b[3]]),
                ];
                let even = [
                    (a8, &[t[3], b[8]][..]),
                    (a6, &[t[2], b[6]]),
                    (a4, &[t[1], b[4]]),
                    (a2, &[t[0], b[2]]),
                ];
                (mul_mat(&a, &sum(&odd, Some(b[1]))), sum(&even, Some(b[0])))
            }
            Choice::Pade13 { s } => self.pade13(&a, &t, s),
        };
        let mut x = solve(u, v);
        if let Choice::Pade13 { s } = choice {
            for _ in 0..s {
                x = mul_mat(&x, &x);
            }
        }
        x
    }

    /// Degree 13 of `A / 2^s` for level matrix `a` and power scales `t` (`2^{kl}` for
    /// `k = 2, 4, …`), the powers scaled as `exp` scales them.
    fn pade13(
        &self,
        a: &SMatrix<f64, D, D>,
        t: &[f64; 5],
        s: u64,
    ) -> (SMatrix<f64, D, D>, SMatrix<f64, D, D>) {
        let b = [
            64_764_752_532_480_000.0,
            32_382_376_266_240_000.0,
            7_771_770_303_897_600.0,
            1_187_353_796_428_800.0,
            129_060_195_264_000.0,
            10_559_470_521_600.0,
            670_442_572_800.0,
            33_522_128_640.0,
            1_323_241_920.0,
            40_840_800.0,
            960_960.0,
            16_380.0,
            182.0,
            1.0,
        ];
        let s = s as f64;
        let [a2, a4, a6, ..] = &self.even;
        let (f1, f2, f4, f6) = (
            2.0_f64.powf(-s),
            2.0_f64.powf(-2.0 * s),
            2.0_f64.powf(-4.0 * s),
            2.0_f64.powf(-6.0 * s),
        );
        let mb = a * f1;
        let mb6 = a6 * t[2] * f6;
        // `mbₖ · c` is `A_0^k · 2^{kl} · 2^{−ks} · c`, three roundings in `exp`'s order.
        let terms = |c6: f64, c4: f64, c2: f64| {
            [(a6, [t[2], f6, c6]), (a4, [t[1], f4, c4]), (a2, [t[0], f2, c2])]
        };
        let high = |c: [f64; 3]| {
            let [x6, x4, x2] = terms(c[0], c[1], c[2]);
            sum(&[(x6.0, &x6.1[..]), (x4.0, &x4.1[..]), (x2.0, &x2.1[..])], None)
        };
        let low = |top: &SMatrix<f64, D, D>, c: [f64; 3], id: f64| {
            let [x6, x4, x2] = terms(c[0], c[1], c[2]);
            sum(
                &[(top, &[][..]), (x6.0, &x6.1[..]), (x4.0, &x4.1[..]), (x2.0, &x2.1[..])],
                Some(id),
            )
        };
        let u2 = mul_mat(&mb6, &high([b[13], b[11], b[9]]));
        let u = mul_mat(&mb, &low(&u2, [b[7], b[5], b[3]], b[1]));
        let v2 = mul_mat(&mb6, &high([b[12], b[10], b[8]]));
        let v = low(&v2, [b[6], b[4], b[2]], b[0]);
        (u, v)
    }
}

/// `Σₜ mₜ · fₜ₁ · fₜ₂ ⋯ (+ c I)` entry by entry, as nalgebra evaluates
/// `m₁ * f₁₁ * f₁₂ + m₂ * f₂₁ + … + I * c`: each term's products in the order of its
/// factors, the terms added from the left, the identity's `1·c` on the diagonal and `0·c`
/// elsewhere (adding that zero turns a −0 into +0, as nalgebra's sum does). One pass, no
/// matrix per operation.
fn sum<const D: usize>(
    terms: &[(&SMatrix<f64, D, D>, &[f64])],
    id: Option<f64>,
) -> SMatrix<f64, D, D> {
    let mut out = SMatrix::<f64, D, D>::zeros();
    for (k, (m, factors)) in terms.iter().enumerate() {
        let first = k == 0;
        match **factors {
            [] => add(&mut out, m, first, |x| x),
            [f] => add(&mut out, m, first, |x| x * f),
            [f, g] => add(&mut out, m, first, |x| x * f * g),
            [f, g, h] => add(&mut out, m, first, |x| x * f * g * h),
            _ => unreachable!("at most three factors a term"),
        }
    }
    if let Some(c) = id {
        let (on, off) = (1.0 * c, 0.0 * c);
        for (j, column) in out.as_mut_slice().chunks_exact_mut(D).enumerate() {
            for (i, o) in column.iter_mut().enumerate() {
                *o += if i == j { on } else { off };
            }
        }
    }
    out
}

/// `out ← f(m)` (the first term) or `out ← out + f(m)`, entry by entry.
#[inline(always)]
fn add<const D: usize>(
    out: &mut SMatrix<f64, D, D>,
    m: &SMatrix<f64, D, D>,
    first: bool,
    f: impl Fn(f64) -> f64,
) {
    // Over the slices, which the compiler vectorizes (nalgebra's `iter` is strided).
    let (out, m) = (out.as_mut_slice(), m.as_slice());
    if first {
        out.iter_mut().zip(m).for_each(|(o, &x)| *o = f(x));
    } else {
        out.iter_mut().zip(m).for_each(|(o, &x)| *o += f(x));
    }
}

/// `(V − U)⁻¹ (U + V)` by LU, as `exp` solves it (`lu::solve`: nalgebra's operations in
/// nalgebra's order). The LU of a Padé denominator `q(A)` is regular for the norms each
/// degree is chosen for.
fn solve<const D: usize>(u: SMatrix<f64, D, D>, v: SMatrix<f64, D, D>) -> SMatrix<f64, D, D> {
    // `u + v` and `v − u` entry by entry, over the slices (nalgebra's operators iterate
    // strided).
    let (mut p, mut q) = (u, v);
    for ((p, q), (&u, &v)) in
        p.as_mut_slice().iter_mut().zip(q.as_mut_slice()).zip(u.as_slice().iter().zip(v.as_slice()))
    {
        *p = u + v;
        *q = v - u;
    }
    crate::numerics::lu::solve(&q, &p).unwrap_or_else(|| SMatrix::from_element(f64::NAN))
}

/// The most products with a vector `ℓ` takes: `2m + 1` for degree 13.
const ITERATES: usize = 27;

/// Level 0's share of Higham's `ℓ` for every level: the iterates `vₖ = |A_0|ᵀ vₖ₋₁`
/// (`v₀ = 1`) as `ℓ` forms them, and the binades their products and sums span. For
/// `A_0 2^e` every product and sum of iterate `k` is the level-0 one times `2^{ek}`,
/// exactly, as long as all of them are normal numbers (or zero) at both scales: then
/// `|A|^{2m+1}`'s norm is `max v_{2m+1} · 2^{e(2m+1)}` and `A`'s one-norm `‖A_0‖₁ 2^e`.
struct AbsPowers {
    /// `max vₖ`.
    max: [f64; ITERATES + 1],
    /// `log₂` of a lower bound of every nonzero product and partial sum of iterate `k`
    /// (the least nonzero `|a_ij|` times the least nonzero component of `vₖ₋₁`; a sum of
    /// non-negative terms is at least its first nonzero one), `+∞` if there is none.
    lo: [f64; ITERATES + 1],
    /// `log₂ max vₖ`: a sum of non-negative terms bounds every partial sum and product.
    hi: [f64; ITERATES + 1],
    /// `‖A_0‖₁` and the `log₂` bounds of the terms and sums that make it.
    norm: f64,
    norm_lo: f64,
    norm_hi: f64,
}

/// The binades an operation's result may reach and still be exact under scaling, with 20
/// binades to spare for the bounds' own rounding: `[2^-1000, 2^1000]`.
const LOG_LO: f64 = -1000.0;
const LOG_HI: f64 = 1000.0;

impl AbsPowers {
    fn new<const D: usize>(a0: &SMatrix<f64, D, D>) -> Self {
        let a_abs = a0.map(|x| x.abs());
        let t = a_abs.transpose();
        let least = |v: &mut dyn Iterator<Item = f64>| {
            v.filter(|&x| x != 0.0).fold(f64::INFINITY, f64::min).log2()
        };
        let a_lo = least(&mut a_abs.iter().copied());
        let mut v = SVector::<f64, D>::repeat(1.0);
        let (mut max, mut lo, mut hi) =
            ([1.0; ITERATES + 1], [0.0; ITERATES + 1], [0.0; ITERATES + 1]);
        for k in 1..=ITERATES {
            lo[k] = a_lo + least(&mut v.iter().copied());
            v = mul_vec(&t, &v);
            max[k] = v.max();
            hi[k] = max[k].log2();
        }
        let norm = a0.one_norm();
        AbsPowers { max, lo, hi, norm, norm_lo: a_lo, norm_hi: norm.log2() }
    }

    /// `ℓ(A_0 2^e, m)`, or `None` if some operation of it could leave the normal range.
    fn ell(&self, e: i32, m: u32) -> Option<u64> {
        let p = 2 * m as usize + 1;
        let inside = |lo: f64, hi: f64, shift: f64| {
            lo >= LOG_LO && lo + shift >= LOG_LO && hi <= LOG_HI && hi + shift <= LOG_HI
        };
        let ok = (1..=p).all(|k| inside(self.lo[k], self.hi[k], f64::from(e) * k as f64))
            && inside(self.norm_lo, self.norm_hi, f64::from(e));
        if !ok {
            return None;
        }
        let e = i64::from(e);
        Some(ell_value(scale(self.max[p], e * p as i64), scale(self.norm, e), m))
    }
}

/// `x · 2^n`, exact where the result is a normal number (by steps of at most `2^±1000`,
/// each between `x` and the result).
fn scale(mut x: f64, mut n: i64) -> f64 {
    while n != 0 {
        let step = n.clamp(-1000, 1000);
        x *= f64::from_bits(((1023 + step) as u64) << 52);
        n -= step;
    }
    x
}

/// `n!` for the small `n` of [`ell`].
const fn factorial(n: u32) -> u128 {
    let mut f = 1u128;
    let mut k = 2;
    while k <= n {
        f *= k as u128;
        k += 1;
    }
    f
}

/// Higham's `ℓ(A, m)`: how many more halvings the rounding of the degree-`m` approximant
/// asks for, from the one-norm of `|A|^{2m+1}` (by `2m + 1` products with a vector).
fn ell<const D: usize>(a: &SMatrix<f64, D, D>, m: u32) -> u64 {
    let t = a.map(|x| x.abs()).transpose();
    let mut v = SVector::<f64, D>::repeat(1.0);
    for _ in 0..2 * m + 1 {
        v = mul_vec(&t, &v);
    }
    ell_value(v.max(), a.one_norm(), m)
}

/// `ℓ` from the one-norms of `|A|^{2m+1}` and of `A`.
fn ell_value(a_abs_onenorm: f64, a_onenorm: f64, m: u32) -> u64 {
    if a_abs_onenorm == 0.0 {
        return 0;
    }
    let m_factorial = factorial(m);
    let choose_2m_m = factorial(2 * m) / (m_factorial * m_factorial);
    let abs_c_recip = choose_2m_m * factorial(2 * m + 1);
    let alpha = a_abs_onenorm / a_onenorm;
    let alpha = alpha / abs_c_recip as f64;
    let u = 2_f64.powf(-53.0);
    let value = ((alpha / u).log2() / (2.0 * m as f64)).ceil();
    if value > 0.0 {
        value as u64
    } else {
        0
    }
}

#[cfg(test)]
mod tests;
