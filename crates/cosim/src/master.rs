//! A fixed-step co-simulation master for FMI 2.0 and 3.0 Co-Simulation FMUs: a flat SSP system or a
//! single FMU, Jacobi or Gauss–Seidel coupling, parameters and parameter sets, a CSV of
//! inputs for unconnected inputs, and the chosen variables recorded at every
//! communication point.

use std::collections::BTreeMap;
use std::path::Path;

use crate::archive::cut;
use crate::fmu::{CsFmu, FmuState, Loaded, MeFmu, ModelDescription, Var, VarType};
pub use crate::input::InputTable;
use crate::limits;
use crate::model_exchange::{MeRun, MeStats, Tolerance};
use crate::ssp::{Archive, End, TypedValue};
use crate::trace::Trace;
use crate::{Error, StopFlag};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coupling {
    /// Every component steps on the others' outputs from the start of the step.
    Jacobi,
    /// Components step in order, each on the outputs the earlier ones just produced.
    GaussSeidel,
}

pub struct Options {
    pub stop_time: Option<f64>,
    pub step_size: Option<f64>,
    pub coupling: Coupling,
    /// `component.variable` (or `variable` for a single FMU) = value text.
    pub params: Vec<(String, String)>,
    pub parameter_set: Option<String>,
    pub input: Option<InputTable>,
    /// Names to record; empty: every system output connector (or every FMU output).
    pub outputs: Vec<String>,
}

/// A variable of one component, resolved.
#[derive(Clone, Copy, Debug)]
struct Port {
    component: usize,
    vr: u32,
    ty: VarType,
}

/// Where an input gets its value each step: the latest read of a component output, or a
/// system input.
#[derive(Clone, Copy, Debug)]
enum Feed {
    Latest(usize),
    SystemInput(usize),
}

/// Where an input's value comes from.
#[derive(Clone, Copy, Debug)]
enum Source {
    Output(Port),
    Input(usize),
}

/// A recorded value: a component variable, or a system input at the row's time.
#[derive(Clone, Copy, Debug)]
enum Probe {
    Port(Port),
    SystemInput(usize),
}

/// Where a row finds one recorded value.
#[derive(Clone, Copy, Debug)]
enum Column {
    /// A port that feeds an input: its latest read, `latest[j]`.
    Latest(usize),
    /// A port read for the rows alone: `port_values[k]`.
    Read(usize),
    /// A system input at the row's time.
    SystemInput(usize),
}

struct Component {
    name: String,
    fmu: Fmu,
}

/// A component's FMU: stepped by its own Co-Simulation, or integrated by the master
/// (Model Exchange). Everything else (variables, initialization, FMU state, reset) is the
/// same calls either way, through `Deref`.
enum Fmu {
    Cs(CsFmu),
    Me(MeRun),
}

impl std::ops::Deref for Fmu {
    type Target = CsFmu;
    fn deref(&self) -> &CsFmu {
        match self {
            Fmu::Cs(f) => f,
            Fmu::Me(m) => &m.fmu,
        }
    }
}

impl std::ops::DerefMut for Fmu {
    fn deref_mut(&mut self) -> &mut CsFmu {
        match self {
            Fmu::Cs(f) => f,
            Fmu::Me(m) => &mut m.fmu,
        }
    }
}

impl Fmu {
    /// One communication step from `t` to `t + h`.
    fn advance(&mut self, t: f64, h: f64) -> Result<(), Error> {
        match self {
            Fmu::Cs(f) => Ok(f.do_step(h)?),
            Fmu::Me(m) => m.advance(t, h),
        }
    }

    /// Another instance under `name`, of the same interface, from the folder this one was
    /// unpacked in. The FMU's errors come as [`Error::Fmu`].
    fn again(&self, name: &str, tolerance: Tolerance) -> Result<Fmu, Error> {
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
    fn open(source: &Path, name: &str, want: Want, tolerance: Tolerance) -> Result<Fmu, Error> {
        let vet = |md: &ModelDescription, me: bool| limits::check_description(name, md, me);
        Ok(match MeFmu::load_vetted(source, name, false, |md| want.is_me(md), vet)? {
            Loaded::Me(fmu) => Fmu::Me(MeRun::new(fmu, name, tolerance)?),
            Loaded::Cs(fmu) => Fmu::Cs(fmu),
        })
    }

    /// The component's Model Exchange integration, if it has one, ends at its next step
    /// once `flag` is set.
    fn stop_when(&mut self, flag: Option<&StopFlag>) {
        if let Fmu::Me(m) = self {
            m.stop_when(flag.cloned());
        }
    }
}

/// Which components the master integrates as Model Exchange, and how finely. A component
/// whose FMU offers only Model Exchange always is; one named here is, if its FMU offers
/// Model Exchange (if not, loading it fails and says so). Every name must be a component
/// of the run ([`System::load_as`] refuses another: [`Error::NoSuchComponent`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Interfaces {
    /// Component names (`fmu` for a single FMU), or `*` for every component whose FMU
    /// offers Model Exchange.
    pub model_exchange: Vec<String>,
    /// Component names to run as Co-Simulation even under `*` (`--interface NAME=cs`).
    pub co_simulation: Vec<String>,
    /// Within [`limits::RTOL`] and [`limits::ATOL`].
    pub tolerance: Tolerance,
}

/// The interface asked of one component.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Want {
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
    fn is_me(self, description: &ModelDescription) -> bool {
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
    fn check(&self, components: &[String]) -> Result<(), Error> {
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

    fn wants_me(&self, component: &str) -> Want {
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

fn set(components: &mut [Component], p: Port, value: f64) -> Result<(), Error> {
    set_var(&mut components[p.component].fmu, Var { vr: p.vr, ty: p.ty }, value)
}

fn set_var(f: &mut CsFmu, v: Var, value: f64) -> Result<(), Error> {
    match v.ty {
        VarType::Real => f.set_real(&[v.vr], &[value]),
        VarType::Integer | VarType::Enumeration => f.set_integer(&[v.vr], &[value.round() as i32]),
        VarType::Boolean => f.set_boolean(&[v.vr], &[value != 0.0]),
        VarType::String => {
            return Err(Error::Config("String variables cannot be connected".into()))
        }
    }
    .map_err(Error::from)
}

/// A start value or parameter given as text (`--param`, an `.ssv`), checked against the
/// variable's type.
fn parse_value(ty: VarType, name: &str, text: &str) -> Result<f64, Error> {
    let value = match ty {
        VarType::Boolean => match text.trim() {
            "true" | "1" => 1.0,
            "false" | "0" => 0.0,
            t => return Err(Error::Config(format!("{name} = {t}: not a Boolean (true/false)"))),
        },
        _ => text
            .trim()
            .parse::<f64>()
            .map_err(|_| Error::Config(format!("{name} = {text}: not a number")))?,
    };
    if !value.is_finite() {
        return Err(Error::Config(format!("{name} = {text}: not a finite number")));
    }
    if matches!(ty, VarType::Integer | VarType::Enumeration) {
        if value.fract() != 0.0 {
            return Err(Error::Config(format!("{name} = {text}: not an integer")));
        }
        // fmi2Integer is 32 bits: a cast would saturate silently.
        if !(f64::from(i32::MIN)..=f64::from(i32::MAX)).contains(&value) {
            return Err(Error::Config(format!(
                "{name} = {text}: out of the Integer range {}..={}",
                i32::MIN,
                i32::MAX
            )));
        }
    }
    Ok(value)
}

/// Whether an SSP type (`Real`, `Integer`, … of `ssc:`/`ssv:`) is that of an FMI variable of
/// type `ty`: the same name, or `Integer` for an enumeration (its values are integers).
fn ssp_type_fits(kind: &str, ty: VarType) -> bool {
    match ty {
        VarType::Real => kind == "Real",
        VarType::Integer => kind == "Integer",
        VarType::Boolean => kind == "Boolean",
        VarType::String => kind == "String",
        VarType::Enumeration => matches!(kind, "Enumeration" | "Integer"),
    }
}

/// A parameter set's value of SSP type `kind` for a variable of type `ty`: SSP 1.0 gives
/// each value the type of the variable it sets (an `ssv:Enumeration` or `ssv:Integer` for
/// an FMI enumeration), and a value of another type (a Real `3` for an Integer, an Integer
/// `1` for a Boolean) is a mistake in the set, not a conversion to make silently.
fn check_binding_type(name: &str, kind: &str, ty: VarType) -> Result<(), Error> {
    if ssp_type_fits(kind, ty) {
        return Ok(());
    }
    Err(Error::Config(format!(
        "parameter `{}`: the parameter set gives it an ssv:{kind} value, but the variable is of type {ty}: refused (SSP 1.0: a value has its variable's type)",
        cut(name, 200)
    )))
}

fn set_text(components: &mut [Component], p: Port, name: &str, text: &str) -> Result<(), Error> {
    set(components, p, parse_value(p.ty, name, text)?)
}

/// Sets one variable of a single FMU by name from text, as `--param NAME=VALUE` does.
pub fn set_param(fmu: &mut CsFmu, name: &str, text: &str) -> Result<(), Error> {
    let v = fmu.var(name)?;
    set_var(fmu, v, parse_value(v.ty, name, text)?)
}

/// Ports grouped by component and type, each group one `fmi2Get*`/`fmi2Set*` call: per step
/// the master crosses the FMI boundary once per group instead of once per variable.
///
/// A group of inputs whose values are those its last `Set*` gave is not set again: FMI
/// 2.0 and 3.0 inputs keep their values until set (neither standard has an input that
/// forgets), so the call would change nothing, and a closed loop's slow inputs (a
/// reference that holds for seconds, an encoder count between moves) cost no call at all.
/// The values compare by their bits, so any change, a zero's sign included, is set.
struct Batches {
    groups: Vec<Group>,
}

struct Group {
    component: usize,
    ty: VarType,
    vrs: Vec<u32>,
    /// Where each value goes in (or comes from) the caller's slice.
    slots: Vec<usize>,
    reals: Vec<f64>,
    integers: Vec<i32>,
    booleans: Vec<bool>,
    /// The FMU holds this group's values as last set: the last `Set*` of it succeeded and
    /// nothing has given the inputs other values since ([`Batches::forget`]).
    held: bool,
}

impl Batches {
    fn new(ports: &[Port]) -> Result<Batches, Error> {
        let mut groups: Vec<Group> = Vec::new();
        for (slot, p) in ports.iter().enumerate() {
            let ty = match p.ty {
                VarType::String => {
                    return Err(Error::Config(
                        "String variables cannot be connected or recorded".into(),
                    ))
                }
                VarType::Enumeration => VarType::Integer,
                t => t,
            };
            let g = match groups.iter().position(|g| g.component == p.component && g.ty == ty) {
                Some(i) => &mut groups[i],
                None => {
                    groups.push(Group {
                        component: p.component,
                        ty,
                        vrs: vec![],
                        slots: vec![],
                        reals: vec![],
                        integers: vec![],
                        booleans: vec![],
                        held: false,
                    });
                    groups.last_mut().expect("just pushed")
                }
            };
            g.vrs.push(p.vr);
            g.slots.push(slot);
            g.reals.push(0.0);
            g.integers.push(0);
            g.booleans.push(false);
        }
        Ok(Batches { groups })
    }

    fn read(
        &mut self,
        components: &mut [Component],
        out: &mut [f64],
        only: Option<usize>,
    ) -> Result<(), Error> {
        for g in self.groups.iter_mut().filter(|g| only.is_none_or(|c| c == g.component)) {
            let f = &mut components[g.component].fmu;
            match g.ty {
                VarType::Real => {
                    f.get_real(&g.vrs, &mut g.reals)?;
                    g.slots.iter().zip(&g.reals).for_each(|(&s, &v)| out[s] = v);
                }
                VarType::Boolean => {
                    f.get_boolean(&g.vrs, &mut g.booleans)?;
                    g.slots
                        .iter()
                        .zip(&g.booleans)
                        .for_each(|(&s, &v)| out[s] = f64::from(u8::from(v)));
                }
                _ => {
                    f.get_integer(&g.vrs, &mut g.integers)?;
                    g.slots.iter().zip(&g.integers).for_each(|(&s, &v)| out[s] = f64::from(v));
                }
            }
        }
        Ok(())
    }

    /// Sets `values` (by slot) on the groups of component `only` (every component if
    /// `None`); a group that holds these values already is skipped.
    fn write(
        &mut self,
        components: &mut [Component],
        values: &[f64],
        only: Option<usize>,
    ) -> Result<(), Error> {
        for g in self.groups.iter_mut().filter(|g| only.is_none_or(|c| c == g.component)) {
            let mut changed = !g.held;
            match g.ty {
                VarType::Real => {
                    for (&s, v) in g.slots.iter().zip(&mut g.reals) {
                        changed |= v.to_bits() != values[s].to_bits();
                        *v = values[s];
                    }
                }
                VarType::Boolean => {
                    for (&s, v) in g.slots.iter().zip(&mut g.booleans) {
                        changed |= *v != (values[s] != 0.0);
                        *v = values[s] != 0.0;
                    }
                }
                _ => {
                    for (&s, v) in g.slots.iter().zip(&mut g.integers) {
                        let i = values[s].round() as i32;
                        changed |= *v != i;
                        *v = i;
                    }
                }
            }
            if !changed {
                continue;
            }
            // Held again only once the FMU has taken them: a refused call is made again.
            g.held = false;
            let f = &mut components[g.component].fmu;
            match g.ty {
                VarType::Real => f.set_real(&g.vrs, &g.reals)?,
                VarType::Boolean => f.set_boolean(&g.vrs, &g.booleans)?,
                _ => f.set_integer(&g.vrs, &g.integers)?,
            }
            g.held = true;
        }
        Ok(())
    }

    /// The FMUs' inputs may now hold other values than the last set (a restored FMU
    /// state): the next [`Batches::write`] sets every group.
    fn forget(&mut self) {
        self.groups.iter_mut().for_each(|g| g.held = false);
    }
}

/// The connections resolved to ports.
struct Wiring {
    /// Every connected component input and where it is fed from.
    inputs: Vec<(Port, Source)>,
    system_outputs: BTreeMap<String, Port>,
}

/// A system loaded and not yet initialized: its components instantiated, its connectors
/// and connections read (phase 1 of [`run`]).
pub struct System {
    /// Kept for the parameter sets, and because the components' FMUs were unpacked in it.
    archive: Option<Archive>,
    components: Vec<Component>,
    inputs: Vec<String>,
    outputs: Vec<String>,
    connections: Vec<(End, End)>,
    /// The SSD's declared connector types (empty for a single FMU).
    connector_types: BTreeMap<End, String>,
    stop_time: Option<f64>,
    step_size: Option<f64>,
}

impl System {
    /// Loads `path`: an `.ssp` (a flat system of FMI 2.0 CS FMUs), or a single `.fmu`,
    /// which is a system whose connectors are the FMU's own.
    pub fn load(path: &Path) -> Result<System, Error> {
        System::load_as(path, &Interfaces::default())
    }

    /// [`System::load`], with the components of `interfaces` run as Model Exchange.
    pub fn load_as(path: &Path, interfaces: &Interfaces) -> Result<System, Error> {
        let tolerance = interfaces.tolerance;
        let is_ssp = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("ssp"));
        if !is_ssp {
            // A single FMU is one component, named `fmu`: checked before it is opened.
            interfaces.check(&["fmu".to_string()])?;
            let fmu = Fmu::open(path, "fmu", interfaces.wants_me("fmu"), tolerance)?;
            let step_size = fmu.default_step_size();
            let inputs = fmu.names_with_causality("input");
            let outputs = fmu.names_with_causality("output");
            let end = |element: Option<&str>, n: &String| End {
                element: element.map(str::to_string),
                connector: n.clone(),
            };
            let connections = inputs
                .iter()
                .map(|n| (end(None, n), end(Some("fmu"), n)))
                .chain(outputs.iter().map(|n| (end(Some("fmu"), n), end(None, n))))
                .collect();
            return Ok(System {
                archive: None,
                components: vec![Component { name: "fmu".into(), fmu }],
                inputs,
                outputs,
                connections,
                connector_types: BTreeMap::new(),
                stop_time: None,
                step_size,
            });
        }
        // The tolerance before the archive is unpacked, the names once its SSD is read.
        interfaces.tolerance.check()?;
        let a = Archive::open(path)?;
        let here = |e: Error| e.context(path.display().to_string());
        let names: Vec<String> = a.system.components.iter().map(|c| c.name.clone()).collect();
        interfaces.check(&names).map_err(here)?;
        // Every name and source checked before any FMU is loaded.
        let mut sources = Vec::new();
        for (i, c) in a.system.components.iter().enumerate() {
            if a.system.components[..i].iter().any(|d| d.name == c.name) {
                return Err(here(Error::Ssp(format!(
                    "two components are named `{}`",
                    cut(&c.name, 200)
                ))));
            }
            sources.push(crate::archive::source_path(&a.dir, &c.name, &c.source).map_err(here)?);
        }
        let named: Vec<(&str, &Path)> = a
            .system
            .components
            .iter()
            .zip(&sources)
            .map(|(c, s)| (c.name.as_str(), s.as_path()))
            .collect();
        let mut used = crate::archive::check_system_budget(&a.dir, &named).map_err(here)?;
        let mut components: Vec<Component> = Vec::new();
        for (i, (c, source)) in a.system.components.iter().zip(&sources).enumerate() {
            let component = |e| match e {
                Error::Fmu(source) => Error::Component { component: c.name.clone(), source },
                e => e,
            };
            // An FMU that several components use is unpacked once and instantiated from
            // that folder again, unless each of its instances needs a library of its own.
            // The earlier instance serves if it runs the interface this one is to run.
            let me = interfaces.wants_me(&c.name);
            let earlier = sources[..i].iter().position(|s| s == source);
            let fmu = match earlier.map(|e| &components[e].fmu) {
                Some(first)
                    if first.can_instantiate_again()
                        && first.is_model_exchange() == me.is_me(first.description()) =>
                {
                    first.again(&c.name, tolerance).map_err(component)?
                }
                Some(_) => {
                    crate::archive::check_another_copy(&mut used, &c.name, source).map_err(here)?;
                    Fmu::open(source, &c.name, me, tolerance).map_err(component)?
                }
                None => Fmu::open(source, &c.name, me, tolerance).map_err(component)?,
            };
            components.push(Component { name: c.name.clone(), fmu });
        }
        let kind = |k: &str| -> Vec<String> {
            a.system
                .connectors
                .iter()
                .filter(|(_, kind)| kind == k)
                .map(|(n, _)| n.clone())
                .collect()
        };
        Ok(System {
            inputs: kind("input"),
            outputs: a.default_outputs(kind("output"))?,
            connections: a.system.connections.clone(),
            connector_types: a.system.connector_types.clone(),
            stop_time: a.system.stop_time,
            step_size: a.system.step_size,
            components,
            archive: Some(a),
        })
    }

    fn port(&self, element: &str, connector: &str) -> Result<Port, Error> {
        port(&self.components, element, connector)
    }

    fn resolve(&self, name: &str) -> Result<Port, Error> {
        resolve(&self.components, self.archive.is_some(), name)
    }

    /// Every input port fed by a component output or a system input, and the port behind
    /// each system output connector.
    fn wire(&self) -> Result<Wiring, Error> {
        let mut wiring: Vec<(Port, Source)> = Vec::new();
        // Who drives each input so far, to name both when a second connection comes.
        let mut drivers: Vec<&End> = Vec::new();
        let mut system_outputs = BTreeMap::new();
        let named = |e: &End| match &e.element {
            Some(el) => format!("{el}.{}", e.connector),
            None => e.connector.clone(),
        };
        // The SSD declares each connector's type; it must be that of what it stands for: a
        // component connector its FMU variable's, a system connector the type of the
        // component variable on the other end of the connection.
        let declared = |e: &End, ty: VarType, var: &End| -> Result<(), Error> {
            match self.connector_types.get(e) {
                Some(kind) if !ssp_type_fits(kind, ty) => Err(Error::Ssp(format!(
                    "connector `{}` is declared ssc:{kind} in the SSD, but `{}` is of type {ty}: refused",
                    cut(&named(e), 200),
                    cut(&named(var), 200)
                ))),
                _ => Ok(()),
            }
        };
        for (a, b) in &self.connections {
            if let (Some(e), Some(f)) = (&a.element, &b.element) {
                let (p, q) = (self.port(e, &a.connector)?, self.port(f, &b.connector)?);
                declared(a, p.ty, a)?;
                declared(b, q.ty, b)?;
            } else if let (None, Some(f)) = (&a.element, &b.element) {
                let q = self.port(f, &b.connector)?;
                declared(b, q.ty, b)?;
                declared(a, q.ty, b)?;
            } else if let (Some(e), None) = (&a.element, &b.element) {
                let p = self.port(e, &a.connector)?;
                declared(a, p.ty, a)?;
                declared(b, p.ty, a)?;
            }
            let source = match &a.element {
                Some(e) => Source::Output(self.port(e, &a.connector)?),
                None => Source::Input(
                    self.inputs.iter().position(|n| *n == a.connector).ok_or_else(|| {
                        Error::Config(format!(
                            "connection starts at unknown system connector `{}`",
                            a.connector
                        ))
                    })?,
                ),
            };
            match (&b.element, source) {
                (Some(e), s) => {
                    let dst = self.port(e, &b.connector)?;
                    if let Source::Output(p) = s {
                        if (p.component, p.vr) == (dst.component, dst.vr) {
                            return Err(Error::Config(format!(
                                "connection from `{}` to itself",
                                named(b)
                            )));
                        }
                    }
                    if let Source::Output(p) = s {
                        if p.ty != dst.ty {
                            // FMI and SSP 1.0 connect a variable only to one of its own
                            // type: a cast (Real to Integer, Integer to Boolean) would change
                            // values silently at every step.
                            return Err(Error::Config(format!(
                                "connection from `{}` ({}) to `{}` ({}): the connectors are of different types: refused",
                                named(a),
                                p.ty,
                                named(b),
                                dst.ty
                            )));
                        }
                    }
                    let same = |q: &Port| (q.component, q.vr) == (dst.component, dst.vr);
                    if let Some(i) = wiring.iter().position(|(q, _)| same(q)) {
                        return Err(Error::Config(format!(
                            "input `{}` is driven by two connections, from `{}` and from `{}`",
                            named(b),
                            named(drivers[i]),
                            named(a)
                        )));
                    }
                    wiring.push((dst, s));
                    drivers.push(a);
                }
                (None, Source::Output(p)) => {
                    if system_outputs.insert(b.connector.clone(), p).is_some() {
                        return Err(Error::Config(format!(
                            "system output `{}` is driven by two connections",
                            b.connector
                        )));
                    }
                }
                (None, Source::Input(_)) => {
                    return Err(Error::Config(format!(
                        "connection from a system input straight to system output `{}`",
                        b.connector
                    )))
                }
            }
        }
        Ok(Wiring { inputs: wiring, system_outputs })
    }

    /// What each recorded name reads: a system output's port, an SSP's system input, or
    /// a component variable.
    fn probes(
        &self,
        names: &[String],
        system_outputs: &BTreeMap<String, Port>,
    ) -> Result<Vec<Probe>, Error> {
        names
            .iter()
            .map(|n| {
                // A system input of an SSP has no port to read; a single FMU's inputs are
                // its own variables and read as such.
                let system_input =
                    self.archive.as_ref().and(self.inputs.iter().position(|i| i == n));
                Ok(match (system_outputs.get(n), system_input) {
                    (Some(p), _) => Probe::Port(*p),
                    (None, Some(i)) => Probe::SystemInput(i),
                    (None, None) => Probe::Port(
                        self.resolve(n).map_err(|e| e.context(format!("output `{n}`")))?,
                    ),
                })
            })
            .collect()
    }

    /// Initialization mode: each component's first binding, the parameter set's values,
    /// then `--param` values (so a `--param` overrides the set). A value from the SSP
    /// carries its SSP type, checked against the variable's.
    fn set_parameters(&mut self, opts: &Options, stop: f64) -> Result<(), Error> {
        let first = crate::ssp::first_bindings_typed(self.archive.as_ref())?;
        set_parameters(&mut self.components, self.archive.as_ref(), first, opts, stop)
    }

    /// Phase 2 of [`run`]: wires the connections, resolves what to record, sets the
    /// parameters in initialization mode, and leaves every component at t = 0 ready to
    /// step.
    pub fn initialise(mut self, opts: &Options) -> Result<Simulation, Error> {
        let stop = opts.stop_time.or(self.stop_time).unwrap_or(1.0);
        let h = opts.step_size.or(self.step_size).unwrap_or(stop / 500.0);
        if !(h > 0.0 && h.is_finite() && stop > 0.0 && stop.is_finite()) {
            return Err(Error::Config(format!(
                "step size {h} and stop time {stop} must be finite and > 0"
            )));
        }
        let n_steps = step_count(stop, h)?;
        if self.components.iter().any(|c| matches!(c.fmu, Fmu::Me(_))) {
            limits::STEP.check("the step size of a run with a Model Exchange component", h)?;
        }
        if let Some(t) = &opts.input {
            // Before its first row a table has no value; holding that row back to t = 0
            // would drive the system with a value it was not given.
            if t.start_time() > 1e-9 {
                return Err(Error::Config(format!(
                    "input CSV starts at t = {}, after the start time 0: its first row must be at t = 0 or earlier",
                    t.start_time()
                )));
            }
        }
        let Wiring { inputs: wiring, system_outputs } = self.wire()?;
        let input_columns: Vec<Option<usize>> = self
            .inputs
            .iter()
            .map(|n| opts.input.as_ref().and_then(|t| t.names.iter().position(|c| c == n)))
            .collect();
        if let Some(t) = &opts.input {
            if let Some(n) = t.names.iter().find(|n| !self.inputs.contains(n)) {
                return Err(Error::Config(format!(
                    "input CSV column `{n}` is not an input of the system (inputs: {})",
                    self.inputs.join(", ")
                )));
            }
        }
        let record_names: Vec<String> =
            if opts.outputs.is_empty() { self.outputs.clone() } else { opts.outputs.clone() };
        let record = self.probes(&record_names, &system_outputs)?;
        self.set_parameters(opts, stop)?;

        // The component outputs that feed inputs, each read once per step into `latest`;
        // the inputs grouped by component, so Gauss–Seidel feeds one component at a time.
        let mut sources: Vec<Port> = Vec::new();
        let mut feeds: Vec<Vec<(Port, Feed)>> = vec![Vec::new(); self.components.len()];
        for (dst, src) in &wiring {
            let feed = match src {
                Source::Output(p) => {
                    let i = sources
                        .iter()
                        .position(|q| q.component == p.component && q.vr == p.vr)
                        .unwrap_or_else(|| {
                            sources.push(*p);
                            sources.len() - 1
                        });
                    Feed::Latest(i)
                }
                Source::Input(i) => Feed::SystemInput(*i),
            };
            feeds[dst.component].push((*dst, feed));
        }
        let destinations: Vec<(Port, Feed)> = feeds.into_iter().flatten().collect();
        // A recorded port that feeds an input is read by every step already: the row
        // takes that read (nothing sets a component's inputs between its read and the
        // row), and only the other ports cost a call of their own.
        let mut record_ports: Vec<Port> = Vec::new();
        let columns: Vec<Column> = record
            .iter()
            .map(|probe| match *probe {
                Probe::SystemInput(i) => Column::SystemInput(i),
                Probe::Port(p) => {
                    let same = |q: &Port| (q.component, q.vr) == (p.component, p.vr);
                    match sources.iter().position(same) {
                        Some(j) => Column::Latest(j),
                        None => {
                            record_ports.push(p);
                            Column::Read(record_ports.len() - 1)
                        }
                    }
                }
            })
            .collect();
        let mut sim = Simulation {
            latest: vec![0.0; sources.len()],
            source_batches: Batches::new(&sources)?,
            record_batches: Batches::new(&record_ports)?,
            destination_batches: Batches::new(
                &destinations.iter().map(|(p, _)| *p).collect::<Vec<_>>(),
            )?,
            values: vec![0.0; destinations.len()],
            port_values: vec![0.0; record_ports.len()],
            row: vec![0.0; record.len()],
            destinations,
            columns,
            record_names,
            input: opts.input.clone(),
            input_rows: vec![0; input_columns.len()],
            input_columns,
            coupling: opts.coupling,
            h,
            n_steps,
            k: 0,
            stop: None,
            components: std::mem::take(&mut self.components),
            _archive: self.archive.take(),
            // The rest of the system (connectors, connections, defaults), for a reset.
            loaded: Some(self),
        };
        sim.source_batches.read(&mut sim.components, &mut sim.latest, None)?;
        Ok(sim)
    }
}

/// An initialized system stepping on a fixed communication grid `k h` (phase 3 of [`run`]).
pub struct Simulation {
    components: Vec<Component>,
    /// The latest read of every component output that feeds an input.
    latest: Vec<f64>,
    source_batches: Batches,
    destinations: Vec<(Port, Feed)>,
    destination_batches: Batches,
    /// The values about to be written to `destinations`.
    values: Vec<f64>,
    /// Where each value of a row comes from, in the order of `record_names`.
    columns: Vec<Column>,
    record_names: Vec<String>,
    record_batches: Batches,
    port_values: Vec<f64>,
    /// The row [`Simulation::sample_row`] fills, kept so that a step's row allocates nothing.
    row: Vec<f64>,
    input: Option<InputTable>,
    input_columns: Vec<Option<usize>>,
    /// Per system input, the row of the input table it was read from last.
    input_rows: Vec<usize>,
    coupling: Coupling,
    h: f64,
    n_steps: u64,
    k: u64,
    stop: Option<StopFlag>,
    _archive: Option<Archive>,
    /// The [`System`] this was initialised from, without its components and archive
    /// (which the simulation holds), for [`Simulation::reset`]; `None` after a reset failed.
    loaded: Option<System>,
}

impl Simulation {
    /// The communication steps to the stop time: `stop / h`, a whole number.
    pub fn n_steps(&self) -> u64 {
        self.n_steps
    }

    /// The current communication point, `k h` (not accumulated, so the grid stays exact).
    pub fn time(&self) -> f64 {
        self.k as f64 * self.h
    }

    pub fn record_names(&self) -> &[String] {
        &self.record_names
    }

    /// Sets the inputs of component `only` (every component if `None`) from the latest
    /// outputs and the system inputs at the current time.
    fn feed(&mut self, only: Option<usize>) -> Result<(), Error> {
        let t = self.time();
        for i in 0..self.destinations.len() {
            let (dst, feed) = self.destinations[i];
            if only.is_none_or(|c| c == dst.component) {
                let v = match feed {
                    Feed::Latest(j) => self.latest[j],
                    Feed::SystemInput(j) => {
                        let row = &mut self.input_rows[j];
                        let v = system_input(&self.input_columns, self.input.as_ref(), j, t, row);
                        // A CSV value for an Integer input: out of 32 bits, the cast
                        // would saturate silently.
                        let int = matches!(dst.ty, VarType::Integer | VarType::Enumeration);
                        if int && !(f64::from(i32::MIN)..=f64::from(i32::MAX)).contains(&v) {
                            let name = match (self.input_columns[j], &self.input) {
                                (Some(c), Some(table)) => table.names[c].as_str(),
                                _ => "?",
                            };
                            return Err(Error::Config(format!(
                                "input CSV column `{name}` = {v} at t = {t}: out of the Integer range {}..={}",
                                i32::MIN,
                                i32::MAX
                            )));
                        }
                        v
                    }
                };
                self.values[i] = v;
            }
        }
        self.destination_batches.write(&mut self.components, &self.values, only)
    }

    /// The recorded variables now, in the order of [`Simulation::record_names`].
    pub fn sample(&mut self) -> Result<Vec<f64>, Error> {
        self.sample_row().map(<[f64]>::to_vec)
    }

    /// [`Simulation::sample`] into a buffer the simulation keeps: valid until the next call.
    pub fn sample_row(&mut self) -> Result<&[f64], Error> {
        self.record_batches.read(&mut self.components, &mut self.port_values, None)?;
        let t = self.time();
        for (out, column) in self.row.iter_mut().zip(&self.columns) {
            *out = match *column {
                Column::Latest(j) => self.latest[j],
                Column::Read(k) => self.port_values[k],
                Column::SystemInput(i) => {
                    let row = &mut self.input_rows[i];
                    system_input(&self.input_columns, self.input.as_ref(), i, t, row)
                }
            };
        }
        Ok(&self.row)
    }

    /// One communication step from `k h` to `(k + 1) h`.
    pub fn step(&mut self) -> Result<(), Error> {
        let h = self.h;
        match self.coupling {
            Coupling::GaussSeidel => {
                let t = self.time();
                for ci in 0..self.components.len() {
                    self.feed(Some(ci))?;
                    self.components[ci].fmu.advance(t, h)?;
                    self.source_batches.read(&mut self.components, &mut self.latest, Some(ci))?;
                }
            }
            Coupling::Jacobi => {
                self.feed(None)?;
                let t = self.time();
                for c in self.components.iter_mut() {
                    c.fmu.advance(t, h)?;
                }
                self.source_batches.read(&mut self.components, &mut self.latest, None)?;
            }
        }
        self.k += 1;
        Ok(())
    }

    /// What integrating each Model Exchange component cost so far, by component name.
    pub fn model_exchange_stats(&self) -> Vec<(String, MeStats)> {
        self.components
            .iter()
            .filter_map(|c| match &c.fmu {
                Fmu::Me(m) => Some((c.name.clone(), m.stats())),
                Fmu::Cs(_) => None,
            })
            .collect()
    }

    pub fn terminate(mut self) -> Result<(), Error> {
        for c in self.components.iter_mut() {
            c.fmu.terminate()?;
        }
        Ok(())
    }

    /// Makes [`Simulation::run_into`] stop between two steps with [`Error::Stopped`] once
    /// `flag` is set, so the caller returns through its destructors (and the unpacked
    /// archives are removed) instead of being killed mid-step.
    pub fn stop_when(mut self, flag: StopFlag) -> Simulation {
        self.stop = Some(flag);
        self.components.iter_mut().for_each(|c| c.fmu.stop_when(self.stop.as_ref()));
        self
    }

    /// Steps to the stop time and hands every row to `sink` as soon as it is computed, t = 0
    /// first: nothing grows with the number of steps, so a run of any length runs in the
    /// same memory. The sink's own error type carries its failures (a full disk) as well
    /// as the engine's. What the run cost its Model Exchange components comes back, since
    /// the simulation is gone after it.
    pub fn run_into<E: From<Error>>(
        mut self,
        mut sink: impl FnMut(f64, &[f64]) -> Result<(), E>,
        mut progress: impl FnMut(f64),
    ) -> Result<RunEnd, E> {
        let n = self.n_steps;
        sink(0.0, self.sample_row()?)?;
        for k in 0..n {
            if let Some(flag) = &self.stop {
                flag.check()?;
            }
            self.step()?;
            let t = self.time();
            sink(t, self.sample_row()?)?;
            progress((k + 1) as f64 / n as f64);
        }
        let end = RunEnd { model_exchange: self.model_exchange_stats() };
        self.terminate()?;
        Ok(end)
    }
}

/// What a finished [`Simulation::run_into`] leaves besides its rows.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunEnd {
    /// What integrating each Model Exchange component cost, by component name (empty when
    /// every component ran its Co-Simulation).
    pub model_exchange: Vec<(String, MeStats)>,
}

/// System input `i` at `t`: its column of the input table (near `row`, the row it was read
/// from last: [`InputTable::value_near`]), or 0 without one.
fn system_input(
    columns: &[Option<usize>],
    input: Option<&InputTable>,
    i: usize,
    t: f64,
    row: &mut usize,
) -> f64 {
    match (columns[i], input) {
        (Some(col), Some(table)) => table.value_near(col, t, row),
        _ => 0.0,
    }
}

/// The largest step count run: past 2^53 steps `k h` is no longer exact in an `f64`, so
/// the grid would drift (and such a run would take years).
const MAX_STEPS: f64 = 9_007_199_254_740_992.0;

/// `stop / h` as a whole number of steps, or why not. A last step shorter than `h` would
/// be refused by FMUs with a fixed communication step, and only at the end of the run:
/// such a stop time is refused before the first step.
fn step_count(stop: f64, h: f64) -> Result<u64, Error> {
    let steps = stop / h;
    if steps > MAX_STEPS {
        return Err(Error::Config(format!(
            "stop time {stop:e} / step size {h} = {steps:e} steps: more than the 2^53 this master can count exactly"
        )));
    }
    let n = steps.round();
    if n < 1.0 || (steps - n).abs() > 1e-9 * n {
        return Err(Error::Config(format!(
            "stop time {stop} is not a whole number of steps of {h} ({stop} / {h} = {steps}): choose a stop time that is"
        )));
    }
    Ok(n as u64)
}

/// Runs `path` (an `.ssp`, or a single `.fmu`): loads it, initializes it, steps it to the
/// stop time and records the chosen variables at every communication point, t = 0 first.
///
/// The whole trace is kept in memory: for short runs (scenarios, tests). A long run
/// streams its rows with [`Simulation::run_into`].
pub fn run(path: &Path, opts: &Options, progress: impl FnMut(f64)) -> Result<Trace, Error> {
    let sim = System::load(path)?.initialise(opts)?;
    let mut trace = Trace::new(sim.record_names().to_vec());
    sim.run_into(
        |t, row| {
            trace.push(t, row.to_vec());
            Ok::<(), Error>(())
        },
        progress,
    )?;
    Ok(trace)
}

/// A communication point of a running [`Simulation`] to come back to: every component's
/// FMU state (`fmi2GetFMUstate` / `fmi3GetFMUState`, whichever standard the component is)
/// and the master's own state there (the step counter and the outputs last read, which
/// feed the next step). Restoring it makes the steps after it repeat bit for bit, so a
/// study can branch many runs from one settled transient. The FMU states live in their
/// components: give a checkpoint back with [`Simulation::release`]; those not released
/// are freed with the simulation.
pub struct Checkpoint {
    states: Vec<FmuState>,
    k: u64,
    latest: Vec<f64>,
}

impl Checkpoint {
    /// The communication step the checkpoint was taken at (its time is `step · h`).
    pub fn step(&self) -> u64 {
        self.k
    }
}

impl Simulation {
    /// Saves the current communication point. An FMU that cannot save its state (it does
    /// not declare `canGetAndSetFMUstate`) fails the call with its component's name, and
    /// the states already taken from the others are freed.
    pub fn checkpoint(&mut self) -> Result<Checkpoint, Error> {
        let mut states = Vec::with_capacity(self.components.len());
        for i in 0..self.components.len() {
            match self.components[i].fmu.get_state() {
                Ok(s) => states.push(s),
                Err(source) => {
                    for (c, s) in self.components.iter_mut().zip(states) {
                        // Freeing is best effort here: the error that matters is the one
                        // that stopped the checkpoint.
                        let _ = c.fmu.free_state(s);
                    }
                    let component = self.components[i].name.clone();
                    return Err(Error::Component { component, source });
                }
            }
        }
        Ok(Checkpoint { states, k: self.k, latest: self.latest.clone() })
    }

    /// Back to `checkpoint`, which this simulation took: every component restores its
    /// state (a checkpoint of another simulation is refused by the first component, whose
    /// FMU did not hand out that state), then the master's step counter and last outputs.
    pub fn restore(&mut self, checkpoint: &Checkpoint) -> Result<(), Error> {
        if checkpoint.states.len() != self.components.len() {
            return Err(Error::Config(format!(
                "the checkpoint holds {} component states, this simulation has {} components",
                checkpoint.states.len(),
                self.components.len()
            )));
        }
        // The restored FMUs hold the inputs of the checkpoint, not those set since.
        self.destination_batches.forget();
        for (c, s) in self.components.iter_mut().zip(&checkpoint.states) {
            c.fmu
                .set_state(s)
                .map_err(|source| Error::Component { component: c.name.clone(), source })?;
        }
        self.k = checkpoint.k;
        self.latest.clone_from(&checkpoint.latest);
        Ok(())
    }

    /// Frees the FMU states of `checkpoint`.
    pub fn release(&mut self, checkpoint: Checkpoint) -> Result<(), Error> {
        if checkpoint.states.len() != self.components.len() {
            return Err(Error::Config("the checkpoint was not taken from this simulation".into()));
        }
        for (c, s) in self.components.iter_mut().zip(checkpoint.states) {
            c.fmu
                .free_state(s)
                .map_err(|source| Error::Component { component: c.name.clone(), source })?;
        }
        Ok(())
    }
}

// Sweeps (crate::sweep): one loaded system run many times, re-initialised in place between
// runs instead of unpacked and instantiated again.
impl Simulation {
    /// Back to t = 0 with `opts`, exactly as a fresh [`System::load`] and
    /// [`System::initialise`] would put it: `fmi2Reset` on every component, then the very
    /// same [`System::initialise`] on them, so the SSD's first bindings, the parameter set,
    /// the `--param` values, the input table, the wiring and the master's step counter
    /// and held connector values all come from the one code path a fresh run takes (a
    /// reset that re-applied only some of them gave rows that differ from `inchworm run`).
    /// After an error the simulation holds no components: drop it and load the system
    /// again.
    pub fn reset(&mut self, opts: &Options) -> Result<(), Error> {
        for c in self.components.iter_mut() {
            c.fmu.reset()?;
        }
        let mut system = self
            .loaded
            .take()
            .ok_or_else(|| Error::Config("a reset failed before: load the system again".into()))?;
        system.archive = self._archive.take();
        system.components = std::mem::take(&mut self.components);
        let stop = self.stop.take();
        *self = system.initialise(opts)?;
        self.components.iter_mut().for_each(|c| c.fmu.stop_when(stop.as_ref()));
        self.stop = stop;
        Ok(())
    }
}

/// The component `element`'s variable `connector`.
fn port(components: &[Component], element: &str, connector: &str) -> Result<Port, Error> {
    let i = components
        .iter()
        .position(|c| c.name == element)
        .ok_or_else(|| Error::Config(format!("no component named `{element}`")))?;
    let v = components[i].fmu.var(connector)?;
    Ok(Port { component: i, vr: v.vr, ty: v.ty })
}

/// Qualified name → port: `component.variable` in an SSP, the bare name for a single FMU.
fn resolve(components: &[Component], ssp: bool, name: &str) -> Result<Port, Error> {
    if !ssp {
        return port(components, "fmu", name);
    }
    let (el, var) = name.split_once('.').ok_or_else(|| {
        Error::Config(format!("`{name}`: name a component variable as component.variable"))
    })?;
    port(components, el, var)
}

/// Initialization mode on every component, from entering it to leaving it: `first`, then
/// the parameter set of `opts`, then its `params`, each value over the ones before. A
/// value from the SSP (a first binding or the set) comes with the SSP type it is given,
/// which must be its variable's ([`check_binding_type`]); a `--param` has no type of its
/// own and is read as the variable's.
fn set_parameters(
    components: &mut [Component],
    archive: Option<&Archive>,
    first: Vec<(String, TypedValue)>,
    opts: &Options,
    stop: f64,
) -> Result<(), Error> {
    for c in components.iter_mut() {
        c.fmu.enter_initialization(None, 0.0, Some(stop))?;
    }
    // (name, the SSP type the SSP gives it, value text).
    let typed = |(n, (k, v)): (String, TypedValue)| (n, Some(k), v);
    let mut values: Vec<(String, Option<String>, String)> = first.into_iter().map(typed).collect();
    if let Some(set_name) = &opts.parameter_set {
        let a = archive.ok_or(Error::Config("--parameter-set needs an .ssp file".into()))?;
        values.extend(a.parameter_set_typed(set_name)?.into_iter().map(typed));
    }
    values.extend(opts.params.iter().map(|(n, v)| (n.clone(), None, v.clone())));
    for (name, kind, text) in &values {
        let p = resolve(components, archive.is_some(), name)
            .map_err(|e| e.context(format!("parameter `{name}`")))?;
        if let Some(kind) = kind {
            check_binding_type(name, kind, p.ty)?;
        }
        set_text(components, p, name, text)?;
    }
    for c in components.iter_mut() {
        c.fmu.exit_initialization()?;
    }
    Ok(())
}
