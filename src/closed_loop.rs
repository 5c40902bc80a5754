//! The closed loop with the two crates coupled directly (no FMI): plant and controller
//! exchange DAC volts and encoder counts every 2 ms as a Jacobi master would, the
//! controller's output at `t` being the sample for `[t + h, t + 2h)`.

use std::path::Path;

use inchworm_controller::{Controller, Params, SAMPLE_PERIOD};
use inchworm_plant::{Dac, Plant, PlantParams};

use crate::fmu::{CsFmu, FmuError, VarType};

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

pub fn run(
    plant: PlantParams,
    controller: Params,
    reference: impl Fn(f64) -> f64,
    duration: f64,
) -> Result<Trace, String> {
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

/// The same loop through the two FMUs (any FMI 2.0 CS master would do the same): a
/// Jacobi coupling at 2 ms, plant parameters at their fia20 defaults, the controller's
/// flags, deadband and start estimates set from `controller`.
pub fn run_fmus(
    plant_fmu: &Path,
    controller_fmu: &Path,
    plant_params: &[(String, f64)],
    controller: &Params,
    reference: impl Fn(f64) -> f64,
    duration: f64,
) -> Result<Trace, FmuError> {
    let mut plant = CsFmu::load(plant_fmu, "plant", false)?;
    let mut ctrl = CsFmu::load(controller_fmu, "controller", false)?;
    let h = SAMPLE_PERIOD;
    plant.enter_initialization(None, 0.0, None)?;
    ctrl.enter_initialization(None, 0.0, None)?;
    for (name, value) in plant_params {
        let vr = plant.vrs_of(&[name.as_str()], VarType::Real)?;
        plant.set_real(&vr, &[*value])?;
    }
    let flags = ctrl.vrs_of(
        &["feedforward", "prefilter", "use_scale_factor_estimate", "use_disturbance_estimate"],
        VarType::Boolean,
    )?;
    ctrl.set_boolean(
        &flags,
        &[
            controller.feedforward,
            controller.prefilter,
            controller.use_scale_factor_estimate,
            controller.use_disturbance_estimate,
        ],
    )?;
    let mut names = vec!["deadband".to_string(), "disturbance_start".to_string()];
    names.extend((1..=10).map(|i| format!("scale_weights_start[{i}]")));
    names.extend((1..=10).map(|i| format!("basis_peak[{i}]")));
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let vrs = ctrl.vrs_of(&names, VarType::Real)?;
    let mut values = vec![controller.deadband, controller.disturbance_start];
    values.extend(controller.scale_weights_start);
    values.extend(controller.basis_peaks);
    ctrl.set_real(&vrs, &values)?;
    plant.exit_initialization()?;
    ctrl.exit_initialization()?;

    let dac_names = ["dac_earth", "dac_nonearth", "dac_extension"];
    let plant_dac = plant.vrs_of(&dac_names, VarType::Real)?;
    let ctrl_dac = ctrl.vrs_of(&dac_names, VarType::Real)?;
    let plant_enc = plant.vrs_of(&["encoder_counts"], VarType::Integer)?;
    let plant_runner = plant.vrs_of(&["runner_position"], VarType::Real)?;
    let ctrl_enc = ctrl.vrs_of(&["encoder_counts"], VarType::Integer)?;
    let ctrl_ref = ctrl.vrs_of(&["reference"], VarType::Real)?;
    let ctrl_out = ctrl.vrs_of(&["disturbance_estimate", "fraction"], VarType::Real)?;
    let ctrl_steps = ctrl.vrs_of(&["n_steps"], VarType::Integer)?;
    let weight_names: Vec<String> = (1..=10).map(|i| format!("scale_weights[{i}]")).collect();
    let weight_names: Vec<&str> = weight_names.iter().map(String::as_str).collect();
    let ctrl_weights = ctrl.vrs_of(&weight_names, VarType::Real)?;

    let n = (duration / h).round() as usize;
    let mut tr = Trace { q_enc: 1.2e-9, ..Trace::default() };
    let (mut enc, mut dac, mut runner, mut out, mut steps) =
        ([0i32], [0.0; 3], [0.0], [0.0; 2], [0i32]);
    let mut previous_steps = None;
    for k in 0..n {
        let t = k as f64 * h;
        // Jacobi: both FMUs get the other's outputs at t, then both step.
        plant.get_integer(&plant_enc, &mut enc)?;
        ctrl.get_real(&ctrl_dac, &mut dac)?;
        plant.set_real(&plant_dac, &dac)?;
        ctrl.set_integer(&ctrl_enc, &enc)?;
        ctrl.set_real(&ctrl_ref, &[reference(t)])?;
        plant.do_step(h)?;
        ctrl.do_step(h)?;
        plant.get_integer(&plant_enc, &mut enc)?;
        plant.get_real(&plant_runner, &mut runner)?;
        ctrl.get_real(&ctrl_out, &mut out)?;
        ctrl.get_integer(&ctrl_steps, &mut steps)?;
        tr.time.push((k + 1) as f64 * h);
        tr.reference.push(reference((k + 1) as f64 * h));
        tr.encoder_counts.push(i64::from(enc[0]));
        tr.runner_position.push(runner[0]);
        tr.dac.push(dac);
        tr.disturbance_estimate.push(out[0]);
        tr.fraction.push(out[1]);
        tr.n_steps.push(steps[0] as u32);
        // The FMU has no "iterated" output; a new plan shows as a change of its outputs.
        tr.iterated.push(previous_steps != Some((steps[0], out[1].to_bits())));
        previous_steps = Some((steps[0], out[1].to_bits()));
    }
    let mut w = [0.0; 10];
    ctrl.get_real(&ctrl_weights, &mut w)?;
    tr.scale_weights = w;
    plant.terminate()?;
    ctrl.terminate()?;
    Ok(tr)
}

impl Trace {
    /// CSV of the run: one row per communication point.
    pub fn write_csv(&self, w: &mut impl std::io::Write) -> std::io::Result<()> {
        writeln!(w, "time,reference,encoder_counts,runner_position,dac_earth,dac_nonearth,dac_extension,disturbance_estimate,n_steps,fraction")?;
        for i in 0..self.time.len() {
            let d = self.dac[i];
            writeln!(
                w,
                "{},{:e},{},{:e},{},{},{},{:e},{},{}",
                self.time[i],
                self.reference[i],
                self.encoder_counts[i],
                self.runner_position[i],
                d[0],
                d[1],
                d[2],
                self.disturbance_estimate[i],
                self.n_steps[i],
                self.fraction[i]
            )?;
        }
        Ok(())
    }

    /// Indices of the parked samples (SPEC 4.1): all three DAC outputs zero for the
    /// previous 8 samples.
    pub fn parked(&self) -> Vec<usize> {
        (8..self.time.len())
            .filter(|&i| self.dac[i - 7..=i].iter().all(|d| d.iter().all(|v| *v == 0.0)))
            .collect()
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
        let e: Vec<f64> = self
            .parked()
            .into_iter()
            .filter(|&i| self.time[i] >= from && self.time[i] < to)
            .map(|i| self.error(i))
            .collect();
        (e.iter().map(|x| x * x).sum::<f64>() / e.len().max(1) as f64).sqrt()
    }
}
