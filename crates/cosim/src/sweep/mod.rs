//! Parameter sweeps over a system: the plan ([`plan`]), what each run reports, reduced
//! row by row as the run goes ([`metrics`]), running a plan on worker threads ([`exec`]),
//! and the results as CSV and JSON lines; [`ranges`] refuses a swept value outside its
//! declared range.
//!
//! The results table has one row per run: `run,sample,<parameter>,…,<metric>,…,status,error`;
//! a metric with no value (a run that never settles) and the metrics of a failed run are
//! empty fields, `status` is `ok` or `failed`, `error` the failure's message (quoted).

pub mod exec;
pub mod metrics;
pub mod plan;
pub mod ranges;

use std::fmt::Write as _;

use exec::Outcome;

fn csv_quote(s: &str) -> String {
    format!("\"{}\"", s.replace('"', "\"\"").replace(['\n', '\r'], " "))
}

/// The results table ([module docs](self)).
/// `metrics` are the metrics' column names ([`metrics::Metrics::names`]).
pub fn results_csv(names: &[String], metrics: &[String], outcomes: &[Outcome]) -> String {
    let mnames: Vec<&str> = metrics.iter().map(String::as_str).collect();
    let mut s = String::from("run,sample");
    for n in names.iter().map(String::as_str).chain(mnames.iter().copied()) {
        let _ = write!(s, ",{n}");
    }
    s.push_str(",status,error\n");
    for o in outcomes {
        let _ = write!(s, "{},{}", o.run, o.sample);
        for v in &o.values {
            let _ = write!(s, ",{v}");
        }
        for i in 0..metrics.len() {
            match o.metrics.get(i).copied().flatten() {
                Some(v) if v.is_finite() => {
                    let _ = write!(s, ",{v}");
                }
                _ => s.push(','),
            }
        }
        match &o.error {
            None => s.push_str(",ok,\n"),
            Some(e) => {
                let _ = writeln!(s, ",failed,{}", csv_quote(e));
            }
        }
    }
    s
}

fn json_string(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if (c as u32) < 0x20 => {
                let _ = write!(out, "\\u{:04x}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

fn json_number(v: Option<f64>) -> String {
    match v {
        Some(v) if v.is_finite() => format!("{v}"),
        _ => "null".into(),
    }
}

/// One run as one JSON line: `{"run":…,"sample":…,"params":{…},"metrics":{…},"status":…,"error":…}`;
/// numbers in the shortest text that reads back as the same `f64`, a missing value `null`.
pub fn json_line(names: &[String], metrics: &[String], o: &Outcome) -> String {
    let params: Vec<String> = names
        .iter()
        .zip(&o.values)
        .map(|(n, v)| format!("{}:{}", json_string(n), json_number(Some(*v))))
        .collect();
    let ms: Vec<String> = metrics
        .iter()
        .enumerate()
        .map(|(i, m)| {
            format!("{}:{}", json_string(m), json_number(o.metrics.get(i).copied().flatten()))
        })
        .collect();
    format!(
        "{{\"run\":{},\"sample\":{},\"params\":{{{}}},\"metrics\":{{{}}},\"status\":\"{}\",\"error\":{}}}",
        o.run,
        o.sample,
        params.join(","),
        ms.join(","),
        if o.error.is_none() { "ok" } else { "failed" },
        o.error.as_deref().map_or("null".into(), json_string)
    )
}

/// Count, mean, standard deviation, min, median and max of the values present.
#[derive(Clone, Debug, PartialEq)]
pub struct Stats {
    pub n: usize,
    pub missing: usize,
    pub mean: f64,
    pub sd: f64,
    pub min: f64,
    pub median: f64,
    pub max: f64,
}

pub fn stats(values: &[Option<f64>]) -> Stats {
    let mut v: Vec<f64> = values.iter().flatten().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    let mean = v.iter().sum::<f64>() / n.max(1) as f64;
    let var = v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n.max(2) - 1) as f64;
    let median = match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => v[n / 2],
        _ => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    };
    Stats {
        n,
        missing: values.len() - n,
        mean: if n == 0 { f64::NAN } else { mean },
        sd: if n < 2 { f64::NAN } else { var.sqrt() },
        min: v.first().copied().unwrap_or(f64::NAN),
        median,
        max: v.last().copied().unwrap_or(f64::NAN),
    }
}
