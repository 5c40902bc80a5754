//! The FMUs behind the bridge: the plant FMU as the virtual board's mechanism, the
//! controller FMU as the controller side's compensator, both through the same import layer
//! the master uses, with the same `--param NAME=VALUE` start values.

use std::path::Path;

use inchworm_bridge::{Compensator, Mechanism, ModelError, PERIOD};
use inchworm_controller::volts_of_code;

use inchworm_cosim::fmu::{CsFmu, VarType};
use inchworm_cosim::master::set_param;

use crate::Error;

fn start(path: &Path, instance: &str, params: &[(String, String)]) -> Result<CsFmu, Error> {
    let mut fmu = CsFmu::load(path, instance, false)?;
    initialise(&mut fmu, path, params)?;
    Ok(fmu)
}

fn initialise(fmu: &mut CsFmu, path: &Path, params: &[(String, String)]) -> Result<(), Error> {
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
        let dac = fmu.vrs_of(&["dac_earth", "dac_nonearth", "dac_extension"], VarType::Real)?;
        let encoder = fmu.vrs_of(&["encoder_counts"], VarType::Integer)?;
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
        let codes = fmu.vrs_of(
            &["dac_earth_code", "dac_nonearth_code", "dac_extension_code"],
            VarType::Integer,
        )?;
        let encoder = fmu.vrs_of(&["encoder_counts"], VarType::Integer)?;
        let reference = fmu.vrs_of(&["reference"], VarType::Real)?;
        Ok(FmuCompensator { fmu, codes, encoder, reference })
    }
}

impl Compensator for FmuCompensator {
    fn codes(&mut self) -> Result<[u16; 3], ModelError> {
        let mut c = [0i32; 3];
        self.fmu.get_integer(&self.codes, &mut c)?;
        let mut out = [0u16; 3];
        for (o, v) in out.iter_mut().zip(c) {
            *o = u16::try_from(v).map_err(|_| Error::DacCode(v))?;
        }
        Ok(out)
    }

    fn step(&mut self, counts: i32, reference: f64) -> Result<(), ModelError> {
        self.fmu.set_integer(&self.encoder, &[counts])?;
        self.fmu.set_real(&self.reference, &[reference])?;
        Ok(self.fmu.do_step(PERIOD.as_secs_f64())?)
    }
}

/// The `param=NAME=VALUE` lines of a log's meta record, to replay with the same start values.
pub fn params_from_meta(meta: &str) -> Vec<(String, String)> {
    meta.lines()
        .filter_map(|l| l.strip_prefix("param="))
        .filter_map(|p| p.split_once('=').map(|(a, b)| (a.to_string(), b.to_string())))
        .collect()
}
