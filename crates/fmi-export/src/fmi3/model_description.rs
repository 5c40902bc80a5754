//! The FMI 3.0 `modelDescription.xml`, generated from the same table as the FMI 2.0 one.
//! Its instantiation token is the FMI 2.0 GUID ([`crate::model_description::guid`]): a
//! digest of the interface, the same for both versions of a model, so that a serialized
//! FMU state moves between them.

use std::fmt::Write;

use super::api::type_name;
use super::TIME_VR;
use crate::arrays;
use crate::entry::has_clocks;
use crate::model_description::{
    causality, common_flags, directional, escape, guid, initial, is_initial_unknown, prolog,
    shared_head, start_attr, start_text, state_of, unit_and_range, variability,
};
use crate::table::{Causality, ClockKind, Kind, Variability, Variable};
use crate::Model;

/// The complete FMI 3.0 `modelDescription.xml`.
pub fn model_description<M: Model>() -> String {
    assert!(
        M::variables().all(|v| v.vr != TIME_VR),
        "value reference {TIME_VR} is the FMI 3.0 independent variable time"
    );
    let info = M::info();
    let mut x = prolog(info.model_identifier, " (FMI 3.0)");
    let w = &mut x;
    let _ = writeln!(
        w,
        r#"<fmiModelDescription fmiVersion="3.0" modelName="{}" instantiationToken="{}" description="{}" version="{}" generationTool="inchworm fmu-build {}" variableNamingConvention="structured">"#,
        escape(info.model_name),
        guid::<M>(),
        escape(info.description),
        escape(info.version),
        env!("CARGO_PKG_VERSION")
    );
    if M::model_exchange().is_some() {
        let _ = writeln!(
            w,
            r#"  <ModelExchange modelIdentifier="{}" {} providesAdjointDerivatives="false" providesPerElementDependencies="false" needsCompletedIntegratorStep="false" providesEvaluateDiscreteStates="false"/>"#,
            escape(info.model_identifier),
            common_flags::<M>("FMUState", "providesDirectionalDerivatives")
        );
    }
    let _ = writeln!(
        w,
        r#"  <CoSimulation modelIdentifier="{}" needsExecutionTool="false" canBeInstantiatedOnlyOncePerProcess="false" canGetAndSetFMUState="true" canSerializeFMUState="true" providesDirectionalDerivatives="{}" providesAdjointDerivatives="false" providesPerElementDependencies="false" canHandleVariableCommunicationStepSize="true" maxOutputDerivativeOrder="0" providesIntermediateUpdate="false" mightReturnEarlyFromDoStep="false" canReturnEarlyAfterIntermediateUpdate="false" hasEventMode="{}" providesEvaluateDiscreteStates="false"/>"#,
        escape(info.model_identifier),
        directional::<M>(),
        has_clocks::<M>()
    );
    // A model with clocks runs its input clocks' partitions under a scheduler too.
    if has_clocks::<M>() {
        let _ = writeln!(
            w,
            r#"  <ScheduledExecution modelIdentifier="{}" {} providesAdjointDerivatives="false" providesPerElementDependencies="false"/>"#,
            escape(info.model_identifier),
            common_flags::<M>("FMUState", "providesDirectionalDerivatives")
        );
    }
    shared_head::<M>(w, "fmi3");
    let _ = writeln!(w, "  <ModelVariables>");
    let _ = writeln!(
        w,
        r#"    <Float64 name="time" valueReference="{TIME_VR}" description="Simulation time" causality="independent" variability="continuous"/>"#
    );
    let vars = M::table();
    let entries = arrays::fmi3_entries(vars).unwrap_or_else(|why| {
        panic!("{}: the variable table's arrays: {why}", info.model_identifier)
    });
    for e in &entries {
        let v = &vars[e.first].var;
        let init = v.initial.map(|i| format!(" initial=\"{}\"", initial(i))).unwrap_or_default();
        let mut attrs = clock_attrs(v);
        attrs += &unit_and_range(v);
        if let Some(state) = state_of::<M>(v) {
            let _ = write!(attrs, " derivative=\"{state}\"");
        }
        let (name, description, start, close) = if e.is_array(vars) {
            // One start value per element, in the serialization order (element 1 first).
            let starts: Vec<String> = vars[e.first..e.first + e.len]
                .iter()
                .filter_map(|x| start_text(x.var.start))
                .collect();
            let start = match starts.len() {
                0 => String::new(),
                _ => format!(" start=\"{}\"", starts.join(" ")),
            };
            let close = format!("><Dimension start=\"{}\"/></{}>", e.len, type_name(v.kind));
            (arrays::array_name(v), v.array.unwrap_or(v.description), start, close)
        } else {
            (v.name, v.description, start_attr(v.start), "/>".to_string())
        };
        let _ = writeln!(
            w,
            r#"    <{} name="{}" valueReference="{}" description="{}" causality="{}" variability="{}"{init}{attrs}{start}{close}"#,
            type_name(v.kind),
            escape(name),
            v.vr,
            escape(description),
            causality(v.causality),
            // A clocked variable changes only at its clock's ticks.
            variability(if v.clocks.is_some() { Variability::Discrete } else { v.variability }),
        );
    }
    let _ = writeln!(w, "  </ModelVariables>");
    let _ = writeln!(w, "  <ModelStructure>");
    // An array is one unknown, under its first element's value reference.
    let vrs = |pred: &dyn Fn(&Variable) -> bool| -> Vec<u32> {
        entries.iter().map(|e| &vars[e.first].var).filter(|v| pred(v)).map(|v| v.vr).collect()
    };
    let outputs = vrs(&|v| v.causality == Causality::Output);
    let derivatives = vrs(&|v| state_of::<M>(v).is_some());
    // A clocked variable is computed at its clock's ticks, not in initialization; an output
    // clock (an output of initial "calculated" by default) is an initial unknown.
    let initial_unknowns = vrs(&|v| {
        (is_initial_unknown::<M>(v) && v.clocks.is_none())
            || (v.kind == Kind::Clock && v.causality == Causality::Output)
    });
    let indicators = M::model_exchange().map_or(&[][..], |me| me.event_indicators);
    for (tag, list) in [
        ("Output", &outputs[..]),
        ("ContinuousStateDerivative", &derivatives[..]),
        ("InitialUnknown", &initial_unknowns[..]),
        ("EventIndicator", indicators),
    ] {
        for vr in list {
            let _ = writeln!(w, "    <{tag} valueReference=\"{vr}\"/>");
        }
    }
    let _ = writeln!(w, "  </ModelStructure>");
    let _ = writeln!(w, "</fmiModelDescription>");
    x
}

/// A clock's attributes (`intervalVariability`, and a periodic input clock's
/// `intervalDecimal` and its `priority` under a scheduler, the highest: it is the model's
/// one partition), or a clocked variable's `clocks`.
fn clock_attrs(v: &Variable) -> String {
    match (v.kind, v.clock) {
        (Kind::Clock, Some(ClockKind::Periodic { interval })) => format!(
            r#" intervalVariability="constant" intervalDecimal="{}" priority="0""#,
            crate::model_description::real(interval)
        ),
        (Kind::Clock, _) => r#" intervalVariability="triggered""#.to_string(),
        _ => v.clocks.map(|c| format!(" clocks=\"{c}\"")).unwrap_or_default(),
    }
}
