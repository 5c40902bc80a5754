//! The optical path disturbances the delay line must follow (docs/delay-line.md §2), each
//! seeded, each a function of time sampled by the loop.
//!
//! * [`Piston`], the atmosphere's differential piston on the ground: a broken power law in
//!   frequency with the slopes of Kolmogorov turbulence seen by two apertures `D` apart by
//!   `B` in a wind `v`: `f^{−2/3}` below `0.2 v/B`, `f^{−8/3}` up to `0.3 v/D`, `f^{−17/3}`
//!   above (Conan, Rousset & Madec 1995, JOSA A 12, 1559), scaled to a given RMS over the
//!   simulated band, since the low-frequency end (and so the RMS) is set by the outer
//!   scale of the site.
//! * [`Lines`], vibration lines of a spacecraft (reaction wheels, cryocoolers): sinusoids of
//!   given frequency and amplitude, seeded phases (the harmonics of a wheel are the model of
//!   Masterson, Miller & Grogan 2002, J. Sound Vib. 249, 575).
//! * [`GaussMarkov`], a first-order (exponentially correlated) error: the ground cart's
//!   tracking error.
//!
//! A random process of a given one-sided PSD `S(f)` is drawn as a sum of cosines at `n`
//! log-spaced frequencies `f_i` with amplitudes `√(2 S(f_i) Δf_i)` and seeded phases
//! (the spectral representation of Shinozuka & Deodatis 1991, Appl. Mech. Rev. 44, 191).

use std::f64::consts::PI;

use crate::random::Gaussian;

/// A sum of cosines: the sampled form of every disturbance here.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Lines {
    /// (frequency Hz, amplitude m, phase rad)
    lines: Vec<(f64, f64, f64)>,
}

impl Lines {
    /// Lines of `(frequency, amplitude)`, their phases drawn from `seed`.
    pub fn new(lines: &[(f64, f64)], seed: u64) -> Lines {
        let mut u = Gaussian::new(seed);
        let lines = lines
            .iter()
            .map(|&(f, a)| {
                // The angle of an isotropic 2-D Gaussian: a phase uniform on (−π, π].
                let (y, x) = (u.sample(), u.sample());
                (f, a, y.atan2(x))
            })
            .collect();
        Lines { lines }
    }

    /// The process of one-sided PSD `psd` (m²/Hz) over `[f_lo, f_hi]` Hz, `n` lines.
    pub fn from_psd(psd: impl Fn(f64) -> f64, f_lo: f64, f_hi: f64, n: usize, seed: u64) -> Lines {
        let ratio = (f_hi / f_lo).powf(1.0 / n as f64);
        let lines: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let (lo, hi) = (f_lo * ratio.powi(i as i32), f_lo * ratio.powi(i as i32 + 1));
                let f = (lo * hi).sqrt();
                (f, (2.0 * psd(f) * (hi - lo)).sqrt())
            })
            .collect();
        Lines::new(&lines, seed)
    }

    /// The value at `t` s (m).
    pub fn at(&self, t: f64) -> f64 {
        self.lines.iter().map(|&(f, a, ph)| a * (2.0 * PI * f * t + ph).cos()).sum()
    }

    /// The RMS the lines have over a long time: `√(Σ a²/2)`.
    pub fn rms(&self) -> f64 {
        (self.lines.iter().map(|&(_, a, _)| a * a / 2.0).sum::<f64>()).sqrt()
    }

    /// The lines scaled to the RMS `rms`.
    pub fn scaled_to(mut self, rms: f64) -> Lines {
        let k = if self.rms() > 0.0 { rms / self.rms() } else { 0.0 };
        for l in &mut self.lines {
            l.1 *= k;
        }
        self
    }
}

/// The atmosphere's differential piston between two apertures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PistonSpectrum {
    /// Baseline (m).
    pub baseline: f64,
    /// Aperture diameter (m).
    pub aperture: f64,
    /// Wind speed (m/s).
    pub wind: f64,
}

impl PistonSpectrum {
    /// The PSD's shape at `f` Hz (continuous at both corners; its scale is set by the RMS).
    pub fn shape(&self, f: f64) -> f64 {
        let f1 = 0.2 * self.wind / self.baseline;
        let f2 = (0.3 * self.wind / self.aperture).max(f1);
        if f < f1 {
            (f / f1).powf(-2.0 / 3.0)
        } else if f < f2 {
            (f / f1).powf(-8.0 / 3.0)
        } else {
            (f2 / f1).powf(-8.0 / 3.0) * (f / f2).powf(-17.0 / 3.0)
        }
    }

    /// Seeded piston of `rms` (m) over `[f_lo, f_hi]` Hz.
    pub fn draw(&self, rms: f64, f_lo: f64, f_hi: f64, seed: u64) -> Lines {
        Lines::from_psd(|f| self.shape(f), f_lo, f_hi, 400, seed).scaled_to(rms)
    }
}

/// A first-order Gauss–Markov error of standard deviation `sigma` and correlation time
/// `tau`, sampled every `h`: `e ← a e + σ√(1 − a²) n`, `a = e^{−h/τ}`.
#[derive(Clone, Debug)]
pub struct GaussMarkov {
    a: f64,
    b: f64,
    value: f64,
    noise: Gaussian,
}

impl GaussMarkov {
    pub fn new(sigma: f64, tau: f64, h: f64, seed: u64) -> GaussMarkov {
        let a = (-h / tau).exp();
        let mut noise = Gaussian::new(seed);
        let value = sigma * noise.sample();
        GaussMarkov { a, b: sigma * (1.0 - a * a).sqrt(), value, noise }
    }

    /// The current value (m).
    pub fn value(&self) -> f64 {
        self.value
    }

    /// Advance by one sample.
    pub fn step(&mut self) -> f64 {
        self.value = self.a * self.value + self.b * self.noise.sample();
        self.value
    }

    pub(crate) fn save_state(&self, w: &mut inchworm_state_bytes::Writer) {
        w.f64(self.value);
        self.noise.save_state(w);
    }

    pub(crate) fn load_state(
        &mut self,
        r: &mut inchworm_state_bytes::Reader,
    ) -> Result<(), String> {
        self.value = crate::optics::finite(r.f64()?)?;
        self.noise.load_state(r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fringes::rms;

    #[test]
    fn a_drawn_piston_has_its_rms_and_slopes() {
        let s = PistonSpectrum { baseline: 10.0, aperture: 1.0, wind: 10.0 };
        // Corners at 0.2 Hz and 3 Hz: the slopes between.
        let slope = |a: f64, b: f64| (s.shape(b) / s.shape(a)).ln() / (b / a).ln();
        assert!((slope(0.01, 0.1) + 2.0 / 3.0).abs() < 1e-12);
        assert!((slope(0.5, 2.0) + 8.0 / 3.0).abs() < 1e-12);
        assert!((slope(10.0, 100.0) + 17.0 / 3.0).abs() < 1e-12);
        let p = s.draw(5e-6, 0.01, 250.0, 3);
        assert!((p.rms() - 5e-6).abs() < 1e-18);
        // Sampled over 200 s (the slowest line's two periods) the series has about its RMS.
        let x: Vec<f64> = (0..100_000).map(|k| p.at(k as f64 * 2e-3)).collect();
        let r = rms(&x);
        assert!((r - 5e-6).abs() / 5e-6 < 0.25, "{r:e}");
    }

    #[test]
    fn gauss_markov_has_its_sigma() {
        let mut g = GaussMarkov::new(1e-6, 0.5, 2e-3, 9);
        let x: Vec<f64> = (0..500_000).map(|_| g.step()).collect();
        let r = rms(&x);
        assert!((r - 1e-6).abs() / 1e-6 < 0.05, "{r:e}");
    }

    #[test]
    fn the_same_seed_replays_and_another_does_not() {
        let a = Lines::new(&[(1.0, 1.0), (3.0, 0.5)], 1);
        assert_eq!(a, Lines::new(&[(1.0, 1.0), (3.0, 0.5)], 1));
        assert_ne!(a, Lines::new(&[(1.0, 1.0), (3.0, 0.5)], 2));
    }
}
