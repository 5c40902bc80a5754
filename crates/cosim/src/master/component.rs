//! A component and its FMU: run by its own Co-Simulation or integrated by the master as
//! Model Exchange, as [`Interfaces`] asks; a component's variable found by name.

use std::path::Path;

use super::{Interfaces, Port};
use crate::archive::cut;
use crate::fmu::{CsFmu, Instance, Loaded, ModelDescription};
use crate::limits;
use crate::model_exchange::{Carry, MeRun, Tolerance};
use crate::{Error, StopFlag};

pub(super) struct Component {
    pub(super) name: String,
    pub(super) fmu: Fmu,
}

/// A component's FMU: stepped by its own Co-Simulation, or integrated by the master
/// (Model Exchange). Everything else (variables, initialization, FMU state, reset) is the
/// same calls either way, through `Deref`.
// One value per component, never moved in a loop: a box would buy nothing.
#[allow(clippy::large_enum_variant)]
pub(super) enum Fmu {
    Cs(CsFmu),
    Me(MeRun),
}

impl std::ops::Deref for Fmu {
    type Target = Instance;
    fn deref(&self) -> &Instance {
        match self {
            Fmu::Cs(f) => f,
            Fmu::Me(m) => &m.fmu,
        }
    }
}

impl std::ops::DerefMut for Fmu {
    fn deref_mut(&mut self) -> &mut Instance {
        match self {
            Fmu::Cs(f) => f,
            Fmu::Me(m) => &mut m.fmu,
        }
    }
}

impl Fmu {
    /// One communication step from `t` to `t + h`.
    pub(super) fn advance(&mut self, t: f64, h: f64) -> Result<(), Error> {
        match self {
            Fmu::Cs(f) => Ok(f.do_step(h)?),
            Fmu::Me(m) => m.advance(t, h),
        }
    }

    /// Another instance under `name`, of the same interface, from the folder this one was
    /// unpacked in. The FMU's errors come as [`Error::Fmu`].
    pub(super) fn again(&self, name: &str, tolerance: Tolerance) -> Result<Fmu, Error> {
        Ok(match self {
            Fmu::Cs(f) => Fmu::Cs(f.instantiate_again(name, false)?),
            Fmu::Me(m) => {
                Fmu::Me(MeRun::new(m.fmu.instantiate_again(name, false)?, name, tolerance)?)
            }
        })
    }

    /// Loads `source` as component `name`, in the interface [`Want::is_me`] picks from
    /// its description, once the description (read from the archive before unpacking it)
    /// is within [`limits`]: an FMU declaring more than the master allocates for is
    /// refused before a file of it is written. The FMU's errors come as [`Error::Fmu`].
    pub(super) fn open(
        source: &Path,
        name: &str,
        want: Want,
        tolerance: Tolerance,
    ) -> Result<Fmu, Error> {
        let vet = |md: &ModelDescription, me: bool| limits::check_description(name, md, me);
        Ok(match Loaded::load_vetted(source, name, false, |md| want.is_me(md), vet)? {
            Loaded::Me(fmu) => Fmu::Me(MeRun::new(fmu, name, tolerance)?),
            Loaded::Cs(fmu) => Fmu::Cs(fmu),
        })
    }

    /// What the component's Model Exchange integrator carries past the current
    /// communication point (for a checkpoint); `None` for Co-Simulation.
    pub(super) fn carry(&self) -> Option<Carry> {
        match self {
            Fmu::Cs(_) => None,
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
}

impl Want {
    /// Whether a component asking for this runs as Model Exchange, by what its FMU's
    /// `description` offers: named, always (an FMU without Model Exchange is then
    /// refused); `*`, where offered; else only an FMU without Co-Simulation.
    pub(super) fn is_me(self, description: &ModelDescription) -> bool {
        match self {
            Want::Me => true,
            Want::MeIfOffered => description.model_exchange.is_some(),
            Want::Cs => description.co_simulation.is_none(),
        }
    }
}

impl Interfaces {
    /// Every name one of `components` (`*` too, for Model Exchange), none asked both
    /// interfaces, the tolerance within its ranges: before anything is loaded.
    pub(super) fn check(&self, components: &[String]) -> Result<(), Error> {
        self.tolerance.check()?;
        let asked = self
            .model_exchange
            .iter()
            .map(|n| (n, "me"))
            .chain(self.co_simulation.iter().map(|n| (n, "cs")));
        for (n, interface) in asked {
            if n.is_empty() {
                return Err(Error::Config(format!(
                    "--interface ={interface}: name a component to run as {}",
                    if interface == "me" { "Model Exchange" } else { "Co-Simulation" }
                )));
            }
            if !(components.contains(n) || interface == "me" && n == "*") {
                return Err(Error::NoSuchComponent {
                    name: cut(n, 200),
                    interface,
                    components: components.to_vec(),
                });
            }
            if interface == "me" && self.co_simulation.contains(n) {
                return Err(Error::Config(format!(
                    "--interface: `{}` is asked to run both as Model Exchange (me) and as Co-Simulation (cs)",
                    cut(n, 200)
                )));
            }
        }
        Ok(())
    }

    pub(super) fn wants_me(&self, component: &str) -> Want {
        if self.co_simulation.iter().any(|n| n == component) {
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
