//! Waveform generation (paper eqs. 21–24): full-step sizes by bisection on the estimated
//! inverse scale factor shifted by the brake disturbance, and the split of a move into
//! full steps and one fractional step.

use crate::basis::Basis;

/// A move as the gait will execute it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plan {
    /// Forward and backward full-step sizes (m); `None` where no root was found.
    pub step_forward: Option<f64>,
    pub step_backward: Option<f64>,
    /// Full steps of the move's direction (≥ 0).
    pub n_steps: u32,
    /// +1 forward, −1 backward (direction of the full steps).
    pub direction: i8,
    /// Amplitude of the final fractional step in [−1, 1] (sign = its direction).
    pub fraction: f64,
    /// The map had no root in its bracket: no full steps this move.
    pub no_root: bool,
}

/// Bisection bracket as a multiple of the outermost basis peak: a full step of the
/// nominal device is below the outer peak, so twice it (plus the disturbance) holds
/// every root a monotone map can have.
pub const BRACKET_PEAKS: f64 = 2.0;

/// Root of `φ(u − bd)ᵀθ = target` in `[lo, hi]` by bisection, if the ends bracket it.
pub fn step_size(basis: &Basis, theta: &[f64; 10], bd: f64, target: f64) -> Option<f64> {
    let (lo, hi) = if target > 0.0 {
        (bd.min(0.0), BRACKET_PEAKS * basis.peaks[9] + bd.abs())
    } else {
        (BRACKET_PEAKS * basis.peaks[0] - bd.abs(), bd.max(0.0))
    };
    let g = |u: f64| basis.eval(u - bd, theta) - target;
    let (mut a, mut b) = (lo, hi);
    let (ga, gb) = (g(a), g(b));
    if !(ga.is_finite() && gb.is_finite()) || ga * gb > 0.0 {
        return None;
    }
    for _ in 0..100 {
        let m = 0.5 * (a + b);
        if g(m) * ga > 0.0 {
            a = m;
        } else {
            b = m;
        }
        if b - a < 1e-13 {
            break;
        }
    }
    Some(0.5 * (a + b))
}

/// Splits a move of `d` metres (paper eqs. 22–24).
pub fn plan(basis: &Basis, theta: &[f64; 10], bd: f64, d: f64) -> Plan {
    let step_forward = step_size(basis, theta, bd, 1.0);
    let step_backward = step_size(basis, theta, bd, -1.0);
    let sd = if d >= 0.0 { step_forward } else { step_backward };
    let (n_steps, frac_d, no_root) = match sd {
        // fix(): towards zero.
        Some(sd) if sd * d > 0.0 => {
            let n = (d / sd).trunc();
            (n as u32, d - n * sd, false)
        }
        Some(_) => (0, d, false),
        None => (0, d, true),
    };
    let fraction = basis.eval(frac_d - bd, theta).clamp(-1.0, 1.0);
    Plan {
        step_forward,
        step_backward,
        n_steps,
        direction: if d >= 0.0 { 1 } else { -1 },
        fraction,
        no_root,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::FIA20_PEAKS;

    #[test]
    fn bisection_on_a_linear_map_and_the_split_of_a_move() {
        let b = Basis::new(FIA20_PEAKS).unwrap();
        let theta = b.linear_weights(20e-6);
        // y = (u − bd)/20 µm: a forward step moves 20 µm + bd, a backward one −20 µm + bd.
        let bd = 4.5e-6;
        let sf = step_size(&b, &theta, bd, 1.0).unwrap();
        let sb = step_size(&b, &theta, bd, -1.0).unwrap();
        assert!((sf - 24.5e-6).abs() < 1e-12 && (sb + 15.5e-6).abs() < 1e-12, "{sf} {sb}");
        let p = plan(&b, &theta, bd, 100e-6);
        assert_eq!((p.n_steps, p.direction), (4, 1));
        assert!(
            (p.fraction - (100e-6 - 4.0 * 24.5e-6 - bd) / 20e-6).abs() < 1e-6,
            "fraction {}",
            p.fraction
        );
        let p = plan(&b, &theta, bd, -40e-6);
        assert_eq!((p.n_steps, p.direction), (2, -1));
        assert!((p.fraction - ((-40e-6 + 31e-6) - bd) / 20e-6).abs() < 1e-6);
        // A tiny move: no full step, a small backward fraction cancels the disturbance.
        let p = plan(&b, &theta, bd, 0.5e-6);
        assert_eq!(p.n_steps, 0);
        assert!((p.fraction + 0.2).abs() < 1e-6);
    }

    #[test]
    fn a_non_monotone_map_has_no_root_and_no_full_steps() {
        let b = Basis::new(FIA20_PEAKS).unwrap();
        let mut theta = b.linear_weights(20e-6);
        for w in theta.iter_mut().skip(5) {
            *w = 0.3; // never reaches +1
        }
        assert_eq!(step_size(&b, &theta, 0.0, 1.0), None);
        let p = plan(&b, &theta, 0.0, 50e-6);
        assert!(p.no_root);
        assert_eq!(p.n_steps, 0);
        assert!((p.fraction - 0.3).abs() < 1e-12);
    }
}
