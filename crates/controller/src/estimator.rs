//! The Kalman filter of the inverse scale factor and the brake disturbance (paper eqs.
//! 13–20): state = ten basis weights θ and the disturbance BD (m), process `ẋ = w`,
//! measurement `z = [EXT_cmd, BD] = H x + v` with `H = [φ(EXT_moved) 0; 0 … 0 1]`.

use inchworm_declare::{Declare, Declared};
use nalgebra::{SMatrix, SVector};

use crate::basis::Basis;

pub type State = SVector<f64, 11>;
pub type Cov = SMatrix<f64, 11, 11>;

/// Noise levels (1-σ), each declared once (the controller FMU's parameters;
/// [`crate::Params`] flattens them). Units: weights dimensionless, disturbance in m, per
/// √s for the process noise; the starts are docs/model.md §4's prototype levels.
#[derive(Clone, Copy, Debug, PartialEq, Declare)]
pub struct Noise {
    /// Prior 1-sigma of each scale-factor weight
    #[var(start = 0.05)]
    pub weight_prior: f64,
    /// Prior 1-sigma of the disturbance
    #[var(unit = "m", start = 5e-6)]
    pub disturbance_prior: f64,
    /// Process noise of the weights per sqrt(s)
    #[var(name = "weight_process_noise", start = 1e-3)]
    pub weight_process: f64,
    /// Process noise of the disturbance per sqrt(s)
    #[var(name = "disturbance_process_noise", unit = "m", start = 0.1e-6)]
    pub disturbance_process: f64,
    /// Measurement noise of EXT_cmd
    #[var(name = "ext_cmd_noise", start = 5e-3)]
    pub ext_cmd_measurement: f64,
    /// Measurement noise of BD
    #[var(name = "bd_noise", unit = "m", start = 0.05e-6)]
    pub bd_measurement: f64,
}

impl Default for Noise {
    fn default() -> Self {
        Noise::declared()
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Estimator {
    pub x: State,
    pub p: Cov,
    q: SVector<f64, 11>,
    r: [f64; 2],
}

impl Estimator {
    pub fn new(weights: [f64; 10], disturbance: f64, noise: &Noise) -> Estimator {
        let mut x = State::zeros();
        x.fixed_rows_mut::<10>(0).copy_from(&SVector::<f64, 10>::from(weights));
        x[10] = disturbance;
        let mut p = Cov::zeros();
        let mut q = SVector::<f64, 11>::zeros();
        for i in 0..10 {
            p[(i, i)] = noise.weight_prior.powi(2);
            q[i] = noise.weight_process.powi(2);
        }
        p[(10, 10)] = noise.disturbance_prior.powi(2);
        q[10] = noise.disturbance_process.powi(2);
        Estimator { x, p, q, r: [noise.ext_cmd_measurement.powi(2), noise.bd_measurement.powi(2)] }
    }

    pub fn weights(&self) -> [f64; 10] {
        std::array::from_fn(|i| self.x[i])
    }

    pub fn disturbance(&self) -> f64 {
        self.x[10]
    }

    /// One step: propagate over `t_step` seconds (`P ← P + Q T`), then update with the
    /// step's raw measurements.
    pub fn update(&mut self, basis: &Basis, t_step: f64, ext_cmd: f64, ext_moved: f64, bd: f64) {
        for i in 0..11 {
            self.p[(i, i)] += self.q[i] * t_step;
        }
        let mut h = SMatrix::<f64, 2, 11>::zeros();
        for (i, v) in basis.phi(ext_moved).iter().enumerate() {
            h[(0, i)] = *v;
        }
        h[(1, 10)] = 1.0;
        let z = SVector::<f64, 2>::new(ext_cmd, bd);
        let mut s = h * self.p * h.transpose();
        s[(0, 0)] += self.r[0];
        s[(1, 1)] += self.r[1];
        let Some(s_inv) = s.try_inverse() else { return };
        let k = self.p * h.transpose() * s_inv;
        self.x += k * (z - h * self.x);
        // Joseph form: keeps P symmetric and positive over millions of updates.
        let ikh = Cov::identity() - k * h;
        let mut r = SMatrix::<f64, 2, 2>::zeros();
        r[(0, 0)] = self.r[0];
        r[(1, 1)] = self.r[1];
        self.p = ikh * self.p * ikh.transpose() + k * r * k.transpose();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::FIA20_PEAKS;

    #[test]
    fn one_update_matches_the_hand_computed_gain() {
        let basis = Basis::new(FIA20_PEAKS).unwrap();
        let noise = Noise::default();
        let w0 = basis.linear_weights(20e-6);
        let mut est = Estimator::new(w0, 0.0, &noise);
        // A measurement exactly at the 8 µm peak: only weight 8 and BD are observed.
        est.update(&basis, 0.2, 0.5, 8e-6, 4e-6);
        let p_w = 0.05f64.powi(2) + 1e-6 * 0.2;
        let gain_w = p_w / (p_w + 25e-6);
        let expect_w = 0.4 + gain_w * (0.5 - 0.4);
        assert!((est.x[7] - expect_w).abs() < 1e-12, "weight at 8 µm: {} vs {expect_w}", est.x[7]);
        let p_d = 25e-12 + 1e-14 * 0.2;
        let expect_d = p_d / (p_d + 2.5e-15) * 4e-6;
        assert!((est.x[10] - expect_d).abs() < 1e-15, "BD {} vs {expect_d}", est.x[10]);
        for i in (0..10).filter(|&i| i != 7) {
            assert_eq!(est.x[i], w0[i], "weight {i} not observed");
        }
    }

    #[test]
    fn update_between_two_peaks_shares_the_innovation_by_the_regressor() {
        let basis = Basis::new(FIA20_PEAKS).unwrap();
        let noise = Noise::default();
        let w0 = basis.linear_weights(20e-6);
        let mut est = Estimator::new(w0, 0.0, &noise);
        // u = 4 µm lies between the 3 and 8 µm peaks: φ = 0.8, 0.2 there. With P = p I on
        // the weights, S = p (0.8² + 0.2²) + R and the gain on weight i is p φ_i / S.
        est.update(&basis, 0.2, 0.25, 4e-6, 0.0);
        let p = 0.05f64.powi(2) + 1e-6 * 0.2;
        let s = p * 0.68 + 25e-6;
        let innovation = 0.25 - (0.8 * 0.15 + 0.2 * 0.4);
        for (i, phi) in [(6, 0.8), (7, 0.2)] {
            let expect = w0[i] + p * phi / s * innovation;
            assert!((est.x[i] - expect).abs() < 1e-12, "weight {i}: {} vs {expect}", est.x[i]);
            let p_ii = p - p * p * phi * phi / s;
            assert!((est.p[(i, i)] - p_ii).abs() < 1e-15, "P[{i},{i}] {} vs {p_ii}", est.p[(i, i)]);
        }
        // The shared measurement correlates the two weights.
        assert!((est.p[(6, 7)] + p * p * 0.16 / s).abs() < 1e-15, "P[6,7] {}", est.p[(6, 7)]);
        assert_eq!(est.p[(6, 7)], est.p[(7, 6)]);
        assert_eq!(est.p[(5, 6)], 0.0, "weights the regressor does not touch stay uncorrelated");
    }

    #[test]
    fn steady_disturbance_gain_of_the_default_noise_levels_is_0_58() {
        let basis = Basis::new(FIA20_PEAKS).unwrap();
        let noise = Noise::default();
        let mut est = Estimator::new(basis.linear_weights(20e-6), 0.0, &noise);
        for _ in 0..500 {
            est.update(&basis, 0.2, 1.0, 20e-6, 0.0);
        }
        let before = est.disturbance();
        est.update(&basis, 0.2, 1.0, 20e-6, 1e-6);
        let gain = (est.disturbance() - before) / 1e-6;
        // Scalar random walk: P⁻ = (qT + √(q²T² + 4 qT R))/2, gain P⁻/(P⁻ + R).
        let (qt, r): (f64, f64) = (1e-14 * 0.2, 2.5e-15);
        let p_minus = (qt + (qt * qt + 4.0 * qt * r).sqrt()) / 2.0;
        let expect = p_minus / (p_minus + r);
        assert!((gain - expect).abs() < 1e-9, "steady gain {gain} vs closed form {expect}");
        assert!(
            (gain - 0.58).abs() < 0.005,
            "steady disturbance gain {gain:.4}, docs/model.md §4 prototype ≈ 0.58"
        );
    }
}
