//! The `InchwormController` FMU as a master sees it: the controller crate's [`Params`] as
//! the FMU's parameters, and the 6 µm device's configuration.

use inchworm_controller::{basis, Params};

/// Every parameter of `p` as the FMU names it, as `controller.<name>` values for the
/// master: the FMU runs exactly `p`, whatever its start values are.
pub fn parameters(p: &Params) -> Vec<(String, String)> {
    let mut v: Vec<(String, String)> = [
        ("feedforward", p.feedforward),
        ("prefilter", p.prefilter),
        ("use_scale_factor_estimate", p.use_scale_factor_estimate),
        ("use_disturbance_estimate", p.use_disturbance_estimate),
    ]
    .into_iter()
    .map(|(n, b)| (n.to_string(), b.to_string()))
    .collect();
    v.push(("samples_per_step".into(), p.samples_per_step.to_string()));
    let reals = [
        ("deadband", p.deadband),
        ("compensator_gain", p.gains.k),
        ("compensator_zero", p.gains.a),
        ("prefilter_pole", p.gains.prefilter_pole),
        ("weight_prior", p.noise.weight_prior),
        ("disturbance_prior", p.noise.disturbance_prior),
        ("weight_process_noise", p.noise.weight_process),
        ("disturbance_process_noise", p.noise.disturbance_process),
        ("ext_cmd_noise", p.noise.ext_cmd_measurement),
        ("bd_noise", p.noise.bd_measurement),
        ("q_enc", p.q_enc),
        ("disturbance_start", p.disturbance_start),
    ];
    v.extend(reals.into_iter().map(|(n, x)| (n.to_string(), format!("{x}"))));
    for (i, (peak, weight)) in p.basis_peaks.iter().zip(&p.scale_weights_start).enumerate() {
        v.push((format!("basis_peak[{}]", i + 1), format!("{peak}")));
        v.push((format!("scale_weights_start[{}]", i + 1), format!("{weight}")));
    }
    // The options of docs/model.md §4.2, only when on: runs with them off set exactly the
    // parameters they always did.
    if p.analog {
        v.push(("analog".into(), "true".into()));
        let a = &p.analog_params;
        for (n, x) in [
            ("analog_range", a.range),
            ("analog_gain", a.gain),
            ("analog_loop_gain", a.loop_gain),
            ("analog_recentre_band", a.recentre_band),
        ] {
            v.push((n.to_string(), format!("{x}")));
        }
    }
    for (n, on) in
        [("disturbance_map", p.disturbance_map), ("use_disturbance_map", p.use_disturbance_map)]
    {
        if on {
            v.push((n.to_string(), "true".into()));
        }
    }
    if p.single_integrator {
        v.push(("single_integrator".into(), "true".into()));
        v.push(("single_integrator_gain".into(), format!("{}", p.single_integrator_gain)));
    }
    v.into_iter().map(|(n, x)| (format!("controller.{n}"), x)).collect()
}

/// Controller parameters for the 6 µm device: the basis peaks scaled to its step, the
/// nominal linear map of a 6 µm step, no disturbance prior knowledge.
pub fn fia6() -> Params {
    let scale = 6.0 / 20.0;
    let peaks = basis::FIA20_PEAKS.map(|p| p * scale);
    Params {
        basis_peaks: peaks,
        scale_weights_start: peaks.map(|p| p / 6e-6),
        disturbance_start: 0.0,
        ..Params::default()
    }
}
