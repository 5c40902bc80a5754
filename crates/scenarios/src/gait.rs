//! The stepping gait of docs/model.md §3 and its raw measurements, plus the docs/model.md §2.9 check
//! sequence and values.
//!
//! This is the open-loop gait the `inchworm gait` command drives the plant FMU with; the
//! tables and the measurements are the controller crate's, so the CLI and the controller
//! can never disagree about them.

pub use inchworm_controller::gait::Direction;
use inchworm_controller::gait::Timing;
pub use inchworm_controller::measurements::Raw as RawMeasurements;
use inchworm_plant::Dac;

/// A gait step's amplitude outside [-1, 1] (or not a number).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("step amplitude {0} is outside [-1, 1]")]
pub struct AmplitudeError(pub f64);

/// Controller sample period `T_s` (s), docs/model.md §3.1.
pub const SAMPLE_PERIOD_S: f64 = inchworm_controller::SAMPLE_PERIOD;
/// Samples per step (`T_sp = 100 · T_s = 0.2 s`), docs/model.md §3.1.
pub const SAMPLES_PER_STEP: usize = 100;
/// Full-scale DAC output (V).
pub const DAC_FULL_SCALE_V: f64 = inchworm_controller::DAC_FULL_SCALE;

/// One step of the gait with amplitude `y` in [−1, 1] (a full step is ±1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    amplitude: f64,
}

impl Step {
    /// A step of amplitude `y`. `y ≥ 0` runs the forward gait (`y = 0` cycles the brakes
    /// with the extension unpowered), `y < 0` the backward gait with `a = |y|`.
    pub fn new(y: f64) -> Result<Self, AmplitudeError> {
        if !y.is_finite() || y.abs() > 1.0 {
            return Err(AmplitudeError(y));
        }
        Ok(Self { amplitude: y })
    }

    pub fn amplitude(&self) -> f64 {
        self.amplitude
    }

    pub fn direction(&self) -> Direction {
        if self.amplitude >= 0.0 {
            Direction::Forward
        } else {
            Direction::Backward
        }
    }

    /// Commanded extension fraction `w_ext(k)` of 1-based sample `k`: DAC volts / 10,
    /// before quantization, positive in both gaits (docs/model.md §3.1, §4).
    pub fn extension_fraction(&self, k: usize) -> f64 {
        self.dac(k).extension / DAC_FULL_SCALE_V
    }

    /// DAC volts held during 1-based sample `k` of this step (docs/model.md §3.2, unquantized).
    pub fn dac(&self, k: usize) -> Dac {
        assert!(
            (1..=SAMPLES_PER_STEP).contains(&k),
            "sample {k} is outside 1..={SAMPLES_PER_STEP}"
        );
        let [earth, nonearth, extension] =
            Timing::new(SAMPLES_PER_STEP).volts(self.direction(), self.amplitude, k);
        Dac { earth, nonearth, extension }
    }

    /// The 100 DAC samples of this step, sample 1 first.
    pub fn samples(&self) -> impl Iterator<Item = Dac> + '_ {
        (1..=SAMPLES_PER_STEP).map(|k| self.dac(k))
    }
}

/// docs/model.md §3.3 from the encoder samples `w_enc(1..=100)` of one step (`enc[k − 1]` is the
/// reading at the end of sample k, in any length unit) and the step that was commanded.
pub fn raw_measurements(step: &Step, enc: &[f64]) -> RawMeasurements {
    assert_eq!(
        enc.len(),
        SAMPLES_PER_STEP,
        "raw_measurements needs the {SAMPLES_PER_STEP} samples of one step"
    );
    let ext: Vec<f64> = (1..=SAMPLES_PER_STEP).map(|k| step.extension_fraction(k)).collect();
    inchworm_controller::measurements::raw(
        &Timing::new(SAMPLES_PER_STEP),
        step.direction(),
        enc,
        &ext,
    )
}

/// docs/model.md §2.9: the five step amplitudes of the check run (from rest).
pub const CHECK_AMPLITUDES: [f64; 5] = [1.0, 1.0, -1.0, 0.3, -0.3];

/// Check values of one step (docs/model.md §2.9), µm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CheckValues {
    pub ext_moved_um: f64,
    pub bd_um: f64,
    pub position_after_um: f64,
}

/// `tests/data/plant-check-values.csv`, compiled in, so the command holds a run to the very
/// file the tests read (its README says where the values come from).
const CHECK_VALUES_CSV: &str = include_str!("../../../tests/data/plant-check-values.csv");

/// The independent reference integration's raw measurements for `device` (`fia20` or
/// `fia6`), one per step of [`CHECK_AMPLITUDES`]; empty for another device.
pub fn check_values(device: &str) -> Vec<CheckValues> {
    CHECK_VALUES_CSV
        .lines()
        .skip(1)
        .filter_map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let v =
                |i: usize| f[i].trim().parse::<f64>().expect("tests/data check values are numbers");
            (f[0] == device).then(|| CheckValues {
                ext_moved_um: v(3),
                bd_um: v(4),
                position_after_um: v(5),
            })
        })
        .collect()
}

/// docs/model.md §2.9: a correct plant matches every check value within this (µm).
pub const CHECK_TOLERANCE_UM: f64 = 0.010;

/// The §2.9 check sequence repeated `repeat` times.
pub fn check_sequence(repeat: usize) -> Vec<Step> {
    let one: Vec<Step> = CHECK_AMPLITUDES
        .iter()
        .map(|&y| Step::new(y).expect("check amplitudes are within [-1, 1]"))
        .collect();
    std::iter::repeat_n(one, repeat).flatten().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_gaits_start_and_end_parked() {
        for y in [1.0, 0.3, -0.3, -1.0] {
            let s = Step::new(y).unwrap();
            assert_eq!(s.dac(1), Dac::default(), "y = {y}: sample 1");
            assert_eq!(s.dac(100), Dac::default(), "y = {y}: sample 100");
        }
    }

    #[test]
    fn out_of_range_amplitudes_are_refused() {
        assert!(Step::new(1.01).is_err());
        assert!(Step::new(f64::NAN).is_err());
        assert!(Step::new(-1.0).is_ok());
    }

    /// The generated check sequence must be exactly the DAC columns of the check trace in
    /// tests/data (the plant test replays that file, the CLI generates it).
    #[test]
    fn check_sequence_reproduces_the_reference_trace_inputs() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/plant-check-trace-fia20-passive.csv"
        );
        let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("reading {path}: {e}"));
        let rows: Vec<Vec<f64>> = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').take(4).map(|f| f.parse().unwrap()).collect())
            .collect();
        let dacs: Vec<Dac> =
            check_sequence(1).iter().flat_map(|s| s.samples().collect::<Vec<_>>()).collect();
        assert_eq!(rows.len(), dacs.len());
        for (k, (r, d)) in rows.iter().zip(&dacs).enumerate() {
            assert!((r[0] - k as f64 * SAMPLE_PERIOD_S).abs() < 1e-9, "row {k}: time {}", r[0]);
            for (name, want, got) in [
                (Dac::EARTH.name(), r[1], d.earth),
                (Dac::NONEARTH.name(), r[2], d.nonearth),
                (Dac::EXTENSION.name(), r[3], d.extension),
            ] {
                assert!(
                    (want - got).abs() < 1e-12,
                    "sample {k} (t = {} s): {name} = {got} V, reference {want} V",
                    r[0]
                );
            }
        }
    }

    #[test]
    fn raw_measurements_follow_spec_3_3() {
        // A forward step whose encoder reads 1 during s1, 3 from the s3 window on,
        // 10 from s4, 12 after: EXT_moved = 10 − 3 = 7, BD = (12 − 1) − 7 = 4.
        let step = Step::new(0.5).unwrap();
        let enc: Vec<f64> = (1..=100)
            .map(|k| match k {
                ..=20 => 1.0,
                21..=43 => 3.0,
                44..=90 => 10.0,
                _ => 12.0,
            })
            .collect();
        let m = raw_measurements(&step, &enc);
        assert_eq!(m.s, [1.0, 3.0, 3.0, 10.0, 10.0, 10.0, 12.0]);
        assert_eq!(m.ext_moved, 7.0);
        assert_eq!(m.bd, 4.0);
        assert_eq!(m.ext_cmd, 0.5);

        // Backward: the extension falls between the s4 and s5 windows.
        let back = Step::new(-0.5).unwrap();
        let m = raw_measurements(&back, &enc);
        assert_eq!(m.ext_moved, 0.0);
        assert_eq!(m.ext_cmd, -0.5);
        assert_eq!(m.bd, 11.0);
    }
}

#[cfg(test)]
mod check_value_tests {
    use super::*;

    #[test]
    fn both_devices_have_five_check_values() {
        assert_eq!(check_values("fia20").len(), 5);
        assert_eq!(check_values("fia6").len(), 5);
        assert_eq!(check_values("fia20")[0].ext_moved_um, 22.757);
        assert!(check_values("fia9").is_empty());
    }
}
