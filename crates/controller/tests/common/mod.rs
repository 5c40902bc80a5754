//! A synthetic step plant for closed-loop tests of the controller alone: fast enough for
//! debug builds, exact enough that every number it produces can be worked out by hand.
#![allow(dead_code)]

use inchworm_controller::{basis::Basis, Controller, Params, Sample};

/// Runner motion (m) of an extension DAC voltage in DRIVE: slightly nonlinear, so that 0.3
/// of a step moves more than 0.3 × a full step (docs/model.md §2.9): `u = (20 y − 2 y²)` µm at
/// `y = V/10`, 18 µm for a full step.
pub fn extension(volts: f64) -> f64 {
    let y = volts / 10.0;
    (20.0 * y - 2.0 * y * y) * 1e-6
}

/// The true inverse scale factor `y(u)` (both directions: a backward step of amplitude
/// `a` moves `−extension(10 a)`).
pub fn true_inverse(u: f64) -> f64 {
    let um = u.abs() * 1e6;
    let y = (20.0 - (400.0 - 8.0 * um).sqrt()) / 4.0;
    y.copysign(u)
}

/// Weights of the true inverse scale factor at the basis peaks.
pub fn true_weights(basis: &Basis) -> [f64; 10] {
    basis.peaks.map(true_inverse)
}

/// Brake logic without the analog chain: the earth brake opens at 5 V on its DAC (50 V
/// after the ×10 amplifier), the non-earth brake closes at 5 V. In DRIVE the runner
/// follows the extension; entering DRIVE it jumps by the brake disturbance.
#[derive(Clone)]
pub struct StepPlant {
    pub runner: f64,
    pub disturbance: f64,
    pub q_enc: f64,
    ext: f64,
    drive: bool,
}

impl StepPlant {
    pub fn new(disturbance: f64) -> StepPlant {
        StepPlant { runner: 0.0, disturbance, q_enc: 1.2e-9, ext: 0.0, drive: false }
    }

    pub fn counts(&self) -> i64 {
        (self.runner / self.q_enc).round() as i64
    }

    /// Holds `dac` for one interval; returns the encoder count at its end.
    pub fn interval(&mut self, dac: [f64; 3]) -> i64 {
        let earth_closed = dac[0] < 5.0;
        let nonearth_closed = dac[1] >= 5.0;
        assert!(earth_closed || nonearth_closed, "both brakes open (FREE) with DAC {dac:?}");
        let drive = !earth_closed && nonearth_closed;
        if drive && !self.drive {
            self.runner += self.disturbance;
        }
        let ext = extension(dac[2]);
        if drive {
            self.runner += ext - self.ext;
        }
        self.ext = ext;
        self.drive = drive;
        self.counts()
    }
}

/// One recorded tick.
pub struct Record {
    pub time: f64,
    pub reference: f64,
    /// Encoder position received by this tick (m).
    pub position: f64,
    pub out: Sample,
}

/// Jacobi coupling at 2 ms: at each communication point both sides get the other's
/// outputs of the previous point; the controller's answer is held one interval later.
pub fn run(
    p: Params,
    plant: &mut StepPlant,
    reference: impl Fn(f64) -> f64,
    seconds: f64,
) -> Vec<Record> {
    let mut c = Controller::new(p).expect("valid parameters");
    let mut dac = [0.0; 3];
    let mut counts = plant.counts();
    let ticks = (seconds / 0.002).round() as usize;
    let mut out = Vec::with_capacity(ticks);
    for j in 0..ticks {
        let time = j as f64 * 0.002;
        let r = reference(time);
        let s = c.tick(counts, r);
        out.push(Record { time, reference: r, position: counts as f64 * plant.q_enc, out: s });
        counts = plant.interval(dac);
        dac = s.dac;
    }
    out
}

/// The parked readings: ticks at step boundaries (tick m of every step), where the
/// encoder holds `w_enc(n)` after samples n and 1 of the gait, both all zeros.
pub fn parked(tr: &[Record], samples_per_step: usize) -> impl Iterator<Item = &Record> {
    tr.iter().step_by(samples_per_step)
}

/// First time after which every parked error stays within `tol`.
pub fn settle_time(tr: &[Record], samples_per_step: usize, tol: f64) -> Option<f64> {
    let boundary: Vec<&Record> = parked(tr, samples_per_step).collect();
    let last_bad = boundary.iter().rposition(|r| (r.reference - r.position).abs() > tol);
    match last_bad {
        None => Some(0.0),
        Some(i) if i + 1 < boundary.len() => Some(boundary[i + 1].time),
        Some(_) => None,
    }
}
