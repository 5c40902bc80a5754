//! The SSP 1.0 systems of `dist/`, generated from the FMUs' variable tables so that they
//! cannot drift from them:
//!
//! * `InchwormSystem.ssp`, closed: reference, controller and plant connected as
//!   docs/model.md §5 says, connections only between components (every SSP master runs
//!   it with no external input), parameter sets bound per component;
//! * `InchwormSystemOpen.ssp`, open: controller and plant only, the reference from a
//!   system input connector and the plotted positions as system output connectors (for
//!   masters that feed a system input, such as `inchworm run --input`).
//!
//! Parameter sets are component-level `ssd:ParameterBinding`s as SSP 1.0 defines them:
//! each binding's `source` is an `.ssv` file relative to the SSP root, its set's name the
//! `ssv:ParameterSet` `name`, its parameter names the FMU's bare variable names (relative
//! to the component). Each component's first binding is the set `default`, equal to the
//! FMU's defaults, because some masters (libcosim) apply a component's first binding
//! whatever is asked.

use std::fmt::Write;

use inchworm_fmi_export::model_description::real;
use inchworm_fmi_export::{
    parameter_values, start_value, Causality, Kind, Model, Value, Var, Variable,
};
use inchworm_fmu_models::{ControllerFmu, PlantFmu, ReferenceFmu};
use inchworm_plant::PlantParams;

pub const STEP_SIZE: f64 = 0.002;

/// Plant and controller connectors: every input and the outputs that the connections or
/// the users' plots need.
pub fn plant_connectors() -> Vec<&'static str> {
    use inchworm_fmu_models::PlantFmu as P;
    names(&[
        P::var(inchworm_plant::Dac::EARTH),
        P::var(inchworm_plant::Dac::NONEARTH),
        P::var(inchworm_plant::Dac::EXTENSION),
        P::ENCODER_COUNTS,
        P::ENCODER_POSITION,
        P::RUNNER_POSITION,
        P::EXTENSION,
        P::MODE,
    ])
}

pub fn controller_connectors() -> Vec<&'static str> {
    use ControllerFmu as C;
    names(&[
        C::REFERENCE,
        C::ENCODER_COUNTS,
        C::DAC_EARTH,
        C::DAC_NONEARTH,
        C::DAC_EXTENSION,
        C::SERVO_ERROR,
        C::DISTURBANCE_ESTIMATE,
        C::N_STEPS,
        C::FRACTION,
    ])
}

pub fn reference_connectors() -> Vec<&'static str> {
    names(&[ReferenceFmu::REFERENCE])
}

fn names<M: Model>(vars: &[Var<M>]) -> Vec<&'static str> {
    vars.iter().map(|v| v.name()).collect()
}

/// The FMU behind a component: its identifier and how to find a variable of its table.
#[derive(Clone, Copy)]
pub struct Fmu {
    pub identifier: &'static str,
    pub find: fn(&str) -> Option<&'static Variable>,
}

pub fn fmu<M: Model>() -> Fmu {
    fn find<M: Model>(name: &str) -> Option<&'static Variable> {
        M::variables().find(|v| v.name == name)
    }
    Fmu { identifier: M::info().model_identifier, find: find::<M> }
}

impl Fmu {
    pub fn variable(&self, name: &str) -> &'static Variable {
        (self.find)(name)
            .unwrap_or_else(|| panic!("{name} is not a variable of {}", self.identifier))
    }
}

/// One component's part of a named parameter set: bare variable names.
#[derive(Clone)]
pub struct Binding {
    pub set: String,
    pub values: Vec<(String, Value)>,
}

pub struct Component {
    pub name: String,
    pub fmu: Fmu,
    pub connectors: Vec<&'static str>,
    /// In order; the first is `default`.
    pub bindings: Vec<Binding>,
}

/// (start element, start connector, end element, end connector); `None` is the system.
pub type Connection = (Option<String>, String, Option<String>, String);

pub struct SystemSpec {
    pub name: &'static str,
    pub description: String,
    pub components: Vec<Component>,
    /// System connectors: (name, kind, unit), all Real.
    pub connectors: Vec<(&'static str, &'static str, &'static str)>,
    pub connections: Vec<Connection>,
    pub stop_time: f64,
}

fn connector(out: &mut String, indent: &str, name: &str, kind: &str, ty: Kind, unit: Option<&str>) {
    let ty = match ty {
        Kind::Real => match unit {
            Some(u) => format!("<ssc:Real unit=\"{u}\"/>"),
            None => "<ssc:Real/>".to_string(),
        },
        Kind::Integer => "<ssc:Integer/>".to_string(),
        Kind::Boolean => "<ssc:Boolean/>".to_string(),
        // SSP 1.0 has no clock type: a system connects the FMUs' values, never their clocks.
        Kind::Clock => {
            panic!("{name}: a clock cannot be an SSP connector (SSP 1.0 has no clock type)")
        }
    };
    let _ = writeln!(
        out,
        "{indent}<ssd:Connector name=\"{name}\" kind=\"{kind}\">{ty}</ssd:Connector>"
    );
}

/// Where a component's part of a set lives in the archive.
pub fn ssv_path(component: &str, set: &str) -> String {
    format!("resources/{component}.{set}.ssv")
}

impl SystemSpec {
    /// `SystemStructure.ssd`.
    pub fn system_description(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
        let _ = writeln!(
            s,
            "<!-- Generated by fmu-build from the FMUs' variable tables: do not edit. -->"
        );
        let _ = writeln!(
            s,
            r#"<ssd:SystemStructureDescription xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" version="1.0" name="{}" generationTool="inchworm fmu-build {}">"#,
            self.name,
            env!("CARGO_PKG_VERSION")
        );
        let _ = writeln!(
            s,
            r#"  <ssd:System name="{}" description="{}">"#,
            self.name, self.description
        );
        if !self.connectors.is_empty() {
            let _ = writeln!(s, "    <ssd:Connectors>");
            for (name, kind, unit) in &self.connectors {
                connector(&mut s, "      ", name, kind, Kind::Real, Some(unit));
            }
            let _ = writeln!(s, "    </ssd:Connectors>");
        }
        let _ = writeln!(s, "    <ssd:Elements>");
        for c in &self.components {
            let _ = writeln!(s, "      <ssd:Component name=\"{}\" type=\"application/x-fmu-sharedlibrary\" source=\"resources/{}.fmu\">", c.name, c.fmu.identifier);
            let _ = writeln!(s, "        <ssd:Connectors>");
            for n in &c.connectors {
                let v = c.fmu.variable(n);
                let kind = match v.causality {
                    Causality::Input => "input",
                    Causality::Output => "output",
                    Causality::Parameter => "parameter",
                    _ => "local",
                };
                connector(&mut s, "          ", n, kind, v.kind, v.unit);
            }
            let _ = writeln!(s, "        </ssd:Connectors>");
            if !c.bindings.is_empty() {
                let _ = writeln!(s, "        <ssd:ParameterBindings>");
                for b in &c.bindings {
                    let _ = writeln!(
                        s,
                        "          <ssd:ParameterBinding source=\"{}\"/>",
                        ssv_path(&c.name, &b.set)
                    );
                }
                let _ = writeln!(s, "        </ssd:ParameterBindings>");
            }
            let _ = writeln!(s, "      </ssd:Component>");
        }
        let _ = writeln!(s, "    </ssd:Elements>");
        let _ = writeln!(s, "    <ssd:Connections>");
        for (se, sc, ee, ec) in &self.connections {
            let start = se.as_ref().map(|e| format!(" startElement=\"{e}\"")).unwrap_or_default();
            let end = ee.as_ref().map(|e| format!(" endElement=\"{e}\"")).unwrap_or_default();
            let _ = writeln!(
                s,
                "      <ssd:Connection{start} startConnector=\"{sc}\"{end} endConnector=\"{ec}\"/>"
            );
        }
        let _ = writeln!(s, "    </ssd:Connections>");
        let _ = writeln!(s, "  </ssd:System>");
        let _ = writeln!(
            s,
            r#"  <ssd:DefaultExperiment startTime="0" stopTime="{}">"#,
            real(self.stop_time)
        );
        let _ = writeln!(s, "    <ssd:Annotations>");
        let _ = writeln!(
            s,
            r#"      <ssc:Annotation type="org.inchworm.communication"><inchworm:CommunicationStep xmlns:inchworm="urn:inchworm:ssp" stepSize="{}" coupling="jacobi"/></ssc:Annotation>"#,
            real(STEP_SIZE)
        );
        let _ = writeln!(s, "    </ssd:Annotations>");
        let _ = writeln!(s, "  </ssd:DefaultExperiment>");
        let _ = writeln!(s, "</ssd:SystemStructureDescription>");
        s
    }

    /// Every `.ssv` file: (path in the archive, text).
    pub fn parameter_files(&self) -> Vec<(String, String)> {
        self.components
            .iter()
            .flat_map(|c| {
                c.bindings
                    .iter()
                    .map(|b| (ssv_path(&c.name, &b.set), parameter_set(&b.set, &b.values)))
            })
            .collect()
    }

    /// The FMUs the system needs, each once.
    pub fn fmus(&self) -> Vec<&'static str> {
        let mut ids: Vec<&'static str> = Vec::new();
        for c in &self.components {
            if !ids.contains(&c.fmu.identifier) {
                ids.push(c.fmu.identifier);
            }
        }
        ids
    }
}

/// An `.ssv` parameter set.
pub fn parameter_set(name: &str, values: &[(String, Value)]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        s,
        r#"<ssv:ParameterSet xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="{name}">"#
    );
    let _ = writeln!(s, "  <ssv:Parameters>");
    for (p, v) in values {
        let v = match v {
            Value::Real(x) => format!("<ssv:Real value=\"{}\"/>", real(*x)),
            Value::Integer(i) => format!("<ssv:Integer value=\"{i}\"/>"),
            Value::Boolean(b) => format!("<ssv:Boolean value=\"{b}\"/>"),
        };
        let _ = writeln!(s, "    <ssv:Parameter name=\"{p}\">{v}</ssv:Parameter>");
    }
    let _ = writeln!(s, "  </ssv:Parameters>");
    let _ = writeln!(s, "</ssv:ParameterSet>");
    s
}

/// `v`'s start value, named.
fn start<M: Model>(v: Var<M>) -> (String, Value) {
    let start = start_value(&v.row().var);
    (v.name().to_string(), start.unwrap_or_else(|| panic!("{} has no start value", v.name())))
}

pub fn binding(set: &str, values: Vec<(String, Value)>) -> Binding {
    Binding { set: set.into(), values }
}

/// Every parameter of `model` as a set's values.
fn parameters<M: Model>(model: &M) -> Vec<(String, Value)> {
    parameter_values(model).map(|(n, v)| (n.to_string(), v)).collect()
}

/// The plant's sets: `default` (every parameter at its start, which is fia20), the two
/// devices of docs/model.md §2.8.
pub fn plant_bindings() -> Vec<Binding> {
    let device = |p: PlantParams| parameters(&PlantFmu::with_params(p));
    vec![
        binding("default", parameters(&PlantFmu::new())),
        binding("fia20", device(PlantParams::fia20())),
        binding("fia6", device(PlantParams::fia6())),
    ]
}

/// The controller's sets: `default` (the four flags at their starts), the control
/// variants of the paper's Fig. 5 and Figs. 6–7.
pub fn controller_bindings() -> Vec<Binding> {
    use inchworm_fmu_models::ControllerParams as P;
    let flags =
        [P::FEEDFORWARD, P::PREFILTER, P::USE_SCALE_FACTOR_ESTIMATE, P::USE_DISTURBANCE_ESTIMATE]
            .map(ControllerFmu::var);
    let set = |values: [bool; 4]| -> Vec<(String, Value)> {
        flags.iter().zip(values).map(|(v, b)| (v.name().to_string(), Value::Boolean(b))).collect()
    };
    vec![
        binding("default", flags.iter().map(|&v| start(v)).collect()),
        binding("full-control", set([true, false, true, true])),
        binding("feedback-only", set([false, false, false, false])),
        binding("prefilter", set([true, true, true, true])),
    ]
}

/// A reference table as a set's values.
pub fn reference_table(points: &[(f64, f64)], ramp_time: f64) -> Vec<(String, Value)> {
    use ReferenceFmu as R;
    let named = |v: Var<ReferenceFmu>, x: Value| (v.name().to_string(), x);
    let mut v = vec![
        named(R::PROFILE, Value::Integer(0)),
        named(R::N_POINTS, Value::Integer(points.len() as i32)),
        named(R::RAMP_TIME, Value::Real(ramp_time)),
    ];
    for (i, (t, p)) in points.iter().enumerate() {
        v.push(named(R::TIMES_1.element(i), Value::Real(*t)));
        v.push(named(R::POSITIONS_1.element(i), Value::Real(*p)));
    }
    v
}

/// The reference's sets: `default` (the table's start values: the Fig. 5 step) and the
/// `staircase` profile of Figs. 6–7.
pub fn reference_bindings() -> Vec<Binding> {
    use ReferenceFmu as R;
    let default = [R::PROFILE, R::N_POINTS, R::RAMP_TIME, R::TIMES_1, R::POSITIONS_1];
    vec![
        binding("default", default.iter().map(|&v| start(v)).collect()),
        binding("staircase", vec![(R::PROFILE.name().into(), Value::Integer(2))]),
    ]
}

fn link(a: &str, ca: &str, b: &str, cb: &str) -> Connection {
    (Some(a.into()), ca.into(), Some(b.into()), cb.into())
}

/// The loop of docs/model.md §5 between `controller` and `plant`.
pub fn loop_connections(controller: &str, plant: &str) -> Vec<Connection> {
    use ControllerFmu as C;
    let dacs = [
        (C::DAC_EARTH, PlantFmu::var(inchworm_plant::Dac::EARTH)),
        (C::DAC_NONEARTH, PlantFmu::var(inchworm_plant::Dac::NONEARTH)),
        (C::DAC_EXTENSION, PlantFmu::var(inchworm_plant::Dac::EXTENSION)),
    ];
    let mut c: Vec<Connection> = dacs
        .into_iter()
        .map(|(from, to)| link(controller, from.name(), plant, to.name()))
        .collect();
    c.push(link(plant, PlantFmu::ENCODER_COUNTS.name(), controller, C::ENCODER_COUNTS.name()));
    c
}

fn component(
    name: &str,
    fmu: Fmu,
    connectors: Vec<&'static str>,
    bindings: Vec<Binding>,
) -> Component {
    Component { name: name.into(), fmu, connectors, bindings }
}

/// `InchwormSystem.ssp`: closed, no system connectors.
pub fn closed_system() -> SystemSpec {
    let mut connections = vec![link(
        "reference",
        ReferenceFmu::REFERENCE.name(),
        "controller",
        ControllerFmu::REFERENCE.name(),
    )];
    connections.extend(loop_connections("controller", "plant"));
    SystemSpec {
        name: "InchwormSystem",
        description: "JPL inchworm actuator, closed loop: InchwormReference gives the reference, InchwormController drives InchwormPlant through its DACs and reads its encoder, sampled every 2 ms".into(),
        components: vec![
            component("reference", fmu::<ReferenceFmu>(), reference_connectors(), reference_bindings()),
            component("controller", fmu::<ControllerFmu>(), controller_connectors(), controller_bindings()),
            component("plant", fmu::<PlantFmu>(), plant_connectors(), plant_bindings()),
        ],
        connectors: vec![],
        connections,
        stop_time: 10.0,
    }
}

/// `InchwormSystemOpen.ssp`: the reference from a system input, the plotted positions as
/// system outputs.
pub fn open_system() -> SystemSpec {
    let mut connections = loop_connections("controller", "plant");
    let sys = |a: Option<&str>, ca: &str, b: Option<&str>, cb: &str| -> Connection {
        (a.map(Into::into), ca.into(), b.map(Into::into), cb.into())
    };
    use ControllerFmu as C;
    let reference = C::REFERENCE.name();
    connections.push(sys(None, reference, Some("controller"), reference));
    let outputs = [
        ("plant", PlantFmu::ENCODER_POSITION.name()),
        ("plant", PlantFmu::RUNNER_POSITION.name()),
        ("controller", C::DISTURBANCE_ESTIMATE.name()),
        ("controller", C::SERVO_ERROR.name()),
    ];
    for (component, output) in outputs {
        connections.push(sys(Some(component), output, None, output));
    }
    SystemSpec {
        name: "InchwormSystemOpen",
        description: "JPL inchworm actuator: InchwormController drives InchwormPlant through its DACs and reads its encoder, sampled every 2 ms; the reference from the system input".into(),
        components: vec![
            component("plant", fmu::<PlantFmu>(), plant_connectors(), plant_bindings()),
            component("controller", fmu::<ControllerFmu>(), controller_connectors(), controller_bindings()),
        ],
        connectors: std::iter::once((reference, "input", "m"))
            .chain(outputs.iter().map(|&(_, output)| (output, "output", "m")))
            .collect(),
        connections,
        stop_time: 10.0,
    }
}

pub use inchworm_fmu_models::mount::{MIRROR_PISTON, MIRROR_TIP, MIRROR_TIP_TIME};
pub const MIRROR_CHAINS: [&str; 3] = ["a", "b", "c"];

/// One mount: three reference → controller → plant chains, 120° apart on a 50 mm
/// radius, and the mount kinematics on their runner positions, its components named
/// `{prefix}reference_x`, `{prefix}controller_x`, `{prefix}plant_x` (x = a, b, c) and
/// `{prefix}mount`. Each reference's first (and only) binding, `default`, is its
/// actuator's share of the command: the piston from t = 0, the piston and the tip from
/// `MIRROR_TIP_TIME`. `plants[i]` are plant x's bindings (none: the FMU's defaults).
pub fn mount(prefix: &str, plants: [Vec<Binding>; 3]) -> (Vec<Component>, Vec<Connection>) {
    use inchworm_fmu_models::mount::{actuator_positions, ANGLE_A_DEG, RADIUS};
    use inchworm_fmu_models::MountFmu;
    let z = actuator_positions(MIRROR_PISTON, MIRROR_TIP, 0.0, RADIUS, ANGLE_A_DEG);
    let mount_inputs = [MountFmu::POSITION_A, MountFmu::POSITION_B, MountFmu::POSITION_C];
    let mount = format!("{prefix}mount");
    let mut components = Vec::new();
    let mut connections = Vec::new();
    for ((i, x), plant_bindings) in MIRROR_CHAINS.iter().enumerate().zip(plants) {
        let r = format!("{prefix}reference_{x}");
        let (c, p) = (format!("{prefix}controller_{x}"), format!("{prefix}plant_{x}"));
        let command = reference_table(&[(0.0, MIRROR_PISTON), (MIRROR_TIP_TIME, z[i])], 0.0);
        components.push(component(
            &r,
            fmu::<ReferenceFmu>(),
            reference_connectors(),
            vec![binding("default", command)],
        ));
        components.push(component(&c, fmu::<ControllerFmu>(), controller_connectors(), vec![]));
        components.push(component(&p, fmu::<PlantFmu>(), plant_connectors(), plant_bindings));
        let reference = ReferenceFmu::REFERENCE.name();
        connections.push(link(&r, reference, &c, ControllerFmu::REFERENCE.name()));
        connections.extend(loop_connections(&c, &p));
        let position = mount_inputs[i].name();
        connections.push(link(&p, PlantFmu::RUNNER_POSITION.name(), &mount, position));
    }
    components.push(component(
        &mount,
        fmu::<MountFmu>(),
        names(
            &[mount_inputs.as_slice(), &[MountFmu::PISTON, MountFmu::TIP, MountFmu::TILT]].concat(),
        ),
        vec![],
    ));
    (components, connections)
}

/// `MirrorMount.ssp`: one [`mount`], its plants and controllers the FMUs' defaults.
pub fn mirror_mount() -> SystemSpec {
    let (components, connections) = mount("", [vec![], vec![], vec![]]);
    SystemSpec {
        name: "MirrorMount",
        description: "Three-actuator mirror mount: three InchwormReference, InchwormController, InchwormPlant chains 120 deg apart on a 50 mm radius, InchwormMount turns the runner positions into piston, tip and tilt".into(),
        components,
        connectors: vec![],
        connections,
        stop_time: 10.0,
    }
}

/// The delay line's sets: `default` (every parameter at its start: a 10 m baseline on the
/// ground, with a cart and the fine stage), and the survey's other cases.
pub fn delay_line_bindings() -> Vec<Binding> {
    use inchworm_delay_line::fine_stage::FineStageParams as F;
    use inchworm_delay_line::system::DelayLineParams as P;
    use inchworm_fmu_models::DelayLineFmu as D;
    let set = |f, v: Value| vec![(D::var(f).name().to_string(), v)];
    vec![
        binding("default", parameters(&D::new())),
        binding("baseline-100m", set(P::BASELINE_LENGTH, Value::Real(100.0))),
        binding("no-fine-stage", set(P::fine(F::ENABLED), Value::Boolean(false))),
        binding("space", set(P::SPACE, Value::Boolean(true))),
    ]
}

/// `InchwormDelayLine.ssp`: an interferometer's delay line (docs/delay-line.md) on one
/// inchworm. InchwormDelayLine gives the controller its reference from the sidereal path,
/// the cart and the offload, and reads the plant's runner position.
pub fn delay_line() -> SystemSpec {
    use inchworm_fmu_models::DelayLineFmu as D;
    let mut connections = loop_connections("controller", "plant");
    connections.push(link(
        "plant",
        PlantFmu::RUNNER_POSITION.name(),
        "delay_line",
        D::RUNNER_POSITION.name(),
    ));
    connections.push(link(
        "delay_line",
        D::REFERENCE.name(),
        "controller",
        ControllerFmu::REFERENCE.name(),
    ));
    let connectors = names(&[
        D::RUNNER_POSITION,
        D::REFERENCE,
        D::PATH,
        D::CART_PATH,
        D::FINE_PATH,
        D::RESIDUAL,
        D::LOCKED,
        D::VISIBILITY_H,
        D::VISIBILITY_N,
        D::NULL_N,
    ]);
    SystemSpec {
        name: "InchwormDelayLine",
        description: "Interferometer delay line on the JPL inchworm: InchwormDelayLine (sidereal path, cart, fringe tracker, fine stage, offload) gives InchwormController its reference, which drives InchwormPlant carrying the cat's eye, sampled every 2 ms".into(),
        components: vec![
            component("delay_line", fmu::<D>(), connectors, delay_line_bindings()),
            component("controller", fmu::<ControllerFmu>(), controller_connectors(), controller_bindings()),
            component("plant", fmu::<PlantFmu>(), plant_connectors(), plant_bindings()),
        ],
        connectors: vec![],
        connections,
        stop_time: 10.0,
    }
}
