//! The reconstructor: the interaction matrix's singular modes, the whole mirror's piston,
//! tip and tilt (which no edge sensor sees) and any mode the sensors see more weakly than
//! a threshold excluded, and the pseudo-inverse over the modes kept (docs/phasing.md).
//!
//! Pose vectors are in the interaction matrix's coordinates ([`crate::EdgeSensors`]):
//! per segment its piston and its tip and tilt times the segment's RMS lever arm, so a
//! vector's norm over `√N` is the mirror's surface RMS.

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

use crate::geometry::Mirror;
use crate::sensors::Interaction;
use crate::PhasingError;

/// One singular mode of the interaction matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mode {
    /// Its singular value over the largest.
    pub relative: f64,
    /// How much of it lies in the global modes (the whole mirror's piston, tip and tilt):
    /// the norm of its projection on them, 0 to 1.
    pub global: f64,
    /// Kept in the reconstructor (`relative` at or above the threshold).
    pub kept: bool,
}

/// The pseudo-inverse of an interaction matrix: over its singular modes at or above a
/// threshold ([`Reconstructor::new`]), or over every mode but the unseen ones by the normal
/// equations ([`Reconstructor::normal_equations`]), for mirrors too large for a dense SVD.
#[derive(Clone, Debug)]
pub struct Reconstructor {
    solve: Solve,
    /// Every singular mode, the weakest first (the SVD's; empty for the normal equations,
    /// which keep every mode a sensor sees).
    pub modes: Vec<Mode>,
    /// The SVD's threshold; 0 for the normal equations.
    pub threshold: f64,
    pub segments: usize,
}

#[derive(Clone, Debug)]
enum Solve {
    /// Pose vector from readings: `3N × sensors`.
    Dense(DMatrix<f64>),
    /// `x = M⁻¹ Aᵀ y` with `M = AᵀA + U Uᵀ`, `U` the unseen modes' orthonormal basis, by
    /// `M`'s Cholesky factor; `trace(M⁻¹)` for the noise multiplier.
    Normal { a: Interaction, cholesky: Cholesky<f64, Dyn>, unseen: usize, trace: f64 },
}

/// An orthonormal basis of the modes no sensor sees: the whole mirror's piston, tip and
/// tilt, and with no dihedral term (`dihedral` 0) the focus mode too (`3N × 3` or `× 4`).
pub fn unseen_modes(mirror: &Mirror, dihedral: f64) -> DMatrix<f64> {
    let g = global_modes(mirror);
    if dihedral > 0.0 {
        return g;
    }
    let mut basis = DMatrix::zeros(g.nrows(), 4);
    basis.columns_mut(0, 3).copy_from(&g);
    basis.set_column(3, &focus_mode(mirror));
    basis.qr().q()
}

/// The whole mirror's piston, tip and tilt as orthonormal pose vectors (`3N × 3`):
/// piston 1 everywhere; a global tip θ is every segment tipped by θ and pistoned by θ y_k
/// (the plane through the centres), a global tilt likewise with x_k.
pub fn global_modes(mirror: &Mirror) -> DMatrix<f64> {
    let n = mirror.segments();
    let lever = mirror.lever();
    let mut g = DMatrix::zeros(3 * n, 3);
    for (k, c) in mirror.centres().iter().enumerate() {
        g[(3 * k, 0)] = 1.0;
        g[(3 * k, 1)] = c[1];
        g[(3 * k + 1, 1)] = lever;
        g[(3 * k, 2)] = c[0];
        g[(3 * k + 2, 2)] = lever;
    }
    g.qr().q()
}

/// The focus mode: every segment on the paraboloid `z = |x|²/2` (m⁻¹ curvature 1), its
/// piston `|x_k|²/2` and its tip and tilt the paraboloid's slopes `y_k`, `x_k` at its
/// centre (a pose vector, not normalised). On any edge the two segments' planes meet on
/// the edge's line (the perpendicular bisector of their centres), so a sensor reading
/// heights alone never sees it; the dihedral term does, as `h` times the slope change
/// across the edge (docs/phasing.md).
pub fn focus_mode(mirror: &Mirror) -> DVector<f64> {
    let lever = mirror.lever();
    DVector::from_iterator(
        3 * mirror.segments(),
        mirror
            .centres()
            .iter()
            .flat_map(|c| [(c[0] * c[0] + c[1] * c[1]) / 2.0, c[1] * lever, c[0] * lever]),
    )
}

/// The threshold that excludes the modes no sensor sees (singular values at round-off,
/// 1e-16 to 1e-15 of the largest up to ELT-class) and keeps every mode a sensor sees,
/// the focus mode included (docs/phasing.md, its table per mirror size).
pub const DEFAULT_THRESHOLD: f64 = 1e-9;

/// A global mode may leave this much of its norm in the kept modes: round-off, far below
/// any mode a sensor sees.
const GLOBAL_LEAK: f64 = 1e-6;

impl Reconstructor {
    /// The reconstructor of `interaction` (sensors × 3N) for `mirror`, keeping the modes
    /// whose singular value is at least `threshold` times the largest (0 < threshold < 1).
    /// Refused when it would keep a global mode (the threshold is below round-off) or keep
    /// nothing.
    pub fn new(
        mirror: &Mirror,
        interaction: &DMatrix<f64>,
        threshold: f64,
    ) -> Result<Reconstructor, PhasingError> {
        if !(threshold.is_finite() && threshold > 0.0 && threshold < 1.0) {
            return Err(PhasingError::Threshold(format!(
                "threshold = {threshold}: the singular-value threshold is a fraction of the largest, above 0 and below 1"
            )));
        }
        let n = mirror.segments();
        assert_eq!(interaction.ncols(), 3 * n, "an interaction matrix of this mirror");
        let svd = interaction.clone().svd(true, true);
        let (u, v_t) = (svd.u.expect("U computed"), svd.v_t.expect("V computed"));
        let sigma = &svd.singular_values;
        let largest = sigma.max();
        let globals = global_modes(mirror);
        let mut order: Vec<usize> = (0..sigma.len()).collect();
        order.sort_by(|&i, &j| sigma[i].total_cmp(&sigma[j]));
        let mut modes = Vec::with_capacity(order.len());
        let mut matrix = DMatrix::zeros(3 * n, interaction.nrows());
        let mut leak = [0.0f64; 3];
        for &i in &order {
            let v = v_t.row(i).transpose();
            let global = (globals.transpose() * &v).norm();
            let relative = sigma[i] / largest;
            let kept = relative >= threshold;
            if kept {
                matrix += &v * u.column(i).transpose() / sigma[i];
                for (g, l) in leak.iter_mut().enumerate() {
                    *l += globals.column(g).dot(&v).powi(2);
                }
            }
            modes.push(Mode { relative, global, kept });
        }
        // Modes of a rank-deficient matrix beyond the SVD's columns (more unknowns than
        // sensors) are unseen, hence excluded.
        if let Some((g, l)) = leak.iter().enumerate().find(|(_, l)| l.sqrt() > GLOBAL_LEAK) {
            let name = ["piston", "tip", "tilt"][g];
            let global_sv =
                modes.iter().filter(|m| m.global > 0.5).map(|m| m.relative).fold(0.0, f64::max);
            return Err(PhasingError::Threshold(format!(
                "threshold = {threshold:e} keeps the whole mirror's {name} ({:.1e} of it in kept modes), which no edge sensor sees: the global modes' singular values reach {global_sv:.1e} of the largest, so the threshold must be above that",
                l.sqrt()
            )));
        }
        if !modes.iter().any(|m| m.kept) {
            return Err(PhasingError::Threshold(format!(
                "threshold = {threshold:e} keeps no mode"
            )));
        }
        Ok(Reconstructor { solve: Solve::Dense(matrix), modes, threshold, segments: n })
    }

    /// The reconstructor of the sensors' interaction `a` for `mirror` by the normal
    /// equations: every mode but the unseen ones ([`unseen_modes`], `dihedral` the
    /// sensors') kept, as [`Reconstructor::new`] keeps them at [`DEFAULT_THRESHOLD`].
    /// `AᵀA` is singular exactly on the unseen modes `U`, so `M = AᵀA + U Uᵀ` is positive
    /// definite, `M⁻¹` maps the readings' `Aᵀ y` (orthogonal to `U`) to the least-squares
    /// pose of least norm, and `‖R‖²_F = trace(M⁻¹) − rank U`. Its cost is `AᵀA` summed row
    /// by row and one Cholesky factorisation, `(3N)³ / 3`: seconds at ELT-class sizes,
    /// where the SVD takes more than half an hour. Refused when `M` is not positive
    /// definite (a mode the sensors do not see beyond `U`).
    pub fn normal_equations(
        mirror: &Mirror,
        a: &Interaction,
        dihedral: f64,
    ) -> Result<Reconstructor, PhasingError> {
        let n = mirror.segments();
        assert_eq!(a.columns, 3 * n, "an interaction matrix of this mirror");
        let u = unseen_modes(mirror, dihedral);
        let m = a.normal() + &u * u.transpose();
        let cholesky = m.cholesky().ok_or_else(|| {
            PhasingError::Threshold(
                "the normal equations AᵀA + UUᵀ are not positive definite: the sensors leave a mode unseen beyond the whole mirror's piston, tip and tilt (and focus with no dihedral term)".into(),
            )
        })?;
        // trace(M⁻¹) = ‖L⁻¹‖²_F.
        let mut l_inv = DMatrix::identity(3 * n, 3 * n);
        cholesky.l_dirty().solve_lower_triangular_mut(&mut l_inv);
        let trace = l_inv.lower_triangle().norm_squared();
        let solve = Solve::Normal { a: a.clone(), cholesky, unseen: u.ncols(), trace };
        Ok(Reconstructor { solve, modes: Vec::new(), threshold: 0.0, segments: n })
    }

    /// The pose vector the readings reconstruct to.
    pub fn reconstruct(&self, readings: &[f64]) -> Vec<f64> {
        match &self.solve {
            Solve::Dense(r) => (r * DVector::from_column_slice(readings)).as_slice().to_vec(),
            Solve::Normal { a, cholesky, .. } => {
                cholesky.solve(&a.transpose_apply(readings)).as_slice().to_vec()
            }
        }
    }

    /// The readings it takes.
    pub fn sensors(&self) -> usize {
        match &self.solve {
            Solve::Dense(r) => r.ncols(),
            Solve::Normal { a, .. } => a.rows.len(),
        }
    }

    /// The noise multiplier: the reconstructed surface RMS per unit of white sensor noise,
    /// `‖R‖_F / √N` (the expected `‖R n‖² / N` for unit white `n` is `trace(R Rᵀ) / N`).
    pub fn noise_multiplier(&self) -> f64 {
        let squared = match &self.solve {
            Solve::Dense(r) => r.norm_squared(),
            Solve::Normal { trace, unseen, .. } => trace - *unseen as f64,
        };
        (squared / self.segments as f64).sqrt()
    }

    /// The same from `draws` seeded draws of unit white noise: the RMS over the draws of the
    /// reconstructed surface RMS.
    pub fn noise_multiplier_monte_carlo(&self, draws: usize, seed: u64) -> f64 {
        let mut state = seed;
        let mut sum = 0.0;
        for _ in 0..draws {
            let n: Vec<f64> =
                (0..self.sensors()).map(|_| inchworm_plant::noise::gaussian(&mut state)).collect();
            let u = self.reconstruct(&n);
            sum += u.iter().map(|x| x * x).sum::<f64>() / self.segments as f64;
        }
        (sum / draws as f64).sqrt()
    }

    /// The modes excluded: the weakest first.
    pub fn excluded(&self) -> impl Iterator<Item = &Mode> {
        self.modes.iter().filter(|m| !m.kept)
    }
}
