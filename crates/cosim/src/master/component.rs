//! A component and its FMU: run by its own Co-Simulation (with event mode and clocks, or
//! without), integrated by the master as Model Exchange, or activated in Scheduled
//! Execution, as [`Interfaces`] asks; a component's variable found by name.

use std::path::Path;

use super::clocked::Clocked;
use super::{Interfaces, Port};
use crate::archive::cut;
use crate::error::interface_name;
use crate::fmu::{CsFmu, Instance, Interface, Loaded, ModelDescription, SeFmu};
use crate::limits;
use crate::model_exchange::{Carry, MeRun, Tolerance};
use crate::{Error, StopFlag};

pub(super) struct Component {
    pub(super) name: String,
    pub(super) fmu: Fmu,
}

/// A component's FMU: stepped by its own Co-Simulation, stepped from clock tick to clock
/// tick with event mode, integrated by the master (Model Exchange), or its model
/// partitions activated at their ticks (Scheduled Execution). Everything else (variables,
/// initialization, FMU state, reset) is the same calls either way, through `Deref`.
// One value per component, never moved in a loop: a box would buy nothing.
#[allow(clippy::large_enum_variant)]
pub(super) enum Fmu {
    Cs(CsFmu),
    Me(MeRun),
    Events(Clocked<CsFmu>),
    Se(Clocked<SeFmu>),
}

impl std::ops::Deref for Fmu {
    type Target = Instance;
    fn deref(&self) -> &Instance {
        match self {
            Fmu::Cs(f) => f,
            Fmu::Me(m) => &m.fmu,
            Fmu::Events(c) => &c.fmu,
            Fmu::Se(c) => &c.fmu,
        }
    }
}

impl std::ops::DerefMut for Fmu {
    fn deref_mut(&mut self) -> &mut Instance {
        match self {
            Fmu::Cs(f) => f,
            Fmu::Me(m) => &mut m.fmu,
            Fmu::Events(c) => &mut c.fmu,
            Fmu::Se(c) => &mut c.fmu,
        }
    }
}

impl Fmu {
    /// One communication step from `t` to `t + h` of a component without clocks (the
    /// clocked ones are stepped by the scheduler, `clocks`).
    pub(super) fn advance(&mut self, t: f64, h: f64) -> Result<(), Error> {
        match self {
            Fmu::Cs(f) => Ok(f.do_step(h)?),
            Fmu::Me(m) => m.advance(t, h),
            Fmu::Events(_) | Fmu::Se(_) => Err(Error::Config(
                "a clocked component is stepped by the master's clock scheduler".into(),
            )),
        }
    }

    /// The clocks of a component run with event mode or in Scheduled Execution.
    pub(super) fn clocked(&self) -> bool {
        matches!(self, Fmu::Events(_) | Fmu::Se(_))
    }

    /// Another instance under `name`, of the same interface, from the folder this one was
    /// unpacked in. The FMU's errors come as [`Error::Fmu`].
    pub(super) fn again(&self, name: &str, tolerance: Tolerance) -> Result<Fmu, Error> {
        Ok(match self {
            Fmu::Cs(f) => Fmu::Cs(f.instantiate_again(name, false)?),
            Fmu::Me(m) => {
                Fmu::Me(MeRun::new(m.fmu.instantiate_again(name, false)?, name, tolerance)?)
            }
            Fmu::Events(c) => Fmu::Events(Clocked::new(c.fmu.instantiate_again(name, false)?)),
            Fmu::Se(c) => Fmu::Se(Clocked::new(c.fmu.instantiate_again(name, false)?)),
        })
    }

    /// Loads `source` as component `name`, in the interface [`Want::interface`] picks from
    /// its description, once the description (read from the archive before unpacking it)
    /// is within [`limits`]: an FMU declaring more than the master allocates for, or not
    /// offering the interface asked (Scheduled Execution or event mode of an FMI 2.0 FMU),
    /// is refused before a file of it is written. The FMU's errors come as [`Error::Fmu`].
    pub(super) fn open(
        source: &Path,
        name: &str,
        want: Want,
        tolerance: Tolerance,
    ) -> Result<Fmu, Error> {
        let vet = |md: &ModelDescription, i: Interface| {
            limits::check_description(name, md, i == Interface::ModelExchange)
        };
        Ok(match Loaded::load_picked(source, name, false, |md| want.interface(md), vet)? {
            Loaded::Me(fmu) => Fmu::Me(MeRun::new(fmu, name, tolerance)?),
            Loaded::Cs(fmu) if fmu.event_mode_used() => Fmu::Events(Clocked::new(fmu)),
            Loaded::Cs(fmu) => Fmu::Cs(fmu),
            Loaded::Se(fmu) => Fmu::Se(Clocked::new(fmu)),
        })
    }

    /// What the component's Model Exchange integrator carries past the current
    /// communication point (for a checkpoint); `None` for the others, which the master
    /// steps or activates and which carry nothing of the master's.
    pub(super) fn carry(&self) -> Option<Carry> {
        match self {
            Fmu::Cs(_) | Fmu::Events(_) | Fmu::Se(_) => None,
            Fmu::Me(m) => Some(m.carry()),
        }
    }

    /// Back to the carry of a checkpoint ([`Fmu::carry`]).
    pub(super) fn set_carry(&mut self, carry: &Option<Carry>) {
        if let (Fmu::Me(m), Some(c)) = (self, carry) {
            m.set_carry(c.clone());
        }
    }

    /// The component's Model Exchange integration, if it has one, ends at its next step
    /// once `flag` is set.
    pub(super) fn stop_when(&mut self, flag: Option<&StopFlag>) {
        if let Fmu::Me(m) = self {
            m.stop_when(flag.cloned());
        }
    }
}

/// The interface asked of one component.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Want {
    /// Co-Simulation (Model Exchange for an ME-only FMU).
    Cs,
    /// Model Exchange: named.
    Me,
    /// Model Exchange where offered: `*`.
    MeIfOffered,
    /// FMI 3.0 Co-Simulation with event mode: `cs-events`.
    CsEvents,
    /// FMI 3.0 Scheduled Execution: `se`.
    Se,
}

impl Want {
    /// The interface a component asking for this runs, by what its FMU's `description`
    /// offers: Model Exchange named, always (an FMU without it is then refused); `*`, where
    /// offered; plain Co-Simulation unless the FMU has none; event mode and Scheduled
    /// Execution as named (refused where not offered).
    pub(super) fn interface(self, description: &ModelDescription) -> Interface {
        let me = match self {
            Want::CsEvents => return Interface::CoSimulationEventMode,
            Want::Se => return Interface::ScheduledExecution,
            Want::Me => true,
            Want::MeIfOffered => description.model_exchange.is_some(),
            Want::Cs => description.co_simulation.is_none(),
        };
        if me {
            Interface::ModelExchange
        } else {
            Interface::CoSimulation
        }
    }
}

impl Interfaces {
    /// Every name one of `components` (`*` too, for Model Exchange), none asked two
    /// interfaces, the tolerance within its ranges: before anything is loaded.
    pub(super) fn check(&self, components: &[String]) -> Result<(), Error> {
        self.tolerance.check()?;
        let asked: Vec<(&String, &'static str)> = self
            .model_exchange
            .iter()
            .map(|n| (n, "me"))
            .chain(self.co_simulation.iter().map(|n| (n, "cs")))
            .chain(self.event_mode.iter().map(|n| (n, "cs-events")))
            .chain(self.scheduled_execution.iter().map(|n| (n, "se")))
            .collect();
        for &(n, interface) in &asked {
            if n.is_empty() {
                return Err(Error::Config(format!(
                    "--interface ={interface}: name a component to run as {}",
                    interface_name(interface)
                )));
            }
            if !(components.contains(n) || interface == "me" && n == "*") {
                return Err(Error::NoSuchComponent {
                    name: cut(n, 200),
                    interface,
                    components: components.to_vec(),
                });
            }
            if let Some(&(_, other)) = asked.iter().find(|(m, i)| *m == n && *i != interface) {
                return Err(Error::Config(format!(
                    "--interface: `{}` is asked to run both as {} ({interface}) and as {} ({other})",
                    cut(n, 200),
                    interface_name(interface),
                    interface_name(other),
                )));
            }
        }
        Ok(())
    }

    /// The interface asked of `component`.
    pub(super) fn wants(&self, component: &str) -> Want {
        let named = |list: &[String]| list.iter().any(|n| n == component);
        if named(&self.event_mode) {
            Want::CsEvents
        } else if named(&self.scheduled_execution) {
            Want::Se
        } else if self.co_simulation.iter().any(|n| n == component) {
            Want::Cs
        } else if self.model_exchange.iter().any(|n| n == component) {
            Want::Me
        } else if self.model_exchange.iter().any(|n| n == "*") {
            Want::MeIfOffered
        } else {
            Want::Cs
        }
    }
}

/// The component `element`'s variable `connector`.
pub(super) fn port(
    components: &[Component],
    element: &str,
    connector: &str,
) -> Result<Port, Error> {
    let i = components
        .iter()
        .position(|c| c.name == element)
        .ok_or_else(|| Error::Config(format!("no component named `{element}`")))?;
    let v = components[i].fmu.var(connector)?;
    Ok(Port { component: i, vr: v.vr, ty: v.ty })
}

/// Qualified name → port: `component.variable` in an SSP, the bare name for a single FMU.
pub(super) fn resolve(components: &[Component], ssp: bool, name: &str) -> Result<Port, Error> {
    if !ssp {
        return port(components, "fmu", name);
    }
    let (el, var) = name.split_once('.').ok_or_else(|| {
        Error::Config(format!("`{name}`: name a component variable as component.variable"))
    })?;
    port(components, el, var)
}
