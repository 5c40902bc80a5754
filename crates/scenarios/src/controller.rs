//! The `InchwormController` FMU as a master sees it: the controller crate's [`Params`] as
//! the FMU's parameters, and the 6 µm device's configuration.

use inchworm_controller::{basis, Params};
use inchworm_fmu_models::ControllerFmu;

/// Every parameter of `p` as the FMU names it, as `controller.<name>` values for the
/// master: the FMU runs exactly `p`, whatever its start values are.
pub fn parameters(p: &Params) -> Vec<(String, String)> {
    crate::component_parameters("controller", &ControllerFmu::with_params(p.clone()))
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
