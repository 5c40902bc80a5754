//! Plant parameters (docs/model.md §2.8), SI units throughout.

use std::fmt;

use inchworm_declare::{Declare, Declared};

/// Number of play operators in the Prandtl–Ishlinskii hysteresis.
pub const N_PLAYS: usize = 5;

/// Every parameter of the plant, each declared once on its field: its FMU name (the field's
/// unless `name` says otherwise), unit, `fia20` value (the start value) and valid range; the
/// doc comment is the model description's text. The FMUs' parameter rows, the SSP
/// parameter sets, `inchworm run --param` and [`PlantParams::validate`] read these
/// declarations (value references 100 onward, in this order).
///
/// The ranges span two to four decades around the nominal devices, so any physically
/// sensible actuator fits, and they keep every configuration's propagators finite and its
/// step's work bounded: the stiffest corner (`k_p` 1e10 N/m on 0.1 g) rings at ~3 MHz,
/// which the exact propagation still represents (docs/model.md §2.8). The analog chain
/// stays a low-pass below 1 MHz (`f_bessel`, `f_amp`): the solver's scan interval assumes it.
#[derive(Clone, Debug, PartialEq, Declare)]
pub struct PlantParams {
    /// Extension PZT mass
    #[var(unit = "kg", start = 0.025, min = 1e-4, max = 10.0)]
    pub m_p: f64,
    /// Extension PZT short-circuit stiffness
    #[var(unit = "N/m", start = 3.0e7, min = 1e5, max = 1e10)]
    pub k_p: f64,
    /// Extension PZT damping
    #[var(unit = "N.s/m", start = 15.0, min = 0.0, max = 1e5)]
    pub c_p: f64,
    /// Non-earth brake mass on node 3
    #[var(unit = "kg", start = 0.040, min = 1e-4, max = 10.0)]
    pub m_b: f64,
    /// Flexure stiffness
    #[var(unit = "N/m", start = 5.0e6, min = 1000.0, max = 1e10)]
    pub k_f: f64,
    /// Flexure damping
    #[var(unit = "N.s/m", start = 20.0, min = 0.0, max = 1e5)]
    pub c_f: f64,
    /// Runner mass
    #[var(unit = "kg", start = 0.150, min = 1e-4, max = 100.0)]
    pub m_r: f64,
    /// Environment stiffness on the runner
    #[var(unit = "N/m", start = 2.0e4, min = 0.0, max = 1e9)]
    pub k_e: f64,
    /// Environment damping on the runner
    #[var(unit = "N.s/m", start = 10.0, min = 0.0, max = 1e5)]
    pub c_e: f64,
    /// Extension PZT rest length
    #[var(name = "L_p", unit = "m", start = 0.036, min = 1e-4, max = 1.0)]
    pub l_p: f64,
    /// Runner rest position
    #[var(name = "L_r", unit = "m", start = 0.0, min = -1.0, max = 1.0)]
    pub l_r: f64,
    /// Electromechanical transformer ratio
    #[var(name = "T_em", unit = "N/V", start = 8.8, min = 0.001, max = 1000.0)]
    pub t_em: f64,
    /// PZT capacitance
    #[var(name = "C", unit = "F", start = 4.0e-6, min = 1e-10, max = 0.01)]
    pub c: f64,
    /// Slip radii of the five hysteresis elements' stop operators (strictly increasing)
    #[var(
        unit = "V",
        start = [15.0, 30.0, 45.0, 60.0, 75.0],
        min = 0.1,
        max = 1000.0,
        elements = [
            "Hysteresis element 1: slip radius of its stop operator (radii strictly increasing)",
            "Hysteresis element 2: slip radius",
            "Hysteresis element 3: slip radius",
            "Hysteresis element 4: slip radius",
            "Hysteresis element 5: slip radius",
        ]
    )]
    pub play_radius: [f64; N_PLAYS],
    /// Weights of the five hysteresis elements (capacitance C / weight)
    #[var(
        start = [0.08, 0.07, 0.06, 0.05, 0.04],
        min = 0.0,
        max = 10.0,
        element = "Hysteresis element {k}: weight (capacitance C / weight)"
    )]
    pub play_weight: [f64; N_PLAYS],
    /// Brake disturbance force in DRIVE
    #[var(name = "F_d0", unit = "N", start = 175.0, min = -1e4, max = 1e4)]
    pub f_d0: f64,
    /// Growth of the brake disturbance with environment load
    #[var(start = 0.0, min = 0.0, max = 100.0)]
    pub gamma: f64,
    /// Brake threshold voltage
    #[var(name = "V_th", unit = "V", start = 50.0, min = 0.001, max = 1e4)]
    pub v_th: f64,
    /// Bessel filter -3 dB frequency
    #[var(unit = "Hz", start = 300.0, min = 1.0, max = 1e6)]
    pub f_bessel: f64,
    /// PZT amplifier gain
    #[var(start = 10.0, min = 0.001, max = 1000.0)]
    pub amp_gain: f64,
    /// PZT amplifier roll-off frequency
    #[var(unit = "Hz", start = 475.0, min = 1.0, max = 1e6)]
    pub f_amp: f64,
    /// Encoder resolution per count
    #[var(unit = "m", start = inchworm_board::ENCODER_RESOLUTION, min = 1e-12, max = 0.001)]
    pub q_enc: f64,
    /// Event time resolution: brake switches and hysteresis slip events are located to this time (1e-12..1e-6)
    // The propagation between events is exact: this is not an error tolerance.
    #[var(unit = "s", start = 1.0e-9, min = 1e-12, max = 1e-6)]
    pub rel_tol: f64,
    /// Standard deviation of additive encoder noise (0 = off)
    #[var(unit = "m", start = 0.0, min = 0.0, max = 0.001)]
    pub encoder_noise: f64,
    /// Seed of the encoder noise generator
    #[var(start = 1)]
    pub noise_seed: u64,
}

/// A parameter value that the model cannot run with.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamError {
    /// FMU name of the offending parameter, e.g. `play_radius[3]`.
    pub field: String,
    pub reason: String,
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "parameter {}: {}", self.field, self.reason)
    }
}

impl std::error::Error for ParamError {}

impl Default for PlantParams {
    fn default() -> Self {
        Self::fia20()
    }
}

impl PlantParams {
    /// The 20-µm device (docs/model.md §2.8 default): every declared start value.
    pub fn fia20() -> Self {
        Self::declared()
    }

    /// The 6-µm device: weaker transducer and brake disturbance.
    pub fn fia6() -> Self {
        PlantParams { t_em: 2.5, f_d0: 105.0, ..Self::fia20() }
    }

    /// Checks every value against its declared range, and the play radii's order; the
    /// error names the first offending parameter, its value and the range.
    pub fn validate(&self) -> Result<(), ParamError> {
        if let Some((field, reason)) = inchworm_declare::out_of_range(self) {
            return Err(ParamError { field: field.into(), reason });
        }
        for i in 1..N_PLAYS {
            let (r, before) = (self.play_radius[i], self.play_radius[i - 1]);
            if r <= before {
                return Err(ParamError {
                    field: format!("play_radius[{}]", i + 1),
                    reason: format!(
                        "play radii must be strictly increasing, got {r} after {before}"
                    ),
                });
            }
        }
        Ok(())
    }
}

/// The declared range `[min, max]` and unit of the parameter named `name` (an array's
/// name, `play_radius`, or one of its elements): what [`PlantParams::validate`] enforces.
pub fn range(name: &str) -> Option<(f64, f64, &'static str)> {
    let f = PlantParams::FIELDS
        .iter()
        .find(|f| f.name == name || f.name.strip_suffix("[1]") == Some(name))?;
    Some((f.min?, f.max?, f.unit.unwrap_or("(dimensionless)")))
}
