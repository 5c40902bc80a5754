//! Summary plots of a sweep: a histogram of each metric, and each metric against each swept
//! parameter (one point per run that has a value); the histograms of the metrics of a
//! system's actuators side by side (`inchworm run --spread`).

use std::error::Error;
use std::path::Path;

use plotters::coord::ranged1d::{AsRangedCoord, Ranged, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

const FONT: &str = "sans-serif";

fn range(v: &[f64]) -> (f64, f64) {
    let (lo, hi) =
        v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let pad = ((hi - lo) * 0.05).max(hi.abs().max(lo.abs()) * 1e-6).max(1e-15);
    (lo - pad, hi + pad)
}

fn fmt(v: &f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-2..1e5).contains(&a) {
        format!("{v:.3e}")
    } else {
        format!("{v:.3}")
    }
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

/// A white picture of `size` pixels at `path`.
fn picture(path: &Path, size: (u32, u32)) -> Result<Area<'_>, Box<dyn Error + Send + Sync>> {
    let root = BitMapBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE)?;
    Ok(root)
}

/// A chart over the whole of `root` with `title` above it, `y_area` pixels for the y
/// labels, the axes' descriptions `[x, y]`, and x values written by [`fmt`].
fn chart<'a, 'b, Y>(
    root: &'a Area<'b>,
    title: &str,
    y_area: u32,
    x: std::ops::Range<f64>,
    y: impl AsRangedCoord<CoordDescType = Y, Value = Y::ValueType>,
    desc: [&str; 2],
    y_fmt: &dyn Fn(&Y::ValueType) -> String,
) -> Result<
    ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, Y>>,
    Box<dyn Error + Send + Sync>,
>
where
    Y: Ranged + ValueFormatter<Y::ValueType>,
{
    let mut chart = ChartBuilder::on(root)
        .caption(title, (FONT, 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(y_area)
        .build_cartesian_2d(x, y)?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .x_desc(desc[0])
        .y_desc(desc[1])
        .label_style((FONT, 15))
        .x_label_formatter(&fmt)
        .y_label_formatter(y_fmt)
        .draw()?;
    Ok(chart)
}

/// Histogram of `values` in `bins` equal bins; `note` goes in the title (e.g. how many runs
/// have no value).
pub fn histogram_png(
    title: &str,
    xlabel: &str,
    values: &[f64],
    bins: usize,
    path: &Path,
) -> Result<(), Box<dyn Error + Send + Sync>> {
    let root = picture(path, (1000, 600))?;
    histogram(&root, title, [xlabel, "runs"], values, bins)?;
    root.present()?;
    Ok(())
}

/// One histogram a panel, three panels a row: each panel's (title, x label, values) in
/// `bins` equal bins, counted in `what` (the y label).
pub fn histograms_png(
    panels: &[(String, String, Vec<f64>)],
    what: &str,
    bins: usize,
    path: &Path,
) -> Result<(), Box<dyn Error + Send + Sync>> {
    let cols = panels.len().clamp(1, 3);
    let rows = panels.len().div_ceil(cols).max(1);
    let root = picture(path, (600 * cols as u32, 450 * rows as u32))?;
    for ((title, xlabel, values), area) in panels.iter().zip(root.split_evenly((rows, cols))) {
        histogram(&area, title, [xlabel, what], values, bins)?;
    }
    root.present()?;
    Ok(())
}

/// A histogram of `values` on `area`, the axes' descriptions `desc`.
fn histogram(
    area: &Area<'_>,
    title: &str,
    desc: [&str; 2],
    values: &[f64],
    bins: usize,
) -> Result<(), Box<dyn Error + Send + Sync>> {
    let (lo, hi) = range(values);
    let bins = bins.max(1);
    let width = (hi - lo) / bins as f64;
    let mut counts = vec![0u32; bins];
    for &v in values {
        let b = (((v - lo) / width) as usize).min(bins - 1);
        counts[b] += 1;
    }
    let top = counts.iter().copied().max().unwrap_or(1).max(1);
    let y = 0u32..top + top / 10 + 1;
    let mut chart = chart(area, title, 60, lo..hi, y, desc, &|c: &u32| c.to_string())?;
    chart.draw_series(counts.iter().enumerate().map(|(i, &c)| {
        let x0 = lo + i as f64 * width;
        Rectangle::new([(x0, 0), (x0 + width, c)], BLUE.mix(0.6).filled())
    }))?;
    Ok(())
}

/// `points` (parameter, metric) as a scatter plot.
pub fn scatter_png(
    title: &str,
    xlabel: &str,
    ylabel: &str,
    points: &[(f64, f64)],
    path: &Path,
) -> Result<(), Box<dyn Error + Send + Sync>> {
    let xs: Vec<f64> = points.iter().map(|p| p.0).collect();
    let ys: Vec<f64> = points.iter().map(|p| p.1).collect();
    let (x0, x1) = range(&xs);
    let (y0, y1) = range(&ys);
    let root = picture(path, (1000, 600))?;
    let mut chart = chart(&root, title, 90, x0..x1, y0..y1, [xlabel, ylabel], &fmt)?;
    chart.draw_series(points.iter().map(|&p| Circle::new(p, 3, BLUE.mix(0.6).filled())))?;
    root.present()?;
    Ok(())
}
