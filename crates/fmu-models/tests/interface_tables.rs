//! docs/model.md §5's interface tables against the FMUs' variable tables (and so the
//! declarations they are built from): every variable a row names exists with the row's
//! causality, type and unit, and every input, output and parameter of the controller, and
//! every input and output of the plant, has its row. A variable added, renamed or retyped
//! without its docs fails here.

use inchworm_fmi_export::{row_named, Causality, Kind, Model, Variable};
use inchworm_fmu_models::{ControllerFmu, PlantFmu, PlantFullFmu};

const MODEL_MD: &str = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/model.md"));

/// The rows (cells) of the interface table that follows the line starting with `before`.
fn table(before: &str) -> Vec<Vec<String>> {
    let at = MODEL_MD.find(before).unwrap_or_else(|| panic!("docs/model.md has no {before:?}"));
    let mut lines = MODEL_MD[at..].lines().skip_while(|l| !l.starts_with("| variable | causality"));
    assert!(lines.next().is_some(), "no interface table after {before:?}");
    lines
        .skip(1)
        .take_while(|l| l.starts_with('|'))
        .map(|l| l.trim_matches('|').split('|').map(|c| c.trim().to_string()).collect())
        .collect()
}

/// The variables a cell names, each with the position of the item that names it:
/// `` `a`, `b` ``, and `` `w[1..10]` `` as its elements.
fn names(cell: &str) -> Vec<(usize, String)> {
    cell.split('`')
        .skip(1)
        .step_by(2)
        .enumerate()
        .flat_map(|(item, n)| match n.split_once('[') {
            None => vec![(item, n.to_string())],
            Some((array, range)) => {
                let (lo, hi) = range.trim_end_matches(']').split_once("..").expect("[a..b]");
                let (lo, hi): (usize, usize) = (lo.parse().unwrap(), hi.parse().unwrap());
                (lo..=hi).map(|k| (item, format!("{array}[{k}]"))).collect()
            }
        })
        .collect()
}

fn causality(text: &str) -> Causality {
    match text {
        "input" => Causality::Input,
        "output" => Causality::Output,
        "parameter" => Causality::Parameter,
        other => panic!("causality {other:?} in docs/model.md"),
    }
}

fn kinds(text: &str) -> Vec<Kind> {
    let kind = |t: &str| match t.trim() {
        "Real" => Kind::Real,
        "Integer" => Kind::Integer,
        "Boolean" => Kind::Boolean,
        t if t.starts_with("Clock") => Kind::Clock,
        other => panic!("type {other:?} in docs/model.md"),
    };
    text.split([',', '/']).map(kind).collect()
}

/// Checks the table's rows against model `M`'s variables; returns the names it lists.
fn check<M: Model>(rows: &[Vec<String>]) -> Vec<String> {
    let mut listed = Vec::new();
    for row in rows {
        let names = names(&row[0]);
        if names.is_empty() {
            continue; // a row that refers to another table (the plant's §2.8 parameters)
        }
        let kinds = kinds(&row[2]);
        let units: Vec<&str> = row[3].split(',').map(str::trim).collect();
        for (i, name) in &names {
            let v: &Variable = &row_named::<M>(name)
                .unwrap_or_else(|| panic!("docs/model.md names {name}, which the FMU lacks"))
                .var;
            if v.kind != Kind::Clock {
                assert_eq!(v.causality, causality(&row[1]), "{name}'s causality in docs/model.md");
            }
            let kind = kinds.get(*i).unwrap_or(&kinds[0]);
            assert!(kinds.contains(&v.kind), "{name} is {:?}, docs/model.md says {kind:?}", v.kind);
            // The docs may say more than the description's unit (`m/√s` for a noise
            // density, `1/√s` for a dimensionless one), never something else.
            let unit = *units.get(*i).unwrap_or(&units[0]);
            match v.unit {
                // A row that points to another table for its units.
                _ if unit.starts_with('§') => {}
                Some(u) => assert!(
                    unit == u || unit.strip_prefix(u).is_some_and(|r| r.starts_with('/')),
                    "{name}'s unit is {u}, docs/model.md says {unit}"
                ),
                None => assert!(
                    unit == "–" || !["m", "V", "s", "Hz"].contains(&unit),
                    "{name} has no unit, docs/model.md says {unit}"
                ),
            }
            listed.push(name.clone());
        }
    }
    listed
}

fn missing<M: Model>(listed: &[String], wanted: &[Causality]) -> Vec<&'static str> {
    M::table()
        .iter()
        .map(|r| &r.var)
        .filter(|v| wanted.contains(&v.causality) && v.kind != Kind::Clock)
        .map(|v| v.name)
        .filter(|n| !listed.iter().any(|l| l == n))
        .collect()
}

#[test]
fn the_controller_table_is_the_controller_fmu() {
    let listed = check::<ControllerFmu>(&table("**`InchwormController`**"));
    let all = [Causality::Input, Causality::Output, Causality::Parameter];
    assert_eq!(
        missing::<ControllerFmu>(&listed, &all),
        Vec::<&str>::new(),
        "not in docs/model.md §5"
    );
}

#[test]
fn the_plant_table_is_both_plant_fmus() {
    let rows = table("**`InchwormPlant`** and **`InchwormPlantFull`**");
    let io = [Causality::Input, Causality::Output];
    let listed = check::<PlantFmu>(&rows);
    assert_eq!(missing::<PlantFmu>(&listed, &io), Vec::<&str>::new(), "not in docs/model.md §5");
    let listed = check::<PlantFullFmu>(&rows);
    assert_eq!(missing::<PlantFullFmu>(&listed, &io), Vec::<&str>::new());
}
