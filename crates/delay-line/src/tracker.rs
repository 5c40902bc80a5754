//! The fringe tracker (docs/delay-line.md §3): once a sample it measures the residual
//! optical path `x` of the two beams as a fringe phase, wrapped to one wavelength, and as a
//! group delay, coarse but unambiguous, which unwraps the phase.
//!
//! * The phase `φ = 2πx/λ + n_φ` is seen modulo 2π. Its photon noise is that of a
//!   four-bin (ABCD) estimator, `σ_φ² = 2/(N V²)` for `N` photons a sample and fringes of
//!   visibility `V` (Shao et al. 1988, A&A 193, 357; Colavita 1999, PASP 111, 111).
//! * The group delay, from the phase's slope across the band `Δλ`, has the noise of the
//!   phase scaled from a wavelength to a coherence length: `σ_g = σ_φ (λ²/Δλ)/2π` (a
//!   model choice: the envelope is `λ/Δλ` times wider than a fringe).
//! * The unwrapped estimate is the phase's path plus the whole wavelengths the group delay
//!   says: `x̂ = λφ/2π + λ round((g − λφ/2π)/λ)`.
//! * Beyond half a coherence length `λ²/Δλ` there are no fringes to see: the tracker has
//!   lost lock and gives no estimate (the loop holds its commands).

use std::f64::consts::PI;

use inchworm_declare::{Declare, Declared};

use crate::random::Gaussian;

/// The fringe tracker's band and photon budget, each declared once on its field.
#[derive(Clone, Copy, Debug, PartialEq, Declare)]
pub struct TrackerParams {
    /// Central wavelength of the fringe tracker's band (H band)
    #[var(name = "tracker_wavelength", unit = "m", start = 1.65e-6, min = 1e-7, max = 1e-4)]
    pub wavelength: f64,
    /// Width of the fringe tracker's band
    #[var(name = "tracker_bandwidth", unit = "m", start = 0.3e-6, min = 1e-9, max = 1e-4)]
    pub bandwidth: f64,
    /// Photons a fringe-tracker sample, both beams (a bright star in 2 ms)
    #[var(name = "tracker_photons", start = 1.0e4, min = 1.0, max = 1e12)]
    pub photons: f64,
    /// Fringe visibility the tracker sees with no residual
    #[var(name = "tracker_visibility", start = 0.8, min = 1e-3, max = 1.0)]
    pub visibility: f64,
    /// Photon noise on the tracker's phase and group delay (off: an ideal sensor)
    #[var(name = "tracker_noise", start = true)]
    pub noise: bool,
    /// Seed of the tracker's noise
    #[var(name = "tracker_seed", start = 7)]
    pub seed: u64,
}

impl Default for TrackerParams {
    fn default() -> Self {
        TrackerParams::declared()
    }
}

/// What the tracker saw in one sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reading {
    /// The residual path estimate (m).
    Locked(f64),
    /// No fringes: the residual is beyond half a coherence length.
    Lost,
}

/// A tracker refused its parameters.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TrackerError {
    /// A parameter outside its declared range.
    #[error("fringe tracker: {name}: {why}")]
    Range { name: &'static str, why: String },
    #[error("fringe tracker: a band of {bandwidth} m as wide as its wavelength {wavelength} m")]
    Band { bandwidth: f64, wavelength: f64 },
}

/// The fringe tracker: its parameters and its noise streams.
#[derive(Clone, Debug)]
pub struct FringeTracker {
    p: TrackerParams,
    sigma_phase: f64,
    noise: Gaussian,
}

impl FringeTracker {
    pub fn new(p: TrackerParams) -> Result<FringeTracker, TrackerError> {
        if let Some((name, why)) = inchworm_declare::out_of_range(&p) {
            return Err(TrackerError::Range { name, why });
        }
        if p.bandwidth >= p.wavelength {
            return Err(TrackerError::Band { bandwidth: p.bandwidth, wavelength: p.wavelength });
        }
        let sigma_phase = (2.0 / (p.photons * p.visibility * p.visibility)).sqrt();
        Ok(FringeTracker { p, sigma_phase, noise: Gaussian::new(p.seed) })
    }

    /// The phase noise a sample (rad).
    pub fn phase_noise(&self) -> f64 {
        self.sigma_phase
    }

    /// The coherence length `λ²/Δλ` (m): the span of path over which fringes are seen.
    pub fn coherence_length(&self) -> f64 {
        self.p.wavelength * self.p.wavelength / self.p.bandwidth
    }

    /// The group delay's noise (m): one coherence length per radian of phase noise.
    pub fn group_delay_noise(&self) -> f64 {
        self.sigma_phase * self.coherence_length() / (2.0 * PI)
    }

    /// One sample of the residual path `x` (m).
    pub fn measure(&mut self, x: f64) -> Reading {
        if !x.is_finite() || x.abs() > self.coherence_length() / 2.0 {
            return Reading::Lost;
        }
        let lambda = self.p.wavelength;
        let (n_phase, n_group) = if self.p.noise {
            (self.sigma_phase * self.noise.sample(), self.group_delay_noise() * self.noise.sample())
        } else {
            (0.0, 0.0)
        };
        let phase = wrap(2.0 * PI * x / lambda + n_phase);
        let group = x + n_group;
        let fine = lambda * phase / (2.0 * PI);
        Reading::Locked(fine + lambda * ((group - fine) / lambda).round())
    }

    pub(crate) fn save_state(&self, w: &mut inchworm_state_bytes::Writer) {
        self.noise.save_state(w);
    }

    pub(crate) fn load_state(
        &mut self,
        r: &mut inchworm_state_bytes::Reader,
    ) -> Result<(), String> {
        self.noise.load_state(r)
    }
}

/// `φ` wrapped into (−π, π].
fn wrap(phi: f64) -> f64 {
    let w = phi - 2.0 * PI * (phi / (2.0 * PI)).round();
    if w <= -PI {
        w + 2.0 * PI
    } else {
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_ideal_tracker_unwraps_every_path_within_the_coherence_length() {
        let mut t =
            FringeTracker::new(TrackerParams { noise: false, ..Default::default() }).unwrap();
        let half = t.coherence_length() / 2.0;
        for k in -400..=400 {
            let x = k as f64 / 400.0 * half * 0.999;
            match t.measure(x) {
                Reading::Locked(e) => assert!((e - x).abs() < 1e-15, "{x:e}: {e:e}"),
                Reading::Lost => panic!("{x:e} lost"),
            }
        }
        assert_eq!(t.measure(half * 1.01), Reading::Lost);
        assert_eq!(t.measure(f64::NAN), Reading::Lost);
    }

    /// With noise, the estimate's error is the phase noise's path (`σ_φ λ/2π`) while the
    /// group delay's noise stays well below half a wavelength: no wrong fringe.
    #[test]
    fn the_noisy_estimate_has_the_phase_noise() {
        let mut t = FringeTracker::new(TrackerParams::default()).unwrap();
        let want = t.phase_noise() * 1.65e-6 / (2.0 * PI);
        assert!(t.group_delay_noise() < 1.65e-6 / 10.0);
        let x = 0.37e-6;
        let err: Vec<f64> = (0..20_000)
            .map(|_| match t.measure(x) {
                Reading::Locked(e) => e - x,
                Reading::Lost => panic!("lost"),
            })
            .collect();
        let sd = crate::fringes::rms(&err);
        assert!((sd - want).abs() / want < 0.03, "{sd:e} vs {want:e}");
    }

    #[test]
    fn bad_parameters_are_refused_by_name() {
        let e =
            FringeTracker::new(TrackerParams { photons: 0.0, ..Default::default() }).unwrap_err();
        assert!(matches!(e, TrackerError::Range { name: "tracker_photons", .. }), "{e}");
        let e = FringeTracker::new(TrackerParams { visibility: f64::NAN, ..Default::default() });
        assert!(matches!(e, Err(TrackerError::Range { name: "tracker_visibility", .. })));
        let e = FringeTracker::new(TrackerParams { bandwidth: 2e-6, ..Default::default() });
        assert!(matches!(e, Err(TrackerError::Band { .. })));
    }
}
