//! `q⁻¹ p` by LU with partial pivoting, bit for bit as nalgebra's `q.lu().solve(&p)`, for
//! the Padé step of the exponentials (`expm`).
//!
//! nalgebra works column by column; every entry it updates, though, goes through the same
//! operations in the same order whichever way the loops run, so this works row by row
//! (rows of a row-major copy, whose updates vectorize without reordering any sum):
//!
//! * **Factorization.** For each column `i`: the pivot is the first row `r ≥ i` of largest
//!   `|q_ri|` (`icamax`); a zero pivot skips the column; otherwise the whole rows `i` and
//!   the pivot's swap (and so do the rows of `p`, as `solve` permutes them after), the
//!   multipliers are `l_r = q_ri · (1 / q_ii)`, and each `q_rk` (`r, k > i`) becomes
//!   `(−q_ik) l_r + q_rk`.
//! * **Forward substitution** (unit diagonal): for `i = 0 …`, `p_rk ← (−p_ik) l_ri + p_rk`
//!   for every row `r > i` (nalgebra's `p_ik / 1` is `p_ik`).
//! * **Back substitution**: for `i = D−1 … 0`, `p_ik ← p_ik / u_ii`, then
//!   `p_rk ← (−p_ik) u_ri + p_rk` for every row `r < i`. A zero `u_ii` makes the solve fail.
//!
//! A product's factors commute and `−(x y) = (−x) y` in IEEE arithmetic, so only NaN
//! payloads could tell the orders apart.

use nalgebra::SMatrix;

/// `q⁻¹ p` with the bits of nalgebra's `q.lu().solve(&p)`; `None` where that is `None`
/// (a zero on the diagonal of `U`).
pub(crate) fn solve<const D: usize>(
    q: &SMatrix<f64, D, D>,
    p: &SMatrix<f64, D, D>,
) -> Option<SMatrix<f64, D, D>> {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: the CPU has AVX.
        return unsafe { solve_avx(q, p) };
    }
    solve_rows(q, p)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn solve_avx<const D: usize>(
    q: &SMatrix<f64, D, D>,
    p: &SMatrix<f64, D, D>,
) -> Option<SMatrix<f64, D, D>> {
    solve_rows(q, p)
}

/// `row ← (−pivot) · l + row`, entry by entry (the loop the compiler vectorizes).
#[inline(always)]
fn eliminate<const D: usize>(row: &mut [f64; D], neg_pivot: &[f64; D], l: f64, from: usize) {
    for (x, n) in row[from..].iter_mut().zip(&neg_pivot[from..]) {
        *x += *n * l;
    }
}

#[inline(always)]
fn solve_rows<const D: usize>(
    q: &SMatrix<f64, D, D>,
    p: &SMatrix<f64, D, D>,
) -> Option<SMatrix<f64, D, D>> {
    let mut lu = [[0.0f64; D]; D];
    let mut b = [[0.0f64; D]; D];
    for i in 0..D {
        for j in 0..D {
            lu[i][j] = q[(i, j)];
            b[i][j] = p[(i, j)];
        }
    }
    for i in 0..D {
        let mut piv = i;
        let mut max = lu[i][i].abs();
        for (r, row) in lu.iter().enumerate().skip(i + 1) {
            if row[i].abs() > max {
                max = row[i].abs();
                piv = r;
            }
        }
        let diag = lu[piv][i];
        if diag == 0.0 {
            continue;
        }
        lu.swap(i, piv);
        b.swap(i, piv);
        let inv_diag = 1.0 / diag;
        let neg_pivot = lu[i].map(|x| -x);
        for row in lu.iter_mut().skip(i + 1) {
            let l = row[i] * inv_diag;
            row[i] = l;
            eliminate(row, &neg_pivot, l, i + 1);
        }
    }
    for i in 0..D {
        let neg = b[i].map(|x| -x);
        for r in i + 1..D {
            let l = lu[r][i];
            eliminate(&mut b[r], &neg, l, 0);
        }
    }
    for i in (0..D).rev() {
        let d = lu[i][i];
        if d == 0.0 {
            return None;
        }
        for x in b[i].iter_mut() {
            *x /= d;
        }
        let neg = b[i].map(|x| -x);
        for r in 0..i {
            let u = lu[r][i];
            eliminate(&mut b[r], &neg, u, 0);
        }
    }
    Some(SMatrix::from_fn(|i, j| b[i][j]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn same<const D: usize>(
        a: &Option<SMatrix<f64, D, D>>,
        b: &Option<SMatrix<f64, D, D>>,
    ) -> bool {
        match (a, b) {
            (Some(a), Some(b)) => a
                .iter()
                .zip(b.iter())
                .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan())),
            (None, None) => true,
            _ => false,
        }
    }

    fn check<const D: usize>(q: &SMatrix<f64, D, D>, p: &SMatrix<f64, D, D>)
    where
        nalgebra::Const<D>: nalgebra::DimMin<nalgebra::Const<D>, Output = nalgebra::Const<D>>,
    {
        let ours = solve(q, p);
        let theirs = q.lu().solve(p);
        assert!(same(&ours, &theirs), "q = {q}, p = {p}: {ours:?} vs {theirs:?}");
        assert!(same(&solve_rows(q, p), &theirs), "portable path, q = {q}");
    }

    /// Random systems of every scale, with ties and zeros in the pivot columns, singular
    /// ones, and non-finite entries.
    #[test]
    fn solves_have_nalgebras_bits() {
        let mut rng = 0x1u64 << 40 | 0x0bad_cafe;
        let mut next = move || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            match rng % 23 {
                0 => 0.0,
                1 => -0.0,
                2 => 1.0,
                3 => -1.0,
                _ => {
                    let m = (rng >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
                    m * 2f64.powi((rng % 80) as i32 - 40)
                }
            }
        };
        for k in 0..3000 {
            let mut q = SMatrix::<f64, 14, 14>::from_fn(|_, _| next());
            let p = SMatrix::<f64, 14, 14>::from_fn(|_, _| next());
            match k % 10 {
                0 => q.set_column(3, &q.column(5).clone_owned()),
                1 => q.fill_row(7, 0.0),
                2 => q[(2, 2)] = f64::NAN,
                3 => q[(4, 9)] = f64::INFINITY,
                _ => {}
            }
            check(&q, &p);
            let q4 = SMatrix::<f64, 4, 4>::from_fn(|_, _| next());
            let p4 = SMatrix::<f64, 4, 4>::from_fn(|_, _| next());
            check(&q4, &p4);
        }
    }
}
