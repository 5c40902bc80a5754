//! [`CsFmu`]: an FMU instantiated for Co-Simulation. It owns the [`Instance`] both
//! interfaces share (variables, initialization, FMU state, terminate, reset: its methods
//! are reached through `Deref`) and adds the Co-Simulation calls: `fmi*DoStep` on a fixed
//! communication grid, and the time on it. An FMI 3.0 instance made with event mode
//! ([`CsFmu::load_event_mode`]) steps to given times instead ([`CsFmu::do_step_to`]: to a
//! clock tick or a communication point) and handles clocks in event mode.
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

use crate::backend::clocks::StepEnd;
use crate::{EventUpdate, FmuError, Instance, Interface};

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
        let cs = |_: &_| Interface::CoSimulation;
        Ok(CsFmu { instance: Instance::load(path, instance_name, (logging_on, cs))? })
    }

    /// [`CsFmu::load`] with FMI 3.0's `eventModeUsed`: after initialization the instance
    /// is in event mode at the start time (a tick of every periodic clock), its steps end at
    /// the next clock tick at the latest ([`CsFmu::do_step_to`]), and each tick is handled
    /// in event mode. Refused for an FMU without `hasEventMode` (every FMI 2.0 FMU).
    pub fn load_event_mode(
        path: &Path,
        instance_name: &str,
        logging_on: bool,
    ) -> Result<Self, FmuError> {
        let events = |_: &_| Interface::CoSimulationEventMode;
        Ok(CsFmu { instance: Instance::load(path, instance_name, (logging_on, events))? })
    }

    /// A Co-Simulation wrapper of `instance`, which was instantiated for Co-Simulation.
    pub(crate) fn wrap(instance: Instance) -> Self {
        debug_assert!(matches!(
            instance.interface(),
            Interface::CoSimulation | Interface::CoSimulationEventMode
        ));
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
        let done = i.backend.do_step(&mut i.cx, t, h, no_prior)?;
        i.cx.steps_done += 1;
        if done.event_handling_needed {
            return Err(FmuError::StepEnded {
                model: i.cx.model.clone(),
                function: "fmi3DoStep",
                time: t,
                why: "the FMU needs event handling (eventHandlingNeeded); an instance with event mode steps with do_step_to",
                last_time: done.last_successful_time,
            });
        }
        Ok(())
    }

    /// Whether the instance was made with event mode ([`CsFmu::load_event_mode`]).
    pub fn event_mode_used(&self) -> bool {
        self.instance.interface == Interface::CoSimulationEventMode
    }

    /// One `fmi3DoStep` from the current time to `end` (> the current time), for an
    /// instance with event mode: steps end at clock ticks and communication points, which
    /// need not lie on one grid. The time becomes `end` exactly (the FMU compares its
    /// ticks with it). `eventHandlingNeeded` is returned, not an error: the master then
    /// enters event mode ([`CsFmu::enter_event_mode`]).
    pub fn do_step_to(&mut self, end: f64) -> Result<StepEnd, FmuError> {
        const F: &str = "fmi3DoStep";
        self.event_mode(F)?;
        let i = &mut self.instance;
        let t = i.cx.time();
        if !(end.is_finite() && end > t) {
            return Err(i.cx.invalid(F, format!("a step to {end} s from {t} s")));
        }
        let no_prior = i.states.is_empty();
        let done = i.backend.do_step(&mut i.cx, t, end - t, no_prior)?;
        i.cx.start_time = end;
        i.cx.steps_done = 0;
        Ok(done)
    }

    /// `fmi3EnterEventMode` (event mode only): after a step that ended at a clock tick or
    /// asked for event handling.
    pub fn enter_event_mode(&mut self) -> Result<(), FmuError> {
        let (clocks, cx) = self.event_mode("fmi3EnterEventMode")?;
        clocks.enter_event_mode(cx)
    }

    /// `fmi3UpdateDiscreteStates` (event mode only): runs the partitions of the clocks set
    /// active, and says whether another update is needed and when the next time event is.
    pub fn update_discrete_states(&mut self) -> Result<EventUpdate, FmuError> {
        let (clocks, cx) = self.event_mode("fmi3UpdateDiscreteStates")?;
        clocks.update_discrete_states(cx)
    }

    /// `fmi3EnterStepMode` (event mode only): back to stepping after an event.
    pub fn enter_step_mode(&mut self) -> Result<(), FmuError> {
        let (clocks, cx) = self.event_mode("fmi3EnterStepMode")?;
        clocks.enter_step_mode(cx)
    }

    /// The clock calls, if the instance was made with event mode; else why not.
    fn event_mode(
        &mut self,
        function: &'static str,
    ) -> Result<(&crate::backend::clocks::Clocks, &mut crate::backend::Calls), FmuError> {
        let i = &mut self.instance;
        i.cx.alive(function)?;
        match i.backend.clocks() {
            Some((clocks, _)) if i.interface == Interface::CoSimulationEventMode => {
                Ok((clocks, &mut i.cx))
            }
            _ => Err(FmuError::Unsupported {
                model: i.cx.model.clone(),
                function,
                why: "the instance was made without event mode (CsFmu::load_event_mode makes one)"
                    .into(),
            }),
        }
    }
}
