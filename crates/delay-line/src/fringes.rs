//! What a residual optical path does to the fringes (docs/delay-line.md §4): a residual
//! of standard deviation `σ` over an exposure blurs them to the visibility
//! `V = V₀ exp(−2π²σ²/λ²)` (the phase `φ = 2πx/λ` Gaussian: `|⟨e^{iφ}⟩| = e^{−σ_φ²/2}`),
//! and leaves a two-beam nuller the null depth `N ≈ π²σ²/λ²` (`⟨(1 − cos φ)/2⟩ ≈ σ_φ²/4`
//! for `σ_φ ≪ 1`; Serabyn 2000, Proc. SPIE 4006, 328). The estimators below reduce a
//! recorded residual the same way, so a run's figures and the formulas can be compared.

use std::f64::consts::PI;

/// The science wavelengths the results are given at (m): H band and N band.
pub const H_BAND: f64 = 1.65e-6;
pub const N_BAND: f64 = 10e-6;

/// The visibility left of `v0` by a Gaussian residual path of `sigma` (m) at `lambda` (m).
pub fn visibility(v0: f64, sigma: f64, lambda: f64) -> f64 {
    v0 * (-2.0 * PI * PI * sigma * sigma / (lambda * lambda)).exp()
}

/// The null depth of a two-beam nuller for a residual path of `sigma` (m) at `lambda`
/// (m), to first order in `σ²` (the rest of the null's leaks, intensity mismatch and
/// polarisation, are not the delay line's).
pub fn null_depth(sigma: f64, lambda: f64) -> f64 {
    PI * PI * sigma * sigma / (lambda * lambda)
}

/// The visibility of fringes integrated over the residual paths `x` (m) at `lambda`:
/// `|mean(e^{2πix/λ})|`, fringes of unit contrast.
pub fn visibility_of(x: &[f64], lambda: f64) -> f64 {
    if x.is_empty() {
        return f64::NAN;
    }
    let (mut re, mut im) = (0.0, 0.0);
    for &p in x {
        let (s, c) = (2.0 * PI * p / lambda).sin_cos();
        re += c;
        im += s;
    }
    (re * re + im * im).sqrt() / x.len() as f64
}

/// The mean null depth over the residual paths `x` (m) at `lambda`: `mean((1 − cos φ)/2)`.
pub fn null_depth_of(x: &[f64], lambda: f64) -> f64 {
    if x.is_empty() {
        return f64::NAN;
    }
    x.iter().map(|&p| (1.0 - (2.0 * PI * p / lambda).cos()) / 2.0).sum::<f64>() / x.len() as f64
}

/// The root mean square of `x` about zero.
pub fn rms(x: &[f64]) -> f64 {
    if x.is_empty() {
        return f64::NAN;
    }
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::Gaussian;

    /// Gaussian residuals of σ, drawn with ten seeds: the visibility and the null depth
    /// measured from them equal the formulas within 1 %.
    fn mean_over_seeds(sigma: f64, f: impl Fn(&[f64]) -> f64) -> f64 {
        let seeds = 10;
        (0..seeds)
            .map(|seed| {
                let mut g = Gaussian::new(seed);
                let x: Vec<f64> = (0..20_000).map(|_| sigma * g.sample()).collect();
                f(&x)
            })
            .sum::<f64>()
            / seeds as f64
    }

    /// Gaussian residuals of σ, drawn with ten seeds: the visibility measured from them
    /// equals the formula within 1 % (it is exact for a Gaussian at any σ), the null depth
    /// too where its first-order formula holds (σ_φ ≤ 0.1 rad: its own error is σ_φ²/4).
    #[test]
    fn gaussian_residuals_give_the_formulas() {
        for (sigma, lambda) in [(40e-9, H_BAND), (150e-9, H_BAND), (300e-9, N_BAND)] {
            let v = mean_over_seeds(sigma, |x| visibility_of(x, lambda));
            let want = visibility(1.0, sigma, lambda);
            assert!(
                (v - want).abs() / want < 0.01,
                "σ = {sigma:e}, λ = {lambda:e}: V {v} vs {want}"
            );
        }
        for (sigma, lambda) in [(20e-9, H_BAND), (150e-9, N_BAND)] {
            let n = mean_over_seeds(sigma, |x| null_depth_of(x, lambda));
            let want = null_depth(sigma, lambda);
            assert!(
                (n - want).abs() / want < 0.01,
                "σ = {sigma:e}, λ = {lambda:e}: N {n:e} vs {want:e}"
            );
        }
    }

    #[test]
    fn no_residual_is_full_contrast_and_a_dark_null() {
        assert_eq!(visibility_of(&[0.0; 8], H_BAND), 1.0);
        assert_eq!(null_depth_of(&[0.0; 8], N_BAND), 0.0);
        assert!(visibility_of(&[], H_BAND).is_nan());
    }
}
