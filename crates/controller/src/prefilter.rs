//! Reference prefilter (paper Fig. 4): `r_f ← p r_f + (1 − p) r`, unit DC gain.
//!
//! The closed loop `L/(1 + L)` of [`crate::compensator`] has the compensator's zero at
//! `z = a`; that zero, not a lack of damping, is what makes the loop overshoot a reference
//! step. A prefilter pole at `p = a` cancels it, so large reference changes are approached
//! over several moves without overshoot (the Figs. 6–7 staircase).

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Prefilter {
    state: f64,
}

impl Prefilter {
    /// Starts at the measured position, so a reference far away at t = 0 is approached
    /// through the filter instead of jumping in on its first sample.
    pub fn start(&mut self, y: f64) {
        self.state = y;
    }

    /// One iteration with pole `p` in [0, 1); returns the filtered reference.
    pub fn filter(&mut self, p: f64, r: f64) -> f64 {
        self.state = p * self.state + (1.0 - p) * r;
        self.state
    }

    pub fn state(&self) -> f64 {
        self.state
    }

    pub(crate) fn with_state(state: f64) -> Prefilter {
        Prefilter { state }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_order_response_from_the_measured_position() {
        let mut f = Prefilter::default();
        f.start(10.0);
        // r_f(k) = r + (r_f(0) − r) p^k with r = 110, r_f(0) = 10, p = 0.8.
        for k in 1..=20 {
            let expect = 110.0 - 100.0 * 0.8f64.powi(k);
            let got = f.filter(0.8, 110.0);
            assert!((got - expect).abs() < 1e-12, "iteration {k}: {got} vs {expect}");
        }
        // p = 0 passes the reference through.
        assert_eq!(f.filter(0.0, -3.0), -3.0);
    }
}
