//! A model the FMUs export (`inchworm-fmu-models`), driven in-process through its
//! [`Model`] trait, every variable named through the model's own table: the same code the
//! FMU runs, with no FFI between. Values go through what the export layer applies to a
//! master's `fmi2SetReal` (non-finite refused, a value past its declared range clamped), and
//! steps through its `check_step`, so a native client computes what the FMU computes.

use inchworm_fmi_export::{row_named, Kind, Model, Row, StepLog, Value};

use crate::Error;

pub struct Driven<M: Model> {
    pub(crate) model: M,
    client: String,
    log: StepLog,
}

impl<M: Model> Driven<M> {
    /// A fresh instance, `client` naming it in errors.
    pub fn new(client: impl Into<String>) -> Self {
        Driven { model: M::new(), client: client.into(), log: StepLog::new(false) }
    }

    pub fn client(&self) -> &str {
        &self.client
    }

    /// The table row of `name`.
    pub fn variable(&self, name: &str) -> Result<&'static Row<M>, Error> {
        row_named::<M>(name).ok_or_else(|| Error::UnknownVariable {
            client: self.client.clone(),
            name: name.to_owned(),
            known: M::variables().map(|v| v.name).collect::<Vec<_>>().join(", "),
        })
    }

    fn refused(&self, message: String) -> Error {
        Error::Model { client: self.client.clone(), message }
    }

    /// Sets a variable by name: a Real through the layer's admission, an Integer or a
    /// Boolean from a whole number (a Boolean from 0 or 1).
    pub fn set(&mut self, name: &str, value: f64) -> Result<(), Error> {
        let row = self.variable(name)?;
        self.set_var(row, value)
    }

    pub(crate) fn set_var(&mut self, row: &'static Row<M>, value: f64) -> Result<(), Error> {
        let v = &row.var;
        let value = match v.kind {
            Kind::Real => {
                let current = row.get(&self.model).real();
                let (x, _clamped) = v.admit_real(value, current).map_err(|m| self.refused(m))?;
                Value::Real(x)
            }
            Kind::Integer if value.fract() == 0.0 && value.abs() <= f64::from(i32::MAX) => {
                Value::Integer(value as i32)
            }
            Kind::Boolean if value == 0.0 || value == 1.0 => Value::Boolean(value == 1.0),
            kind => {
                let message = format!("{} is {kind:?}: {value} is not one of its values", v.name);
                return Err(self.refused(message));
            }
        };
        row.set(&mut self.model, value).map_err(|m| self.refused(m))
    }

    /// Reads a variable by name as `f64` (an Integer exactly, a Boolean as 0 or 1).
    pub fn get(&self, name: &str) -> Result<f64, Error> {
        Ok(self.get_var(self.variable(name)?))
    }

    pub(crate) fn get_var(&self, row: &'static Row<M>) -> f64 {
        row.get(&self.model).real()
    }

    /// Leaves initialization at `start_time`: the model checks its parameters.
    pub fn exit_initialization(&mut self, start_time: f64) -> Result<(), Error> {
        self.model.exit_initialization(start_time).map_err(|m| self.refused(m))
    }

    /// One step from `t` of `h` seconds.
    pub fn step(&mut self, t: f64, h: f64) -> Result<(), Error> {
        self.model.check_step(t, h).map_err(|m| self.refused(m))?;
        let r = self.model.do_step(t, h, &mut self.log);
        r.map_err(|m| self.refused(format!("step from t = {t} s: {m}")))
    }
}

/// A value as an SSP parameter binding writes it: `true`, `false` or a number.
pub fn ssp_value(text: &str) -> Option<f64> {
    match text.trim() {
        "true" => Some(1.0),
        "false" => Some(0.0),
        t => t.parse().ok(),
    }
}
