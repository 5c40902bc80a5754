//! The brake-disturbance map (docs/model.md §4.2, docs/controller-design.md
//! "Disturbance map"): a second fuzzy map, `BD ≈ ψ(EXT_cmd)ᵀ β`, that predicts the
//! disturbance of the coming step from its extension command.
//!
//! `ψ` is a triangular partition of unity over the command (−1 = a full backward step,
//! +1 = a full forward one) with knots [`KNOTS`], denser near 0 where fractional steps
//! live; a constant map is `β` all equal. It is estimated by a second Kalman filter with
//! the random-walk process of the first one's disturbance state, on the same measured
//! `BD` of every step. A second filter rather than nine more states in the first: the
//! first filter's two measurement rows share no state (its weights and its disturbance
//! are uncorrelated), so a joint filter would be block-diagonal in the map's states and
//! give the same estimates; the second filter keeps the first, and every trace made with
//! it, bit for bit, and costs a 9×9 update instead of a 20×20 one.

use nalgebra::{SMatrix, SVector};

/// Knots of the map over `EXT_cmd`.
pub const KNOTS: [f64; 9] = [-1.0, -0.6, -0.3, -0.1, 0.0, 0.1, 0.3, 0.6, 1.0];
pub const N: usize = KNOTS.len();
/// Correlation length of the prior over the command (fraction of a full step).
pub const CORRELATION: f64 = 0.5;

/// `ψ(c)`: hat functions on [`KNOTS`], `c` clamped to [−1, 1].
pub fn psi(c: f64) -> [f64; N] {
    let c = c.clamp(KNOTS[0], KNOTS[N - 1]);
    let mut out = [0.0; N];
    let j = (0..N - 1).find(|&j| c <= KNOTS[j + 1]).unwrap_or(N - 2);
    let t = (c - KNOTS[j]) / (KNOTS[j + 1] - KNOTS[j]);
    out[j] = 1.0 - t;
    out[j + 1] = t;
    out
}

#[derive(Clone, Debug, PartialEq)]
pub struct DisturbanceMap {
    pub beta: SVector<f64, N>,
    pub p: SMatrix<f64, N, N>,
    /// Process noise per weight (m²/s) and measurement noise (m²).
    q: f64,
    r: f64,
    /// Command of the last step it was updated with.
    pub last_command: f64,
}

impl DisturbanceMap {
    /// Every weight at `start` (a constant map) with prior `prior` (m, 1σ), process noise
    /// `process` (m/√s) and measurement noise `measurement` (m).
    pub fn new(start: f64, prior: f64, process: f64, measurement: f64) -> DisturbanceMap {
        DisturbanceMap {
            beta: SVector::from_element(start),
            // Neighbouring weights correlated a priori (exp(−|Δc|/0.5)): a step at one
            // command also informs the commands near it that have not been seen yet.
            p: SMatrix::from_fn(|i, j| {
                prior * prior * (-(KNOTS[i] - KNOTS[j]).abs() / CORRELATION).exp()
            }),
            q: process * process,
            r: measurement * measurement,
            last_command: 0.0,
        }
    }

    /// The predicted disturbance of a step with extension command `c`.
    pub fn predict(&self, c: f64) -> f64 {
        psi(c).iter().zip(self.beta.iter()).map(|(a, b)| a * b).sum()
    }

    /// The disturbance of a step commanded `c`, from the latest disturbance estimate
    /// `level` (which followed the last step's): the level plus the map's change from the
    /// last step's command to `c`. The level carries what the map cannot: the drift of the
    /// disturbance with the extension state and the load (docs/model.md §2.5), which the
    /// map's weights at commands not visited for a while do not follow.
    pub fn predict_from(&self, level: f64, c: f64) -> f64 {
        level + self.predict(c) - self.predict(self.last_command)
    }

    /// Propagate over `t_step` s, then update with the measured `bd` of a step commanded
    /// `c` (Joseph form).
    pub fn update(&mut self, t_step: f64, c: f64, bd: f64) {
        for i in 0..N {
            self.p[(i, i)] += self.q * t_step;
        }
        let h = SVector::<f64, N>::from(psi(c));
        let ph = self.p * h;
        let s = h.dot(&ph) + self.r;
        let k = ph / s;
        self.beta += k * (bd - h.dot(&self.beta));
        let a = SMatrix::<f64, N, N>::identity() - k * h.transpose();
        self.p = a * self.p * a.transpose() + k * k.transpose() * self.r;
        self.last_command = c;
    }

    pub(crate) fn save(&self, w: &mut inchworm_state_bytes::Writer) {
        for v in self.beta.iter().chain(self.p.iter()) {
            w.f64(*v);
        }
        w.f64(self.last_command);
    }

    pub(crate) fn load(&mut self, r: &mut inchworm_state_bytes::Reader) -> Result<(), String> {
        for v in self.beta.iter_mut() {
            *v = r.f64()?;
        }
        for v in self.p.iter_mut() {
            *v = r.f64()?;
        }
        self.last_command = r.f64()?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hat_functions_are_a_partition_of_unity() {
        for k in -120..=120 {
            let c = k as f64 / 100.0;
            let p = psi(c);
            assert!((p.iter().sum::<f64>() - 1.0).abs() < 1e-15, "c = {c}");
            assert!(p.iter().all(|v| (0.0..=1.0).contains(v)));
        }
        assert_eq!(psi(0.3)[6], 1.0);
        let p = psi(-0.2);
        assert!((p[2] - 0.5).abs() < 1e-12 && (p[3] - 0.5).abs() < 1e-12, "{p:?}");
        assert_eq!(p.iter().filter(|v| **v != 0.0).count(), 2);
    }

    #[test]
    fn learns_a_disturbance_that_depends_on_the_command() {
        // BD = 4.5 µm forward, 5.4 µm backward, linear in between.
        let truth = |c: f64| 4.95e-6 - 0.45e-6 * c;
        let mut m = DisturbanceMap::new(4.7e-6, 5e-6, 0.1e-6, 0.05e-6);
        for k in 0..4000 {
            let c = [1.0, -1.0, 0.3, -0.27, 0.05, -0.6, 0.6, -0.1][k % 8];
            m.update(0.2, c, truth(c));
        }
        for c in [1.0, -1.0, 0.3, -0.27, 0.0, 0.45] {
            assert!((m.predict(c) - truth(c)).abs() < 0.01e-6, "c = {c}: {}", m.predict(c));
        }
    }
}
