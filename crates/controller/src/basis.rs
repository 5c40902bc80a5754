//! Triangular (fuzzy) basis of the inverse scale factor (paper eqs. b5..b1, f1..f5).

/// Ten peaks `u_min < u_b4 < u_b3 < u_b2 < u_b1 < 0 < u_f1 < … < u_f4 < u_max` (m).
/// Zero is not a peak, so every map built on the basis passes through 0; beyond the end
/// peaks the end functions continue linearly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Basis {
    pub peaks: [f64; 10],
}

/// Default peaks for fia20: ±1, ±3, ±8, ±16, ±24 µm.
pub const FIA20_PEAKS: [f64; 10] =
    [-24e-6, -16e-6, -8e-6, -3e-6, -1e-6, 1e-6, 3e-6, 8e-6, 16e-6, 24e-6];

impl Basis {
    pub fn new(peaks: [f64; 10]) -> Result<Basis, String> {
        if peaks.iter().any(|p| !p.is_finite()) {
            return Err("basis peaks must be finite".into());
        }
        if !(peaks[4] < 0.0 && peaks[5] > 0.0) {
            return Err("basis peaks 5 and 6 must straddle 0 (u_b1 < 0 < u_f1)".into());
        }
        if peaks.windows(2).any(|w| w[0] >= w[1]) {
            return Err("basis peaks must be strictly increasing".into());
        }
        Ok(Basis { peaks })
    }

    /// The regressor φ(u): weights of the ten functions at `u`.
    pub fn phi(&self, u: f64) -> [f64; 10] {
        let p = &self.peaks;
        let mut phi = [0.0; 10];
        // Knots of the piecewise-linear interpolation: the peaks with 0 inserted, where
        // every function vanishes.
        let knots = [p[0], p[1], p[2], p[3], p[4], 0.0, p[5], p[6], p[7], p[8], p[9]];
        let slot = |i: usize| -> Option<usize> {
            match i {
                0..=4 => Some(i),
                5 => None,
                _ => Some(i - 1),
            }
        };
        let (i0, i1) = if u <= knots[1] {
            (0, 1)
        } else if u >= knots[9] {
            (9, 10)
        } else {
            let j = (1..10).find(|&j| u < knots[j + 1]).unwrap_or(9);
            (j, j + 1)
        };
        let t = (u - knots[i0]) / (knots[i1] - knots[i0]);
        if let Some(s) = slot(i0) {
            phi[s] += 1.0 - t;
        }
        if let Some(s) = slot(i1) {
            phi[s] += t;
        }
        phi
    }

    /// `φ(u)ᵀθ`.
    pub fn eval(&self, u: f64, theta: &[f64; 10]) -> f64 {
        self.phi(u).iter().zip(theta).map(|(a, b)| a * b).sum()
    }

    /// Weights of the linear map `u ↦ u / step`.
    pub fn linear_weights(&self, step: f64) -> [f64; 10] {
        self.peaks.map(|p| p / step)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn partition_of_unity_except_towards_zero_and_linear_beyond_the_ends() {
        let b = Basis::new(FIA20_PEAKS).unwrap();
        for k in -300..=300 {
            let u = k as f64 * 0.1e-6;
            let phi = b.phi(u);
            let sum: f64 = phi.iter().sum();
            if u <= -1e-6 || u >= 1e-6 {
                assert!((sum - 1.0).abs() < 1e-12 || u.abs() > 24e-6, "sum {sum} at {u}");
            } else {
                assert!(
                    sum <= 1.0 + 1e-12 && (sum - u.abs() / 1e-6).abs() < 1e-9,
                    "between the inner peaks the map fades to 0: {sum} at {u}"
                );
            }
        }
        assert_eq!(b.phi(0.0), [0.0; 10]);
        assert_eq!(b.phi(8e-6)[7], 1.0);
        // Beyond u_max the last function keeps its slope: f5 = 1 + (u − u_max)/(u_max − u_f4).
        let phi = b.phi(32e-6);
        assert!((phi[9] - 2.0).abs() < 1e-12 && (phi[8] + 1.0).abs() < 1e-12, "{phi:?}");
        // The linear weights reproduce the line everywhere.
        let w = b.linear_weights(20e-6);
        for u in [-40e-6, -10e-6, -0.5e-6, 0.3e-6, 5e-6, 30e-6] {
            assert!((b.eval(u, &w) - u / 20e-6).abs() < 1e-12);
        }
    }

    #[test]
    fn peaks_are_checked() {
        assert!(Basis::new([1.0; 10]).is_err());
        let mut p = FIA20_PEAKS;
        p[4] = 0.5e-6;
        assert!(Basis::new(p).is_err());
    }
}
