//! The `InchwormPlant` FMU as a master sees it (SPEC 5): its inputs and outputs by name,
//! and an open-loop run of a gait sequence through it.

use std::io::Write;

use crate::fmu::{CsFmu, FmuError, VarType};
use crate::gait::{self, Dac, RawMeasurements, Step, SAMPLES_PER_STEP, SAMPLE_PERIOD_S};

/// The DAC inputs (V), in the order of [`Dac`]'s fields.
pub const INPUTS: [&str; 3] = ["dac_earth", "dac_nonearth", "dac_extension"];
const REAL_OUTPUTS: [&str; 6] = [
    "encoder_position",
    "runner_position",
    "extension",
    "voltage_earth",
    "voltage_nonearth",
    "voltage_extension",
];
const INTEGER_OUTPUTS: [&str; 3] = ["encoder_counts", "mode", "slip_events"];

/// The plant's outputs at one communication point (SI units, as the FMU gives them).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outputs {
    pub encoder_counts: i32,
    /// Encoder reading (m): counts × `q_enc`.
    pub encoder_position: f64,
    /// True runner position (m).
    pub runner_position: f64,
    /// Extension stack elongation (m).
    pub extension: f64,
    /// PZT voltages after the analog chain (V).
    pub voltage_earth: f64,
    pub voltage_nonearth: f64,
    pub voltage_extension: f64,
    /// 1 HOLD, 2 LOCKED, 3 DRIVE, 4 FREE (SPEC 2.2).
    pub mode: i32,
    /// Entries into FREE so far.
    pub slip_events: i32,
}

/// The name SPEC 2.2 gives mode `m`.
pub fn mode_name(m: i32) -> &'static str {
    match m {
        1 => "HOLD",
        2 => "LOCKED",
        3 => "DRIVE",
        4 => "FREE",
        _ => "?",
    }
}

/// A plant FMU instance, initialized and ready to step from t = 0.
pub struct Plant {
    fmu: CsFmu,
    inputs: Vec<u32>,
    reals: Vec<u32>,
    integers: Vec<u32>,
    /// Encoder resolution (m), the FMU's `q_enc` parameter.
    pub q_enc: f64,
}

impl Plant {
    /// Resolves the SPEC 5 variables (a missing or mistyped one is an error naming it) and
    /// initializes the FMU with its default parameters from t = 0.
    pub fn new(mut fmu: CsFmu) -> Result<Self, FmuError> {
        let inputs = fmu.vrs_of(&INPUTS, VarType::Real)?;
        let reals = fmu.vrs_of(&REAL_OUTPUTS, VarType::Real)?;
        let integers = fmu.vrs_of(&INTEGER_OUTPUTS, VarType::Integer)?;
        fmu.enter_initialization(None, 0.0, None)?;
        fmu.exit_initialization()?;
        let q_enc = fmu.real("q_enc")?;
        Ok(Self { fmu, inputs, reals, integers, q_enc })
    }

    pub fn time(&self) -> f64 {
        self.fmu.time()
    }

    pub fn outputs(&mut self) -> Result<Outputs, FmuError> {
        let mut r = [0.0; 6];
        let mut i = [0; 3];
        self.fmu.get_real(&self.reals, &mut r)?;
        self.fmu.get_integer(&self.integers, &mut i)?;
        Ok(Outputs {
            encoder_counts: i[0],
            encoder_position: r[0],
            runner_position: r[1],
            extension: r[2],
            voltage_earth: r[3],
            voltage_nonearth: r[4],
            voltage_extension: r[5],
            mode: i[1],
            slip_events: i[2],
        })
    }

    /// Holds `dac` over one controller sample (one 2 ms `fmi2DoStep`).
    pub fn step(&mut self, dac: Dac) -> Result<(), FmuError> {
        self.fmu.set_real(&self.inputs, &[dac.earth, dac.nonearth, dac.extension])?;
        self.fmu.do_step(SAMPLE_PERIOD_S)
    }

    pub fn terminate(mut self) -> Result<(), FmuError> {
        self.fmu.terminate()
    }
}

/// One communication point of a run: the outputs at `time`, and the DAC volts held from
/// `time` over the next sample (what a master's result file holds at that time).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    pub time: f64,
    pub dac: Dac,
    pub out: Outputs,
}

/// An open-loop run of a sequence of steps from rest.
pub struct GaitRun {
    pub steps: Vec<Step>,
    /// `steps.len() · 100 + 1` points: t = 0 (at rest) and the end of every sample.
    pub samples: Vec<Sample>,
    /// Encoder resolution (m).
    pub q_enc: f64,
}

impl GaitRun {
    /// Drives `plant` through `steps`, 100 samples each.
    pub fn run(plant: &mut Plant, steps: &[Step]) -> Result<Self, FmuError> {
        let dacs: Vec<Dac> = steps.iter().flat_map(|s| s.samples().collect::<Vec<_>>()).collect();
        let mut samples = Vec::with_capacity(dacs.len() + 1);
        let mut out = plant.outputs()?;
        for &dac in &dacs {
            samples.push(Sample { time: plant.time(), dac, out });
            plant.step(dac)?;
            out = plant.outputs()?;
        }
        // The sequence ends parked and nothing is commanded after it: the controller idles.
        samples.push(Sample { time: plant.time(), dac: Dac::IDLE, out });
        Ok(Self { steps: steps.to_vec(), samples, q_enc: plant.q_enc })
    }

    /// SPEC 3.3 for step `i` (0-based), in metres: `w_enc(k)` is the encoder at the end of
    /// sample k of that step.
    pub fn measurements(&self, i: usize) -> RawMeasurements {
        let first = i * SAMPLES_PER_STEP + 1;
        let enc: Vec<f64> = self.samples[first..first + SAMPLES_PER_STEP]
            .iter()
            .map(|s| s.out.encoder_counts as f64 * self.q_enc)
            .collect();
        gait::raw_measurements(&self.steps[i], &enc)
    }

    /// Writes the run as CSV: one row per communication point, SI units (s, V, m), the
    /// DAC volts being those held from that time on, the outputs those at that time.
    pub fn write_csv(&self, w: &mut impl Write) -> std::io::Result<()> {
        writeln!(
            w,
            "time,dac_earth,dac_nonearth,dac_extension,encoder_counts,encoder_position,runner_position,extension,\
             voltage_earth,voltage_nonearth,voltage_extension,mode,slip_events"
        )?;
        for s in &self.samples {
            let o = &s.out;
            writeln!(
                w,
                // Times are on the 2 ms grid: three decimals print them exactly, where `k · h`
                // in binary would show as 0.30000000000000004.
                "{:.3},{},{},{},{},{},{},{},{},{},{},{},{}",
                s.time,
                real(s.dac.earth),
                real(s.dac.nonearth),
                real(s.dac.extension),
                o.encoder_counts,
                real(o.encoder_position),
                real(o.runner_position),
                real(o.extension),
                real(o.voltage_earth),
                real(o.voltage_nonearth),
                real(o.voltage_extension),
                o.mode,
                o.slip_events
            )?;
        }
        Ok(())
    }
}

/// Shortest text that reads back as the same `f64`, in exponent form where plain decimals
/// would be long runs of zeros (positions in metres, voltages decaying toward 0).
fn real(x: f64) -> String {
    if x == 0.0 || (1e-3..1e9).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}
