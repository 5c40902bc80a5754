//! FMI 3.0 clocks on an [`Instance`] made with event mode or for Scheduled Execution
//! (reached through [`crate::CsFmu`] and [`crate::SeFmu`]): set and read clocks, and their
//! intervals and shifts as the FMU reports them. The description's declarations are
//! [`crate::ModelDescription::clocks`].

use crate::backend::clocks::{Clocks, Interval};
use crate::backend::Calls;
use crate::{FmuError, Instance};

impl Instance {
    /// The clock calls, or why the instance has none.
    fn clock_calls(&mut self, function: &'static str) -> Result<(&Clocks, &mut Calls), FmuError> {
        self.cx.alive(function)?;
        match self.backend.clocks() {
            Some((clocks, _)) => Ok((clocks, &mut self.cx)),
            None => Err(FmuError::Unsupported {
                model: self.cx.model.clone(),
                function,
                why: match self.description.is_fmi3() {
                    true => "clocks are read and set on an instance made with event mode or for Scheduled Execution".into(),
                    false => "FMI 2.0 has no clocks".into(),
                },
            }),
        }
    }

    /// Checks that `vrs` are clocks of the description (and `values` as many).
    fn check_clocks(&self, function: &'static str, vrs: &[u32], n: usize) -> Result<(), FmuError> {
        if vrs.len() != n {
            let m = format!("{} clocks and {n} values", vrs.len());
            return Err(self.cx.invalid(function, m));
        }
        match vrs.iter().find(|&&vr| self.description.clock(vr).is_none()) {
            Some(vr) => {
                Err(self.cx.invalid(function, format!("value reference {vr} is no <Clock>")))
            }
            None => Ok(()),
        }
    }

    /// `fmi3SetClock`: activates (true) or deactivates the input clocks `vrs`, in event mode.
    pub fn set_clocks(&mut self, vrs: &[u32], values: &[bool]) -> Result<(), FmuError> {
        const F: &str = "fmi3SetClock";
        self.check_clocks(F, vrs, values.len())?;
        let (clocks, cx) = self.clock_calls(F)?;
        clocks.set_clocks(cx, vrs, values)
    }

    /// `fmi3GetClock`: whether the output clocks `vrs` ticked (reading one deactivates it).
    pub fn get_clocks(&mut self, vrs: &[u32], out: &mut [bool]) -> Result<(), FmuError> {
        const F: &str = "fmi3GetClock";
        self.check_clocks(F, vrs, out.len())?;
        let (clocks, cx) = self.clock_calls(F)?;
        clocks.get_clocks(cx, vrs, out)
    }

    /// `fmi3GetIntervalDecimal` of the clocks `vrs`: each interval with its qualifier.
    pub fn intervals(&mut self, vrs: &[u32]) -> Result<Vec<Interval>, FmuError> {
        const F: &str = "fmi3GetIntervalDecimal";
        self.check_clocks(F, vrs, vrs.len())?;
        let (clocks, cx) = self.clock_calls(F)?;
        clocks.intervals(cx, vrs)
    }

    /// `fmi3GetShiftDecimal` of the clocks `vrs`: the first tick's offset from the start.
    pub fn shifts(&mut self, vrs: &[u32]) -> Result<Vec<f64>, FmuError> {
        const F: &str = "fmi3GetShiftDecimal";
        self.check_clocks(F, vrs, vrs.len())?;
        let (clocks, cx) = self.clock_calls(F)?;
        clocks.shifts(cx, vrs)
    }
}
