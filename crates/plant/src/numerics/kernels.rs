//! The vector kernels of the tables and of propagation: matrix × vector and matrix ×
//! matrix with the bits of nalgebra's products for these fixed sizes, and the dot products
//! of the scan and of the bounds, each with an AVX path where the CPU has it and a portable
//! one with the same bits.

use nalgebra::{SMatrix, SVector};

/// `m x`, bit for bit as nalgebra's `&m * &x` computes it for these fixed sizes
/// (`gemv` with `α = 1`, `β = 0`: `y = m₀ x₀`, then `y = mⱼ xⱼ + y` column by column, the
/// `1·` factors exact), without copying `m`, and with AVX where the CPU has it: the same
/// IEEE multiplications and additions in the same order, four lanes wide instead of two
/// (no FMA: Rust never contracts a product and a sum into one rounding).
#[inline(always)]
pub fn mul_vec<const D: usize>(m: &SMatrix<f64, D, D>, x: &SVector<f64, D>) -> SVector<f64, D> {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: the CPU has AVX.
        return unsafe { mul_vec_avx(m, x) };
    }
    SVector::from(gemv_columns::<D>(m.as_slice(), x.as_slice()))
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn mul_vec_avx<const D: usize>(
    m: &SMatrix<f64, D, D>,
    x: &SVector<f64, D>,
) -> SVector<f64, D> {
    SVector::from(gemv_columns::<D>(m.as_slice(), x.as_slice()))
}

/// [`mul_vec`] for a caller that has dispatched on the CPU already, inlined into it: with
/// `AVX` (only in a caller that runs with AVX) the products are written out in AVX
/// instructions, which stay vectorized however much is inlined around them.
#[inline(always)]
pub fn mul_vec_inline<const D: usize, const AVX: bool>(
    m: &SMatrix<f64, D, D>,
    x: &SVector<f64, D>,
) -> SVector<f64, D> {
    #[cfg(target_arch = "x86_64")]
    if AVX {
        // SAFETY: `AVX` callers run with AVX.
        return SVector::from(unsafe { gemv_avx::<D>(m.as_slice(), x.as_slice()) });
    }
    SVector::from(gemv_columns::<D>(m.as_slice(), x.as_slice()))
}

/// `gemv_columns` in AVX: each lane does exactly the multiplications and additions of its
/// row, in the same order (a group of four rows per register, a tail of two in a half one).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn gemv_avx<const D: usize>(a: &[f64], x: &[f64]) -> [f64; D] {
    use std::arch::x86_64::*;
    assert!(D <= 16 && D.is_multiple_of(2) && a.len() >= D * D && x.len() >= D);
    let (a, xs) = (a.as_ptr(), x.as_ptr());
    let full = D / 4;
    let half = D % 4 == 2;
    // SAFETY: every load and store is inside `a` (D·D), `x` (D) or `y` (D), by the assert.
    unsafe {
        let mut y = [_mm256_setzero_pd(); 4];
        let x0 = _mm256_set1_pd(*xs);
        for (g, yg) in y.iter_mut().enumerate().take(full) {
            *yg = _mm256_mul_pd(_mm256_loadu_pd(a.add(4 * g)), x0);
        }
        let mut t = _mm_mul_pd(
            if half { _mm_loadu_pd(a.add(4 * full)) } else { _mm_setzero_pd() },
            _mm256_castpd256_pd128(x0),
        );
        for j in 1..D {
            let col = a.add(j * D);
            let xj = _mm256_set1_pd(*xs.add(j));
            for (g, yg) in y.iter_mut().enumerate().take(full) {
                *yg = _mm256_add_pd(_mm256_mul_pd(_mm256_loadu_pd(col.add(4 * g)), xj), *yg);
            }
            if half {
                t = _mm_add_pd(
                    _mm_mul_pd(_mm_loadu_pd(col.add(4 * full)), _mm256_castpd256_pd128(xj)),
                    t,
                );
            }
        }
        let mut out = [0.0; D];
        for (g, yg) in y.iter().enumerate().take(full) {
            _mm256_storeu_pd(out.as_mut_ptr().add(4 * g), *yg);
        }
        if half {
            _mm_storeu_pd(out.as_mut_ptr().add(4 * full), t);
        }
        out
    }
}

/// `Σ aᵢ bᵢ` over the components of `b`, in one fixed order on every path: four lane sums
/// `accₗ = 0 + a_l b_l + a_{4+l} b_{4+l} + …` over the whole groups of four, then
/// `t₀ = acc₀ + acc₂`, `t₁ = acc₁ + acc₃`, the last two products added to `t₀` and `t₁` (for
/// `D ≡ 2 mod 4`), then `t₀ + t₁`: what the AVX path's registers do. A bound's sums may
/// take any order, but the bisection decides on these values
/// (`Propagators::level_value`), so a CPU without AVX (and the aarch64 build) must get the
/// same bits as one with it.
#[inline(always)]
pub(crate) fn dot_lanes<const D: usize, const AVX: bool>(a: &Lanes, b: &SVector<f64, D>) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if AVX {
        // SAFETY: `AVX` callers run with AVX.
        return unsafe { dot_lanes_avx(a, b) };
    }
    const { assert!(D <= 16 && D.is_multiple_of(2), "dot_lanes is for even sizes up to 16") };
    let full = D / 4;
    let mut acc = [0.0f64; 4];
    for g in 0..full {
        for (l, s) in acc.iter_mut().enumerate() {
            *s += a[4 * g + l] * b[4 * g + l];
        }
    }
    let (mut t0, mut t1) = (acc[0] + acc[2], acc[1] + acc[3]);
    if D % 4 == 2 {
        t0 += a[4 * full] * b[4 * full];
        t1 += a[4 * full + 1] * b[4 * full + 1];
    }
    t0 + t1
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn dot_lanes_avx<const D: usize>(a: &Lanes, b: &SVector<f64, D>) -> f64 {
    use std::arch::x86_64::*;
    assert!(D <= 16 && D.is_multiple_of(2));
    let (a, b) = (a.as_ptr(), b.as_slice().as_ptr());
    let full = D / 4;
    // SAFETY: every load is inside `a` (16) or `b` (D), by the assert.
    unsafe {
        let mut acc = _mm256_setzero_pd();
        for g in 0..full {
            acc = _mm256_add_pd(
                _mm256_mul_pd(_mm256_loadu_pd(a.add(4 * g)), _mm256_loadu_pd(b.add(4 * g))),
                acc,
            );
        }
        let mut t = _mm_add_pd(_mm256_castpd256_pd128(acc), _mm256_extractf128_pd(acc, 1));
        if D % 4 == 2 {
            t = _mm_add_pd(
                _mm_mul_pd(_mm_loadu_pd(a.add(4 * full)), _mm_loadu_pd(b.add(4 * full))),
                t,
            );
        }
        _mm_cvtsd_f64(_mm_add_sd(t, _mm_unpackhi_pd(t, t)))
    }
}

/// `y = a₀ x₀; y = aⱼ xⱼ + y` (j = 1 … D−1) over the columns `aⱼ` of the column-major `a`,
/// written as nalgebra's `axcpy` writes it (IEEE addition commutes, so `+=` would do too).
#[inline(always)]
#[allow(clippy::assign_op_pattern)]
fn gemv_columns<const D: usize>(a: &[f64], x: &[f64]) -> [f64; D] {
    let (a, x) = (&a[..D * D], &x[..D]);
    let mut y = [0.0f64; D];
    for i in 0..D {
        y[i] = a[i] * x[0];
    }
    for j in 1..D {
        let xj = x[j];
        let col = &a[j * D..j * D + D];
        for i in 0..D {
            y[i] = col[i] * xj + y[i];
        }
    }
    y
}

/// `a b`, bit for bit as nalgebra's `&a * &b` computes it for these fixed sizes: a static
/// product is `gemm` column by column, each column `a bⱼ` by `gemv` as in [`mul_vec`]
/// (nalgebra hands only dynamic matrices to `matrixmultiply`), here with AVX where the CPU
/// has it.
#[inline]
pub fn mul_mat<const D: usize>(
    a: &SMatrix<f64, D, D>,
    b: &SMatrix<f64, D, D>,
) -> SMatrix<f64, D, D> {
    #[cfg(target_arch = "x86_64")]
    if D <= 16 && D.is_multiple_of(2) && std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: the CPU has AVX.
        return unsafe { mul_mat_avx(a, b) };
    }
    let mut out = SMatrix::<f64, D, D>::zeros();
    for (j, col) in out.as_mut_slice().chunks_exact_mut(D).enumerate() {
        col.copy_from_slice(&gemv_columns::<D>(a.as_slice(), &b.as_slice()[j * D..]));
    }
    out
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn mul_mat_avx<const D: usize>(
    a: &SMatrix<f64, D, D>,
    b: &SMatrix<f64, D, D>,
) -> SMatrix<f64, D, D> {
    let mut out = SMatrix::<f64, D, D>::zeros();
    for (j, col) in out.as_mut_slice().chunks_exact_mut(D).enumerate() {
        // SAFETY: this function runs with AVX.
        col.copy_from_slice(&unsafe { gemv_avx::<D>(a.as_slice(), &b.as_slice()[j * D..]) });
    }
    out
}

/// A vector of up to 16 components padded with zeros, summed four lanes wide: the order of
/// a bound's sums is free (its slack covers any), and this one vectorizes.
pub(crate) type Lanes = [f64; 16];

pub(crate) fn lanes<const D: usize>(v: &SVector<f64, D>) -> Lanes {
    let mut l = [0.0; 16];
    l[..D].copy_from_slice(v.as_slice());
    l
}

/// nalgebra's `dot` of four rows with `z` (rows point-minor, see `scan_lanes`), one row per
/// lane: for 4 components `(p₀ + p₂) + (p₁ + p₃)`; from 8 on, eight accumulators
/// `accₘ = 0 + p_m (+ p_{m+8} …)`, `res = 0 + (acc₀ + acc₄)`, `+ (acc₁ + acc₅)`, …, then the
/// remaining products one by one. The additions of the zeros they start from are left out:
/// `0 + x` is `x` but for the sign of a zero, and the scan only compares these values.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
pub(crate) unsafe fn dot4_avx<const D: usize>(rows: &[f64], z: &SVector<f64, D>) -> [f64; 4] {
    use std::arch::x86_64::*;
    assert!(rows.len() == 4 * D && (D == 4 || D >= 8));
    // SAFETY: every load is inside `rows` (4·D) and every index of `z` below D.
    unsafe {
        let p = |i: usize| {
            _mm256_mul_pd(_mm256_loadu_pd(rows.as_ptr().add(4 * i)), _mm256_set1_pd(z[i]))
        };
        let res = if D == 4 {
            _mm256_add_pd(_mm256_add_pd(p(0), p(2)), _mm256_add_pd(p(1), p(3)))
        } else {
            let mut acc: [__m256d; 8] = std::array::from_fn(p);
            let mut i = 8;
            while D - i >= 8 {
                for (m, a) in acc.iter_mut().enumerate() {
                    *a = _mm256_add_pd(*a, p(i + m));
                }
                i += 8;
            }
            let mut res = _mm256_add_pd(acc[0], acc[4]);
            for m in 1..4 {
                res = _mm256_add_pd(res, _mm256_add_pd(acc[m], acc[m + 4]));
            }
            for k in i..D {
                res = _mm256_add_pd(res, p(k));
            }
            res
        };
        let mut out = [0.0; 4];
        _mm256_storeu_pd(out.as_mut_ptr(), res);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The two paths of `dot_lanes` give the same bits: the bisection's decisions, and with
    /// them every trace, must not depend on whether the CPU has AVX.
    #[test]
    fn dot_lanes_has_the_same_bits_on_both_paths() {
        let mut rng = 0x2026_1202_u64;
        let mut next = move || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            let m = (rng >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            m * 2f64.powi((rng % 60) as i32 - 30)
        };
        #[cfg_attr(not(target_arch = "x86_64"), allow(unused_variables, unused_mut))]
        let mut compared = 0;
        for _ in 0..5000 {
            let a: Lanes = std::array::from_fn(|_| next());
            let b14 = SVector::<f64, 14>::from_fn(|_, _| next());
            let b4 = SVector::<f64, 4>::from_fn(|_, _| next());
            let portable = (dot_lanes::<14, false>(&a, &b14), dot_lanes::<4, false>(&a, &b4));
            // The sum over the components in the documented order, written out.
            let t0 = ((0.0 + a[0] * b14[0] + a[4] * b14[4] + a[8] * b14[8])
                + (0.0 + a[2] * b14[2] + a[6] * b14[6] + a[10] * b14[10]))
                + a[12] * b14[12];
            let t1 = ((0.0 + a[1] * b14[1] + a[5] * b14[5] + a[9] * b14[9])
                + (0.0 + a[3] * b14[3] + a[7] * b14[7] + a[11] * b14[11]))
                + a[13] * b14[13];
            assert_eq!(portable.0.to_bits(), (t0 + t1).to_bits());
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx") {
                // SAFETY: the CPU has AVX.
                let avx = unsafe { dot_lanes_both_avx(&a, &b14, &b4) };
                assert_eq!(portable.0.to_bits(), avx.0.to_bits());
                assert_eq!(portable.1.to_bits(), avx.1.to_bits());
                compared += 1;
            }
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            assert_eq!(compared, 5000);
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn dot_lanes_both_avx(
        a: &Lanes,
        b14: &SVector<f64, 14>,
        b4: &SVector<f64, 4>,
    ) -> (f64, f64) {
        (dot_lanes::<14, true>(a, b14), dot_lanes::<4, true>(a, b4))
    }

    /// Random entries of every sign and of magnitudes over 2⁻⁶⁰ … 2⁶⁰, with some zeros.
    fn entries(seed: u64) -> impl FnMut() -> f64 {
        let mut rng = seed;
        move || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            if rng.is_multiple_of(17) {
                return 0.0;
            }
            let m = (rng >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            m * 2f64.powi((rng % 120) as i32 - 60)
        }
    }

    fn same_bits<const D: usize>(a: &SMatrix<f64, D, D>, b: &SMatrix<f64, D, D>) -> bool {
        a.iter().zip(b.iter()).all(|(x, y)| x.to_bits() == y.to_bits())
    }

    /// `mul_mat` and `mul_vec` against nalgebra's products, bit for bit, on both paths.
    #[test]
    fn products_have_nalgebras_bits() {
        fn check<const D: usize>(next: &mut impl FnMut() -> f64) {
            let a = SMatrix::<f64, D, D>::from_fn(|_, _| next());
            let b = SMatrix::<f64, D, D>::from_fn(|_, _| next());
            let x = SVector::<f64, D>::from_fn(|_, _| next());
            let product = a * b;
            assert!(same_bits(&mul_mat(&a, &b), &product), "{a} × {b}");
            let mut portable = SMatrix::<f64, D, D>::zeros();
            for (j, col) in portable.as_mut_slice().chunks_exact_mut(D).enumerate() {
                col.copy_from_slice(&gemv_columns::<D>(a.as_slice(), &b.as_slice()[j * D..]));
            }
            assert!(same_bits(&portable, &product), "{a} × {b}, portable");
            let y = a * x;
            assert!(mul_vec(&a, &x).iter().zip(y.iter()).all(|(p, q)| p.to_bits() == q.to_bits()));
        }
        let mut next = entries(0x5eed_0fa1_1b17_5eed);
        for _ in 0..2000 {
            check::<14>(&mut next);
            check::<4>(&mut next);
            check::<6>(&mut next);
        }
    }
}
