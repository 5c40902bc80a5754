//! docs/model.md §2.8's two parameter tables against the declarations on `PlantParams`'
//! fields: every row of the docs names declared parameters and gives their declared start
//! values (the `fia20` column), the `fia6` values, units and ranges. A declaration changed
//! without its docs, or docs without the declaration, fails here.

use inchworm_declare::{Declared, Field, Start};
use inchworm_plant::PlantParams;

const MODEL_MD: &str = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/model.md"));

/// The rows of the Markdown table whose header line starts with `header`, as cells.
fn table(header: &str) -> Vec<Vec<String>> {
    let mut lines = MODEL_MD.lines().skip_while(|l| !l.starts_with(header));
    assert!(lines.next().is_some(), "docs/model.md has no table headed {header:?}");
    lines
        .skip(1)
        .take_while(|l| l.starts_with('|'))
        .map(|l| l.trim_matches('|').split('|').map(|c| c.trim().to_string()).collect())
        .collect()
}

/// The parameter names a cell lists: `` `m_p`, `k_p` `` or `` `play_radius[1..5]` ``
/// (each element) or `` `play_radius[i]` `` (the array: every element).
fn names(cell: &str) -> Vec<String> {
    let names: Vec<&str> = cell.split('`').skip(1).step_by(2).collect();
    assert!(!names.is_empty(), "no parameter names in {cell:?}");
    names
        .iter()
        .flat_map(|n| match n.split_once('[') {
            None => vec![n.to_string()],
            Some((array, _)) => PlantParams::FIELDS
                .iter()
                .filter(|f| f.name.strip_prefix(array).is_some_and(|r| r.starts_with('[')))
                .map(|f| f.name.to_string())
                .collect(),
        })
        .collect()
}

fn field(name: &str) -> &'static Field<PlantParams> {
    inchworm_declare::field_named::<PlantParams>(name)
        .unwrap_or_else(|| panic!("docs/model.md names {name}, which PlantParams does not declare"))
}

/// A number as the docs write it (`−1` with the minus sign).
fn number(text: &str) -> f64 {
    let text = text.trim().replace('−', "-");
    text.parse().unwrap_or_else(|_| panic!("{text:?} in docs/model.md is not a number"))
}

/// A unit as the docs write it (`N s/m`, `–` for none) in the declarations' spelling.
fn unit(text: &str) -> Option<String> {
    match text.trim() {
        "–" => None,
        u => Some(u.replace(' ', ".")),
    }
}

fn start(f: &Field<PlantParams>) -> f64 {
    match f.start {
        Start::Real(x) => x,
        Start::Integer(n) => n as f64,
        Start::Boolean(b) => b as u8 as f64,
    }
}

#[test]
fn the_range_table_is_the_declared_ranges() {
    let rows = table("| parameters | range | unit |");
    let mut listed = Vec::new();
    for row in &rows {
        let (lo, hi) = row[1].split_once('…').expect("a range `lo … hi`");
        let hi = hi.split(',').next().unwrap();
        for name in names(&row[0]) {
            let f = field(&name);
            assert_eq!(f.min, Some(number(lo)), "{name}'s lower bound in docs/model.md");
            assert_eq!(f.max, Some(number(hi)), "{name}'s upper bound in docs/model.md");
            assert_eq!(f.unit.map(str::to_string), unit(&row[2]), "{name}'s unit in docs/model.md");
            listed.push(name);
        }
    }
    // Every ranged Real parameter of the declarations has its row.
    for f in PlantParams::FIELDS.iter().filter(|f| f.max.is_some()) {
        assert!(listed.iter().any(|n| n == f.name), "docs/model.md gives no range for {}", f.name);
    }
}

#[test]
fn the_parameter_table_is_the_declared_starts_and_fia6() {
    let rows = table("| symbol | FMU name |");
    let fia6 = PlantParams::fia6();
    let mut listed = 0;
    for row in &rows {
        let names = names(&row[1]);
        let values: Vec<f64> = row[2].split(',').map(number).collect();
        assert_eq!(values.len(), names.len(), "one fia20 value per name in {row:?}");
        let units: Vec<&str> = row[4].split(',').collect();
        for (i, (name, value)) in names.iter().zip(&values).enumerate() {
            let f = field(name);
            assert_eq!(start(f), *value, "{name}'s fia20 value (its start) in docs/model.md");
            let unit_text = units.get(i).or(units.first()).unwrap();
            assert_eq!(
                f.unit.map(str::to_string),
                unit(unit_text),
                "{name}'s unit in docs/model.md"
            );
            let in_fia6 = f.real(&fia6).unwrap();
            let documented = match row[3].as_str() {
                "same" => *value,
                v => number(v.split(',').nth(i).expect("one fia6 value per name")),
            };
            assert_eq!(in_fia6, documented, "{name}'s fia6 value in docs/model.md");
            listed += 1;
        }
    }
    assert!(listed >= 25, "docs/model.md §2.8 lists {listed} parameters");
}
