//! The controller's parameters, their defaults (the calibrated estimates among them) and
//! their validation: everything a caller can get wrong is refused here, by name, before
//! a [`Controller`](crate::Controller) is built.

use inchworm_declare::{Declare, Declared};

use crate::analog::AnalogParams;
use crate::basis::{self, Basis};
use crate::compensator::Gains;
use crate::estimator::Noise;

/// Estimates the estimator converges to on the fia20 plant in regulation (weights of the
/// inverse scale factor at the default basis peaks, and the brake disturbance in m). See
/// docs/controller-design.md for the run that produced them and how to redo it.
pub const CALIBRATED_WEIGHTS: [f64; 10] = [
    -1.172492, -0.833551, -0.444175, -0.174458, -0.054124, 0.052323, 0.176492, 0.436781, 0.872245,
    1.105740,
];
pub const CALIBRATED_DISTURBANCE: f64 = 4.7012e-6;

/// The nominal linear inverse scale factor of the 20 µm device: weight = peak / 20 µm.
pub const NOMINAL_WEIGHTS: [f64; 10] = [-1.2, -0.8, -0.4, -0.15, -0.05, 0.05, 0.15, 0.4, 0.8, 1.2];

/// Every parameter of the controller, each declared once on its field (or on the fields
/// of the structs it flattens): its FMU name, unit, default (the start value), range where
/// the model description gives one; the first paragraph of the doc comment is the model
/// description's text. The controller FMU's parameter rows, its SSP parameter set and
/// `inchworm run --param` read these declarations (value references 100 onward, in this
/// order); [`Params::validate`] is the full check.
#[derive(Clone, Debug, PartialEq, Declare)]
pub struct Params {
    /// Feed the reference increment forward (feedback sees it one iteration later)
    #[var(start = true)]
    pub feedforward: bool,
    /// Prefilter the reference
    #[var(start = false)]
    pub prefilter: bool,
    /// Use the estimated inverse scale factor (else scale_weights_start)
    #[var(start = true)]
    pub use_scale_factor_estimate: bool,
    /// Use the estimated brake disturbance (else 0)
    #[var(start = true)]
    pub use_disturbance_estimate: bool,
    /// No step while |reference - position| is below this (0 = always step)
    #[var(unit = "m", start = 0.0)]
    pub deadband: f64,
    /// Samples of 2 ms per step (7..10000)
    #[var(start = 100)]
    pub samples_per_step: u32,
    #[var(flatten)]
    pub gains: Gains,
    #[var(flatten)]
    pub noise: Noise,
    /// Encoder resolution per count
    #[var(unit = "m", start = inchworm_board::ENCODER_RESOLUTION)]
    pub q_enc: f64,
    /// Initial disturbance estimate (fia20 calibration)
    #[var(unit = "m", start = CALIBRATED_DISTURBANCE)]
    pub disturbance_start: f64,
    /// Peaks of the fuzzy basis of the extension command (strictly increasing, peak 5 < 0 < peak 6)
    #[var(
        name = "basis_peak",
        at = 20,
        unit = "m",
        start = basis::FIA20_PEAKS,
        element = "Peak {k} of the fuzzy basis (strictly increasing, 5 < 0 < 6)"
    )]
    pub basis_peaks: [f64; 10],
    /// Initial inverse scale factor weights (fia20 calibration)
    #[var(
        start = CALIBRATED_WEIGHTS,
        element = "Initial inverse scale factor weight {k} (fia20 calibration)"
    )]
    pub scale_weights_start: [f64; 10],
    /// Analog mode near the target: hold in DRIVE with the extension under a loop of its own instead of stepping (deadband must be 0)
    ///
    /// ([`analog`](crate::analog), docs/model.md §4.2); default off.
    #[var(start = false)]
    pub analog: bool,
    #[var(flatten)]
    pub analog_params: AnalogParams,
    /// Estimate the brake-disturbance map over the extension command (a second Kalman filter, 9 weights)
    ///
    /// ([`bdmap`](crate::bdmap)).
    #[var(start = false)]
    pub disturbance_map: bool,
    /// Plan with the map's prediction for the coming step (needs disturbance_map and use_disturbance_estimate)
    ///
    /// Instead of the latest estimate.
    #[var(start = false)]
    pub use_disturbance_map: bool,
    /// Single-integrator compensator C(z) = single_integrator_gain instead of K (z - a)/(z - 1) (needs use_disturbance_map)
    #[var(start = false)]
    pub single_integrator: bool,
    /// k of the single-integrator compensator, loop k/(z - 1) (0 < k < 2)
    #[var(start = 0.6, min = 0.0, max = 2.0)]
    pub single_integrator_gain: f64,
}

impl Default for Params {
    fn default() -> Self {
        Params::declared()
    }
}

impl Params {
    /// Checks every value; the error names the parameter.
    pub fn validate(&self) -> Result<(), String> {
        let finite = |name: &str, v: f64| {
            if v.is_finite() {
                Ok(())
            } else {
                Err(format!("{name} must be finite, got {v}"))
            }
        };
        let positive = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be > 0, got {v}"))
            }
        };
        if !(self.deadband.is_finite() && self.deadband >= 0.0) {
            return Err(format!("{} must be >= 0, got {}", Params::DEADBAND.name(), self.deadband));
        }
        if !(7..=10_000).contains(&self.samples_per_step) {
            return Err(format!(
                "{} must be within 7..10000, got {}",
                Params::SAMPLES_PER_STEP.name(),
                self.samples_per_step
            ));
        }
        positive(Gains::K.name(), self.gains.k)?;
        if !(0.0..1.0).contains(&self.gains.a) {
            return Err(format!("{} must be in [0, 1), got {}", Gains::A.name(), self.gains.a));
        }
        if !(0.0..1.0).contains(&self.gains.prefilter_pole) {
            return Err(format!(
                "{} must be in [0, 1), got {}",
                Gains::PREFILTER_POLE.name(),
                self.gains.prefilter_pole
            ));
        }
        let n = &self.noise;
        for (name, v) in [
            (Noise::WEIGHT_PRIOR, n.weight_prior),
            (Noise::DISTURBANCE_PRIOR, n.disturbance_prior),
            (Noise::WEIGHT_PROCESS, n.weight_process),
            (Noise::DISTURBANCE_PROCESS, n.disturbance_process),
            (Noise::EXT_CMD_MEASUREMENT, n.ext_cmd_measurement),
            (Noise::BD_MEASUREMENT, n.bd_measurement),
        ] {
            positive(name.name(), v)?;
        }
        Basis::new(self.basis_peaks)
            .map_err(|e| format!("{}: {e}", Params::BASIS_PEAKS.base_name()))?;
        for (i, w) in self.scale_weights_start.iter().enumerate() {
            finite(&format!("{}[{}]", Params::SCALE_WEIGHTS_START.base_name(), i + 1), *w)?;
        }
        finite(Params::DISTURBANCE_START.name(), self.disturbance_start)?;
        positive(Params::Q_ENC.name(), self.q_enc)?;
        if self.use_disturbance_map && !(self.disturbance_map && self.use_disturbance_estimate) {
            return Err(format!(
                "{} needs {} and {} on",
                Params::USE_DISTURBANCE_MAP.name(),
                Params::DISTURBANCE_MAP.name(),
                Params::USE_DISTURBANCE_ESTIMATE.name()
            ));
        }
        if self.single_integrator {
            if !self.use_disturbance_map {
                return Err(format!(
                    "{} needs {} on (the map's prediction replaces the second integrator)",
                    Params::SINGLE_INTEGRATOR.name(),
                    Params::USE_DISTURBANCE_MAP.name()
                ));
            }
            let k = self.single_integrator_gain;
            if !(k > 0.0 && k < 2.0) {
                return Err(format!(
                    "{} must be in (0, 2), got {k}",
                    Params::SINGLE_INTEGRATOR_GAIN.name()
                ));
            }
        }
        if self.analog {
            self.analog_params.validate()?;
            if self.deadband > 0.0 {
                return Err(format!(
                    "{} must be 0 with {} on (analog mode holds the target instead of parking), got {}",
                    Params::DEADBAND.name(),
                    Params::ANALOG.name(),
                    self.deadband
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Controller;

    #[test]
    fn validate_names_the_field() {
        assert_eq!(Params::default().validate(), Ok(()));
        let d = Params::default;
        let mut peaks = basis::FIA20_PEAKS;
        peaks.swap(1, 2);
        let mut weights = NOMINAL_WEIGHTS;
        weights[3] = f64::NAN;
        let cases: [(&str, Params); 11] = [
            ("deadband", Params { deadband: -1e-9, ..d() }),
            ("samples_per_step", Params { samples_per_step: 6, ..d() }),
            ("compensator_gain", Params { gains: Gains { k: 0.0, ..Gains::default() }, ..d() }),
            ("compensator_zero", Params { gains: Gains { a: 1.0, ..Gains::default() }, ..d() }),
            (
                "prefilter_pole",
                Params { gains: Gains { prefilter_pole: -0.1, ..Gains::default() }, ..d() },
            ),
            (
                "weight_process_noise",
                Params {
                    noise: Noise { weight_process: f64::INFINITY, ..Noise::default() },
                    ..d()
                },
            ),
            (
                "bd_noise",
                Params { noise: Noise { bd_measurement: 0.0, ..Noise::default() }, ..d() },
            ),
            ("basis_peak", Params { basis_peaks: peaks, ..d() }),
            ("scale_weights_start[4]", Params { scale_weights_start: weights, ..d() }),
            ("disturbance_start", Params { disturbance_start: f64::NAN, ..d() }),
            ("q_enc", Params { q_enc: 0.0, ..d() }),
        ];
        for (field, p) in cases {
            let e = p.validate().expect_err(field);
            assert!(e.starts_with(field), "error for {field}: {e:?}");
            assert!(Controller::new(p).is_err());
        }
    }

    #[test]
    fn analog_options_are_checked_together() {
        let on = || Params { analog: true, ..Params::default() };
        assert_eq!(on().validate(), Ok(()));
        let a = AnalogParams::default;
        let cases: [(&str, Params); 5] = [
            ("deadband", Params { deadband: 1e-9, ..on() }),
            ("analog_range", Params { analog_params: AnalogParams { range: 3e-6, ..a() }, ..on() }),
            ("analog_gain", Params { analog_params: AnalogParams { gain: 0.0, ..a() }, ..on() }),
            (
                "analog_loop_gain",
                Params { analog_params: AnalogParams { loop_gain: 1.0, ..a() }, ..on() },
            ),
            (
                "analog_recentre_band",
                Params { analog_params: AnalogParams { recentre_band: 4.0, ..a() }, ..on() },
            ),
        ];
        for (field, p) in cases {
            let e = p.validate().expect_err(field);
            assert!(e.starts_with(field), "error for {field}: {e:?}");
            // Off, the analog values are not looked at.
            assert_eq!(Params { analog: false, deadband: 0.0, ..p }.validate(), Ok(()));
        }
    }

    #[test]
    fn the_disturbance_map_flag_needs_the_map_and_the_estimate() {
        let e = Params { use_disturbance_map: true, ..Params::default() }.validate().unwrap_err();
        assert!(e.starts_with("use_disturbance_map"), "{e}");
        let p = Params {
            use_disturbance_map: true,
            disturbance_map: true,
            use_disturbance_estimate: false,
            ..Params::default()
        };
        assert!(p.validate().is_err());
        assert_eq!(Params { use_disturbance_map: false, ..p }.validate(), Ok(()));
        let e = Params { single_integrator: true, ..Params::default() }.validate().unwrap_err();
        assert!(e.starts_with("single_integrator"), "{e}");
        let p = Params {
            single_integrator: true,
            single_integrator_gain: 2.0,
            disturbance_map: true,
            use_disturbance_map: true,
            ..Params::default()
        };
        assert!(p.validate().unwrap_err().starts_with("single_integrator_gain"));
        assert_eq!(Params { single_integrator_gain: 0.6, ..p }.validate(), Ok(()));
    }
}
