//! One configuration's split into the slow and the fast part (the equations of the parent
//! module's documentation): `X` and `Y` by fixed-point iteration, `L`'s modes for the fast
//! part in closed form.

use nalgebra::{Complex, SMatrix};

use super::{Modal, FAST, SLOW};
use crate::linear::Matrix;
use crate::Mode;

/// Iterations of the invariant-subspace equations before the modes count as not separated.
/// Each shrinks the error by about the ratio of the slow to the fast frequencies (the
/// amplifier's 475 Hz to the 2.2 kHz DRIVE ring, 0.21, for the nominal devices): 30 or so
/// reach rounding.
const MAX_ITERATIONS: usize = 400;

/// One configuration's split into slow and fast parts.
#[derive(Clone, Debug)]
pub(super) struct Split {
    pub(super) x: SMatrix<f64, 6, 8>,
    pub(super) y: SMatrix<f64, 8, 6>,
    pub(super) l: SMatrix<f64, 6, 6>,
    /// `L`'s eigendecomposition, if it has one that reproduces `L`.
    pub(super) modes: Option<Modes>,
}

/// `L = V Λ V⁻¹`, so that `e^{L τ} f = Re(V (e^{λ τ} ∘ V⁻¹ f))`: six complex exponentials
/// where the matrix exponential takes a Padé approximant and its squarings.
#[derive(Clone, Debug)]
pub(super) struct Modes {
    pub(super) lambda: Modal,
    pub(super) v: SMatrix<Complex<f64>, 6, 6>,
    pub(super) v_inv: SMatrix<Complex<f64>, 6, 6>,
}

/// The largest relative error of `V Λ V⁻¹` against `L` (balanced) with which the modes stand in for
/// the matrix exponential.
const MODES_TOLERANCE: f64 = 1e-12;

/// `l`'s eigendecomposition (each eigenvector the null vector of `L − λ I`, from its SVD),
/// or `None` if it does not reproduce `l` to [`MODES_TOLERANCE`] (repeated or nearly
/// repeated eigenvalues).
fn modes(l: &SMatrix<f64, 6, 6>) -> Option<Modes> {
    // Balanced first (`D⁻¹ L D`, the rows' and columns' norms made alike): positions and
    // velocities differ by the modes' frequencies, and the eigenvectors of the balanced
    // matrix are accurate where those of `L` are not.
    let mut d = [1.0f64; 6];
    let mut b = *l;
    for _ in 0..20 {
        for i in 0..6 {
            let c: f64 = (0..6).filter(|&k| k != i).map(|k| b[(k, i)].abs()).sum();
            let r: f64 = (0..6).filter(|&k| k != i).map(|k| b[(i, k)].abs()).sum();
            if c > 0.0 && r > 0.0 {
                let f = (r / c).sqrt();
                d[i] *= f;
                for k in 0..6 {
                    b[(k, i)] *= f;
                    b[(i, k)] /= f;
                }
            }
        }
    }
    let lambda = b.complex_eigenvalues();
    let bc = b.map(|x| Complex::new(x, 0.0));
    let mut w = SMatrix::<Complex<f64>, 6, 6>::zeros();
    for k in 0..6 {
        let shifted = bc - SMatrix::<Complex<f64>, 6, 6>::identity() * lambda[k];
        let svd = shifted.svd(false, true);
        let v_t = svd.v_t?;
        let smallest = svd.singular_values.argmin().0;
        w.set_column(k, &v_t.row(smallest).adjoint());
    }
    let w_inv = w.try_inverse()?;
    let back = w * SMatrix::from_diagonal(&lambda) * w_inv;
    let error = (back - bc).norm() / bc.norm();
    // V = D W, V⁻¹ = W⁻¹ D⁻¹.
    let v = SMatrix::<Complex<f64>, 6, 6>::from_fn(|i, j| w[(i, j)] * d[i]);
    let v_inv = SMatrix::<Complex<f64>, 6, 6>::from_fn(|i, j| w_inv[(i, j)] / d[j]);
    (error <= MODES_TOLERANCE).then_some(Modes { lambda, v, v_inv })
}

/// One configuration's reduced dynamics.
#[derive(Clone, Debug)]
pub(super) struct Config {
    /// `S` over `linear`'s state: the rows of `x2` the slow dynamics, those of `x1` zero.
    pub(super) a: Matrix,
    /// `None` in LOCKED.
    pub(super) split: Option<Split>,
}

fn block<const R: usize, const C: usize>(
    a: &Matrix,
    rows: &[usize; R],
    cols: &[usize; C],
) -> SMatrix<f64, R, C> {
    SMatrix::from_fn(|r, c| a[(rows[r], cols[c])])
}

/// Iterates `m ← step(m)` to its fixed point; `None` if it doesn't settle (rounding leaves
/// a relative change of 1e-14 or so there) or leaves the finite numbers.
fn fixed_point<const R: usize, const C: usize>(
    mut m: SMatrix<f64, R, C>,
    step: impl Fn(&SMatrix<f64, R, C>) -> SMatrix<f64, R, C>,
) -> Option<SMatrix<f64, R, C>> {
    for _ in 0..MAX_ITERATIONS {
        let next = step(&m);
        if !next.iter().all(|v| v.is_finite()) {
            return None;
        }
        let settled = next.iter().zip(m.iter()).all(|(n, o)| (n - o).abs() <= 1e-12 * n.abs());
        m = next;
        if settled {
            return Some(m);
        }
    }
    None
}

/// The split of the model's rate matrix `a`; `None` if its fast and slow modes are not
/// separated.
pub(super) fn reduce(a: &Matrix, mode: Mode) -> Option<Config> {
    if mode == Mode::Locked {
        return Some(Config { a: *a, split: None });
    }
    let (a11, a12) = (block(a, &FAST, &FAST), block(a, &FAST, &SLOW));
    let (a21, a22) = (block(a, &SLOW, &FAST), block(a, &SLOW, &SLOW));
    let a11_inv = a11.try_inverse()?;
    let x = fixed_point(-a11_inv * a12, |x| a11_inv * (x * (a22 + a21 * x) - a12))?;
    let l = a11 - x * a21;
    let l_inv = l.try_inverse()?;
    let s = a22 + a21 * x;
    let y = fixed_point(a21 * l_inv, |y| (a21 + s * y) * l_inv)?;
    let mut r = Matrix::zeros();
    for (i, &row) in SLOW.iter().enumerate() {
        for (j, &col) in SLOW.iter().enumerate() {
            r[(row, col)] = s[(i, j)];
        }
    }
    let modes = modes(&l);
    r.iter()
        .all(|v| v.is_finite())
        .then_some(Config { a: r, split: Some(Split { x, y, l, modes }) })
}

#[cfg(test)]
mod tests {
    use super::super::{Fast, Reduced};
    use super::*;
    use crate::linear::{ix, Vector};
    use crate::numerics::configs::every_configuration;
    use crate::PlantParams;
    use nalgebra::DMatrix;
    use std::f64::consts::PI;

    /// Every configuration of the nominal devices has modes, and `Re(V (e^{λ τ} ∘ V⁻¹ f))`
    /// is the matrix exponential's `e^{L τ} f` to 1e-12 of `|f|` over 1 µs to 10 ms.
    #[test]
    fn the_modes_give_the_matrix_exponential() {
        let p = PlantParams::default();
        for (mode, _, config) in configurations(&p) {
            let Some(split) = config.split else { continue };
            let m = modes(&split.l).unwrap_or_else(|| panic!("{mode:?}: no modes"));
            let f = Fast::from_fn(|i, _| [1e-9, -2e-3, 3e-9, 1e-3, -5e-10, 4e-4][i]);
            let c = m.v_inv * f.map(|x| Complex::new(x, 0.0));
            for tau in [1e-6, 3.7e-5, 1e-4, 1e-3, 1e-2] {
                let exact = (split.l * tau).exp() * f;
                let modal = (m.v * m.lambda.zip_map(&c, |l, c| (l * tau).exp() * c)).map(|z| z.re);
                let e = (modal - exact).norm() / f.norm();
                assert!(e < 1e-12, "{mode:?} at {tau} s: {e:e}");
            }
        }
    }

    /// Every configuration of the default devices: its mode, the model's matrix and the
    /// reduced one.
    fn configurations(p: &PlantParams) -> Vec<(Mode, Matrix, Config)> {
        let r = Reduced::new(p.clone()).unwrap();
        every_configuration(p)
            .zip(r.configs.iter())
            .map(|((mode, _, a), config)| (mode, a, config.clone()))
            .collect()
    }

    /// Eigenvalues (rad/s) of the rows and columns `idx` of `a`.
    fn eigenvalues(a: &Matrix, idx: &[usize]) -> Vec<Complex<f64>> {
        let m = DMatrix::from_fn(idx.len(), idx.len(), |r, c| a[(idx[r], idx[c])]);
        m.complex_eigenvalues().iter().copied().collect()
    }

    /// The states that move: the mechanics and the extension channel.
    const MOVING: [usize; 11] =
        [ix::Y1, ix::V1, ix::Y2, ix::V2, ix::Y3, ix::V3, ix::Y4, ix::V4, ix::BX1, ix::BX2, ix::VX];

    #[test]
    fn the_slow_eigenvalues_are_the_models_and_no_fast_one_is_left() {
        for p in [PlantParams::fia20(), PlantParams::fia6()] {
            let (mut fastest_full, mut fastest_reduced, mut worst) = (0.0f64, 0.0f64, 0.0f64);
            for (mode, full, reduced) in configurations(&p) {
                if mode == Mode::Locked {
                    assert!(reduced.split.is_none() && reduced.a == full);
                    continue;
                }
                let ef = eigenvalues(&full, &MOVING);
                let er = eigenvalues(&reduced.a, &MOVING[6..]);
                let hz = |l: &Complex<f64>| l.norm() / (2.0 * PI);
                fastest_full = ef.iter().map(hz).fold(fastest_full, f64::max);
                fastest_reduced = er.iter().map(hz).fold(fastest_reduced, f64::max);
                // Each reduced eigenvalue is one of the model's, to rounding.
                for l in &er {
                    let nearest = ef.iter().map(|m| (m - l).norm()).fold(f64::INFINITY, f64::min);
                    // Relative, and absolute below 1000 rad/s (DRIVE's pair at 0, a Jordan block
                    // the solver splits by ~1e-5 rad/s).
                    let e = nearest / l.norm().max(1000.0);
                    worst = worst.max(e);
                    // The eigenvalue solver's own error on the model's badly scaled matrix
                    // (entries from 1 to 1e10) is of this order.
                    assert!(e < 1e-6, "{mode:?}: {l} is not an eigenvalue of the model ({e:e})");
                }
                // And the model's 6 fastest (node 3's ring, 2.1-4.6 kHz, and the surge) are
                // the ones left out: the rest is 475 Hz or slower.
                let mut by_size: Vec<f64> = ef.iter().map(hz).collect();
                by_size.sort_by(f64::total_cmp);
                let n = by_size.len();
                assert!(by_size[n - 7] < 500.0 && by_size[n - 6] > 2e3, "{mode:?}: {by_size:?}");
            }
            eprintln!("T_em = {}: fastest mode {fastest_full:.0} Hz in the model, {fastest_reduced:.0} Hz reduced; reduced eigenvalues within {worst:.1e} of the model's", p.t_em);
            assert!(fastest_full > 28e3, "{fastest_full}");
            assert!(fastest_reduced < 500.0, "{fastest_reduced}");
        }
    }

    /// The propagator over 1.024 s, where every mode has decayed by e⁻³³ or more: 1 ms
    /// exponentiated (its norm small enough to be exact), squared ten times.
    fn settle(a: &Matrix) -> Matrix {
        let mut m = (a * 1e-3).exp();
        for _ in 0..10 {
            m = m * m;
        }
        m
    }

    #[test]
    fn the_static_solution_is_the_models() {
        let p = PlantParams::fia20();
        let mut worst = 0.0f64;
        for (mode, full, reduced) in configurations(&p) {
            let Some(Split { x, y, .. }) = &reduced.split else { continue };
            // A state away from rest: moving, the amplifier at 65 V, an offset c0.
            let mut z = Vector::zeros();
            (z[ix::ONE], z[ix::UX], z[ix::BX1], z[ix::VX], z[ix::C0]) = (1.0, 7.0, 6.0, 65.0, -3.0);
            (z[ix::Y1], z[ix::V1], z[ix::Y2], z[ix::V2]) = (0.3e-6, -0.02, 1.9e-6, 0.03);
            (z[ix::Y3], z[ix::V3], z[ix::Y4], z[ix::V4]) = (2e-6, 0.01, 5e-6, 0.01);
            if mode == Mode::Drive {
                z[ix::V4] = z[ix::V3];
            }
            let settled = settle(&full) * z;
            let x2 = SMatrix::<f64, 8, 1>::from_fn(|i, _| z[SLOW[i]]);
            let f = Fast::from_fn(|i, _| z[FAST[i]]) - x * x2;
            let mut s = Vector::zeros();
            for (i, &k) in SLOW.iter().enumerate() {
                s[k] = (x2 - y * f)[i];
            }
            // Settled, the fast part is gone: the physical state is `x2 = s`, `x1 = X x2`.
            let mut s_settled = settle(&reduced.a) * s;
            let x1 = x * SMatrix::<f64, 8, 1>::from_fn(|i, _| s_settled[SLOW[i]]);
            for (i, &k) in FAST.iter().enumerate() {
                s_settled[k] = x1[i];
            }
            for &k in &[ix::Y1, ix::Y2, ix::Y3, ix::Y4, ix::VX] {
                let scale = if k == ix::VX { 100.0 } else { 1e-5 };
                let e = (settled[k] - s_settled[k]).abs() / scale;
                worst = worst.max(e);
                // The settling products' rounding on the model's stiff matrix is of this order.
                assert!(e < 1e-6, "{mode:?}, state {k}: {} against {}", settled[k], s_settled[k]);
            }
            assert!(settled[ix::Y3].abs() > 1e-6, "{mode:?}: the stack is loaded");
        }
        eprintln!("static solutions within {worst:.1e} (of 10 µm, 100 V)");
    }
}
