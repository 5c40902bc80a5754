//! [`CsFmu`]: an FMU instantiated for Co-Simulation. It owns the [`Instance`] both
//! interfaces share (variables, initialization, FMU state, terminate, reset: its methods
//! are reached through `Deref`) and adds the Co-Simulation calls: `fmi*DoStep` on a fixed
//! communication grid, and the time on it.
//!
//! ```no_run
//! # fn run(path: &std::path::Path) -> Result<(), inchworm_fmi_import::FmuError> {
//! let mut fmu = inchworm_fmi_import::CsFmu::load(path, "plant", false)?;
//! fmu.enter_initialization(None, 0.0, None)?;
//! fmu.exit_initialization()?;
//! fmu.do_step(0.001)?;
//! assert_eq!(fmu.time(), 0.001);
//! # Ok(()) }
//! ```

use std::ops::{Deref, DerefMut};
use std::path::Path;

use crate::{FmuError, Instance};

/// One instantiated Co-Simulation FMU (FMI 2.0 or 3.0), stepped with a fixed
/// communication step.
#[derive(Debug)]
pub struct CsFmu {
    instance: Instance,
}

impl Deref for CsFmu {
    type Target = Instance;
    fn deref(&self) -> &Instance {
        &self.instance
    }
}

impl DerefMut for CsFmu {
    fn deref_mut(&mut self) -> &mut Instance {
        &mut self.instance
    }
}

impl CsFmu {
    /// Unpacks `path`, loads its library (`binaries/<platform>/` of FMI 2.0 or FMI 3.0, by
    /// the description's `fmiVersion`) and instantiates it for Co-Simulation under
    /// `instance_name`. `logging_on` is the FMI `loggingOn` flag (debug messages);
    /// warnings and errors reach the logger either way.
    pub fn load(path: &Path, instance_name: &str, logging_on: bool) -> Result<Self, FmuError> {
        Ok(CsFmu { instance: Instance::load(path, instance_name, (logging_on, |_| false))? })
    }

    /// A Co-Simulation wrapper of `instance`, which was instantiated for Co-Simulation.
    pub(crate) fn wrap(instance: Instance) -> Self {
        debug_assert!(!instance.is_model_exchange());
        CsFmu { instance }
    }

    /// Another Co-Simulation instance of the same FMU under `instance_name`, from the
    /// folder this one was unpacked in: a system that uses one FMU many times unpacks it
    /// once ([`Instance::can_instantiate_again`] says whether the FMU allows it).
    pub fn instantiate_again(
        &self,
        instance_name: &str,
        logging_on: bool,
    ) -> Result<Self, FmuError> {
        Ok(CsFmu { instance: self.instance.instantiate_again(instance_name, logging_on)? })
    }

    /// The current communication point, `start + k · h` after k steps of size h.
    pub fn time(&self) -> f64 {
        self.instance.cx.time()
    }

    /// One `fmi*DoStep` of `h` seconds from the current communication point. The step
    /// size is fixed by the first step: the time is kept as `start + k · h` (not summed) so
    /// that it stays exactly on the grid the FMU compares it with.
    pub fn do_step(&mut self, h: f64) -> Result<(), FmuError> {
        let i = &mut self.instance;
        i.cx.alive(i.cx.named("fmi2DoStep", "fmi3DoStep"))?;
        if i.cx.steps_done == 0 {
            i.cx.step_size = h;
        } else {
            assert_eq!(
                h, i.cx.step_size,
                "CsFmu::do_step: the communication step is fixed at the first step"
            );
        }
        let t = i.cx.time();
        // While a state is held, the master may go back to it: the FMU must know.
        let no_prior = i.states.is_empty();
        i.backend.do_step(&mut i.cx, t, h, no_prior)?;
        i.cx.steps_done += 1;
        Ok(())
    }
}
