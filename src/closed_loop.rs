//! The closed loop with the two crates coupled directly (no FMI): plant and controller
//! exchange DAC volts and encoder counts every 2 ms as a Jacobi master would, the
//! controller's output at `t` being the sample for `[t + h, t + 2h)`.

use inchworm_controller::{Controller, Params, SAMPLE_PERIOD};
use inchworm_plant::{Dac, Plant, PlantParams};

/// One row per communication point `t_k = k h`, k ≥ 1: the plant outputs at `t_k` and the
/// DAC volts that were held during `[t_{k-1}, t_k)`.
#[derive(Clone, Debug, Default)]
pub struct Trace {
    pub time: Vec<f64>,
    pub reference: Vec<f64>,
    pub encoder_counts: Vec<i64>,
    pub runner_position: Vec<f64>,
    pub dac: Vec<[f64; 3]>,
    pub disturbance_estimate: Vec<f64>,
    pub n_steps: Vec<u32>,
    pub fraction: Vec<f64>,
    pub iterated: Vec<bool>,
    pub scale_weights: [f64; 10],
    pub q_enc: f64,
}

pub fn run(plant: PlantParams, controller: Params, reference: impl Fn(f64) -> f64, duration: f64) -> Result<Trace, String> {
    let q_enc = plant.q_enc;
    let mut plant = Plant::new(plant).map_err(|e| e.to_string())?;
    let mut ctrl = Controller::new(controller)?;
    let h = SAMPLE_PERIOD;
    let n = (duration / h).round() as usize;
    let mut tr = Trace { q_enc, ..Trace::default() };
    let mut held = [0.0; 3];
    for k in 0..n {
        let t = k as f64 * h;
        let r = reference(t);
        let s = ctrl.tick(plant.outputs().encoder_counts, r);
        plant.step(Dac { earth: held[0], nonearth: held[1], extension: held[2] }, h);
        let o = plant.outputs();
        tr.time.push((k + 1) as f64 * h);
        tr.reference.push(reference((k + 1) as f64 * h));
        tr.encoder_counts.push(o.encoder_counts);
        tr.runner_position.push(o.runner_position);
        tr.dac.push(held);
        tr.disturbance_estimate.push(s.disturbance_estimate);
        tr.n_steps.push(s.n_steps);
        tr.fraction.push(s.fraction);
        tr.iterated.push(s.iterated);
        tr.scale_weights = s.scale_weights;
        held = s.dac;
    }
    Ok(tr)
}

impl Trace {
    /// Indices of the parked samples (SPEC 4.1): all three DAC outputs zero for the
    /// previous 8 samples.
    pub fn parked(&self) -> Vec<usize> {
        (8..self.time.len()).filter(|&i| self.dac[i - 7..=i].iter().all(|d| d.iter().all(|v| *v == 0.0))).collect()
    }

    /// Position error (m) of sample `i`: reference − encoder position.
    pub fn error(&self, i: usize) -> f64 {
        self.reference[i] - self.encoder_counts[i] as f64 * self.q_enc
    }

    /// First time after which every parked sample is within `tol` of the reference.
    pub fn settle_time(&self, tol: f64) -> Option<f64> {
        let parked = self.parked();
        let last_bad = parked.iter().rposition(|&i| self.error(i).abs() > tol);
        match last_bad {
            None => parked.first().map(|&i| self.time[i]),
            Some(j) if j + 1 < parked.len() => Some(self.time[parked[j + 1]]),
            Some(_) => None,
        }
    }

    /// RMS error of the parked samples in `[from, to)` s.
    pub fn parked_rms(&self, from: f64, to: f64) -> f64 {
        let e: Vec<f64> = self.parked().into_iter().filter(|&i| self.time[i] >= from && self.time[i] < to).map(|i| self.error(i)).collect();
        (e.iter().map(|x| x * x).sum::<f64>() / e.len().max(1) as f64).sqrt()
    }
}
