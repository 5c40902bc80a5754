//! What a run records, whoever ran it: the master on an SSP or FMU, or the crates coupled
//! directly. Both write the same type under the same qualified names, so a test compares
//! them column by column and a CSV or a plot reads either.

/// One row per communication point, t = 0 first (the state after initialization).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trace {
    pub names: Vec<String>,
    pub rows: Vec<(f64, Vec<f64>)>,
}

impl Trace {
    pub fn new(names: Vec<String>) -> Trace {
        Trace { names, rows: Vec::new() }
    }

    pub fn push(&mut self, time: f64, row: Vec<f64>) {
        debug_assert_eq!(row.len(), self.names.len(), "a row holds one value per name");
        self.rows.push((time, row));
    }

    pub fn index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    pub fn column(&self, name: &str) -> Option<Vec<f64>> {
        let i = self.index(name)?;
        Some(self.rows.iter().map(|(_, v)| v[i]).collect())
    }

    pub fn times(&self) -> Vec<f64> {
        self.rows.iter().map(|(t, _)| *t).collect()
    }

    /// CSV `time,<name>,…`, every value in the shortest text that reads back as the same
    /// `f64`.
    pub fn write_csv(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        writeln!(w, "time,{}", self.names.join(","))?;
        for (t, v) in &self.rows {
            let vals: Vec<String> = v.iter().map(|x| format!("{x}")).collect();
            writeln!(w, "{t},{}", vals.join(","))?;
        }
        Ok(())
    }
}
