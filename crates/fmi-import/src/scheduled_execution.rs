//! [`SeFmu`]: an FMI 3.0 FMU instantiated for Scheduled Execution
//! (`fmi3InstantiateScheduledExecution`). It owns the [`Instance`] the interfaces share
//! (variables, initialization, FMU state, clocks: through `Deref`) and adds
//! `fmi3ActivateModelPartition`. The FMU's callbacks are this crate's: `clockUpdate`
//! counts on the instance's environment, `lockPreemption`/`unlockPreemption` on the
//! activating thread; none can unwind into the FMU. Each activation says what was
//! signalled during it ([`Activation`]).
//!
//! ```no_run
//! # fn run(path: &std::path::Path) -> Result<(), inchworm_fmi_import::FmuError> {
//! let mut fmu = inchworm_fmi_import::SeFmu::load(path, "controller", false)?;
//! fmu.enter_initialization(None, 0.0, None)?;
//! fmu.exit_initialization()?;
//! let clock = fmu.var("sample_clock")?.vr;
//! let done = fmu.activate_model_partition(clock, 0.0)?;
//! if done.clock_updates > 0 { /* an output clock ticked: fmi3GetClock */ }
//! # Ok(()) }
//! ```

use std::ops::{Deref, DerefMut};
use std::path::Path;

use crate::backend::clocks::Activation;
use crate::{FmuError, Instance, Interface};

/// One FMU instantiated for Scheduled Execution.
#[derive(Debug)]
pub struct SeFmu {
    instance: Instance,
}

impl Deref for SeFmu {
    type Target = Instance;
    fn deref(&self) -> &Instance {
        &self.instance
    }
}

impl DerefMut for SeFmu {
    fn deref_mut(&mut self) -> &mut Instance {
        &mut self.instance
    }
}

impl SeFmu {
    /// Unpacks `path`, loads its FMI 3.0 library and instantiates it for Scheduled
    /// Execution under `instance_name`; an FMU without `<ScheduledExecution>` (every FMI 2.0
    /// FMU) is refused.
    pub fn load(path: &Path, instance_name: &str, logging_on: bool) -> Result<Self, FmuError> {
        let se = |_: &_| Interface::ScheduledExecution;
        Ok(SeFmu { instance: Instance::load(path, instance_name, (logging_on, se))? })
    }

    /// A Scheduled Execution wrapper of `instance`, which was instantiated for it.
    pub(crate) fn wrap(instance: Instance) -> Self {
        debug_assert_eq!(instance.interface(), Interface::ScheduledExecution);
        SeFmu { instance }
    }

    /// Another instance of the same FMU under `instance_name`, from the folder this one
    /// was unpacked in.
    pub fn instantiate_again(
        &self,
        instance_name: &str,
        logging_on: bool,
    ) -> Result<Self, FmuError> {
        Ok(SeFmu { instance: self.instance.instantiate_again(instance_name, logging_on)? })
    }

    /// The time of the last activation (the start time before any).
    pub fn time(&self) -> f64 {
        self.instance.cx.time()
    }

    /// `fmi3ActivateModelPartition(clock, t)`: runs the partition of the input clock
    /// `clock` at its tick `t`, and says how often the FMU called `clockUpdate` (an output
    /// clock ticked: read it with [`Instance::get_clocks`]) and locked preemption meanwhile.
    /// An FMU that leaves preemption locked is an error.
    pub fn activate_model_partition(&mut self, clock: u32, t: f64) -> Result<Activation, FmuError> {
        const F: &str = "fmi3ActivateModelPartition";
        let i = &mut self.instance;
        i.cx.alive(F)?;
        let input =
            i.description.clock(clock).is_some_and(|c| c.causality == crate::Causality::Input);
        if !input {
            return Err(i.cx.invalid(F, format!("value reference {clock} is no input <Clock>")));
        }
        if !t.is_finite() {
            return Err(i.cx.invalid(F, format!("the time {t}")));
        }
        let (clocks, env) = i.backend.clocks().expect("an SeFmu is made for Scheduled Execution");
        // The time errors name.
        i.cx.start_time = t;
        i.cx.steps_done = 0;
        clocks.activate(&mut i.cx, env, clock, t)
    }
}
