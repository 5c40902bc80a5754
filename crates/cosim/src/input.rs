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
        let tol = 1e-9 * t.abs().max(1e-3);
        let i = self.rows.partition_point(|(rt, _)| *rt <= t + tol);
        self.rows[i.saturating_sub(1)].1[column]
    }
}
