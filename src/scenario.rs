//! Named closed-loop scenarios of the paper (SPEC 4.1), run through the FMUs or with the
//! crates coupled directly, written as CSV and PNG.

use std::path::Path;

use inchworm_controller::{Params, NOMINAL_WEIGHTS};
use inchworm_plant::PlantParams;

use crate::closed_loop::{run, run_fmus, Trace};

/// One run of a scenario: a controller configuration under a reference.
pub struct Variant {
    pub name: &'static str,
    pub params: Params,
}

pub struct Scenario {
    pub name: &'static str,
    pub title: &'static str,
    pub duration: f64,
    pub reference: fn(f64) -> f64,
    pub variants: Vec<Variant>,
    /// Windows (s) in which the loop regulates, for the RMS of the parked samples.
    pub regulation: Vec<(f64, f64)>,
}

fn fig5_reference(_t: f64) -> f64 {
    100e-6
}

/// Reference levels of the Figs. 6–7 staircase (µm), 100 s each.
pub const STAIRCASE_UM: [f64; 7] = [100.0, 60.0, 250.0, 245.0, 130.0, 131.5, 20.0];

pub fn staircase_reference(t: f64) -> f64 {
    STAIRCASE_UM[((t / 100.0) as usize).min(STAIRCASE_UM.len() - 1)] * 1e-6
}

/// Each level from 20 s after its change to its end.
fn staircase_regulation() -> Vec<(f64, f64)> {
    (0..STAIRCASE_UM.len()).map(|k| (k as f64 * 100.0 + 20.0, (k + 1) as f64 * 100.0)).collect()
}

pub const NAMES: [&str; 5] = ["fig5", "staircase", "calibration", "fia6", "stall"];

/// Controller parameters for the 6 µm device: the basis peaks scaled to its step, the
/// nominal linear map of a 6 µm step, no disturbance prior knowledge.
pub fn fia6_controller() -> Params {
    let scale = 6.0 / 20.0;
    let peaks = inchworm_controller::basis::FIA20_PEAKS.map(|p| p * scale);
    Params {
        basis_peaks: peaks,
        scale_weights_start: peaks.map(|p| p / 6e-6),
        disturbance_start: 0.0,
        ..Params::default()
    }
}

/// Open-loop slew (the paper's Fig. 11): `steps` full forward steps with the plant alone,
/// for each brake-disturbance growth `gamma`; one trace per value, DACs and encoder.
pub fn open_loop_slew(gammas: &[f64], steps: usize) -> Vec<Trace> {
    use inchworm_controller::gait::{Direction, Timing};
    use inchworm_plant::{Dac, Plant};
    let timing = Timing::new(100);
    gammas
        .iter()
        .map(|&gamma| {
            let mut plant = Plant::new(PlantParams { gamma, ..PlantParams::fia20() })
                .expect("valid parameters");
            let mut tr = Trace { q_enc: 1.2e-9, ..Trace::default() };
            for s in 0..steps {
                for k in 1..=100 {
                    let [e, n, x] = timing.volts(Direction::Forward, 1.0, k);
                    plant.step(Dac { earth: e, nonearth: n, extension: x }, 0.002);
                    let o = plant.outputs();
                    tr.time.push(((s * 100 + k) as f64) * 0.002);
                    tr.reference.push(0.0);
                    tr.encoder_counts.push(o.encoder_counts);
                    tr.runner_position.push(o.runner_position);
                    tr.dac.push([e, n, x]);
                    tr.disturbance_estimate.push(0.0);
                    tr.n_steps.push(0);
                    tr.fraction.push(0.0);
                    tr.iterated.push(false);
                }
            }
            tr
        })
        .collect()
}

pub fn by_name(name: &str) -> Option<Scenario> {
    let feedback_only = Params {
        feedforward: false,
        use_scale_factor_estimate: false,
        use_disturbance_estimate: false,
        ..Params::default()
    };
    Some(match name {
        "fig5" => Scenario {
            name: "fig5",
            title: "Fig. 5: runner at rest at 0, reference 100 µm from t = 0",
            duration: 10.0,
            reference: fig5_reference,
            variants: vec![
                Variant { name: "full control", params: Params::default() },
                Variant { name: "feedback only", params: feedback_only },
            ],
            regulation: vec![(6.0, 10.0)],
        },
        "staircase" => Scenario {
            name: "staircase",
            title: "Figs. 6-7: reference staircase with the prefilter on",
            duration: 700.0,
            reference: staircase_reference,
            variants: vec![Variant { name: "full control + prefilter", params: Params { prefilter: true, ..Params::default() } }],
            regulation: staircase_regulation(),
        },
        "calibration" => Scenario {
            name: "calibration",
            title: "Calibration: the staircase from the nominal inverse scale factor and zero disturbance",
            duration: 700.0,
            reference: staircase_reference,
            variants: vec![Variant {
                name: "from nominal",
                params: Params { prefilter: true, scale_weights_start: NOMINAL_WEIGHTS, disturbance_start: 0.0, ..Params::default() },
            }],
            regulation: staircase_regulation(),
        },
        "fia6" => Scenario {
            name: "fia6",
            title: "The 6 µm device (fia6): reference 30 µm, estimator started from the nominal 6 µm map",
            duration: 20.0,
            reference: |_| 30e-6,
            variants: vec![Variant { name: "full control", params: fia6_controller() }],
            regulation: vec![(10.0, 20.0)],
        },
        _ => return None,
    })
}

/// Runs every variant, through the FMUs in `dist` if given, else with the crates.
pub fn run_scenario(s: &Scenario, dist: Option<&Path>) -> Result<Vec<Trace>, String> {
    let plant = if s.name == "fia6" { PlantParams::fia6() } else { PlantParams::fia20() };
    let plant_params: Vec<(String, f64)> =
        if s.name == "fia6" { vec![("T_em".into(), 2.5), ("F_d0".into(), 105.0)] } else { vec![] };
    s.variants
        .iter()
        .map(|v| match dist {
            Some(d) => run_fmus(
                &d.join("InchwormPlant.fmu"),
                &d.join("InchwormController.fmu"),
                &plant_params,
                &v.params,
                s.reference,
                s.duration,
            )
            .map_err(|e| e.to_string()),
            None => run(plant.clone(), v.params.clone(), s.reference, s.duration),
        })
        .collect()
}
