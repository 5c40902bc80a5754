//! A segmented mirror co-phased on its inchworms, plain Rust (docs/phasing.md): every
//! segment on a three-actuator mount, each actuator a plant with its controller stepped
//! every 2 ms, and the segments' targets set either from perfect knowledge of their
//! errors (the reference run) or by a global loop through the edge sensors: at every
//! global sample the sensors read the mirror, the reconstructor turns the readings into
//! segment poses and each segment's actuator targets move against them, `gain` times.

use inchworm_controller::{Controller, Params};
use inchworm_plant::{Dac, Plant, PlantParams};

use crate::geometry::Mirror;
use crate::mount::{actuator_positions, pose, ANGLE_A_DEG, RADIUS};
use crate::reconstructor::{global_modes, Reconstructor};
use crate::sensors::EdgeSensors;
use crate::PhasingError;

/// The local loops' sample period (s).
pub const SAMPLE_PERIOD: f64 = 0.002;

/// How the segments' targets are set.
#[derive(Clone, Debug)]
pub enum Knowledge {
    /// From each segment's true error, once at the start: the reference run.
    Perfect,
    /// By the global loop through the edge sensors, every `period` local samples.
    EdgeSensors { reconstructor: Reconstructor, period: usize, gain: f64 },
}

/// What a run gives.
#[derive(Clone, Debug, Default)]
pub struct Run {
    /// At every local sample: the co-phasing error, the surface RMS of the segments' poses
    /// with the whole mirror's piston, tip and tilt removed (m).
    pub cophasing_rms: Vec<f64>,
    /// Every segment's pose `[piston, tip, tilt]` at the end.
    pub poses: Vec<[f64; 3]>,
    /// Every segment's pose averaged over the last second (or the whole run if shorter):
    /// its parked state, the hold's dither (the encoder's quantum) averaged out.
    pub parked: Vec<[f64; 3]>,
    /// Global-loop updates made.
    pub updates: usize,
}

/// The segments' surface RMS with the global modes removed (m), of poses `[piston, tip,
/// tilt]`.
pub fn cophasing_rms(mirror: &Mirror, sensors: &EdgeSensors, poses: &[[f64; 3]]) -> f64 {
    rms_without(&global_modes(mirror), sensors, poses)
}

/// The same with the global modes' orthonormal basis `g` given (computed once per run).
fn rms_without(g: &nalgebra::DMatrix<f64>, sensors: &EdgeSensors, poses: &[[f64; 3]]) -> f64 {
    let u = nalgebra::DVector::from_vec(sensors.coordinates(poses));
    let r = &u - g * (g.transpose() * &u);
    r.norm() / (poses.len() as f64).sqrt()
}

/// Runs `duration` seconds from the runners at rest, the segments at `errors` (each its
/// pose with the runners at zero), actuator `3k + i` of segment `k` the plant `plants[3k + i]`
/// under the controller `controller`.
pub fn run(
    mirror: &Mirror,
    sensors: &EdgeSensors,
    errors: &[[f64; 3]],
    plants: &[PlantParams],
    controller: &Params,
    knowledge: &Knowledge,
    duration: f64,
) -> Result<Run, PhasingError> {
    let n = mirror.segments();
    if errors.len() != n || plants.len() != 3 * n {
        return Err(PhasingError::Loop(format!(
            "{} segments need {n} errors and {} plants, got {} and {}",
            n,
            3 * n,
            errors.len(),
            plants.len()
        )));
    }
    let duration = crate::check("duration", duration, SAMPLE_PERIOD, 1e4, "s")?;
    if let Knowledge::EdgeSensors { period, gain, .. } = knowledge {
        if *period == 0 || !(gain.is_finite() && *gain > 0.0 && *gain <= 2.0) {
            return Err(PhasingError::Loop(format!(
                "global loop: period {period} samples (at least 1) and gain {gain} (above 0, at most 2)"
            )));
        }
    }
    let mut actuators = Vec::with_capacity(3 * n);
    for p in plants {
        let plant = Plant::new(p.clone()).map_err(|e| PhasingError::Loop(e.to_string()))?;
        let ctrl = Controller::new(controller.clone()).map_err(PhasingError::Loop)?;
        actuators.push((plant, ctrl, [0.0f64; 3]));
    }
    let mut targets: Vec<f64> = match knowledge {
        Knowledge::Perfect => errors
            .iter()
            .flat_map(|e| actuator_positions(-e[0], -e[1], -e[2], RADIUS, ANGLE_A_DEG))
            .collect(),
        Knowledge::EdgeSensors { .. } => vec![0.0; 3 * n],
    };
    let poses = |actuators: &[(Plant, Controller, [f64; 3])]| -> Vec<[f64; 3]> {
        (0..n)
            .map(|k| {
                let z: [f64; 3] =
                    std::array::from_fn(|i| actuators[3 * k + i].0.outputs().runner_position);
                let p = pose(z, RADIUS, ANGLE_A_DEG);
                std::array::from_fn(|j| errors[k][j] + p[j])
            })
            .collect()
    };
    let interaction = sensors.interaction(mirror.centres());
    let globals = global_modes(mirror);
    let samples = (duration / SAMPLE_PERIOD).round() as usize;
    let mut out = Run { parked: vec![[0.0; 3]; n], ..Run::default() };
    let averaged = samples.min((1.0 / SAMPLE_PERIOD) as usize);
    for k in 0..samples {
        let now = poses(&actuators);
        out.cophasing_rms.push(rms_without(&globals, sensors, &now));
        if k >= samples - averaged {
            for (mean, p) in out.parked.iter_mut().zip(&now) {
                for j in 0..3 {
                    mean[j] += p[j] / averaged as f64;
                }
            }
        }
        if let Knowledge::EdgeSensors { reconstructor, period, gain } = knowledge {
            if k % period == 0 {
                let readings =
                    &interaction * nalgebra::DVector::from_vec(sensors.coordinates(&now));
                let estimate = sensors.poses(&reconstructor.reconstruct(readings.as_slice()));
                for (s, e) in estimate.iter().enumerate() {
                    let dz = actuator_positions(e[0], e[1], e[2], RADIUS, ANGLE_A_DEG);
                    for i in 0..3 {
                        targets[3 * s + i] -= gain * dz[i];
                    }
                }
                out.updates += 1;
            }
        }
        for ((plant, ctrl, held), &target) in actuators.iter_mut().zip(&targets) {
            let tick = ctrl.tick(plant.outputs().encoder_counts, target);
            plant
                .step(Dac { earth: held[0], nonearth: held[1], extension: held[2] }, SAMPLE_PERIOD)
                .map_err(|e| PhasingError::Loop(e.to_string()))?;
            *held = tick.dac;
        }
    }
    out.poses = poses(&actuators);
    out.cophasing_rms.push(rms_without(&globals, sensors, &out.poses));
    Ok(out)
}
