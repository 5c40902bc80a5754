//! Prandtl–Ishlinskii hysteresis on the PZT charge (SPEC 2.4).
//!
//! The solver propagates the plays exactly: between events every play is either stuck
//! (memory constant) or dragged by `ξ` in the current direction, so `u_h = W_s ξ + c0`
//! is affine in `ξ`, and the whole plant is linear. This module owns the play memories
//! and answers the questions the event loop asks: which plays slide, what `W_s` and `c0`
//! are, and where the next play starts to move.

use crate::params::N_PLAYS;

/// One backlash (play) operator: `F_r[ξ](t) = min(ξ + r, max(ξ − r, F_r(t⁻)))`.
pub fn play(memory: f64, xi: f64, radius: f64) -> f64 {
    (xi - radius).max(memory).min(xi + radius)
}

/// The plays of the stack and which of them the charge is dragging right now.
#[derive(Clone, Debug, PartialEq)]
pub struct Hysteresis {
    pub radius: [f64; N_PLAYS],
    pub weight: [f64; N_PLAYS],
    /// Play outputs (their memories), V.
    pub memory: [f64; N_PLAYS],
    /// Bit i set: play i is being dragged in `direction`.
    pub sliding: u8,
    /// +1 while `ξ` rises, −1 while it falls, 0 at rest.
    pub direction: i8,
}

impl Hysteresis {
    pub fn new(radius: [f64; N_PLAYS], weight: [f64; N_PLAYS]) -> Self {
        Hysteresis { radius, weight, memory: [0.0; N_PLAYS], sliding: 0, direction: 0 }
    }

    /// `H[ξ]` with the memories held: the static Prandtl–Ishlinskii sum.
    pub fn output_held(&self, xi: f64) -> f64 {
        (0..N_PLAYS).map(|i| self.weight[i] * play(self.memory[i], xi, self.radius[i])).sum()
    }

    /// Solves `ξ + H[ξ] = drive` with the memories held (SPEC 2.4). The left side is
    /// strictly increasing and piecewise linear with kinks at `p_i ± r_i`, so walking the
    /// kinks gives the root exactly.
    pub fn solve_xi(&self, drive: f64) -> f64 {
        let f = |xi: f64| xi + self.output_held(xi) - drive;
        let mut kinks = [0.0; 2 * N_PLAYS];
        for i in 0..N_PLAYS {
            kinks[2 * i] = self.memory[i] - self.radius[i];
            kinks[2 * i + 1] = self.memory[i] + self.radius[i];
        }
        kinks.sort_by(|a, b| a.total_cmp(b));
        // Find the linear piece that holds the root, then solve it in closed form.
        let mut lo = f64::NEG_INFINITY;
        let mut hi = f64::INFINITY;
        for &k in &kinks {
            if f(k) >= 0.0 {
                hi = k;
                break;
            }
            lo = k;
        }
        let probe = match (lo.is_finite(), hi.is_finite()) {
            (true, true) => 0.5 * (lo + hi),
            (true, false) => lo + 1.0,
            (false, true) => hi - 1.0,
            (false, false) => 0.0,
        };
        // On this piece f(ξ) = (1 + W) ξ + b: slope from the sliding plays at the probe.
        let slope = 1.0
            + (0..N_PLAYS)
                .filter(|&i| (probe - self.memory[i]).abs() > self.radius[i])
                .map(|i| self.weight[i])
                .sum::<f64>();
        probe - f(probe) / slope
    }

    /// Sum of the weights of the sliding plays.
    pub fn sliding_weight(&self) -> f64 {
        (0..N_PLAYS).filter(|&i| self.sliding & (1 << i) != 0).map(|i| self.weight[i]).sum()
    }

    /// `c0` in `u_h = W_s ξ + c0` for the current sliding set and direction.
    pub fn offset(&self) -> f64 {
        let s = f64::from(self.direction);
        (0..N_PLAYS)
            .map(|i| {
                if self.sliding & (1 << i) != 0 {
                    -s * self.weight[i] * self.radius[i]
                } else {
                    self.weight[i] * self.memory[i]
                }
            })
            .sum()
    }

    /// Re-derives memories and the sliding set from the exact `ξ` and the sign of `ξ̇`.
    /// Called after every event and at the start of every step, so the linear pieces the
    /// solver propagates always start from a consistent operator state.
    pub fn sync(&mut self, xi: f64, xi_rate_sign: i8) {
        self.direction = xi_rate_sign;
        self.sliding = 0;
        for i in 0..N_PLAYS {
            self.memory[i] = play(self.memory[i], xi, self.radius[i]);
            // A play at its bound slides only if ξ keeps moving that way; the tolerance
            // absorbs the rounding of the located event (ξ overshoots by ~ξ̇·1 ns).
            let tol = 1e-9 * (1.0 + self.radius[i]);
            let at_upper = self.memory[i] <= xi - self.radius[i] + tol;
            let at_lower = self.memory[i] >= xi + self.radius[i] - tol;
            if (xi_rate_sign > 0 && at_upper) || (xi_rate_sign < 0 && at_lower) {
                self.sliding |= 1 << i;
                self.memory[i] = xi - f64::from(xi_rate_sign) * self.radius[i];
            }
        }
    }

    /// The `ξ` at which the next stuck play starts to move upwards / downwards.
    pub fn next_thresholds(&self) -> (f64, f64) {
        let mut up = f64::INFINITY;
        let mut down = f64::NEG_INFINITY;
        for i in 0..N_PLAYS {
            if self.sliding & (1 << i) == 0 {
                up = up.min(self.memory[i] + self.radius[i]);
                down = down.max(self.memory[i] - self.radius[i]);
            }
        }
        (up, down)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fia20() -> Hysteresis {
        Hysteresis::new([10.0, 20.0, 30.0, 40.0, 50.0], [0.08, 0.07, 0.06, 0.05, 0.04])
    }

    #[test]
    fn play_operator_traces_its_parallelogram() {
        // Up to 30, down to -30, up to 0: a radius-10 play with memory 0.
        let mut p = 0.0;
        let path = [5.0, 30.0, 25.0, 10.0, -30.0, -25.0, 0.0];
        let expect = [0.0, 20.0, 20.0, 20.0, -20.0, -20.0, -10.0];
        for (xi, e) in path.iter().zip(expect) {
            p = play(p, *xi, 10.0);
            assert_eq!(p, e, "play output at xi = {xi}");
        }
    }

    #[test]
    fn solve_xi_is_the_root_of_the_monotone_equation() {
        let mut h = fia20();
        h.memory = [3.0, -4.0, 0.0, 12.0, -1.0];
        for drive in [-200.0, -35.0, -3.0, 0.0, 0.7, 17.0, 61.0, 150.0] {
            let xi = h.solve_xi(drive);
            let resid = xi + h.output_held(xi) - drive;
            assert!(resid.abs() < 1e-12, "residual {resid} at drive {drive}");
        }
    }

    #[test]
    fn sliding_set_affine_form_matches_the_operator() {
        // Drag ξ up from 0 to 35: plays of radius 10, 20, 30 slide, 40 and 50 stay.
        let mut h = fia20();
        h.sync(35.0, 1);
        assert_eq!(h.sliding, 0b00111);
        let w = h.sliding_weight();
        assert!((w - 0.21).abs() < 1e-15);
        let affine = w * 35.0 + h.offset();
        assert!((affine - h.output_held(35.0)).abs() < 1e-12);
        let (up, down) = h.next_thresholds();
        assert_eq!((up, down), (40.0, -40.0));
        // Reversal: all stick at their dragged positions.
        h.sync(35.0, -1);
        assert_eq!(h.sliding, 0);
        assert_eq!(h.memory, [25.0, 15.0, 5.0, 0.0, 0.0]);
        assert_eq!(h.next_thresholds(), (35.0, 15.0));
    }
}
