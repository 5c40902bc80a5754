//! Everything of the delay line but the inchworm (docs/delay-line.md §3): the sky and its
//! disturbances, the cart, the fringe tracker, the fine stage and the offload, stepped once
//! a 2 ms sample around the runner's position. [`crate::system::run`] closes it around the
//! plant and controller crates; the `InchwormDelayLine` FMU around their FMUs.
//!
//! Sample `k`, at `t_k = k h`, given the runner's position `r_k`:
//! 1. the residual `x_k = path(t_k) − cart_k − 2 r_k − fine_k` is what the tracker
//!    measures (no fringes: the fine stage and the offload hold);
//! 2. the fine stage steps on the estimate to `fine_(k+1)`, whose position is offloaded to
//!    the inchworm's reference by an integrator of time constant `offload_time` (without a
//!    fine stage the estimate itself is integrated);
//! 3. the cart (ground) moves on to the sidereal delay at `t_(k+2)`, rate-limited, its
//!    error on top: the inchworm's reference for the tick at `t_(k+1)` is where the path
//!    will be at the end of that tick's sample, `(model(t_(k+2)) − cart_(k+2) + offload)/2`
//!    (the cat's eye doubles the path; the model and the cart's metrology are known ahead).

use inchworm_controller::SAMPLE_PERIOD;
use inchworm_state_bytes::{Reader, Writer};

use crate::disturbance::{GaussMarkov, Lines, PistonSpectrum};
use crate::fine_stage::FineStage;
use crate::fringes::{H_BAND, N_BAND};
use crate::geometry::Sidereal;
use crate::system::{DelayLineParams, Error};
use crate::tracker::{FringeTracker, Reading};

/// What one sample saw, at `time` (s since the start): optical paths (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub time: f64,
    /// The path to add: the sidereal delay (or the move) and the disturbances.
    pub path: f64,
    pub cart: f64,
    pub fine: f64,
    /// `path − cart − 2 runner − fine`.
    pub residual: f64,
    /// The tracker saw fringes in this sample.
    pub locked: bool,
}

/// The path's disturbance, by regime.
#[derive(Clone, Debug)]
enum Disturbance {
    None,
    Lines(Lines),
}

/// The delay line's optics and their state.
#[derive(Clone, Debug)]
pub struct Optics {
    p: DelayLineParams,
    sky: Sidereal,
    /// The hour angle (rad) and the sidereal delay (m) at the start.
    h0: f64,
    d0: f64,
    disturbance: Disturbance,
    cart_error: GaussMarkov,
    tracker: FringeTracker,
    fine: FineStage,
    /// Samples done.
    k: u64,
    /// The cart's rate-limited command and its optical path, now (`t_k`) and a sample
    /// ahead (`t_(k+1)`).
    cart_cmd: f64,
    cart: [f64; 2],
    offload: f64,
}

/// Reaction-wheel-like lines in space: a wheel's fundamental and harmonics, a cryocooler
/// (Hz, relative amplitude).
const SPACE_LINES: [(f64, f64); 5] = [(0.7, 1.0), (1.4, 0.5), (2.1, 0.3), (7.3, 0.4), (40.0, 0.2)];

impl Optics {
    /// The optics of `p` at the start, sample 0: parameters checked, the star above the
    /// horizon, the cart a sample ahead.
    pub fn new(p: &DelayLineParams) -> Result<Optics, Error> {
        if let Some((name, why)) = inchworm_declare::out_of_range(p) {
            return Err(Error::Range { name, why });
        }
        let h = SAMPLE_PERIOD;
        let sky = Sidereal::new(
            p.baseline_length,
            p.baseline_azimuth,
            p.baseline_elevation,
            p.latitude,
            p.declination,
        )?;
        let h0 = p.hour_angle.to_radians();
        sky.visible(h0)?;
        let d0 = sky.delay(h0);
        let disturbance = match (p.disturbances, p.space) {
            (false, _) => Disturbance::None,
            (true, false) => Disturbance::Lines(
                PistonSpectrum {
                    baseline: p.baseline_length,
                    aperture: p.aperture,
                    wind: p.wind_speed,
                }
                .draw(p.piston, 0.01, 250.0, p.seed),
            ),
            (true, true) => {
                Disturbance::Lines(Lines::new(&SPACE_LINES, p.seed).scaled_to(p.vibration))
            }
        };
        let mut o = Optics {
            p: p.clone(),
            sky,
            h0,
            d0,
            disturbance,
            cart_error: GaussMarkov::new(p.cart_error, p.cart_error_time, h, p.seed ^ 0x5eed),
            tracker: FringeTracker::new(p.tracker)?,
            fine: FineStage::new(p.fine, h)?,
            k: 0,
            cart_cmd: 0.0,
            cart: [0.0; 2],
            offload: 0.0,
        };
        o.cart[1] = o.advance_cart(h);
        Ok(o)
    }

    /// The parameters.
    pub fn params(&self) -> &DelayLineParams {
        &self.p
    }

    /// Samples done: the next is at `k h`.
    pub fn samples(&self) -> u64 {
        self.k
    }

    /// The sidereal delay since the start (m), `t` s after it.
    pub fn sidereal(&self, t: f64) -> f64 {
        self.sky.delay(Sidereal::hour_angle(self.h0, t)) - self.d0
    }

    /// The sidereal rate (m/s) `t` s after the start; 0 in space.
    pub fn sidereal_rate(&self, t: f64) -> f64 {
        if self.p.space {
            0.0
        } else {
            self.sky.rate(Sidereal::hour_angle(self.h0, t))
        }
    }

    /// The path's known model: the sidereal delay on the ground, the move in space.
    fn model(&self, t: f64) -> f64 {
        if self.p.space {
            self.p.retarget
        } else {
            self.sidereal(t)
        }
    }

    /// The path to add `t` s after the start. The drift (space) is deterministic and
    /// unknown to the model: it is not switched with the random disturbances, a
    /// drift_rate of 0 turns it off.
    pub fn path(&self, t: f64) -> f64 {
        let drift = if self.p.space { self.p.drift_rate * t } else { 0.0 };
        let d = match &self.disturbance {
            Disturbance::None => 0.0,
            Disturbance::Lines(lines) => lines.at(t),
        };
        self.model(t) + drift + d
    }

    /// The cart's path at `t1`, one sample on: it follows the sidereal delay (ground, where
    /// there is one), rate-limited, its error on top.
    fn advance_cart(&mut self, t1: f64) -> f64 {
        if self.p.space || !self.p.cart {
            return 0.0;
        }
        let step = self.p.cart_rate_limit * SAMPLE_PERIOD;
        self.cart_cmd += (self.sidereal(t1) - self.cart_cmd).clamp(-step, step);
        if self.p.disturbances {
            self.cart_error.step();
            self.cart_cmd + self.cart_error.value()
        } else {
            self.cart_cmd
        }
    }

    /// The inchworm's reference for the controller's tick at `t_k` (m of runner).
    pub fn reference(&self) -> f64 {
        let t1 = (self.k + 1) as f64 * SAMPLE_PERIOD;
        let known = if self.p.feedforward { self.model(t1) } else { 0.0 };
        (known - self.cart[1] + self.offload) / 2.0
    }

    /// The residual the runner at `runner` leaves now, without measuring it.
    pub fn residual(&self, runner: f64) -> f64 {
        let t = self.k as f64 * SAMPLE_PERIOD;
        self.path(t) - self.cart[0] - 2.0 * runner - self.fine.position()
    }

    /// Sample `k` with the runner at `runner` (m): the tracker measures the residual, the
    /// fine stage and the offload step on its estimate, the cart moves on.
    pub fn sample(&mut self, runner: f64) -> Sample {
        let h = SAMPLE_PERIOD;
        let t = self.k as f64 * h;
        let residual = self.residual(runner);
        let seen = Sample {
            time: t,
            path: self.path(t),
            cart: self.cart[0],
            fine: if self.p.fine.enabled { self.fine.position() } else { 0.0 },
            residual,
            locked: false,
        };
        let estimate = match self.tracker.measure(residual) {
            Reading::Locked(e) => Some(e),
            Reading::Lost => None,
        };
        if self.p.fine.enabled {
            self.fine.step(estimate);
            if estimate.is_some() {
                self.offload += h / self.p.offload_time * self.fine.position();
            }
        } else if let Some(e) = estimate {
            self.offload += h / self.p.offload_time * e;
        }
        self.k += 1;
        let next = self.advance_cart((self.k + 1) as f64 * h);
        self.cart = [self.cart[1], next];
        Sample { locked: estimate.is_some(), ..seen }
    }

    /// Samples at which the fine stage's command hit its range.
    pub fn fine_saturated(&self) -> u32 {
        self.fine.saturated()
    }

    /// Everything beyond the parameters needed to continue bit for bit.
    pub fn save_state(&self, w: &mut Writer) {
        w.u64(self.k);
        for v in [self.cart_cmd, self.cart[0], self.cart[1], self.offload] {
            w.f64(v);
        }
        self.cart_error.save_state(w);
        self.tracker.save_state(w);
        self.fine.save_state(w);
    }

    /// Restores what [`Optics::save_state`] wrote into optics of the same parameters.
    pub fn load_state(&mut self, r: &mut Reader) -> Result<(), String> {
        let k = r.u64()?;
        if k > MAX_SAMPLES {
            return Err(format!("delay line state: sample {k} beyond {MAX_SAMPLES}"));
        }
        self.k = k;
        let mut v = [0.0; 4];
        for x in &mut v {
            *x = finite(r.f64()?)?;
        }
        [self.cart_cmd, self.cart[0], self.cart[1], self.offload] = v;
        self.cart_error.load_state(r)?;
        self.tracker.load_state(r)?;
        self.fine.load_state(r)
    }
}

/// The most samples a run holds: 1e5 s of 2 ms samples.
pub const MAX_SAMPLES: u64 = 50_000_000;

/// `v` if it is finite.
pub(crate) fn finite(v: f64) -> Result<f64, String> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("delay line state: a value of {v}"))
    }
}

/// Accumulates the fringes of a science frame: the mean phasor `e^{2πix/λ}` at 1.65 µm and
/// 10 µm of its samples (`fringes::visibility_of` summed as they come).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Frame {
    sums: [f64; 4],
    n: u32,
}

impl Frame {
    pub fn add(&mut self, x: f64) {
        let tau = 2.0 * std::f64::consts::PI;
        let (sh, ch) = (tau * x / H_BAND).sin_cos();
        let (sn, cn) = (tau * x / N_BAND).sin_cos();
        for (s, v) in self.sums.iter_mut().zip([ch, sh, cn, sn]) {
            *s += v;
        }
        self.n += 1;
    }

    pub fn len(&self) -> u32 {
        self.n
    }

    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The frame's visibility at 1.65 µm and at 10 µm (NaN for an empty frame).
    pub fn visibility(&self) -> [f64; 2] {
        let n = f64::from(self.n);
        let [a, b, c, d] = self.sums;
        [(a * a + b * b).sqrt() / n, (c * c + d * d).sqrt() / n]
    }

    /// The frame's mean null depth at 10 µm, `mean((1 − cos φ)/2)` (NaN for an empty
    /// frame).
    pub fn null_depth(&self) -> f64 {
        (1.0 - self.sums[2] / f64::from(self.n)) / 2.0
    }

    pub fn save_state(&self, w: &mut Writer) {
        self.sums.iter().for_each(|s| w.f64(*s));
        w.u64(u64::from(self.n));
    }

    pub fn load_state(&mut self, r: &mut Reader) -> Result<(), String> {
        for s in &mut self.sums {
            *s = finite(r.f64()?)?;
        }
        self.n = u32::try_from(r.u64()?).map_err(|_| "delay line state: frame length")?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A saved state restored into fresh optics of the same parameters continues to the
    /// same bits; a state cut short or with a non-finite value is refused.
    #[test]
    fn a_saved_state_continues_bit_for_bit() {
        let p = DelayLineParams::default();
        let mut a = Optics::new(&p).unwrap();
        for k in 0..500 {
            a.sample(1e-9 * k as f64);
        }
        let mut bytes = Vec::new();
        a.save_state(&mut Writer(&mut bytes));
        let mut b = Optics::new(&p).unwrap();
        let mut r = Reader::new(&bytes, "delay line state");
        b.load_state(&mut r).unwrap();
        r.finish().unwrap();
        for k in 500..1000 {
            let runner = 1e-9 * k as f64;
            assert_eq!(a.reference(), b.reference());
            assert_eq!(a.sample(runner), b.sample(runner));
        }
        let mut c = Optics::new(&p).unwrap();
        assert!(c.load_state(&mut Reader::new(&bytes[..bytes.len() - 1], "s")).is_err());
        let mut bad = bytes.clone();
        bad[8..16].copy_from_slice(&f64::NAN.to_le_bytes());
        assert!(c.load_state(&mut Reader::new(&bad, "s")).unwrap_err().contains("NaN"));
    }

    #[test]
    fn a_frame_sums_the_visibility_of_its_samples() {
        let x: Vec<f64> = (0..25).map(|k| 40e-9 * (k as f64 * 0.7).sin()).collect();
        let mut f = Frame::default();
        x.iter().for_each(|&v| f.add(v));
        let [vh, vn] = f.visibility();
        assert!((vh - crate::fringes::visibility_of(&x, H_BAND)).abs() < 1e-14);
        assert!((vn - crate::fringes::visibility_of(&x, N_BAND)).abs() < 1e-14);
        assert!((f.null_depth() - crate::fringes::null_depth_of(&x, N_BAND)).abs() < 1e-14);
        assert_eq!(f.len(), 25);
    }
}
