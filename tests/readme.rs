//! The README's scenario table is the code's: the same names in the same order, with the
//! same descriptions, so neither can gain or lose a scenario alone.

use inchworm_scenarios::scenario::{ALIASES, SCENARIOS};

#[test]
fn the_readme_lists_exactly_the_scenarios_of_the_code() {
    let readme = include_str!("../README.md");
    let start = readme.find("<!-- scenarios:").expect("the README marks its scenario table");
    let end = readme.find("<!-- /scenarios -->").expect("the table's end is marked");
    let rows: Vec<(String, String)> = readme[start..end]
        .lines()
        .filter_map(|l| {
            let cells: Vec<&str> =
                l.trim().strip_prefix('|')?.strip_suffix('|')?.split('|').collect();
            let name = cells.first()?.trim().strip_prefix('`')?.strip_suffix('`')?;
            Some((name.to_string(), cells.get(1)?.trim().to_string()))
        })
        .collect();
    let code: Vec<(String, String)> =
        SCENARIOS.iter().map(|(n, what)| (n.to_string(), what.to_string())).collect();
    assert_eq!(rows, code, "README.md's scenario table against SCENARIOS");
    for (old, _) in ALIASES {
        assert!(!rows.iter().any(|(n, _)| n == old), "`{old}` is an alias, not listed");
    }
}
