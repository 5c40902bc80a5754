//! Property tests of the modelDescription reader (crates/properties: 10 000 cases each, a
//! fixed seed). A generated FMI 2.0 description (any printable names and descriptions,
//! escaped; every type, causality and variability; start values of every kind) reads back
//! to exactly the variables written. Edits of the shipped descriptions (FMI 2.0 and 3.0:
//! bytes cut, flipped, repeated, hostile tokens) read or are refused with the reader's
//! error, never a panic, and what reads keeps its promises: names unique and found by
//! name, every start valid for its type, within the size cap.

use std::path::PathBuf;

use inchworm_fmi_import::{ModelDescription, VarType};
use inchworm_properties::{apply_text, check, mutations};
use proptest::collection::btree_map;
use proptest::prelude::*;

/// The descriptions fmu-build generates, committed under modelDescription/.
fn shipped() -> Vec<String> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../modelDescription");
    let mut xmls = Vec::new();
    for dir in [root.clone(), root.join("fmi3")] {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "xml") {
                xmls.push(std::fs::read_to_string(&p).unwrap());
            }
        }
    }
    xmls.sort();
    assert!(xmls.len() >= 9, "{}: the shipped descriptions", root.display());
    xmls
}

#[test]
fn edited_descriptions_read_or_are_refused() {
    let xmls = shipped();
    check("modelDescription: edits of the shipped ones", mutations(xmls.len()), |(i, edits)| {
        let xml = apply_text(&xmls[i], &edits);
        if let Ok(md) = ModelDescription::parse_within(&xml, 1 << 22) {
            let mut names: Vec<&str> = md.variables.iter().map(|v| v.name.as_str()).collect();
            names.sort();
            let n = names.len();
            names.dedup();
            prop_assert_eq!(n, names.len(), "a name used twice was read");
            for v in &md.variables {
                prop_assert!(
                    std::ptr::eq(md.variable(&v.name).unwrap(), v),
                    "{} not found",
                    v.name
                );
                if let (Some(start), VarType::Integer | VarType::Enumeration) = (&v.start, v.ty) {
                    prop_assert!(
                        start.split_ascii_whitespace().all(|s| s.parse::<i64>().is_ok()),
                        "{}",
                        start
                    );
                }
            }
        }
        Ok(())
    });
}

#[derive(Clone, Debug)]
struct Var {
    vr: u32,
    ty: &'static str,
    causality: &'static str,
    variability: &'static str,
    start: Option<String>,
    description: Option<String>,
}

fn start(ty: &'static str) -> BoxedStrategy<Option<String>> {
    let text = match ty {
        "Real" => any::<f64>()
            .prop_filter("finite", |x| x.is_finite())
            .prop_map(|x| format!("{x:?}"))
            .boxed(),
        "Integer" => any::<i32>().prop_map(|n| n.to_string()).boxed(),
        "Boolean" => prop_oneof![Just("true"), Just("false"), Just("1"), Just("0")]
            .prop_map(str::to_string)
            .boxed(),
        _ => "\\PC{0,16}".boxed(),
    };
    proptest::option::of(text).boxed()
}

fn var() -> impl Strategy<Value = Var> {
    let ty = proptest::sample::select(&["Real", "Integer", "Boolean", "String"][..]);
    let causality = proptest::sample::select(
        &["parameter", "calculatedParameter", "input", "output", "local", "independent"][..],
    );
    let variability =
        proptest::sample::select(&["constant", "fixed", "tunable", "discrete", "continuous"][..]);
    (any::<u32>(), ty, causality, variability, proptest::option::of("\\PC{0,30}")).prop_flat_map(
        |(vr, ty, causality, variability, description)| {
            start(ty).prop_map(move |start| Var {
                vr,
                ty,
                causality,
                variability,
                start,
                description: description.clone(),
            })
        },
    )
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

fn description(vars: &std::collections::BTreeMap<String, Var>) -> String {
    let mut xml = String::from(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<fmiModelDescription fmiVersion=\"2.0\" modelName=\"M\" guid=\"{g}\">\n  <CoSimulation modelIdentifier=\"m\"/>\n  <ModelVariables>\n",
    );
    for (name, v) in vars {
        let desc = v.description.as_ref().map(|d| format!(" description=\"{}\"", escape(d)));
        let start = v.start.as_ref().map(|s| format!(" start=\"{}\"", escape(s)));
        xml.push_str(&format!(
            "    <ScalarVariable name=\"{}\" valueReference=\"{}\" causality=\"{}\" variability=\"{}\"{}>\n      <{}{}/>\n    </ScalarVariable>\n",
            escape(name),
            v.vr,
            v.causality,
            v.variability,
            desc.unwrap_or_default(),
            v.ty,
            start.unwrap_or_default(),
        ));
    }
    xml.push_str("  </ModelVariables>\n  <ModelStructure/>\n</fmiModelDescription>\n");
    xml
}

#[test]
fn a_written_description_reads_back_exactly() {
    let vars = btree_map("[a-zA-Z_][\\PC]{0,24}", var(), 0..16);
    check("modelDescription: write then read", vars, |vars| {
        let xml = description(&vars);
        let md = ModelDescription::parse_within(&xml, 1 << 22)
            .map_err(|e| TestCaseError::fail(format!("{e}\n{xml}")))?;
        prop_assert_eq!(md.variables.len(), vars.len());
        for (v, (name, want)) in md.variables.iter().zip(&vars) {
            prop_assert_eq!(&v.name, name);
            prop_assert_eq!(v.vr, want.vr);
            prop_assert_eq!(v.ty.to_string(), want.ty);
            prop_assert_eq!(v.causality.as_str(), want.causality);
            prop_assert_eq!(v.variability.as_str(), want.variability);
            prop_assert_eq!(&v.start, &want.start);
            prop_assert_eq!(&v.description, &want.description);
        }
        Ok(())
    });
}
