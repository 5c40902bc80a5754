//! The stepping gait of SPEC section 3 and its raw measurements, plus the SPEC 2.9 check
//! sequence and values.
//!
//! This is the open-loop gait the `inchworm gait` command drives the plant FMU with. The
//! controller crate will own the canonical gait once it exists; until then the table below
//! is the one place the CLI takes it from.

/// Controller sample period `T_s` (s), SPEC 3.1.
pub const SAMPLE_PERIOD_S: f64 = 0.002;
/// Samples per step (`T_sp = 100 · T_s = 0.2 s`), SPEC 3.1.
pub const SAMPLES_PER_STEP: usize = 100;
/// Full-scale DAC output (V).
pub const DAC_FULL_SCALE_V: f64 = 10.0;

/// First sample (1-based) of each of the seven segments, SPEC 3.2.
pub const SEGMENT_STARTS: [usize; 7] = [1, 15, 30, 44, 59, 72, 87];

/// Averaging windows (1-based, inclusive) giving `s1..s7` and `e1..e7`, SPEC 3.3.
pub const MEASUREMENT_WINDOWS: [(usize, usize); 7] =
    [(9, 13), (24, 28), (38, 42), (53, 57), (66, 70), (81, 85), (95, 99)];

/// Per-segment levels of SPEC 3.2 as fractions of full scale. Brakes are 0 or 1; the
/// extension column is multiplied by `y` (forward) or `|y|` (backward).
struct Table {
    earth: [f64; 7],
    nonearth: [f64; 7],
    extension: [f64; 7],
}

const FORWARD: Table = Table {
    earth: [0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0],
    nonearth: [0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0],
    extension: [0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0],
};

const BACKWARD: Table = Table {
    earth: [0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0],
    nonearth: [0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 0.0],
    extension: [0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0],
};

/// DAC output volts of the three channels, held over one sample.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Dac {
    pub earth: f64,
    pub nonearth: f64,
    pub extension: f64,
}

impl Dac {
    /// All channels at 0 V: the parked (idle) sample.
    pub const IDLE: Dac = Dac {
        earth: 0.0,
        nonearth: 0.0,
        extension: 0.0,
    };
}

/// Direction of a step: the sign of its amplitude picks the gait.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    Forward,
    Backward,
}

/// One step of the gait with amplitude `y` in [−1, 1] (a full step is ±1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    amplitude: f64,
}

impl Step {
    /// A step of amplitude `y`. `y ≥ 0` runs the forward gait (`y = 0` cycles the brakes
    /// with the extension unpowered), `y < 0` the backward gait with `a = |y|`.
    pub fn new(y: f64) -> Result<Self, String> {
        if !y.is_finite() || y.abs() > 1.0 {
            return Err(format!("step amplitude {y} is outside [-1, 1]"));
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

    /// Segment (0-based) of 1-based sample `k`.
    fn segment(k: usize) -> usize {
        assert!(
            (1..=SAMPLES_PER_STEP).contains(&k),
            "sample {k} is outside 1..={SAMPLES_PER_STEP}"
        );
        SEGMENT_STARTS
            .iter()
            .rposition(|&s| s <= k)
            .expect("segment 1 starts at sample 1")
    }

    /// Commanded extension fraction `w_ext(k)` of 1-based sample `k`: DAC volts / 10,
    /// before quantization, positive in both gaits (SPEC 3.1, 4).
    pub fn extension_fraction(&self, k: usize) -> f64 {
        let seg = Self::segment(k);
        match self.direction() {
            Direction::Forward => FORWARD.extension[seg] * self.amplitude,
            Direction::Backward => BACKWARD.extension[seg] * self.amplitude.abs(),
        }
    }

    /// DAC volts held during 1-based sample `k` of this step (SPEC 3.2, unquantized).
    pub fn dac(&self, k: usize) -> Dac {
        let seg = Self::segment(k);
        let table = match self.direction() {
            Direction::Forward => &FORWARD,
            Direction::Backward => &BACKWARD,
        };
        Dac {
            earth: table.earth[seg] * DAC_FULL_SCALE_V,
            nonearth: table.nonearth[seg] * DAC_FULL_SCALE_V,
            extension: self.extension_fraction(k) * DAC_FULL_SCALE_V,
        }
    }

    /// The 100 DAC samples of this step, sample 1 first.
    pub fn samples(&self) -> impl Iterator<Item = Dac> + '_ {
        (1..=SAMPLES_PER_STEP).map(|k| self.dac(k))
    }
}

/// The raw measurements of one step (SPEC 3.3), in the unit of the encoder samples given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawMeasurements {
    /// Segment averages `s1..s7` of the encoder.
    pub s: [f64; 7],
    /// Segment averages `e1..e7` of the commanded extension fraction.
    pub e: [f64; 7],
    /// Commanded extension: forward `e4 − e3`, backward `e5 − e4` (negative).
    pub ext_cmd: f64,
    /// Measured extension: forward `s4 − s3`, backward `s5 − s4`.
    pub ext_moved: f64,
    /// Brake disturbance: `(s7 − s1) − EXT_moved`.
    pub bd: f64,
}

impl RawMeasurements {
    /// The runner position after the step (the `s7` average).
    pub fn position_after(&self) -> f64 {
        self.s[6]
    }
}

fn window_averages(samples: &[f64]) -> [f64; 7] {
    MEASUREMENT_WINDOWS.map(|(a, b)| samples[a - 1..b].iter().sum::<f64>() / (b - a + 1) as f64)
}

/// SPEC 3.3 from the encoder samples `w_enc(1..=100)` of one step (`enc[k − 1]` is the
/// reading at the end of sample k, in any length unit) and the step that was commanded.
pub fn raw_measurements(step: &Step, enc: &[f64]) -> RawMeasurements {
    assert_eq!(
        enc.len(),
        SAMPLES_PER_STEP,
        "raw_measurements needs the {SAMPLES_PER_STEP} samples of one step"
    );
    let ext: Vec<f64> = (1..=SAMPLES_PER_STEP).map(|k| step.extension_fraction(k)).collect();
    let s = window_averages(enc);
    let e = window_averages(&ext);
    // The runner rides on the non-earth brake (DRIVE: earth open, non-earth closed) while
    // the extension changes: it rises between the s3 and s4 windows forward and falls
    // between s4 and s5 backward. The rest of s7 − s1 comes from the brake events: the
    // brake disturbance.
    let (ext_cmd, ext_moved) = match step.direction() {
        Direction::Forward => (e[3] - e[2], s[3] - s[2]),
        Direction::Backward => (e[4] - e[3], s[4] - s[3]),
    };
    RawMeasurements {
        s,
        e,
        ext_cmd,
        ext_moved,
        bd: (s[6] - s[0]) - ext_moved,
    }
}

/// SPEC 2.9: the five step amplitudes of the check run (fia20, from rest).
pub const CHECK_AMPLITUDES: [f64; 5] = [1.0, 1.0, -1.0, 0.3, -0.3];

/// SPEC 2.9 check values of one step, µm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CheckValues {
    pub ext_moved_um: f64,
    pub bd_um: f64,
    pub position_after_um: f64,
}

/// SPEC 2.9: the independent reference integration's raw measurements, one per step of
/// [`CHECK_AMPLITUDES`].
pub const CHECK_VALUES: [CheckValues; 5] = [
    CheckValues {
        ext_moved_um: 18.210,
        bd_um: 4.685,
        position_after_um: 22.895,
    },
    CheckValues {
        ext_moved_um: 19.383,
        bd_um: 4.853,
        position_after_um: 47.130,
    },
    CheckValues {
        ext_moved_um: -19.342,
        bd_um: 3.902,
        position_after_um: 31.691,
    },
    CheckValues {
        ext_moved_um: 6.633,
        bd_um: 4.687,
        position_after_um: 43.010,
    },
    CheckValues {
        ext_moved_um: -6.690,
        bd_um: 4.244,
        position_after_um: 40.565,
    },
];

/// SPEC 2.9: a correct plant matches every check value within this (µm).
pub const CHECK_TOLERANCE_UM: f64 = 0.010;

/// The SPEC 2.9 check sequence repeated `repeat` times.
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
    fn segments_start_where_spec_3_2_says() {
        let starts: Vec<usize> = (1..=SAMPLES_PER_STEP)
            .filter(|&k| k == 1 || Step::segment(k) != Step::segment(k - 1))
            .collect();
        assert_eq!(starts, SEGMENT_STARTS);
        assert_eq!(Step::segment(100), 6);
    }

    #[test]
    fn both_gaits_start_and_end_parked() {
        for y in [1.0, 0.3, -0.3, -1.0] {
            let s = Step::new(y).unwrap();
            assert_eq!(s.dac(1), Dac::IDLE, "y = {y}: sample 1");
            assert_eq!(s.dac(100), Dac::IDLE, "y = {y}: sample 100");
        }
    }

    #[test]
    fn out_of_range_amplitudes_are_refused() {
        assert!(Step::new(1.01).is_err());
        assert!(Step::new(f64::NAN).is_err());
        assert!(Step::new(-1.0).is_ok());
    }

    /// The generated check sequence must be exactly the DAC columns of the reference trace
    /// that came with the SPEC (the plant test replays that file, the CLI generates it).
    #[test]
    fn check_sequence_reproduces_the_reference_trace_inputs() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../shared/reference/plant-check-trace-fia20.csv"
        );
        let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("reading {path}: {e}"));
        let rows: Vec<Vec<f64>> = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').take(4).map(|f| f.parse().unwrap()).collect())
            .collect();
        let dacs: Vec<Dac> = check_sequence(1)
            .iter()
            .flat_map(|s| s.samples().collect::<Vec<_>>())
            .collect();
        assert_eq!(rows.len(), dacs.len());
        for (k, (r, d)) in rows.iter().zip(&dacs).enumerate() {
            assert!(
                (r[0] - k as f64 * SAMPLE_PERIOD_S).abs() < 1e-9,
                "row {k}: time {}",
                r[0]
            );
            for (name, want, got) in [
                ("dac_earth", r[1], d.earth),
                ("dac_nonearth", r[2], d.nonearth),
                ("dac_extension", r[3], d.extension),
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
