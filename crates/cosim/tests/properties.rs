//! Property tests of what the engine reads from outside (crates/properties: 10 000 cases
//! each, a fixed seed): the SSD, parameter sets (`.ssv`) and input CSVs. Generated valid
//! files parse back to exactly what was written; edits of the shipped files (bytes cut,
//! flipped, inserted, hostile tokens) parse or are refused with the engine's error, never
//! a panic, and what parses keeps the parser's promises (finite, ordered, unique).

use std::collections::BTreeMap;
use std::path::PathBuf;

use inchworm_cosim::ssp::{parse_parameter_bindings, parse_ssd, parse_ssv_typed};
use inchworm_cosim::InputTable;
use inchworm_properties::{apply_text, check, mutations};
use proptest::collection::vec;
use proptest::prelude::*;

/// The SSDs fmu-build generates, committed under modelDescription/ssp.
fn shipped_ssds() -> Vec<String> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../modelDescription/ssp");
    let mut ssds: Vec<String> = std::fs::read_dir(&root)
        .unwrap()
        .map(|d| std::fs::read_to_string(d.unwrap().path().join("SystemStructure.ssd")).unwrap())
        .collect();
    ssds.sort();
    assert!(ssds.len() >= 4, "{}: the shipped systems", root.display());
    ssds
}

#[test]
fn edited_ssds_parse_or_are_refused() {
    let ssds = shipped_ssds();
    check("ssd: edits of the shipped systems", mutations(ssds.len()), |(i, edits)| {
        let xml = apply_text(&ssds[i], &edits);
        if let Ok(sys) = parse_ssd(&xml) {
            let mut names: Vec<&str> = sys.components.iter().map(|c| c.name.as_str()).collect();
            names.sort();
            let before = names.len();
            names.dedup();
            prop_assert_eq!(before, names.len(), "a component named twice was accepted");
            for t in [sys.stop_time, sys.step_size].into_iter().flatten() {
                prop_assert!(t.is_finite() && t > 0.0, "a time {} was accepted", t);
            }
        }
        let _ = parse_parameter_bindings(&xml);
        Ok(())
    });
}

/// XML-escaped text, as a writer of `.ssv` files escapes an attribute.
fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\'', "&apos;")
}

/// A parameter's SSP type and value text, as a tool writes it.
fn typed_value() -> impl Strategy<Value = (String, String)> {
    prop_oneof![
        any::<f64>()
            .prop_filter("finite", |x| x.is_finite())
            .prop_map(|x| ("Real".to_string(), format!("{x:?}"))),
        any::<i32>().prop_map(|n| ("Integer".to_string(), n.to_string())),
        any::<bool>().prop_map(|b| ("Boolean".to_string(), b.to_string())),
        "\\PC{0,24}".prop_map(|s| ("String".to_string(), s)),
    ]
}

/// A parameter set of up to 12 parameters with distinct names of any printable text.
fn parameter_set() -> impl Strategy<Value = BTreeMap<String, (String, String)>> {
    proptest::collection::btree_map("[a-zA-Z_][\\PC]{0,20}", typed_value(), 0..12)
}

fn ssv(set: &BTreeMap<String, (String, String)>) -> String {
    let mut xml = String::from(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<ssv:ParameterSet version=\"1.0\" name=\"set\" xmlns:ssv=\"http://ssp-standard.org/SSP1/SystemStructureParameterValues\">\n  <ssv:Parameters>\n",
    );
    for (name, (kind, value)) in set {
        xml.push_str(&format!(
            "    <ssv:Parameter name=\"{}\"><ssv:{kind} value=\"{}\"/></ssv:Parameter>\n",
            escape(name),
            escape(value)
        ));
    }
    xml.push_str("  </ssv:Parameters>\n</ssv:ParameterSet>\n");
    xml
}

#[test]
fn a_written_parameter_set_reads_back_exactly() {
    check("ssv: write then parse", parameter_set(), |set| {
        let back = parse_ssv_typed(&ssv(&set)).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert_eq!(back, set);
        Ok(())
    });
}

#[test]
fn edited_parameter_sets_parse_or_are_refused() {
    let sets: Vec<String> = [
        BTreeMap::from([
            ("plant.k_flexure".to_string(), ("Real".to_string(), "1.5e7".to_string())),
            ("controller.analog".to_string(), ("Boolean".to_string(), "true".to_string())),
            ("controller.samples_per_step".to_string(), ("Integer".to_string(), "100".into())),
        ]),
        BTreeMap::from([("a&b".to_string(), ("String".to_string(), "<x>\"'".to_string()))]),
    ]
    .iter()
    .map(ssv)
    .collect();
    check("ssv: edits of a parameter set", mutations(sets.len()), |(i, edits)| {
        let _ = parse_ssv_typed(&apply_text(&sets[i], &edits));
        Ok(())
    });
}

/// An input table: names and rows of non-decreasing times and finite values.
fn table() -> impl Strategy<Value = (Vec<String>, Vec<(f64, Vec<f64>)>)> {
    (1usize..5).prop_flat_map(|columns| {
        let finite = any::<f64>().prop_filter("finite", |x| x.is_finite());
        let row = (0.0f64..1e3, vec(finite, columns));
        (vec("[a-z][a-z0-9_.]{0,12}", columns), vec(row, 1..40)).prop_map(|(names, mut rows)| {
            rows.sort_by(|a, b| a.0.total_cmp(&b.0));
            (names, rows)
        })
    })
}

fn csv(names: &[String], rows: &[(f64, Vec<f64>)]) -> String {
    let mut text = format!("time,{}\n", names.join(","));
    for (t, values) in rows {
        let values: Vec<String> = values.iter().map(|v| format!("{v:?}")).collect();
        text.push_str(&format!("{t:?},{}\n", values.join(",")));
    }
    text
}

#[test]
fn a_written_input_csv_reads_back_exactly() {
    check("input csv: write then parse", table(), |(names, rows)| {
        let t = InputTable::parse(&csv(&names, &rows))
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert_eq!(&t.names, &names);
        for (c, _) in names.iter().enumerate() {
            let want: Vec<(f64, f64)> = rows.iter().map(|(t, v)| (*t, v[c])).collect();
            let got = t.points(c);
            prop_assert_eq!(
                got.iter().map(|(t, v)| (t.to_bits(), v.to_bits())).collect::<Vec<_>>(),
                want.iter().map(|(t, v)| (t.to_bits(), v.to_bits())).collect::<Vec<_>>()
            );
        }
        Ok(())
    });
}

#[test]
fn edited_input_csvs_parse_or_are_refused_and_parsed_ones_are_finite_and_ordered() {
    let bases = [
        "time,reference\n0,0\n0.1,3e-5\n0.5,3e-5\n",
        "\u{feff}time,\"a\",b\r\n0,1,2\r\n1,1e-300,-0\r\n1,5,6\r\n",
    ];
    check("input csv: edits", mutations(bases.len()), |(i, edits)| {
        let text = apply_text(bases[i], &edits);
        if let Ok(t) = InputTable::parse(&text) {
            for c in 0..t.names.len() {
                let points = t.points(c);
                prop_assert!(!points.is_empty());
                prop_assert!(points.iter().all(|(t, v)| t.is_finite() && v.is_finite()));
                prop_assert!(points.windows(2).all(|w| w[0].0 <= w[1].0), "time goes backwards");
            }
        }
        Ok(())
    });
}
