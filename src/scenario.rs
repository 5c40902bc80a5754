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

pub const NAMES: [&str; 3] = ["fig5", "staircase", "calibration"];

pub fn by_name(name: &str) -> Option<Scenario> {
    let feedback_only = Params { feedforward: false, use_scale_factor_estimate: false, use_disturbance_estimate: false, ..Params::default() };
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
        _ => return None,
    })
}

/// Runs every variant, through the FMUs in `dist` if given, else with the crates.
pub fn run_scenario(s: &Scenario, dist: Option<&Path>) -> Result<Vec<Trace>, String> {
    s.variants
        .iter()
        .map(|v| match dist {
            Some(d) => run_fmus(&d.join("InchwormPlant.fmu"), &d.join("InchwormController.fmu"), &v.params, s.reference, s.duration).map_err(|e| e.to_string()),
            None => run(PlantParams::fia20(), v.params.clone(), s.reference, s.duration),
        })
        .collect()
}
