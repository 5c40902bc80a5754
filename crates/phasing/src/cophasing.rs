//! A segmented mirror co-phased on its inchworms, plain Rust (docs/phasing.md): every
//! segment on a three-actuator mount, each actuator a plant with its controller stepped
//! every 2 ms, and a global loop that moves the segments' targets against what it knows of
//! their poses: perfect knowledge (the reference run) or the edge sensors through the
//! reconstructor. The disturbances ([`crate::disturbances`]) move the segments and corrupt
//! the readings.

use inchworm_controller::{Controller, Params};
use inchworm_mount::{actuator_positions, pose, ANGLE_A_DEG, RADIUS};
use inchworm_plant::{Dac, Plant, PlantParams};
use nalgebra::{DMatrix, DVector};

use crate::disturbances::{Buffeting, Disturbances, SensorErrors};
use crate::geometry::Mirror;
use crate::reconstructor::{global_modes, Reconstructor};
use crate::sensors::EdgeSensors;
use crate::PhasingError;

/// The local loops' sample period (s).
pub const SAMPLE_PERIOD: f64 = 0.002;

/// The controller modes of a segmented mirror's actuators.
pub const MODES: [&str; 3] = ["stepping", "deadband", "analog"];

/// The deadband of the `deadband` mode: 5 nm, about 4 encoder counts of 1.2 nm, wider than
/// the count or two a parked runner's reading moves, so the gait halts once there and
/// stays halted.
pub const DEADBAND: f64 = 5e-9;

/// The controller of mode `name` of [`MODES`]: the paper's stepping gait, the same with no
/// step while the error is within [`DEADBAND`], or analog mode near the target.
pub fn controller(name: &str) -> Option<Params> {
    let d = Params::default();
    match name {
        "stepping" => Some(d),
        "deadband" => Some(Params { deadband: DEADBAND, ..d }),
        "analog" => Some(Params { analog: true, ..d }),
        _ => None,
    }
}

/// How the global loop knows the segments' poses.
#[derive(Clone, Debug)]
pub enum Knowledge {
    /// Their true poses, the whole mirror's piston, tip and tilt (which no edge sensor
    /// sees and the co-phasing error leaves out) removed: the reference run.
    Perfect,
    /// The edge sensors' readings, errors and all, through the reconstructor.
    EdgeSensors(Reconstructor),
}

/// The global loop: every `period` local samples it takes the mean of its knowledge over
/// the last `average` samples (the hold's dither and the sensors' white noise averaged
/// down) and the mean of every actuator's encoder over the same samples. Each actuator's
/// wanted position is its encoder's less its share of the segment's known error, and its
/// target moves `gain` of the way there: an integrator at `1 / (period × 2 ms)` once the
/// runners are at their targets, and no wind-up while a stepping actuator is still on
/// its way (what the sensors see of the way left is in its encoder too).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GlobalLoop {
    pub period: usize,
    pub gain: f64,
    pub average: usize,
}

impl GlobalLoop {
    /// Every second, gain 1, over the last 0.1 s.
    pub const DEFAULT: GlobalLoop = GlobalLoop { period: 500, gain: 1.0, average: 50 };

    fn check(&self) -> Result<(), PhasingError> {
        let GlobalLoop { period, gain, average } = *self;
        if period == 0 || average == 0 || average > period || !(gain > 0.0 && gain <= 2.0) {
            return Err(PhasingError::Loop(format!(
                "global loop: period {period} samples (at least 1), averaging {average} samples (1 to the period) and gain {gain} (above 0, at most 2)"
            )));
        }
        Ok(())
    }
}

/// A segmented mirror on its inchworms: the geometry, the sensors, every segment's initial
/// error (its pose with the runners at zero), actuator `3k + i` of segment `k` the plant
/// `plants[3k + i]`, every actuator under `controller`, and what disturbs it.
#[derive(Clone, Debug)]
pub struct Setup {
    pub mirror: Mirror,
    pub sensors: EdgeSensors,
    pub errors: Vec<[f64; 3]>,
    pub plants: Vec<PlantParams>,
    pub controller: Params,
    pub disturbances: Disturbances,
}

/// What a run gives.
#[derive(Clone, Debug, Default)]
pub struct Run {
    /// At every local sample and at the end: the co-phasing error, the surface RMS of the
    /// segments' poses with the whole mirror's piston, tip and tilt removed (m).
    pub cophasing_rms: Vec<f64>,
    /// Every segment's pose `[piston, tip, tilt]` at the end.
    pub poses: Vec<[f64; 3]>,
    /// Every segment's pose averaged over the last second (or the whole run if shorter):
    /// its parked state, the hold's dither (the encoder's quantum) averaged out.
    pub parked: Vec<[f64; 3]>,
    /// Global-loop updates made.
    pub updates: usize,
}

/// The co-phasing error of poses `[piston, tip, tilt]`: the segments' surface RMS with the
/// whole mirror's piston, tip and tilt removed (m).
pub fn cophasing_rms(mirror: &Mirror, poses: &[[f64; 3]]) -> f64 {
    rms_without(&global_modes(mirror), mirror.lever(), poses)
}

/// The telescope's pointing and focus stage: what takes the whole mirror's piston, tip and
/// tilt out of the segments' poses, which the edge sensors cannot see and a telescope
/// corrects by pointing (the optics' input: a coronagraph's star on its mask).
#[derive(Clone, Debug)]
pub struct Pointing {
    globals: DMatrix<f64>,
    lever: f64,
}

impl Pointing {
    pub fn new(mirror: &Mirror) -> Pointing {
        Pointing { globals: global_modes(mirror), lever: mirror.lever() }
    }

    /// `poses` less their projection on the whole mirror's piston, tip and tilt.
    pub fn correct(&self, poses: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let u = coordinates(self.lever, poses);
        let r = &u - &self.globals * (self.globals.transpose() * &u);
        r.as_slice().chunks_exact(3).map(|c| [c[0], c[1] / self.lever, c[2] / self.lever]).collect()
    }
}

/// How far apart two sets of poses are: the co-phasing error of their difference (m).
pub fn apart(mirror: &Mirror, a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let d: Vec<[f64; 3]> =
        a.iter().zip(b).map(|(p, q)| std::array::from_fn(|j| p[j] - q[j])).collect();
    cophasing_rms(mirror, &d)
}

/// Pose vector (the interaction matrix's coordinates) of poses, `lever` the segments'.
fn coordinates(lever: f64, poses: &[[f64; 3]]) -> DVector<f64> {
    DVector::from_iterator(
        3 * poses.len(),
        poses.iter().flat_map(|p| [p[0], p[1] * lever, p[2] * lever]),
    )
}

/// The same with the global modes' orthonormal basis `g` given (computed once per run).
fn rms_without(g: &DMatrix<f64>, lever: f64, poses: &[[f64; 3]]) -> f64 {
    let u = coordinates(lever, poses);
    let r = &u - g * (g.transpose() * &u);
    r.norm() / (poses.len() as f64).sqrt()
}

/// Runs `duration` seconds from the runners at rest.
pub fn run(
    setup: &Setup,
    knowledge: &Knowledge,
    global: GlobalLoop,
    duration: f64,
) -> Result<Run, PhasingError> {
    run_observed(setup, knowledge, global, duration, |_, _| {})
}

/// [`run`], calling `observe(t, poses)` with every segment's pose at every local sample
/// (and at the end): the traces a caller keeps, at the cost it chooses.
pub fn run_observed(
    setup: &Setup,
    knowledge: &Knowledge,
    global: GlobalLoop,
    duration: f64,
    mut observe: impl FnMut(f64, &[[f64; 3]]),
) -> Result<Run, PhasingError> {
    let Setup { mirror, sensors, errors, plants, controller, disturbances } = setup;
    let n = mirror.segments();
    if errors.len() != n || plants.len() != 3 * n || sensors.segments != n {
        return Err(PhasingError::Loop(format!(
            "{n} segments need {n} errors, {} plants and sensors of {n} segments, got {}, {} and {}",
            3 * n,
            errors.len(),
            plants.len(),
            sensors.segments
        )));
    }
    let duration = crate::check("duration", duration, SAMPLE_PERIOD, 1e5, "s")?;
    global.check()?;
    let mut actuators = Vec::with_capacity(3 * n);
    for p in plants {
        let plant = Plant::new(p.clone()).map_err(|e| PhasingError::Loop(e.to_string()))?;
        let ctrl = Controller::new(controller.clone()).map_err(PhasingError::Loop)?;
        actuators.push((plant, ctrl, [0.0f64; 3]));
    }
    let lever = mirror.lever();
    let cell = disturbances.cell.map(|c| (c, c.shape(mirror)));
    let mut wind = disturbances.wind.map(|w| Buffeting::new(w, n));
    let mut sensor_errors = disturbances.sensors.map(|s| SensorErrors::new(s, sensors.len()));
    let poses = |actuators: &[(Plant, Controller, [f64; 3])], t: f64, wind: &Option<Buffeting>| {
        (0..n)
            .map(|k| {
                let z: [f64; 3] =
                    std::array::from_fn(|i| actuators[3 * k + i].0.outputs().runner_position);
                let p = pose(z, RADIUS, ANGLE_A_DEG);
                std::array::from_fn(|j| {
                    let mut v = errors[k][j] + p[j];
                    if let Some((c, shape)) = &cell {
                        v += c.growth(t) * shape[k][j];
                    }
                    if let Some(w) = wind {
                        v += w.poses()[k][j];
                    }
                    v
                })
            })
            .collect::<Vec<[f64; 3]>>()
    };
    let interaction = sensors.sparse(mirror.centres());
    let globals = global_modes(mirror);
    let samples = (duration / SAMPLE_PERIOD).round() as usize;
    let mut out = Run { parked: vec![[0.0; 3]; n], ..Run::default() };
    let parked_over = samples.min((1.0 / SAMPLE_PERIOD) as usize);
    let mut targets = vec![0.0; 3 * n];
    // The global loop's mean knowledge: readings (edge sensors) or pose vectors (perfect).
    let width = match knowledge {
        Knowledge::Perfect => 3 * n,
        Knowledge::EdgeSensors(_) => sensors.len(),
    };
    let (mut sum, mut count) = (DVector::zeros(width), 0usize);
    // And the mean of every actuator's encoder over the same samples.
    let mut encoders = vec![0.0; 3 * n];
    for k in 0..samples {
        let t = k as f64 * SAMPLE_PERIOD;
        let now = poses(&actuators, t, &wind);
        observe(t, &now);
        out.cophasing_rms.push(rms_without(&globals, lever, &now));
        if k >= samples - parked_over {
            for (mean, p) in out.parked.iter_mut().zip(&now) {
                for j in 0..3 {
                    mean[j] += p[j] / parked_over as f64;
                }
            }
        }
        if let Some(e) = &mut sensor_errors {
            e.advance(SAMPLE_PERIOD);
        }
        // Sample k is in the window of the next update, at the next multiple of the period.
        if (global.period - k % global.period) % global.period < global.average {
            let u = coordinates(lever, &now);
            match knowledge {
                Knowledge::Perfect => sum += &u - &globals * (globals.transpose() * &u),
                Knowledge::EdgeSensors(_) => {
                    let mut readings = interaction.apply(&u);
                    if let Some(e) = &mut sensor_errors {
                        e.corrupt(readings.as_mut_slice());
                    }
                    sum += readings;
                }
            }
            for (mean, (plant, _, _)) in encoders.iter_mut().zip(&actuators) {
                *mean += plant.outputs().encoder_position;
            }
            count += 1;
        }
        if k % global.period == 0 {
            let mean = &sum / count as f64;
            let estimate = match knowledge {
                Knowledge::Perfect => mean,
                Knowledge::EdgeSensors(r) => DVector::from_vec(r.reconstruct(mean.as_slice())),
            };
            for (s, e) in sensors.poses(estimate.as_slice()).iter().enumerate() {
                let dz = actuator_positions(e[0], e[1], e[2], RADIUS, ANGLE_A_DEG);
                for (i, dz) in dz.iter().enumerate() {
                    let a = 3 * s + i;
                    let wanted = encoders[a] / count as f64 - dz;
                    targets[a] += global.gain * (wanted - targets[a]);
                }
            }
            sum.fill(0.0);
            encoders.fill(0.0);
            count = 0;
            out.updates += 1;
        }
        for ((plant, ctrl, held), &target) in actuators.iter_mut().zip(&targets) {
            let tick = ctrl.tick(plant.outputs().encoder_counts, target);
            plant
                .step(Dac { earth: held[0], nonearth: held[1], extension: held[2] }, SAMPLE_PERIOD)
                .map_err(|e| PhasingError::Loop(e.to_string()))?;
            *held = tick.dac;
        }
        if let Some(w) = &mut wind {
            w.advance(SAMPLE_PERIOD);
        }
    }
    let end = samples as f64 * SAMPLE_PERIOD;
    out.poses = poses(&actuators, end, &wind);
    observe(end, &out.poses);
    out.cophasing_rms.push(rms_without(&globals, lever, &out.poses));
    Ok(out)
}
