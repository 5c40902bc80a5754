//! The reconstructor: the interaction matrix's singular modes, the whole mirror's piston,
//! tip and tilt (which no edge sensor sees) and any mode the sensors see more weakly than
//! a threshold excluded, and the pseudo-inverse over the modes kept (docs/phasing.md).
//!
//! Pose vectors are in the interaction matrix's coordinates ([`crate::EdgeSensors`]):
//! per segment its piston and its tip and tilt times the segment's RMS lever arm, so a
//! vector's norm over `√N` is the mirror's surface RMS.

use nalgebra::{DMatrix, DVector};

use crate::geometry::Mirror;
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

/// The pseudo-inverse of an interaction matrix over its modes at or above `threshold`.
#[derive(Clone, Debug)]
pub struct Reconstructor {
    /// Pose vector from readings: `3N × sensors`.
    pub matrix: DMatrix<f64>,
    /// Every singular mode, the weakest first.
    pub modes: Vec<Mode>,
    pub threshold: f64,
    pub segments: usize,
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
        Ok(Reconstructor { matrix, modes, threshold, segments: n })
    }

    /// The pose vector the readings reconstruct to.
    pub fn reconstruct(&self, readings: &[f64]) -> Vec<f64> {
        (&self.matrix * DVector::from_column_slice(readings)).as_slice().to_vec()
    }

    /// The noise multiplier: the reconstructed surface RMS per unit of white sensor noise,
    /// `‖R‖_F / √N` (the expected `‖R n‖² / N` for unit white `n` is `trace(R Rᵀ) / N`).
    pub fn noise_multiplier(&self) -> f64 {
        self.matrix.norm() / (self.segments as f64).sqrt()
    }

    /// The same from `draws` seeded draws of unit white noise: the RMS over the draws of the
    /// reconstructed surface RMS.
    pub fn noise_multiplier_monte_carlo(&self, draws: usize, seed: u64) -> f64 {
        let mut state = seed;
        let mut sum = 0.0;
        for _ in 0..draws {
            let n: Vec<f64> = (0..self.matrix.ncols())
                .map(|_| inchworm_plant::noise::gaussian(&mut state))
                .collect();
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
