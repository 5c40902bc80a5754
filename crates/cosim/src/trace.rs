//! What a run records, whoever ran it: the master on an SSP or FMU, or the crates coupled
//! directly. Both write the same type under the same qualified names, so a test compares
//! them column by column and a CSV or a plot reads either.

use crate::float_text;

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
        write_header(w, &self.names)?;
        let mut rows = RowWriter::new();
        for (t, v) in &self.rows {
            rows.write(w, *t, v)?;
        }
        Ok(())
    }
}

/// The CSV header of [`Trace::write_csv`], for a writer that streams its rows.
pub fn write_header(w: &mut dyn std::io::Write, names: &[String]) -> std::io::Result<()> {
    writeln!(w, "time,{}", names.join(","))
}

/// The CSV rows of [`Trace::write_csv`], one after another, for a writer that streams
/// them. Each value is its `{}` text (the shortest that reads back as the same `f64`),
/// written by [`float_text::push`]. The writer keeps the last row's line and rewrites in it
/// only the values whose bits changed (and the time): a closed loop's slow columns (a DAC
/// between gaits, a mode, a held reference) change in a few rows in a hundred, so a long
/// run's row costs the text of its few changed values and a move of the line's tail where
/// a text's length changed, and no byte changes. A row goes to the writer in one call.
#[derive(Debug, Default)]
pub struct RowWriter {
    /// Per column: the bits of its value in the line.
    bits: Vec<u64>,
    /// Where each text of the line ends, the time's first, then each column's (its
    /// comma first); empty before the first row.
    ends: Vec<usize>,
    /// A value's text while it is formatted.
    scratch: Vec<u8>,
    /// The last row written, its line end included.
    line: Vec<u8>,
}

impl RowWriter {
    pub fn new() -> RowWriter {
        RowWriter::default()
    }

    /// Writes the row `t, row…` and its line end.
    pub fn write(
        &mut self,
        w: &mut dyn std::io::Write,
        t: f64,
        row: &[f64],
    ) -> std::io::Result<()> {
        if self.ends.len() != row.len() + 1 {
            self.first(t, row);
        } else {
            self.scratch.clear();
            float_text::push(&mut self.scratch, t);
            self.replace(0);
            for (i, &x) in row.iter().enumerate() {
                if self.bits[i] != x.to_bits() {
                    self.bits[i] = x.to_bits();
                    self.scratch.clear();
                    self.scratch.push(b',');
                    float_text::push(&mut self.scratch, x);
                    self.replace(i + 1);
                }
            }
        }
        w.write_all(&self.line)
    }

    /// The line of a first row (or of a row of another width than the last).
    fn first(&mut self, t: f64, row: &[f64]) {
        let line = &mut self.line;
        line.clear();
        self.ends.clear();
        float_text::push(line, t);
        self.ends.push(line.len());
        for x in row {
            line.push(b',');
            float_text::push(line, *x);
            self.ends.push(line.len());
        }
        line.push(b'\n');
        self.bits = row.iter().map(|x| x.to_bits()).collect();
    }

    /// Puts the text in `scratch` in the place of text `i` of the line (0 the time), the
    /// rest of the line moved if the lengths differ.
    fn replace(&mut self, i: usize) {
        let start = match i {
            0 => 0,
            _ => self.ends[i - 1],
        };
        let (end, text, line) = (self.ends[i], &self.scratch, &mut self.line);
        if text.len() != end - start {
            let tail = line.len();
            let moved = start + text.len();
            if moved > end {
                line.resize(tail + (moved - end), 0);
            }
            line.copy_within(end..tail, moved);
            line.truncate(tail + moved - end);
            for e in &mut self.ends[i..] {
                *e = *e + moved - end;
            }
        }
        line[start..start + text.len()].copy_from_slice(text);
    }
}

/// A bounded, evenly spaced sample of a run of any length, for a plot: it keeps every
/// `stride`-th row, and when it holds `2 cap` rows it drops every other one and doubles
/// the stride. So it never holds more than `2 cap` rows, and always at least `cap` once
/// the run is that long, spread over the whole run; the last row is always kept.
pub struct Decimated {
    trace: Trace,
    cap: usize,
    stride: u64,
    seen: u64,
    last: Option<(f64, Vec<f64>)>,
}

impl Decimated {
    pub fn new(names: Vec<String>, cap: usize) -> Decimated {
        Decimated { trace: Trace::new(names), cap: cap.max(1), stride: 1, seen: 0, last: None }
    }

    pub fn push(&mut self, t: f64, row: &[f64]) {
        // The stride is a power of two (rust-version 1.82 predates is_multiple_of).
        if self.seen & (self.stride - 1) == 0 {
            self.last = None;
            self.trace.push(t, row.to_vec());
            if self.trace.rows.len() >= 2 * self.cap {
                // The newest row has an odd index and goes: keep it as the last.
                self.last = self.trace.rows.last().cloned();
                let mut i = 0;
                self.trace.rows.retain(|_| {
                    i += 1;
                    i % 2 == 1
                });
                self.stride *= 2;
            }
        } else {
            self.last = Some((t, row.to_vec()));
        }
        self.seen += 1;
    }

    /// The sample, ending at the last row pushed.
    pub fn finish(mut self) -> Trace {
        if let Some((t, row)) = self.last.take() {
            self.trace.push(t, row);
        }
        self.trace
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_is_bounded_even_and_ends_at_the_end() {
        let mut d = Decimated::new(vec!["x".into()], 100);
        for k in 0..1_000_001u64 {
            d.push(k as f64, &[k as f64]);
        }
        let t = d.finish();
        assert!((100..=201).contains(&t.rows.len()), "{}", t.rows.len());
        assert_eq!(t.rows[0].0, 0.0);
        assert_eq!(t.rows.last().unwrap().0, 1e6);
        let gaps: Vec<f64> = t.rows.windows(2).map(|w| w[1].0 - w[0].0).collect();
        let stride = gaps[0];
        assert!(gaps[..gaps.len() - 1].iter().all(|&g| g == stride), "even spacing");
    }

    #[test]
    fn streamed_rows_are_the_csv_rows() {
        let mut t = Trace::new(vec!["a".into(), "b".into()]);
        t.push(0.0, vec![1.5, -2.0]);
        t.push(0.002, vec![1e-7, 3.0]);
        let mut whole = Vec::new();
        t.write_csv(&mut whole).unwrap();
        let mut streamed = Vec::new();
        write_header(&mut streamed, &t.names).unwrap();
        let mut rows = RowWriter::new();
        for (time, row) in &t.rows {
            rows.write(&mut streamed, *time, row).unwrap();
        }
        assert_eq!(whole, streamed);
        assert_eq!(String::from_utf8(whole).unwrap(), "time,a,b\n0,1.5,-2\n0.002,0.0000001,3\n");
    }

    #[test]
    fn a_repeated_value_is_written_as_a_fresh_one_would_be() {
        // Each row's text as `{}` formats it, whether a column repeats its last value or
        // not; 0 and -0, and two NaNs, are told apart by their bits.
        // Texts that grow and shrink in the middle of the line and at its end, long ones
        // (1e300, 1e-30) among them, with the time's text growing and shrinking too.
        let rows: [(f64, [f64; 3]); 9] = [
            (0.0, [0.0, 1.25, f64::NAN]),
            (0.002, [0.0, 1.25, f64::NAN]),
            (0.004, [-0.0, 1.25, -f64::NAN]),
            (0.006, [-0.0, 3e-9, f64::INFINITY]),
            (0.008, [0.0, 3e-9, 1e300]),
            (0.01, [0.0, 3e-9, 1e300]),
            (0.012, [-1.2345678901234567e-4, 1e-30, 1e300]),
            (0.014, [-1.234567890123456e-9, 1e-30, -1.2345678901234567e-12]),
            (0.016, [-1.234567890123456e-9, 2.5, -1.2345678901234567e-12]),
        ];
        let mut out = Vec::new();
        let mut w = RowWriter::new();
        let mut expected = String::new();
        for (t, row) in &rows {
            w.write(&mut out, *t, row).unwrap();
            expected += &format!("{t},{},{},{}\n", row[0], row[1], row[2]);
        }
        assert_eq!(String::from_utf8(out).unwrap(), expected);
        assert!(expected.contains("0.004,-0,1.25,NaN\n"), "{expected}");
    }
}
