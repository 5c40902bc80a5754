//! Input tables: piecewise-constant signals for a system's unconnected inputs.

use crate::archive::cut;
use crate::Error;

/// Piecewise-constant signals from a CSV: `time,<name>,…`; the value at `t` is that of the
/// last row with `time ≤ t` (a repeated time row marks a jump; the later row wins).
#[derive(Clone, Debug)]
pub struct InputTable {
    pub names: Vec<String>,
    rows: Vec<(f64, Vec<f64>)>,
}

impl InputTable {
    /// The `(time, value)` rows of column `column`.
    pub fn points(&self, column: usize) -> Vec<(f64, f64)> {
        self.rows.iter().map(|(t, v)| (*t, v[column])).collect()
    }

    /// One signal from `(time, value)` rows, held from each time on; the times as
    /// [`InputTable::parse`] wants them, non-decreasing and finite.
    pub fn steps(name: &str, rows: &[(f64, f64)]) -> Result<InputTable, Error> {
        if rows.is_empty() || rows.windows(2).any(|w| w[1].0 < w[0].0) {
            return Err(Error::Input(format!(
                "input `{name}`: times must be non-decreasing, at least one row"
            )));
        }
        if rows.iter().any(|(t, v)| !t.is_finite() || !v.is_finite()) {
            return Err(Error::Input(format!("input `{name}`: times and values must be finite")));
        }
        Ok(InputTable {
            names: vec![name.to_string()],
            rows: rows.iter().map(|&(t, v)| (t, vec![v])).collect(),
        })
    }

    /// Parses the CSV text. A leading UTF-8 byte-order mark is skipped; a line echoed in an
    /// error is cut to 200 characters.
    pub fn parse(text: &str) -> Result<InputTable, Error> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let header = lines.next().ok_or(Error::Input("input CSV is empty".into()))?;
        let cols: Vec<String> =
            header.split(',').map(|c| c.trim().trim_matches('"').to_string()).collect();
        if cols.first().map(String::as_str) != Some("time") || cols.len() < 2 {
            let header = cut(header, 200);
            return Err(Error::Input(format!(
                "input CSV header must be `time,<name>,…`, got `{header}`"
            )));
        }
        let mut rows = Vec::new();
        for (i, l) in lines.enumerate() {
            let v: Result<Vec<f64>, _> = l.split(',').map(|x| x.trim().parse::<f64>()).collect();
            let v = v.map_err(|_| {
                Error::Input(format!(
                    "input CSV line {}: not all numbers: `{}`",
                    i + 2,
                    cut(l, 200)
                ))
            })?;
            if v.len() != cols.len() || v.iter().any(|x| !x.is_finite()) {
                return Err(Error::Input(format!(
                    "input CSV line {}: expected {} finite numbers, got `{}`",
                    i + 2,
                    cols.len(),
                    cut(l, 200)
                )));
            }
            if rows.last().is_some_and(|(t, _): &(f64, Vec<f64>)| v[0] < *t) {
                return Err(Error::Input(format!("input CSV line {}: time goes backwards", i + 2)));
            }
            rows.push((v[0], v[1..].to_vec()));
        }
        if rows.is_empty() {
            return Err(Error::Input("input CSV has no rows".into()));
        }
        Ok(InputTable { names: cols[1..].to_vec(), rows })
    }

    /// The time of the first row: before it the table has no value.
    pub fn start_time(&self) -> f64 {
        self.rows[0].0
    }

    pub fn value(&self, column: usize, t: f64) -> f64 {
        self.value_near(column, t, &mut 0)
    }

    /// [`InputTable::value`] for a caller whose times advance a little at a time (a
    /// master's steps): `row` is the row found last, tried first, then the one after it,
    /// and only then searched for; it is updated to the row that holds at `t`.
    pub fn value_near(&self, column: usize, t: f64, row: &mut usize) -> f64 {
        let at = t + 1e-9 * t.abs().max(1e-3);
        // The row that holds at `at`: the last one of its time at or before it (the first
        // row before every time).
        let holds = |r: usize| {
            (r == 0 || self.rows[r].0 <= at) && self.rows.get(r + 1).is_none_or(|n| n.0 > at)
        };
        if !(*row < self.rows.len() && holds(*row)) {
            *row = match *row + 1 < self.rows.len() && holds(*row + 1) {
                true => *row + 1,
                false => self.rows.partition_point(|(rt, _)| *rt <= at).saturating_sub(1),
            };
        }
        self.rows[*row].1[column]
    }
}

#[cfg(test)]
mod tests {
    use super::InputTable;

    /// From any row it was left at, forward or back, the value is the search's.
    #[test]
    fn a_value_near_the_last_row_is_the_value() {
        let t = InputTable::parse("time,a\n0.1,1\n0.3,2\n0.3,3\n0.5,4\n").unwrap();
        let times: [f64; 10] = [0.0, 0.05, 0.1, 0.1 - 1e-12, 0.2, 0.3, 0.3 - 1e-12, 0.4, 0.5, 7.0];
        for start in 0..5 {
            for &at in times.iter().chain(times.iter().rev()) {
                let mut row = start;
                let searched = {
                    let i = t.rows.partition_point(|(rt, _)| *rt <= at + 1e-9 * at.abs().max(1e-3));
                    t.rows[i.saturating_sub(1)].1[0]
                };
                assert_eq!(t.value_near(0, at, &mut row), searched, "t = {at} from row {start}");
                assert_eq!(t.value(0, at), searched, "t = {at}");
            }
        }
    }
}
