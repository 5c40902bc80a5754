//! Plant parameters (docs/model.md §2.8), SI units throughout.

use std::fmt;

/// Number of play operators in the Prandtl–Ishlinskii hysteresis.
pub const N_PLAYS: usize = 5;

/// Every parameter of the plant. Field names follow the FMU parameter names
/// (`L_p` → `l_p`, `T_em` → `t_em`, `C` → `c`, `play_radius[i]` → `play_radius[i-1]`).
#[derive(Clone, Debug, PartialEq)]
pub struct PlantParams {
    /// Extension PZT mass (kg).
    pub m_p: f64,
    /// Extension PZT short-circuit stiffness (N/m).
    pub k_p: f64,
    /// Extension PZT damping (N s/m).
    pub c_p: f64,
    /// Non-earth brake mass carried by node 3 (kg).
    pub m_b: f64,
    /// Flexure stiffness (N/m).
    pub k_f: f64,
    /// Flexure damping (N s/m).
    pub c_f: f64,
    /// Runner mass (kg).
    pub m_r: f64,
    /// Environment stiffness acting on the runner (N/m).
    pub k_e: f64,
    /// Environment damping (N s/m).
    pub c_e: f64,
    /// PZT rest length (m).
    pub l_p: f64,
    /// Runner rest position (m).
    pub l_r: f64,
    /// Electromechanical transformer ratio (N/V).
    pub t_em: f64,
    /// PZT capacitance (F).
    pub c: f64,
    /// Play operator radii (V), strictly increasing.
    pub play_radius: [f64; N_PLAYS],
    /// Play operator weights (dimensionless).
    pub play_weight: [f64; N_PLAYS],
    /// Brake disturbance force at zero environment load (N).
    pub f_d0: f64,
    /// Growth of the brake disturbance with environment load (dimensionless).
    pub gamma: f64,
    /// Brake threshold voltage (V).
    pub v_th: f64,
    /// Bessel filter -3 dB frequency (Hz).
    pub f_bessel: f64,
    /// PZT amplifier gain (V/V).
    pub amp_gain: f64,
    /// PZT amplifier roll-off frequency (Hz).
    pub f_amp: f64,
    /// Encoder resolution (m per count).
    pub q_enc: f64,
    /// Standard deviation of the additive encoder noise (m); 0 = off.
    pub encoder_noise: f64,
    /// Seed of the encoder noise generator.
    pub noise_seed: u64,
    /// Event location tolerance: brake switches and play events are located to `rel_tol`
    /// seconds (the propagation between events is exact).
    pub rel_tol: f64,
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
    /// The 20-µm device (docs/model.md §2.8 default).
    pub fn fia20() -> Self {
        PlantParams {
            m_p: 0.025,
            k_p: 3.0e7,
            c_p: 15.0,
            m_b: 0.040,
            k_f: 5.0e6,
            c_f: 20.0,
            m_r: 0.150,
            k_e: 2.0e4,
            c_e: 10.0,
            l_p: 0.036,
            l_r: 0.0,
            t_em: 8.8,
            c: 4.0e-6,
            play_radius: [15.0, 30.0, 45.0, 60.0, 75.0],
            play_weight: [0.08, 0.07, 0.06, 0.05, 0.04],
            f_d0: 175.0,
            gamma: 0.0,
            v_th: 50.0,
            f_bessel: 300.0,
            amp_gain: 10.0,
            f_amp: 475.0,
            q_enc: inchworm_board::ENCODER_RESOLUTION,
            encoder_noise: 0.0,
            noise_seed: 1,
            rel_tol: 1e-9,
        }
    }

    /// The 6-µm device: weaker transducer and brake disturbance.
    pub fn fia6() -> Self {
        PlantParams { t_em: 2.5, f_d0: 105.0, ..Self::fia20() }
    }

    /// The scalar parameters with their FMU names, values and valid ranges.
    fn scalars(&self) -> [(&'static str, f64); 22] {
        [
            ("m_p", self.m_p),
            ("k_p", self.k_p),
            ("c_p", self.c_p),
            ("m_b", self.m_b),
            ("k_f", self.k_f),
            ("c_f", self.c_f),
            ("m_r", self.m_r),
            ("k_e", self.k_e),
            ("c_e", self.c_e),
            ("L_p", self.l_p),
            ("L_r", self.l_r),
            ("T_em", self.t_em),
            ("C", self.c),
            ("F_d0", self.f_d0),
            ("gamma", self.gamma),
            ("V_th", self.v_th),
            ("f_bessel", self.f_bessel),
            ("amp_gain", self.amp_gain),
            ("f_amp", self.f_amp),
            ("q_enc", self.q_enc),
            ("encoder_noise", self.encoder_noise),
            ("rel_tol", self.rel_tol),
        ]
    }

    /// Checks every value against its range (`range`); the error names the first offending
    /// parameter, its value and the range.
    pub fn validate(&self) -> Result<(), ParamError> {
        fn err(field: impl Into<String>, reason: impl Into<String>) -> Result<(), ParamError> {
            Err(ParamError { field: field.into(), reason: reason.into() })
        }
        let check = |name: &str, v: f64| -> Result<(), ParamError> {
            let (lo, hi, unit) = range(name).expect("every parameter has a range");
            if v.is_finite() && (lo..=hi).contains(&v) {
                Ok(())
            } else {
                err(name, format!("must be within [{lo:e}, {hi:e}] {unit}, got {v:e}"))
            }
        };
        for (name, v) in self.scalars() {
            check(name, v)?;
        }
        for i in 0..N_PLAYS {
            let (r, w) = (self.play_radius[i], self.play_weight[i]);
            let rname = format!("play_radius[{}]", i + 1);
            check_named(&rname, "play_radius", r)?;
            check_named(&format!("play_weight[{}]", i + 1), "play_weight", w)?;
            if i > 0 && r <= self.play_radius[i - 1] {
                return err(
                    rname,
                    format!(
                        "play radii must be strictly increasing, got {r} after {}",
                        self.play_radius[i - 1]
                    ),
                );
            }
        }
        Ok(())
    }
}

/// Checks an element of an array parameter against the range of its array.
fn check_named(name: &str, array: &str, v: f64) -> Result<(), ParamError> {
    let (lo, hi, unit) = range(array).expect("every parameter has a range");
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(ParamError {
            field: name.into(),
            reason: format!("must be within [{lo:e}, {hi:e}] {unit}, got {v:e}"),
        })
    }
}

/// Valid range `[min, max]` and unit of each parameter (by FMU name; `play_radius` and
/// `play_weight` for every element of those arrays). The ranges span two to four decades
/// around the nominal devices, so any physically sensible actuator fits, and they keep
/// every configuration's propagators finite and its step's work bounded: the stiffest
/// corner (`k_p` 1e10 N/m on 0.1 g) rings at ~3 MHz, which the exact propagation still
/// represents (docs/model.md §2.8).
pub fn range(name: &str) -> Option<(f64, f64, &'static str)> {
    Some(match name {
        "m_p" | "m_b" => (1e-4, 10.0, "kg"),
        "m_r" => (1e-4, 100.0, "kg"),
        "k_p" => (1e5, 1e10, "N/m"),
        "k_f" => (1e3, 1e10, "N/m"),
        "k_e" => (0.0, 1e9, "N/m"),
        "c_p" | "c_f" | "c_e" => (0.0, 1e5, "N s/m"),
        "L_p" => (1e-4, 1.0, "m"),
        "L_r" => (-1.0, 1.0, "m"),
        "T_em" => (1e-3, 1e3, "N/V"),
        "C" => (1e-10, 1e-2, "F"),
        "play_radius" => (0.1, 1e3, "V"),
        "play_weight" => (0.0, 10.0, "(dimensionless)"),
        "F_d0" => (-1e4, 1e4, "N"),
        "gamma" => (0.0, 100.0, "(dimensionless)"),
        "V_th" => (1e-3, 1e4, "V"),
        // The analog chain stays a low-pass below 1 MHz: the solver's scan interval assumes it.
        "f_bessel" | "f_amp" => (1.0, 1e6, "Hz"),
        "amp_gain" => (1e-3, 1e3, "V/V"),
        "q_enc" => (1e-12, 1e-3, "m"),
        "encoder_noise" => (0.0, 1e-3, "m"),
        "rel_tol" => (1e-12, 1e-6, "s (event time resolution)"),
        _ => return None,
    })
}
