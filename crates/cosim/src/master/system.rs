//! Phases 1 and 2 of a run: a system loaded (its components instantiated, its connectors
//! and connections read), then wired and initialised into a [`Simulation`].

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use super::batches::Batches;
use super::component::{port, resolve, Component, Fmu};
use super::parameters::ssp_type_fits;
use super::{Column, Feed, Interfaces, Options, Port, Simulation, System};
use crate::archive::cut;
use crate::fmu::VarType;
use crate::limits;
use crate::ssp::{Archive, End};
use crate::Error;

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

/// The connections resolved to ports.
struct Wiring {
    /// Every connected component input and where it is fed from.
    inputs: Vec<(Port, Source)>,
    system_outputs: BTreeMap<String, Port>,
}

impl System {
    /// Loads `path`: an `.ssp` (a flat system of FMI 2.0 CS FMUs), or a single `.fmu`,
    /// which is a system whose connectors are the FMU's own.
    pub fn load(path: &Path) -> Result<System, Error> {
        System::load_as(path, &Interfaces::default())
    }

    /// [`System::load`], with the components of `interfaces` run as Model Exchange.
    pub fn load_as(path: &Path, interfaces: &Interfaces) -> Result<System, Error> {
        System::load_selected(path, None, interfaces, None)
    }

    /// One part of the SSP `path`, unpacked as `archive` ([`partition::Split`]): every
    /// component but those of `elsewhere`, which other parts run, and the connections
    /// among its own; it records `records` (by default). Every name, source and
    /// `--interface` is checked against the whole SSD, as a whole run checks them, so a
    /// part refuses what the whole run refuses. The parts of one split share `archive`'s
    /// unpacked folder (a clone each).
    ///
    /// [`partition::Split`]: super::partition::Split
    pub fn load_part(
        path: &Path,
        archive: Archive,
        interfaces: &Interfaces,
        elsewhere: &BTreeSet<String>,
        records: &[String],
    ) -> Result<System, Error> {
        System::load_selected(path, Some(archive), interfaces, Some((elsewhere, records)))
    }

    /// `path` (unpacked as `archive`, if given), whole or the part `part`.
    fn load_selected(
        path: &Path,
        archive: Option<Archive>,
        interfaces: &Interfaces,
        part: Option<(&BTreeSet<String>, &[String])>,
    ) -> Result<System, Error> {
        let tolerance = interfaces.tolerance;
        let is_ssp = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("ssp"));
        if !is_ssp {
            // A single FMU is one component, named `fmu`: checked before it is opened.
            interfaces.check(&["fmu".to_string()])?;
            let fmu = Fmu::open(path, "fmu", interfaces.wants("fmu"), tolerance)?;
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
                elsewhere: BTreeSet::new(),
            });
        }
        // The tolerance before the archive is unpacked, the names once its SSD is read.
        interfaces.tolerance.check()?;
        let mut a = match archive {
            Some(a) => a,
            None => Archive::open(path)?,
        };
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
        if let Some((elsewhere, _)) = part {
            let kept = |c: &&crate::ssp::Component| !elsewhere.contains(&c.name);
            sources = a
                .system
                .components
                .iter()
                .zip(sources)
                .filter(|(c, _)| kept(c))
                .map(|(_, s)| s)
                .collect();
            super::partition::keep_part(&mut a.system, elsewhere);
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
            let me = interfaces.wants(&c.name);
            let earlier = sources[..i].iter().position(|s| s == source);
            let fmu = match earlier.map(|e| &components[e].fmu) {
                Some(first)
                    if first.can_instantiate_again()
                        && first.interface() == me.interface(first.description()) =>
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
        let outputs = match part {
            Some((_, records)) => records.to_vec(),
            None => a.default_outputs(kind("output"))?,
        };
        Ok(System {
            inputs: kind("input"),
            outputs,
            elsewhere: part.map(|(e, _)| e.clone()).unwrap_or_default(),
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

    /// Phase 2 of [`run`]: wires the connections, resolves what to record, sets the
    /// parameters in initialization mode, and leaves every component at t = 0 ready to
    /// step.
    ///
    /// [`run`]: super::run
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
        // The clocked inputs of clocked components are set at their ticks, apart.
        let all: Vec<(Port, Feed)> = feeds.into_iter().flatten().collect();
        let (ticked, destinations): (Vec<_>, Vec<_>) =
            all.into_iter().partition(|(dst, _)| super::clocks::at_ticks(&self.components, dst));
        // A recorded port that feeds an input is read by every step already: the row
        // takes that read (nothing sets a component's inputs between its read and the
        // row). The other recorded ports follow the sources in `latest`: a step without
        // clocks reads them in the same calls, a row after anything else on their own.
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
                            Column::Latest(sources.len() + record_ports.len() - 1)
                        }
                    }
                }
            })
            .collect();
        // A step reads the recorded ports with the sources, each component's of one type in
        // one call ([`Simulation::step`]).
        let read: Vec<Port> = sources.iter().chain(&record_ports).copied().collect();
        let mut sim = Simulation {
            latest: vec![0.0; read.len()],
            sources: sources.len(),
            source_batches: Batches::new(&sources)?,
            record_batches: Batches::new(&record_ports)?,
            read_batches: Batches::new(&read)?,
            rows_read: false,
            destination_batches: Batches::new(
                &destinations.iter().map(|(p, _)| *p).collect::<Vec<_>>(),
            )?,
            values: vec![0.0; destinations.len()],
            ticked: super::clocks::TickInputs {
                batches: Batches::new(&ticked.iter().map(|(p, _)| *p).collect::<Vec<_>>())?,
                values: vec![0.0; ticked.len()],
                destinations: ticked,
            },
            clocked: self.components.iter().any(|c| c.fmu.clocked()),
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
        sim.schedule_clocks(0.0)?;
        sim.source_batches.read(&mut sim.components, &mut sim.latest, None)?;
        Ok(sim)
    }
}

/// The largest step count run: past 2^53 steps `k h` is no longer exact in an `f64`, so
/// the grid would drift (and such a run would take years).
const MAX_STEPS: f64 = 9_007_199_254_740_992.0;

/// `stop / h` as a whole number of steps, or why not. A last step shorter than `h` would
/// be refused by FMUs with a fixed communication step, and only at the end of the run:
/// such a stop time is refused before the first step.
pub(super) fn step_count(stop: f64, h: f64) -> Result<u64, Error> {
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
