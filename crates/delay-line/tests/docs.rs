//! docs/delay-line.md §5's parameter table is the declarations' table: a renamed, added
//! or re-ranged parameter fails here until the page says the same.

use inchworm_declare::{Declared, Start};
use inchworm_delay_line::system::DelayLineParams;

fn number(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// The table, one row per declared parameter, in declaration order.
fn table() -> String {
    let mut s = String::from(
        "| parameter | unit | default | range | what it is |\n|---|---|---|---|---|\n",
    );
    for f in DelayLineParams::FIELDS {
        let start = match f.start {
            Start::Real(v) => number(v),
            Start::Integer(i) => i.to_string(),
            Start::Boolean(b) => b.to_string(),
        };
        let range = match (f.min, f.max) {
            (Some(lo), Some(hi)) => format!("{} … {}", number(lo), number(hi)),
            _ => String::new(),
        };
        s += &format!(
            "| `{}` | {} | {} | {} | {} |\n",
            f.name,
            f.unit.unwrap_or(""),
            start,
            range,
            f.description
        );
    }
    s
}

#[test]
fn the_page_lists_every_declared_parameter() {
    let page = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/delay-line.md"),
    )
    .unwrap();
    let want = table();
    assert!(page.contains(&want), "docs/delay-line.md §5 should hold:\n{want}");
}
