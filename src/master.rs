//! A fixed-step co-simulation master for FMI 2.0 Co-Simulation FMUs: a flat SSP system or a
//! single FMU, Jacobi or Gauss–Seidel coupling, parameters and parameter sets, a CSV of
//! inputs for unconnected inputs, and the chosen variables recorded at every
//! communication point.

use std::collections::BTreeMap;
use std::path::Path;

use crate::fmu::{CsFmu, FmuError, Var, VarType};
use crate::ssp::{Archive, End};

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

/// Piecewise-constant signals from a CSV: `time,<name>,…`; the value at `t` is that of the
/// last row with `time ≤ t` (a repeated time row marks a jump; the later row wins).
#[derive(Clone, Debug)]
pub struct InputTable {
    pub names: Vec<String>,
    rows: Vec<(f64, Vec<f64>)>,
}

impl InputTable {
    pub fn parse(text: &str) -> Result<InputTable, String> {
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let header = lines.next().ok_or("input CSV is empty")?;
        let cols: Vec<String> =
            header.split(',').map(|c| c.trim().trim_matches('"').to_string()).collect();
        if cols.first().map(String::as_str) != Some("time") || cols.len() < 2 {
            return Err(format!("input CSV header must be `time,<name>,…`, got `{header}`"));
        }
        let mut rows = Vec::new();
        for (i, l) in lines.enumerate() {
            let v: Result<Vec<f64>, _> = l.split(',').map(|x| x.trim().parse::<f64>()).collect();
            let v = v.map_err(|_| format!("input CSV line {}: not all numbers: `{l}`", i + 2))?;
            if v.len() != cols.len() || v.iter().any(|x| !x.is_finite()) {
                return Err(format!(
                    "input CSV line {}: expected {} finite numbers, got `{l}`",
                    i + 2,
                    cols.len()
                ));
            }
            if rows.last().is_some_and(|(t, _): &(f64, Vec<f64>)| v[0] < *t) {
                return Err(format!("input CSV line {}: time goes backwards", i + 2));
            }
            rows.push((v[0], v[1..].to_vec()));
        }
        if rows.is_empty() {
            return Err("input CSV has no rows".into());
        }
        Ok(InputTable { names: cols[1..].to_vec(), rows })
    }

    pub fn value(&self, column: usize, t: f64) -> f64 {
        let tol = 1e-9 * t.abs().max(1e-3);
        let i = self.rows.partition_point(|(rt, _)| *rt <= t + tol);
        self.rows[i.saturating_sub(1)].1[column]
    }
}

/// What a run recorded: one row per communication point, t = 0 first.
pub struct Results {
    pub names: Vec<String>,
    pub rows: Vec<(f64, Vec<f64>)>,
}

impl Results {
    pub fn write_csv(&self, w: &mut impl std::io::Write) -> std::io::Result<()> {
        writeln!(w, "time,{}", self.names.join(","))?;
        for (t, v) in &self.rows {
            let vals: Vec<String> = v.iter().map(|x| format!("{x}")).collect();
            writeln!(w, "{t},{}", vals.join(","))?;
        }
        Ok(())
    }

    pub fn column(&self, name: &str) -> Option<Vec<f64>> {
        let i = self.names.iter().position(|n| n == name)?;
        Some(self.rows.iter().map(|(_, v)| v[i]).collect())
    }
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

struct Component {
    name: String,
    fmu: CsFmu,
}

fn err(e: FmuError) -> String {
    e.to_string()
}

fn set(components: &mut [Component], p: Port, value: f64) -> Result<(), String> {
    set_var(&mut components[p.component].fmu, Var { vr: p.vr, ty: p.ty }, value)
}

fn set_var(f: &mut CsFmu, v: Var, value: f64) -> Result<(), String> {
    match v.ty {
        VarType::Real => f.set_real(&[v.vr], &[value]),
        VarType::Integer | VarType::Enumeration => f.set_integer(&[v.vr], &[value.round() as i32]),
        VarType::Boolean => f.set_boolean(&[v.vr], &[value != 0.0]),
        VarType::String => return Err("String variables cannot be connected".into()),
    }
    .map_err(err)
}

/// A start value or parameter given as text (`--param`, an `.ssv`), checked against the
/// variable's type.
fn parse_value(ty: VarType, name: &str, text: &str) -> Result<f64, String> {
    let value = match ty {
        VarType::Boolean => match text.trim() {
            "true" | "1" => 1.0,
            "false" | "0" => 0.0,
            t => return Err(format!("{name} = {t}: not a Boolean (true/false)")),
        },
        _ => text.trim().parse::<f64>().map_err(|_| format!("{name} = {text}: not a number"))?,
    };
    if ty == VarType::Integer && value.fract() != 0.0 {
        return Err(format!("{name} = {text}: not an integer"));
    }
    Ok(value)
}

fn set_text(components: &mut [Component], p: Port, name: &str, text: &str) -> Result<(), String> {
    set(components, p, parse_value(p.ty, name, text)?)
}

/// Sets one variable of a single FMU by name from text, as `--param NAME=VALUE` does.
pub fn set_param(fmu: &mut CsFmu, name: &str, text: &str) -> Result<(), String> {
    let v = fmu.var(name).map_err(err)?;
    set_var(fmu, v, parse_value(v.ty, name, text)?)
}

/// Ports grouped by component and type, each group one `fmi2Get*`/`fmi2Set*` call: per step
/// the master crosses the FMI boundary once per group instead of once per variable.
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
}

impl Batches {
    fn new(ports: &[Port]) -> Result<Batches, String> {
        let mut groups: Vec<Group> = Vec::new();
        for (slot, p) in ports.iter().enumerate() {
            let ty = match p.ty {
                VarType::String => {
                    return Err("String variables cannot be connected or recorded".into())
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
    ) -> Result<(), String> {
        for g in self.groups.iter_mut().filter(|g| only.is_none_or(|c| c == g.component)) {
            let f = &mut components[g.component].fmu;
            match g.ty {
                VarType::Real => {
                    f.get_real(&g.vrs, &mut g.reals).map_err(err)?;
                    g.slots.iter().zip(&g.reals).for_each(|(&s, &v)| out[s] = v);
                }
                VarType::Boolean => {
                    f.get_boolean(&g.vrs, &mut g.booleans).map_err(err)?;
                    g.slots
                        .iter()
                        .zip(&g.booleans)
                        .for_each(|(&s, &v)| out[s] = f64::from(u8::from(v)));
                }
                _ => {
                    f.get_integer(&g.vrs, &mut g.integers).map_err(err)?;
                    g.slots.iter().zip(&g.integers).for_each(|(&s, &v)| out[s] = f64::from(v));
                }
            }
        }
        Ok(())
    }

    fn write(
        &mut self,
        components: &mut [Component],
        values: &[f64],
        only: Option<usize>,
    ) -> Result<(), String> {
        for g in self.groups.iter_mut().filter(|g| only.is_none_or(|c| c == g.component)) {
            let f = &mut components[g.component].fmu;
            match g.ty {
                VarType::Real => {
                    g.slots.iter().zip(&mut g.reals).for_each(|(&s, v)| *v = values[s]);
                    f.set_real(&g.vrs, &g.reals).map_err(err)?;
                }
                VarType::Boolean => {
                    g.slots.iter().zip(&mut g.booleans).for_each(|(&s, v)| *v = values[s] != 0.0);
                    f.set_boolean(&g.vrs, &g.booleans).map_err(err)?;
                }
                _ => {
                    g.slots
                        .iter()
                        .zip(&mut g.integers)
                        .for_each(|(&s, v)| *v = values[s].round() as i32);
                    f.set_integer(&g.vrs, &g.integers).map_err(err)?;
                }
            }
        }
        Ok(())
    }
}

/// Runs `path` (an `.ssp`, or a single `.fmu`).
pub fn run(path: &Path, opts: &Options, mut progress: impl FnMut(f64)) -> Result<Results, String> {
    let is_ssp = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("ssp"));
    let archive = if is_ssp { Some(Archive::open(path)?) } else { None };
    let mut components = Vec::new();
    let mut system_inputs: Vec<String> = Vec::new();
    let mut system_outputs: Vec<String> = Vec::new();
    let mut connections: Vec<(End, End)> = Vec::new();
    let (stop, step) = match &archive {
        Some(a) => {
            for c in &a.system.components {
                let fmu = CsFmu::load(&a.dir.join(&c.source), &c.name, false)
                    .map_err(|e| format!("component {}: {e}", c.name))?;
                components.push(Component { name: c.name.clone(), fmu });
            }
            for (name, kind) in &a.system.connectors {
                match kind.as_str() {
                    "input" => system_inputs.push(name.clone()),
                    "output" => system_outputs.push(name.clone()),
                    _ => {}
                }
            }
            connections = a.system.connections.clone();
            (a.system.stop_time, a.system.step_size)
        }
        None => {
            let fmu = CsFmu::load(path, "fmu", false).map_err(err)?;
            let step = fmu.default_step_size();
            system_inputs = fmu.names_with_causality("input");
            system_outputs = fmu.names_with_causality("output");
            // A single FMU is a system whose connectors are the FMU's own.
            for n in &system_inputs {
                connections.push((
                    End { element: None, connector: n.clone() },
                    End { element: Some("fmu".into()), connector: n.clone() },
                ));
            }
            for n in &system_outputs {
                connections.push((
                    End { element: Some("fmu".into()), connector: n.clone() },
                    End { element: None, connector: n.clone() },
                ));
            }
            components.push(Component { name: "fmu".into(), fmu });
            (None, step)
        }
    };
    let stop = opts.stop_time.or(stop).unwrap_or(1.0);
    let h = opts.step_size.or(step).unwrap_or(stop / 500.0);
    if !(h > 0.0 && h.is_finite() && stop > 0.0 && stop.is_finite()) {
        return Err(format!("step size {h} and stop time {stop} must be finite and > 0"));
    }

    let port = |components: &[Component], element: &str, connector: &str| -> Result<Port, String> {
        let i = components
            .iter()
            .position(|c| c.name == element)
            .ok_or_else(|| format!("no component named `{element}`"))?;
        let v = components[i].fmu.var(connector).map_err(err)?;
        Ok(Port { component: i, vr: v.vr, ty: v.ty })
    };
    // Qualified name → port: `component.variable`, or the bare name for a single FMU.
    let resolve = |components: &[Component], name: &str| -> Result<Port, String> {
        if archive.is_none() {
            return port(components, "fmu", name);
        }
        let (el, var) = name
            .split_once('.')
            .ok_or_else(|| format!("`{name}`: name a component variable as component.variable"))?;
        port(components, el, var)
    };

    // Wiring: every input port fed by a component output or a system input.
    let mut wiring: Vec<(Port, Source)> = Vec::new();
    let mut system_output_ports: BTreeMap<String, Port> = BTreeMap::new();
    for (a, b) in &connections {
        let source = match &a.element {
            Some(e) => Source::Output(port(&components, e, &a.connector)?),
            None => {
                Source::Input(system_inputs.iter().position(|n| *n == a.connector).ok_or_else(
                    || format!("connection starts at unknown system connector `{}`", a.connector),
                )?)
            }
        };
        match (&b.element, source) {
            (Some(e), s) => wiring.push((port(&components, e, &b.connector)?, s)),
            (None, Source::Output(p)) => {
                system_output_ports.insert(b.connector.clone(), p);
            }
            (None, Source::Input(_)) => {
                return Err(format!(
                    "connection from a system input straight to system output `{}`",
                    b.connector
                ))
            }
        }
    }
    let input_columns: Vec<Option<usize>> = system_inputs
        .iter()
        .map(|n| opts.input.as_ref().and_then(|t| t.names.iter().position(|c| c == n)))
        .collect();
    if let Some(t) = &opts.input {
        for n in &t.names {
            if !system_inputs.contains(n) {
                return Err(format!(
                    "input CSV column `{n}` is not an input of the system (inputs: {})",
                    system_inputs.join(", ")
                ));
            }
        }
    }

    let record_names: Vec<String> =
        if opts.outputs.is_empty() { system_outputs.clone() } else { opts.outputs.clone() };
    let mut record: Vec<Port> = Vec::new();
    for n in &record_names {
        match system_output_ports.get(n) {
            Some(p) => record.push(*p),
            None => record.push(resolve(&components, n).map_err(|e| format!("output `{n}`: {e}"))?),
        }
    }

    // Initialization: parameter set, then --param values.
    for c in components.iter_mut() {
        c.fmu.enter_initialization(None, 0.0, Some(stop)).map_err(err)?;
    }
    let mut values: Vec<(String, String)> = Vec::new();
    if let Some(set_name) = &opts.parameter_set {
        let a = archive.as_ref().ok_or("--parameter-set needs an .ssp file")?;
        values.extend(a.parameter_set(set_name)?);
    }
    values.extend(opts.params.iter().cloned());
    for (name, text) in &values {
        let p = resolve(&components, name).map_err(|e| format!("parameter `{name}`: {e}"))?;
        set_text(&mut components, p, name, text)?;
    }
    for c in components.iter_mut() {
        c.fmu.exit_initialization().map_err(err)?;
    }

    let input_value = |k: usize, t: f64| -> f64 {
        input_columns[k].map_or(0.0, |col| opts.input.as_ref().expect("has columns").value(col, t))
    };
    // The component outputs that feed inputs, each read once per step into `latest`.
    let mut sources: Vec<Port> = Vec::new();
    let mut feeds: Vec<Vec<(Port, Feed)>> = vec![Vec::new(); components.len()];
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
    let mut latest = vec![0.0; sources.len()];
    let mut source_batches = Batches::new(&sources)?;
    let mut record_batches = Batches::new(&record)?;
    let destinations: Vec<(Port, Feed)> = feeds.into_iter().flatten().collect();
    let mut destination_batches =
        Batches::new(&destinations.iter().map(|(p, _)| *p).collect::<Vec<_>>())?;
    let mut values = vec![0.0; destinations.len()];
    source_batches.read(&mut components, &mut latest, None)?;
    let n_steps = (stop / h).round().max(1.0) as u64;
    let mut rows = Vec::with_capacity(n_steps as usize + 1);
    let mut sample = |components: &mut [Component]| -> Result<Vec<f64>, String> {
        let mut row = vec![0.0; record.len()];
        record_batches.read(components, &mut row, None)?;
        Ok(row)
    };
    // The first row is the state after initialization.
    rows.push((0.0, sample(&mut components)?));
    for k in 0..n_steps {
        let t = k as f64 * h;
        let mut feed = |only: Option<usize>,
                        components: &mut [Component],
                        latest: &[f64]|
         -> Result<(), String> {
            for (v, (dst, feed)) in values.iter_mut().zip(&destinations) {
                if only.is_none_or(|c| c == dst.component) {
                    *v = match feed {
                        Feed::Latest(i) => latest[*i],
                        Feed::SystemInput(i) => input_value(*i, t),
                    };
                }
            }
            destination_batches.write(components, &values, only)
        };
        match opts.coupling {
            Coupling::GaussSeidel => {
                for ci in 0..components.len() {
                    feed(Some(ci), &mut components, &latest)?;
                    components[ci].fmu.do_step(h).map_err(err)?;
                    source_batches.read(&mut components, &mut latest, Some(ci))?;
                }
            }
            Coupling::Jacobi => {
                feed(None, &mut components, &latest)?;
                for c in components.iter_mut() {
                    c.fmu.do_step(h).map_err(err)?;
                }
                source_batches.read(&mut components, &mut latest, None)?;
            }
        }
        rows.push(((k + 1) as f64 * h, sample(&mut components)?));
        progress((k + 1) as f64 / n_steps as f64);
    }
    for c in components.iter_mut() {
        c.fmu.terminate().map_err(err)?;
    }
    Ok(Results { names: record_names, rows })
}
