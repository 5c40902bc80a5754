//! The FMUs behind the bridge: the plant FMU as the virtual board's mechanism, the
//! controller FMU as the controller side's compensator (Co-Simulation, or Scheduled
//! Execution on its sample clock), all through the same import layer the master uses, with
//! the same `--param NAME=VALUE` start values.

use std::path::Path;

use inchworm_bridge::{Compensator, Mechanism, ModelError, Schedule, PERIOD};
use inchworm_controller::volts_of_code;
use inchworm_fmi_export::same_time;
use inchworm_fmu_models::{ControllerFmu, PlantFmu};

use inchworm_cosim::fmu::{Causality, Clock, CsFmu, FmuError, Instance, SeFmu, VarType};
use inchworm_cosim::master::set_param;

/// What loading the bridge's FMUs reports: the import layer's error as it is, a
/// `--param` the FMU refused, or an FMU without the interface the bridge drives.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    #[error(transparent)]
    Fmu(#[from] FmuError),
    /// A `--param NAME=VALUE` the FMU at `path` refused.
    #[error("{}: parameter `{name}`: {source}", path.display())]
    Parameter {
        path: std::path::PathBuf,
        name: String,
        #[source]
        source: Box<inchworm_cosim::Error>,
    },
    /// The controller FMU lacks a clock the bridge drives it by (Scheduled Execution).
    #[error("{}: no {causality} clock `{name}` in modelDescription.xml (the bridge activates `sample_clock` and reads `gait_step`)", path.display())]
    NoClock { path: std::path::PathBuf, name: &'static str, causality: Causality },
    /// The controller FMU's sample clock does not tick at the bridge's period.
    #[error("{}: the clock `{name}` ticks every {} s; the bridge ticks every {period} s", path.display(), interval.map_or("(no intervalDecimal)".to_string(), |i| i.to_string()))]
    ClockInterval {
        path: std::path::PathBuf,
        name: &'static str,
        interval: Option<f64>,
        period: f64,
    },
    /// The controller FMU's DAC code does not fit the wire's 16 bits.
    #[error("the controller FMU gave DAC code {0}, outside 0–65535")]
    DacCode(i32),
}

fn start(path: &Path, instance: &str, params: &[(String, String)]) -> Result<CsFmu, Error> {
    let mut fmu = CsFmu::load(path, instance, false)?;
    initialise(&mut fmu, path, params)?;
    Ok(fmu)
}

fn initialise(fmu: &mut Instance, path: &Path, params: &[(String, String)]) -> Result<(), Error> {
    fmu.enter_initialization(None, 0.0, None)?;
    for (name, value) in params {
        set_param(fmu, name, value).map_err(|source| Error::Parameter {
            path: path.to_path_buf(),
            name: name.clone(),
            source: Box::new(source),
        })?;
    }
    Ok(fmu.exit_initialization()?)
}

/// `InchwormPlant.fmu` (or any FMU with its interface) as the board's mechanism.
pub struct FmuMechanism {
    fmu: CsFmu,
    dac: Vec<u32>,
    encoder: Vec<u32>,
    /// Kept to re-initialise with the same start values (`--fresh-plant-per-session`).
    path: std::path::PathBuf,
    params: Vec<(String, String)>,
}

impl FmuMechanism {
    pub fn load(path: &Path, params: &[(String, String)]) -> Result<FmuMechanism, Error> {
        let fmu = start(path, "plant", params)?;
        let dac = fmu.vrs_of(&PlantFmu::DAC_INPUTS.map(|v| v.name()), VarType::Real)?;
        let encoder = fmu.vrs_of(&[PlantFmu::ENCODER_COUNTS.name()], VarType::Integer)?;
        Ok(FmuMechanism { fmu, dac, encoder, path: path.to_path_buf(), params: params.to_vec() })
    }
}

impl Mechanism for FmuMechanism {
    fn counts(&mut self) -> Result<i32, ModelError> {
        let mut c = [0];
        self.fmu.get_integer(&self.encoder, &mut c)?;
        Ok(c[0])
    }

    fn step(&mut self, codes: [u16; 3]) -> Result<i32, ModelError> {
        self.fmu.set_real(&self.dac, &codes.map(volts_of_code))?;
        self.fmu.do_step(PERIOD.as_secs_f64())?;
        self.counts()
    }

    fn reinitialise(&mut self) -> Result<(), ModelError> {
        self.fmu.reset()?;
        Ok(initialise(&mut self.fmu, &self.path, &self.params)?)
    }
}

/// `InchwormController.fmu` as the bridge's compensator: its `dac_*_code` outputs go on
/// the wire, the board's count goes into `encoder_counts`.
pub struct FmuCompensator {
    fmu: CsFmu,
    codes: Vec<u32>,
    encoder: Vec<u32>,
    reference: Vec<u32>,
}

impl FmuCompensator {
    pub fn load(path: &Path, params: &[(String, String)]) -> Result<FmuCompensator, Error> {
        let fmu = start(path, "controller", params)?;
        let (codes, encoder, reference) = controller_vrs(&fmu)?;
        Ok(FmuCompensator { fmu, codes, encoder, reference })
    }
}

/// The value references of the controller FMU's DAC codes, encoder input and reference,
/// by the names of its table's rows.
type ControllerVrs = (Vec<u32>, Vec<u32>, Vec<u32>);
fn controller_vrs(fmu: &Instance) -> Result<ControllerVrs, Error> {
    Ok((
        fmu.vrs_of(&ControllerFmu::DAC_CODES.map(|v| v.name()), VarType::Integer)?,
        fmu.vrs_of(&[ControllerFmu::ENCODER_COUNTS.name()], VarType::Integer)?,
        fmu.vrs_of(&[ControllerFmu::REFERENCE.name()], VarType::Real)?,
    ))
}

/// The three DAC code outputs `vrs` of `fmu`, each checked to fit the wire's 16 bits.
fn dac_codes(fmu: &mut Instance, vrs: &[u32]) -> Result<[u16; 3], Error> {
    let mut c = [0i32; 3];
    fmu.get_integer(vrs, &mut c)?;
    let mut out = [0u16; 3];
    for (o, v) in out.iter_mut().zip(c) {
        *o = u16::try_from(v).map_err(|_| Error::DacCode(v))?;
    }
    Ok(out)
}

impl Compensator for FmuCompensator {
    fn codes(&mut self) -> Result<[u16; 3], ModelError> {
        Ok(dac_codes(&mut self.fmu, &self.codes)?)
    }

    fn step(&mut self, counts: i32, reference: f64) -> Result<(), ModelError> {
        self.fmu.set_integer(&self.encoder, &[counts])?;
        self.fmu.set_real(&self.reference, &[reference])?;
        Ok(self.fmu.do_step(PERIOD.as_secs_f64())?)
    }
}

/// `InchwormController.fmu` of FMI 3.0 (or any FMU with its interface and clocks) through
/// Scheduled Execution: each tick sets the count and the reference and activates the
/// partition of the input clock `sample_clock` at the tick's time, which writes the
/// sample of the interval that starts there and latches the inputs
/// ([`Schedule::AtTick`]). The output clock `gait_step` comes back through clockUpdate.
pub struct SeCompensator {
    fmu: SeFmu,
    codes: Vec<u32>,
    encoder: Vec<u32>,
    reference: Vec<u32>,
    sample_clock: u32,
    gait_step: u32,
    /// Activations so far: tick n is at `n × PERIOD` from the start time 0 (counted,
    /// never accumulated).
    ticks: u64,
    /// `gait_step` ticked in the last activation.
    gait_ticked: bool,
}

impl SeCompensator {
    pub fn load(path: &Path, params: &[(String, String)]) -> Result<SeCompensator, Error> {
        let mut fmu = SeFmu::load(path, "controller", false)?;
        initialise(&mut fmu, path, params)?;
        let (codes, encoder, reference) = controller_vrs(&fmu)?;
        // The input clock, whose partition is one 2 ms sample, and the output clock that
        // ticks when a sample ended a gait step and updated the estimator.
        let sample_clock = clock(&fmu, path, ControllerFmu::SAMPLE_CLOCK.name(), Causality::Input)?;
        let gait_step = clock(&fmu, path, ControllerFmu::GAIT_STEP.name(), Causality::Output)?;
        let interval = sample_clock.interval_decimal;
        if interval.is_none_or(|i| !same_time(i, PERIOD.as_secs_f64())) {
            return Err(Error::ClockInterval {
                path: path.to_path_buf(),
                name: ControllerFmu::SAMPLE_CLOCK.name(),
                interval,
                period: PERIOD.as_secs_f64(),
            });
        }
        let (sample_clock, gait_step) = (sample_clock.vr, gait_step.vr);
        Ok(SeCompensator {
            fmu,
            codes,
            encoder,
            reference,
            sample_clock,
            gait_step,
            ticks: 0,
            gait_ticked: false,
        })
    }
}

/// The `<Clock>` `name` of `fmu`, which must have `causality`.
fn clock<'a>(
    fmu: &'a SeFmu,
    path: &Path,
    name: &'static str,
    causality: Causality,
) -> Result<&'a Clock, Error> {
    fmu.description()
        .clocks
        .iter()
        .find(|c| c.name == name && c.causality == causality)
        .ok_or_else(|| Error::NoClock { path: path.to_path_buf(), name, causality })
}

impl Compensator for SeCompensator {
    fn schedule(&self) -> Schedule {
        Schedule::AtTick
    }

    fn codes(&mut self) -> Result<[u16; 3], ModelError> {
        Ok(dac_codes(&mut self.fmu, &self.codes)?)
    }

    fn step(&mut self, counts: i32, reference: f64) -> Result<(), ModelError> {
        self.fmu.set_integer(&self.encoder, &[counts])?;
        self.fmu.set_real(&self.reference, &[reference])?;
        let t = self.ticks as f64 * PERIOD.as_secs_f64();
        let done = self.fmu.activate_model_partition(self.sample_clock, t)?;
        self.ticks += 1;
        self.gait_ticked = false;
        if done.clock_updates > 0 {
            let mut ticked = [false];
            self.fmu.get_clocks(&[self.gait_step], &mut ticked)?;
            self.gait_ticked = ticked[0];
        }
        Ok(())
    }

    fn ticked_clock(&mut self) -> Result<Option<&str>, ModelError> {
        Ok(self.gait_ticked.then_some(ControllerFmu::GAIT_STEP.name()))
    }
}

/// How the bridge drives the controller FMU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interface {
    /// Scheduled Execution if the FMU offers it, else Co-Simulation.
    Auto,
    ScheduledExecution,
    CoSimulation,
}

/// The controller FMU behind the bridge, through the interface it was loaded for.
pub enum FmuController {
    Cs(FmuCompensator),
    Se(SeCompensator),
}

impl FmuController {
    /// Loads `path` for `interface`; [`Interface::Auto`] takes Scheduled Execution when the
    /// FMU declares it (`<ScheduledExecution>`, FMI 3.0), else Co-Simulation.
    pub fn load(
        path: &Path,
        params: &[(String, String)],
        interface: Interface,
    ) -> Result<FmuController, Error> {
        match interface {
            Interface::CoSimulation => Ok(FmuController::Cs(FmuCompensator::load(path, params)?)),
            Interface::ScheduledExecution => {
                Ok(FmuController::Se(SeCompensator::load(path, params)?))
            }
            Interface::Auto => match SeCompensator::load(path, params) {
                Ok(se) => Ok(FmuController::Se(se)),
                Err(Error::Fmu(FmuError::NotOffered { .. })) => {
                    Ok(FmuController::Cs(FmuCompensator::load(path, params)?))
                }
                Err(e) => Err(e),
            },
        }
    }

    /// The interface it runs: `se` or `cs`, as `--interface` names it.
    pub fn interface(&self) -> &'static str {
        match self {
            FmuController::Cs(_) => "cs",
            FmuController::Se(_) => "se",
        }
    }
}

impl Compensator for FmuController {
    fn schedule(&self) -> Schedule {
        match self {
            FmuController::Cs(c) => c.schedule(),
            FmuController::Se(c) => c.schedule(),
        }
    }
    fn codes(&mut self) -> Result<[u16; 3], ModelError> {
        match self {
            FmuController::Cs(c) => c.codes(),
            FmuController::Se(c) => c.codes(),
        }
    }
    fn step(&mut self, counts: i32, reference: f64) -> Result<(), ModelError> {
        match self {
            FmuController::Cs(c) => c.step(counts, reference),
            FmuController::Se(c) => c.step(counts, reference),
        }
    }
    fn ticked_clock(&mut self) -> Result<Option<&str>, ModelError> {
        match self {
            FmuController::Cs(c) => c.ticked_clock(),
            FmuController::Se(c) => c.ticked_clock(),
        }
    }
}

/// The `param=NAME=VALUE` lines of a log's meta record, to replay with the same start values.
pub fn params_from_meta(meta: &str) -> Vec<(String, String)> {
    meta.lines()
        .filter_map(|l| l.strip_prefix("param="))
        .filter_map(|p| p.split_once('=').map(|(a, b)| (a.to_string(), b.to_string())))
        .collect()
}
