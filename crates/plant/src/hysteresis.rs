//! Passive hysteresis on the PZT charge: a Maxwell-slip sum of stop operators
//! (docs/model.md §2.4).
//!
//! Element i is an elastic capacitance of weight `w_i` with a slip limit `r_i`: its output
//! is `E_i = clamp(ξ − p_i, −r_i, r_i)`, where `p_i` is the memory of the play operator
//! `F_r[ξ] = min(ξ + r, max(ξ − r, F_r⁻))`, so `E_i = ξ − F_{r_i}[ξ]`. The element *sticks*
//! while `|ξ − p_i| < r_i` (output `ξ − p_i`, linear in `ξ`) and *slips* once the bound is
//! reached (output `±r_i`, constant, memory dragged along). The power into the element,
//! `u_h q̇ = d/dt (C Σ w_i E_i² / 2) + C Σ w_i r_i |ṗ_i|`, is stored energy plus a dissipation
//! that is never negative: the form is passive.
//!
//! The solver propagates the elements exactly: between events every element either sticks
//! or slips in the current direction, so `u_h = W ξ + c0` is affine in `ξ` with `W` the
//! weight of the sticking elements, and the whole plant is linear. This module owns the
//! memories and answers the questions the event loop asks: which elements slip, what `W`
//! and `c0` are, and where the next element starts to slip.

use crate::params::N_PLAYS;

/// One backlash (play) operator: `F_r[ξ](t) = min(ξ + r, max(ξ − r, F_r(t⁻)))`. Its output
/// is the memory `p` of the stop operator of the same radius.
pub fn play(memory: f64, xi: f64, radius: f64) -> f64 {
    (xi - radius).max(memory).min(xi + radius)
}

/// One stop operator (elastic-plastic element) with memory `p`: `clamp(ξ − p, −r, r)`.
pub fn stop(memory: f64, xi: f64, radius: f64) -> f64 {
    (xi - memory).clamp(-radius, radius)
}

/// The elements of the stack and which of them slip right now.
#[derive(Clone, Debug, PartialEq)]
pub struct Hysteresis {
    pub radius: [f64; N_PLAYS],
    pub weight: [f64; N_PLAYS],
    /// Element memories `p_i` (the play outputs), V.
    pub memory: [f64; N_PLAYS],
    /// Bit i set: element i slips in `direction`.
    pub sliding: u8,
    /// +1 while `ξ` rises, −1 while it falls, 0 at rest.
    pub direction: i8,
}

impl Hysteresis {
    pub fn new(radius: [f64; N_PLAYS], weight: [f64; N_PLAYS]) -> Self {
        Hysteresis { radius, weight, memory: [0.0; N_PLAYS], sliding: 0, direction: 0 }
    }

    /// `H[ξ] = Σ w_i clamp(ξ − p_i, −r_i, r_i)` with the memories held.
    pub fn output_held(&self, xi: f64) -> f64 {
        (0..N_PLAYS).map(|i| self.weight[i] * stop(self.memory[i], xi, self.radius[i])).sum()
    }

    /// Solves `ξ + H[ξ] = drive` with the memories held (docs/model.md §2.4). The left side
    /// is strictly increasing (slope between 1 and `1 + Σ w_i`) and piecewise linear with
    /// kinks at `p_i ± r_i`, so walking the kinks gives the root exactly.
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
        // On this piece f(ξ) = (1 + W) ξ + b, W the weight of the elements that stick there.
        let slope = 1.0
            + (0..N_PLAYS)
                .filter(|&i| (probe - self.memory[i]).abs() < self.radius[i])
                .map(|i| self.weight[i])
                .sum::<f64>();
        probe - f(probe) / slope
    }

    /// `W` in `u_h = W ξ + c0`: the weight of the sticking elements.
    pub fn sticking_weight(&self) -> f64 {
        (0..N_PLAYS).filter(|&i| self.sliding & (1 << i) == 0).map(|i| self.weight[i]).sum()
    }

    /// `c0` in `u_h = W ξ + c0` for the current slipping set and direction: a sticking
    /// element adds `−w_i p_i`, a slipping one its constant output `±w_i r_i`.
    pub fn offset(&self) -> f64 {
        let s = f64::from(self.direction);
        (0..N_PLAYS)
            .map(|i| {
                if self.sliding & (1 << i) != 0 {
                    s * self.weight[i] * self.radius[i]
                } else {
                    -self.weight[i] * self.memory[i]
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

    /// Whether [`Self::sync`] at `ξ` and the sign of `ξ̇` would leave the memories and the
    /// slipping set as they are, with nothing slipping: then it only sets the direction,
    /// which then weighs nothing (`c0` and the thresholds ignore it), and a quiet step can
    /// skip the re-derivation. The same operations as `sync`, so the same decision.
    #[inline(always)]
    pub fn sync_keeps(&self, xi: f64, xi_rate_sign: i8) -> bool {
        self.sliding == 0
            && (0..N_PLAYS).all(|i| {
                let memory = play(self.memory[i], xi, self.radius[i]);
                let tol = 1e-9 * (1.0 + self.radius[i]);
                let at_upper = memory <= xi - self.radius[i] + tol;
                let at_lower = memory >= xi + self.radius[i] - tol;
                memory.to_bits() == self.memory[i].to_bits()
                    && !((xi_rate_sign > 0 && at_upper) || (xi_rate_sign < 0 && at_lower))
            })
    }

    /// An open interval of `ξ` on which [`Self::sync_keeps`] holds whatever the direction:
    /// inside `m_i ± (r_i − 3 tol_i)` for every element, where `(ξ ∓ r_i) ± tol_i` can't reach
    /// `m_i` in floating point as long as every magnitude is below 1e6 V (a rounding there is
    /// below 1e-10 V, the tolerance at least 1e-9 V). Empty if something slips or the
    /// magnitudes are larger.
    pub fn keep_interval(&self) -> (f64, f64) {
        let (mut lo, mut hi) = (-1e6, 1e6);
        for i in 0..N_PLAYS {
            let (m, r) = (self.memory[i], self.radius[i]);
            let small = m.abs() + r < 1e6;
            if self.sliding != 0 || !small {
                return (0.0, 0.0);
            }
            let tol = 1e-9 * (1.0 + r);
            lo = f64::max(lo, m - r + 3.0 * tol);
            hi = f64::min(hi, m + r - 3.0 * tol);
        }
        (lo, hi)
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
    fn slipping_set_affine_form_matches_the_operator() {
        // Drag ξ up from 0 to 35: elements of radius 10, 20, 30 slip, 40 and 50 stick.
        let mut h = fia20();
        h.sync(35.0, 1);
        assert_eq!(h.sliding, 0b00111);
        let w = h.sticking_weight();
        assert!((w - 0.09).abs() < 1e-15);
        let affine = w * 35.0 + h.offset();
        assert!((affine - h.output_held(35.0)).abs() < 1e-12);
        // Slipping elements sit at their limits, sticking ones are strained elastically.
        let expect = 0.08 * 10.0 + 0.07 * 20.0 + 0.06 * 30.0 + 0.05 * 35.0 + 0.04 * 35.0;
        assert!((h.output_held(35.0) - expect).abs() < 1e-12);
        let (up, down) = h.next_thresholds();
        assert_eq!((up, down), (40.0, -40.0));
        // Reversal: all stick at their dragged positions.
        h.sync(35.0, -1);
        assert_eq!(h.sliding, 0);
        assert_eq!(h.memory, [25.0, 15.0, 5.0, 0.0, 0.0]);
        assert_eq!(h.next_thresholds(), (35.0, 15.0));
        assert!((h.sticking_weight() * 35.0 + h.offset() - h.output_held(35.0)).abs() < 1e-12);
    }

    #[test]
    fn stop_is_the_complement_of_play() {
        let (mut p, r) = (0.0, 10.0);
        for xi in [5.0, 30.0, 25.0, 10.0, -30.0, -25.0, 0.0] {
            let e = stop(p, xi, r);
            p = play(p, xi, r);
            assert_eq!(e, xi - p, "stop output at xi = {xi}");
            assert!(e.abs() <= r);
        }
    }
}
