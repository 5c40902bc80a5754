//! `inchworm run --spread DIR`: the sweep metrics of every actuator of a run
//! ([`inchworm_scenarios::actuators`]), written as `DIR/actuators.csv` (one row an
//! actuator) and `DIR/spread.png` (a histogram a metric, side by side), each metric's
//! spread printed.

use std::path::Path;

use inchworm_scenarios::actuators::Spread;
use inchworm_scenarios::metrics::{Kind, LoopMetrics, Metric};
use inchworm_scenarios::sweep_plots;

use super::Text;

/// What `--spread` reduces each actuator to without `--spread-metric`: the settle time
/// within 1 µm, the holding RMS from 6 s to 10 s, the final disturbance estimate.
pub const DEFAULT_METRICS: [&str; 3] = ["settle:1e-6", "rms:6:10", "disturbance"];

/// Bins of each histogram.
const BINS: usize = 20;

/// The metrics of `texts` (none: [`DEFAULT_METRICS`]) for every actuator among `names`.
pub fn spread(texts: &[String], names: &[String]) -> Result<Spread, String> {
    let metrics = if texts.is_empty() {
        LoopMetrics::parse(&DEFAULT_METRICS)
    } else {
        LoopMetrics::parse(texts)
    };
    let metrics = metrics.map_err(|e| format!("--spread-metric: {e}"))?;
    Spread::new(&metrics, names).map_err(|e| format!("--spread: {e}"))
}

/// The unit a metric is shown in and its value in that unit per SI unit; none for a
/// count or any variable's value, shown as recorded.
fn unit(m: &Metric) -> Option<(&'static str, f64)> {
    match m.kind {
        Kind::Settle { .. } => Some(("s", 1.0)),
        Kind::ParkedRms { .. } => Some(("nm", 1e9)),
        Kind::Disturbance => Some(("um", 1e6)),
        Kind::Slips | Kind::Reduce(_) => None,
    }
}

/// Writes `dir/actuators.csv` and `dir/spread.png` of `spread`, and prints each metric's
/// least, median, mean, standard deviation and greatest value over the actuators.
pub fn write(dir: &Path, spread: &Spread) -> Result<(), String> {
    let csv = spread.csv();
    super::write_file(&dir.join("actuators.csv"), |w| w.write_all(csv.as_bytes()))?;
    let results = spread.finish();
    let mut panels = Vec::new();
    for (i, name) in spread.metrics().iter().enumerate() {
        let unit = unit(&Metric::parse(name).text()?);
        let (label, scale) = match unit {
            Some((u, scale)) => (format!("{name} ({u})"), scale),
            None => (name.clone(), 1.0),
        };
        let mut v: Vec<f64> = results
            .iter()
            .filter_map(|(_, m)| m[i])
            .filter(|x| x.is_finite())
            .map(|x| x * scale)
            .collect();
        v.sort_by(f64::total_cmp);
        let missing = results.len() - v.len();
        if let (Some(lo), Some(hi)) = (v.first(), v.last()) {
            let n = v.len() as f64;
            let mean = v.iter().sum::<f64>() / n;
            let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt();
            let median = v[v.len() / 2];
            println!(
                "{label} over {} actuators: min {lo:.4}, median {median:.4}, mean {mean:.4}, sd {sd:.4}, max {hi:.4}{}",
                v.len(),
                if missing > 0 { format!("; {missing} without a value") } else { String::new() }
            );
        } else {
            println!("{name}: no actuator has a value");
        }
        let title = format!("{name}: {} actuators, {missing} without", v.len());
        panels.push((title, label, v));
    }
    let png = dir.join("spread.png");
    super::write_png(&png, |p| sweep_plots::histograms_png(&panels, "actuators", BINS, p))
}
