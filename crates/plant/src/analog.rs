//! Driver-board analog chain of one channel (docs/model.md §2.1): a unity-gain 2nd-order Bessel
//! low-pass followed by the PZT amplifier's first-order roll-off.

use crate::params::PlantParams;

/// Bessel natural frequency `w = 2π f_b / 1.36165` (rad/s): puts the −3 dB point at `f_b`.
pub fn bessel_w(p: &PlantParams) -> f64 {
    2.0 * std::f64::consts::PI * p.f_bessel / 1.36165
}

/// Amplifier pole `2π f_a` (rad/s).
pub fn amp_pole(p: &PlantParams) -> f64 {
    2.0 * std::f64::consts::PI * p.f_amp
}

/// The 3×4 rows `d/dt [b1, b2, V] = M [b1, b2, V, u]` of one channel; `b1` is the Bessel output.
pub fn chain_rows(p: &PlantParams) -> [[f64; 4]; 3] {
    let w = bessel_w(p);
    let wa = amp_pole(p);
    [
        [0.0, 1.0, 0.0, 0.0],
        [-3.0 * w * w, -3.0 * w, 0.0, 3.0 * w * w],
        [wa * p.amp_gain, 0.0, -wa, 0.0],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// |H_b(j2πf)| = |3w² / (3w² − ω² + j 3wω)|.
    fn bessel_gain(p: &PlantParams, f: f64) -> f64 {
        let w = bessel_w(p);
        let om = 2.0 * std::f64::consts::PI * f;
        let (re, im) = (3.0 * w * w - om * om, 3.0 * w * om);
        3.0 * w * w / (re * re + im * im).sqrt()
    }

    #[test]
    fn bessel_minus_3db_at_f_b() {
        let p = PlantParams::fia20();
        let g = bessel_gain(&p, p.f_bessel);
        let db = 20.0 * g.log10();
        assert!((db + 3.0103).abs() < 0.01, "Bessel gain at f_b = {db} dB, expected -3.01 dB");
        let rows = chain_rows(&p);
        // DC: b1 = u, V = G b1.
        let (u, b1, b2, v) = (1.0, 1.0, 0.0, p.amp_gain);
        let d: Vec<f64> =
            rows.iter().map(|r| r[0] * b1 + r[1] * b2 + r[2] * v + r[3] * u).collect();
        assert!(d.iter().all(|x| x.abs() < 1e-9), "DC point is an equilibrium: {d:?}");
    }
}
