//! What moves the segments and what corrupts the edge sensors' readings, each seeded and
//! each off by default (docs/phasing.md, "Disturbances"):
//!
//! - [`SensorNoise`]: every reading's white noise, every sensor's fixed bias (drawn once)
//!   and its drift, a random walk;
//! - [`CellDeformation`]: the mirror cell's slow gravity and thermal deformation, a smooth
//!   low-order surface under the segments that grows from nothing to its full size over a
//!   ramp, compressed in time from the hours it takes on a telescope;
//! - [`Wind`]: buffeting on every segment, a first-order Gauss–Markov process per piston,
//!   tip and tilt with a given RMS and corner frequency.
//!
//! The segments' disturbances are poses added to those the actuators give: the inchworm's
//! brake holds the runner rigidly, so what moves the cell or pushes the segment moves the
//! surface with it.

use inchworm_plant::noise::gaussian;

use crate::geometry::Mirror;
use crate::{check, PhasingError};

/// The edge sensors' errors. The defaults ([`SensorNoise::published`]) are of the order of
/// the published systems: ESO's ELT edge sensors measure "with an accuracy of a few
/// nanometres" (ESO announcement ann24017, 2024), and an optical edge-sensor prototype for
/// SALT and the E-ELT moved 10 nm per °C in height (SPIE); docs/phasing.md gives the
/// reasoning.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorNoise {
    /// Every reading's white noise (m RMS).
    pub white: f64,
    /// Every sensor's bias, drawn once per run (m RMS over the sensors).
    pub bias: f64,
    /// Every sensor's drift, a random walk (m per √s).
    pub drift: f64,
    pub seed: u64,
}

impl SensorNoise {
    /// No noise, bias or drift.
    pub const OFF: SensorNoise = SensorNoise { white: 0.0, bias: 0.0, drift: 0.0, seed: 0 };

    /// 1 nm RMS white per reading, 2 nm RMS bias and a drift of 10 nm over 8 hours
    /// (1e-8 / √28 800 m/√s), seed 1.
    pub fn published() -> SensorNoise {
        SensorNoise { white: 1e-9, bias: 2e-9, drift: 1e-8 / 28_800f64.sqrt(), seed: 1 }
    }

    /// Each at least 0 and at most 1 µm (per √s for the drift).
    pub fn new(white: f64, bias: f64, drift: f64, seed: u64) -> Result<SensorNoise, PhasingError> {
        Ok(SensorNoise {
            white: check("sensor_noise", white, 0.0, 1e-6, "m")?,
            bias: check("sensor_bias", bias, 0.0, 1e-6, "m")?,
            drift: check("sensor_drift", drift, 0.0, 1e-6, "m/√s")?,
            seed,
        })
    }
}

/// The errors of a set of sensors through a run: the biases drawn, the drifts so far.
#[derive(Clone, Debug)]
pub struct SensorErrors {
    noise: SensorNoise,
    bias: Vec<f64>,
    drift: Vec<f64>,
    state: u64,
}

impl SensorErrors {
    pub fn new(noise: SensorNoise, sensors: usize) -> SensorErrors {
        let mut state = noise.seed;
        let bias = (0..sensors).map(|_| noise.bias * gaussian(&mut state)).collect();
        SensorErrors { noise, bias, drift: vec![0.0; sensors], state }
    }

    /// Moves the drifts on by `dt` seconds.
    pub fn advance(&mut self, dt: f64) {
        if self.noise.drift > 0.0 {
            let step = self.noise.drift * dt.sqrt();
            for d in &mut self.drift {
                *d += step * gaussian(&mut self.state);
            }
        }
    }

    /// Adds every sensor's bias, drift and a fresh white-noise draw to `readings`.
    pub fn corrupt(&mut self, readings: &mut [f64]) {
        for ((r, b), d) in readings.iter_mut().zip(&self.bias).zip(&self.drift) {
            *r += b + d;
            if self.noise.white > 0.0 {
                *r += self.noise.white * gaussian(&mut self.state);
            }
        }
    }
}

/// The cell's deformation: a seeded combination of the mirror's low-order surface modes
/// (focus, astigmatism, coma and trefoil over the mirror's radius), sampled at every
/// segment as its piston and its tip and tilt (the surface's value and slopes at the
/// segment's centre), scaled so that the co-phasing error it leaves uncorrected (the
/// segments' surface RMS, the whole mirror's piston, tip and tilt removed) is `amplitude`
/// when full. It grows as `(1 − cos(π t / ramp)) / 2` and stays full after `ramp`: a
/// night's micrometres of gravity and thermal sag in seconds, which the local loops follow
/// as they would the slow original, their bandwidth being far above `1 / ramp`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CellDeformation {
    /// The co-phasing error when full (m RMS).
    pub amplitude: f64,
    /// From nothing to full (s).
    pub ramp: f64,
    pub seed: u64,
}

impl CellDeformation {
    /// 0 to 100 µm, over 0.01 s to 10⁵ s.
    pub fn new(amplitude: f64, ramp: f64, seed: u64) -> Result<CellDeformation, PhasingError> {
        Ok(CellDeformation {
            amplitude: check("cell_amplitude", amplitude, 0.0, 1e-4, "m")?,
            ramp: check("cell_ramp", ramp, 0.01, 1e5, "s")?,
            seed,
        })
    }

    /// Every segment's pose when full, `[piston, tip, tilt]`.
    pub fn shape(&self, mirror: &Mirror) -> Vec<[f64; 3]> {
        let mut state = self.seed ^ 0xCE11;
        let coefficients: [f64; 7] = std::array::from_fn(|_| gaussian(&mut state));
        let radius = mirror
            .centres()
            .iter()
            .map(|c| c[0].hypot(c[1]))
            .fold(0.0, f64::max)
            .max(mirror.pitch());
        let poses: Vec<[f64; 3]> = mirror
            .centres()
            .iter()
            .map(|c| {
                let (x, y) = (c[0] / radius, c[1] / radius);
                let (z, dzdx, dzdy) = low_order(&coefficients, x, y);
                [z, dzdy / radius, dzdx / radius]
            })
            .collect();
        let rms = crate::cophasing::cophasing_rms(mirror, &poses);
        let scale = if rms > 0.0 { self.amplitude / rms } else { 0.0 };
        poses.iter().map(|p| p.map(|v| v * scale)).collect()
    }

    /// The fraction of the full deformation at `t`.
    pub fn growth(&self, t: f64) -> f64 {
        if t >= self.ramp {
            1.0
        } else {
            0.5 * (1.0 - (std::f64::consts::PI * t / self.ramp).cos())
        }
    }
}

/// The surface `Σ c_j M_j(x, y)` of focus `2r² − 1`, astigmatism `x² − y²` and `2xy`, coma
/// `(3r² − 2) x` and `(3r² − 2) y`, trefoil `x³ − 3xy²` and `3x²y − y³`, with its two
/// slopes.
fn low_order(c: &[f64; 7], x: f64, y: f64) -> (f64, f64, f64) {
    let r2 = x * x + y * y;
    let modes = [
        (2.0 * r2 - 1.0, 4.0 * x, 4.0 * y),
        (x * x - y * y, 2.0 * x, -2.0 * y),
        (2.0 * x * y, 2.0 * y, 2.0 * x),
        ((3.0 * r2 - 2.0) * x, 9.0 * x * x + 3.0 * y * y - 2.0, 6.0 * x * y),
        ((3.0 * r2 - 2.0) * y, 6.0 * x * y, 3.0 * x * x + 9.0 * y * y - 2.0),
        (x * x * x - 3.0 * x * y * y, 3.0 * x * x - 3.0 * y * y, -6.0 * x * y),
        (3.0 * x * x * y - y * y * y, 6.0 * x * y, 3.0 * x * x - 3.0 * y * y),
    ];
    modes
        .iter()
        .zip(c)
        .fold((0.0, 0.0, 0.0), |(z, gx, gy), (m, k)| (z + k * m.0, gx + k * m.1, gy + k * m.2))
}

/// Wind buffeting: every segment's piston, tip and tilt each a first-order Gauss–Markov
/// process, `x ← a x + √(1 − a²) σ ξ` with `a = exp(−2π f_c Δt)`: a Lorentzian PSD with
/// corner `corner` and RMS `piston` (m) and `angle` (rad). docs/phasing.md says why these
/// defaults ([`Wind::published`]) and that a measured site spectrum would replace the shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wind {
    pub piston: f64,
    pub angle: f64,
    pub corner: f64,
    pub seed: u64,
}

impl Wind {
    /// 5 nm RMS piston, 20 nrad RMS tip and tilt, 1 Hz corner, seed 2.
    pub fn published() -> Wind {
        Wind { piston: 5e-9, angle: 20e-9, corner: 1.0, seed: 2 }
    }

    /// Piston 0 to 10 µm, angles 0 to 10 µrad, corner 0.001 to 100 Hz.
    pub fn new(piston: f64, angle: f64, corner: f64, seed: u64) -> Result<Wind, PhasingError> {
        Ok(Wind {
            piston: check("wind_piston", piston, 0.0, 1e-5, "m")?,
            angle: check("wind_angle", angle, 0.0, 1e-5, "rad")?,
            corner: check("wind_corner", corner, 1e-3, 100.0, "Hz")?,
            seed,
        })
    }
}

/// The segments' wind poses through a run, from the stationary distribution at `t = 0`.
#[derive(Clone, Debug)]
pub struct Buffeting {
    wind: Wind,
    poses: Vec<[f64; 3]>,
    state: u64,
}

impl Buffeting {
    pub fn new(wind: Wind, segments: usize) -> Buffeting {
        let mut state = wind.seed ^ 0x5EED;
        let sigma = [wind.piston, wind.angle, wind.angle];
        let poses = (0..segments)
            .map(|_| std::array::from_fn(|j| sigma[j] * gaussian(&mut state)))
            .collect();
        Buffeting { wind, poses, state }
    }

    pub fn poses(&self) -> &[[f64; 3]] {
        &self.poses
    }

    /// Moves every pose on by `dt` seconds.
    pub fn advance(&mut self, dt: f64) {
        let a = (-2.0 * std::f64::consts::PI * self.wind.corner * dt).exp();
        let b = (1.0 - a * a).sqrt();
        let sigma = [self.wind.piston, self.wind.angle, self.wind.angle];
        for p in &mut self.poses {
            for j in 0..3 {
                p[j] = a * p[j] + b * sigma[j] * gaussian(&mut self.state);
            }
        }
    }
}

/// Everything that disturbs a run; [`Disturbances::OFF`] by default.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Disturbances {
    pub sensors: Option<SensorNoise>,
    pub cell: Option<CellDeformation>,
    pub wind: Option<Wind>,
}

impl Disturbances {
    pub const OFF: Disturbances = Disturbances { sensors: None, cell: None, wind: None };
}
