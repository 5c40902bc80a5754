//! The `InchwormPlant` FMU as a master sees it (docs/model.md §5): its inputs and outputs by name,
//! and an open-loop run of a gait sequence through it.

use std::io::Write;

use inchworm_fmi_export::Var;
use inchworm_fmu_models::PlantFmu;
use inchworm_plant::PlantParams;
pub use inchworm_plant::{Dac, Mode, Outputs};

use crate::gait::{self, RawMeasurements, Step, SAMPLES_PER_STEP, SAMPLE_PERIOD_S};
use inchworm_cosim::fmu::{CsFmu, FmuError, VarType};

/// What a run through the plant FMU reports: the import layer's error as it is, or an
/// output outside the plant's interface.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    #[error(transparent)]
    Fmu(#[from] FmuError),
    /// The plant FMU's `mode` is none of its four.
    #[error("the plant FMU gave mode {0}, not 1–4")]
    Mode(i32),
    /// The plant FMU's `slip_events` is negative.
    #[error("the plant FMU gave {0} slip events")]
    SlipEvents(i32),
}

const INTEGER_OUTPUTS: [Var<PlantFmu>; 3] =
    [PlantFmu::ENCODER_COUNTS, PlantFmu::MODE, PlantFmu::SLIP_EVENTS];
const BOOLEAN_OUTPUTS: [Var<PlantFmu>; 2] = [PlantFmu::EARTH_CLOSED, PlantFmu::NONEARTH_CLOSED];

/// The plant's `mode` output decoded: the FMU sends [`Mode`]'s discriminant.
pub fn mode(code: i32) -> Option<Mode> {
    [Mode::Hold, Mode::Locked, Mode::Drive, Mode::Free].into_iter().find(|m| *m as i32 == code)
}

/// The plant's parameters as the FMU names them (docs/model.md §2.8), every one of them, as
/// `plant.<name>` values for the master: the FMU runs exactly `p`, whatever its start
/// values are.
pub fn parameters(p: &PlantParams) -> Vec<(String, String)> {
    crate::component_parameters("plant", &PlantFmu::with_params(p.clone()))
}

/// A plant FMU instance, initialized and ready to step from t = 0.
pub struct Plant {
    fmu: CsFmu,
    inputs: Vec<u32>,
    reals: Vec<u32>,
    integers: Vec<u32>,
    booleans: Vec<u32>,
    /// Encoder resolution (m), the FMU's `q_enc` parameter.
    pub q_enc: f64,
}

impl Plant {
    /// Resolves the docs/model.md §5 variables (a missing or mistyped one is an error naming it) and
    /// initializes the FMU with its default parameters from t = 0.
    pub fn new(mut fmu: CsFmu) -> Result<Self, FmuError> {
        let vrs_of = |vars: &[Var<PlantFmu>], ty| {
            fmu.vrs_of(&vars.iter().map(|v| v.name()).collect::<Vec<_>>(), ty)
        };
        let inputs = vrs_of(&PlantFmu::DAC_INPUTS, VarType::Real)?;
        let reals = vrs_of(&PlantFmu::REAL_OUTPUTS, VarType::Real)?;
        let integers = vrs_of(&INTEGER_OUTPUTS, VarType::Integer)?;
        let booleans = vrs_of(&BOOLEAN_OUTPUTS, VarType::Boolean)?;
        fmu.enter_initialization(None, 0.0, None)?;
        fmu.exit_initialization()?;
        let q_enc = fmu.real(PlantFmu::var(inchworm_plant::PlantParams::Q_ENC).name())?;
        Ok(Self { fmu, inputs, reals, integers, booleans, q_enc })
    }

    pub fn time(&self) -> f64 {
        self.fmu.time()
    }

    pub fn outputs(&mut self) -> Result<Outputs, Error> {
        let mut r = [0.0; 6];
        let mut i = [0; 3];
        let mut b = [false; 2];
        self.fmu.get_real(&self.reals, &mut r)?;
        self.fmu.get_integer(&self.integers, &mut i)?;
        self.fmu.get_boolean(&self.booleans, &mut b)?;
        Ok(Outputs {
            encoder_counts: i64::from(i[0]),
            encoder_position: r[0],
            runner_position: r[1],
            extension: r[2],
            voltage_earth: r[3],
            voltage_nonearth: r[4],
            voltage_extension: r[5],
            mode: mode(i[1]).ok_or(Error::Mode(i[1]))?,
            earth_closed: b[0],
            nonearth_closed: b[1],
            slip_events: u32::try_from(i[2]).map_err(|_| Error::SlipEvents(i[2]))?,
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
    pub fn run(plant: &mut Plant, steps: &[Step]) -> Result<Self, Error> {
        let dacs: Vec<Dac> = steps.iter().flat_map(|s| s.samples().collect::<Vec<_>>()).collect();
        let mut samples = Vec::with_capacity(dacs.len() + 1);
        let mut out = plant.outputs()?;
        for &dac in &dacs {
            samples.push(Sample { time: plant.time(), dac, out });
            plant.step(dac)?;
            out = plant.outputs()?;
        }
        // The sequence ends parked and nothing is commanded after it: the controller idles.
        samples.push(Sample { time: plant.time(), dac: Dac::default(), out });
        Ok(Self { steps: steps.to_vec(), samples, q_enc: plant.q_enc })
    }

    /// docs/model.md §3.3 for step `i` (0-based), in metres: `w_enc(k)` is the encoder at the end of
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
    pub fn write_csv(&self, w: &mut dyn Write) -> std::io::Result<()> {
        let mut header = vec!["time"];
        header.extend(PlantFmu::DAC_INPUTS.map(|v| v.name()));
        header.extend(
            [
                PlantFmu::ENCODER_COUNTS,
                PlantFmu::ENCODER_POSITION,
                PlantFmu::RUNNER_POSITION,
                PlantFmu::EXTENSION,
                PlantFmu::VOLTAGE_EARTH,
                PlantFmu::VOLTAGE_NONEARTH,
                PlantFmu::VOLTAGE_EXTENSION,
                PlantFmu::MODE,
                PlantFmu::SLIP_EVENTS,
            ]
            .map(|v| v.name()),
        );
        writeln!(w, "{}", header.join(","))?;
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
                o.mode as i32,
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
