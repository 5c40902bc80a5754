//! PNG plots with `plotters`' bitmap backend.
//!
//! Text is rendered by `ab_glyph` from a TrueType file read at run time, so the build needs
//! no system font libraries (fontconfig, freetype); the default file is Debian's
//! `fonts-dejavu-core`.

use std::error::Error;
use std::path::Path;

use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

use crate::closed_loop::{LoopView, SlewView};
use crate::gait::{SAMPLES_PER_STEP, SAMPLE_PERIOD_S};
use crate::plant::{self, GaitRun};
use inchworm_cosim::Trace;

/// Where Debian's `fonts-dejavu-core` puts its sans-serif face.
pub const DEFAULT_FONT: &str = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";

const FONT: &str = "sans-serif";

/// A plot font that cannot be used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FontError {
    /// The plot font cannot be read.
    #[error("{}: cannot read the plot font: {source} (on Debian: apt-get install fonts-dejavu-core, or pass --font)", path.display())]
    File {
        path: std::path::PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The plot font is not a font plotters can use.
    #[error("{}: not a TrueType/OpenType font", .0.display())]
    NotAFont(std::path::PathBuf),
}

/// Reads a TrueType/OpenType font and registers it as the face every plot uses.
pub fn load_font(path: &Path) -> Result<(), FontError> {
    let bytes = std::fs::read(path)
        .map_err(|source| FontError::File { path: path.to_path_buf(), source })?;
    // plotters keeps registered fonts for the life of the process and wants them 'static;
    // one font per process, so leaking it is the intended use.
    let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
    register_font(FONT, FontStyle::Normal, bytes)
        .map_err(|_| FontError::NotAFont(path.to_path_buf()))
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;
type Chart<'a, 'b> = ChartContext<
    'a,
    BitMapBackend<'b>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

const COLORS: [RGBColor; 3] = [BLUE, RGBColor(220, 80, 0), RGBColor(0, 140, 0)];

/// A white 1400×900 picture with its title, and its area below the title split at
/// `split` percent into a top and a bottom panel.
fn canvas<'a>(
    path: &'a Path,
    title: &str,
    split: u32,
) -> Result<[Area<'a>; 3], Box<dyn Error + Send + Sync>> {
    let root = BitMapBackend::new(path, (1400, 900)).into_drawing_area();
    root.fill(&WHITE)?;
    let body = root.titled(title, (FONT, 24))?;
    let (top, bottom) = body.split_vertically(900 * split / 100);
    Ok([root, top, bottom])
}

/// A panel with the axes every plot here has: margins, label areas, a light mesh, labels.
fn panel<'a, 'b>(
    area: &'a Area<'b>,
    x: std::ops::Range<f64>,
    y: std::ops::Range<f64>,
    x_desc: &str,
    y_desc: &str,
) -> Result<Chart<'a, 'b>, Box<dyn Error + Send + Sync>> {
    let mut chart = ChartBuilder::on(area)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(80)
        .build_cartesian_2d(x, y)?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .x_desc(x_desc)
        .y_desc(y_desc)
        .label_style((FONT, 16))
        .draw()?;
    Ok(chart)
}

/// The legend box of the series labelled so far, at `position`.
fn legend<'a, 'b: 'a, C: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, BitMapBackend<'b>, C>,
    position: SeriesLabelPosition,
) -> Result<(), Box<dyn Error + Send + Sync>> {
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font((FONT, 15))
        .draw()?;
    Ok(())
}

/// The reference of a closed-loop run (µm against time), thin black, labelled.
fn reference_line(chart: &mut Chart, r: &LoopView) -> Result<(), Box<dyn Error + Send + Sync>> {
    chart
        .draw_series(LineSeries::new(
            r.time.iter().zip(&r.reference).map(|(&t, &x)| (t, x * 1e6)),
            BLACK.stroke_width(1),
        ))?
        .label("reference")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK));
    Ok(())
}

/// The end of a time axis that shows every run: the latest last time, and at least 1 s.
fn time_axis_end<'a>(times: impl Iterator<Item = &'a [f64]>) -> f64 {
    times.filter_map(|t| t.last()).fold(1.0f64, |a, &b| a.max(b))
}

/// The smallest and largest of some values.
fn extent(values: impl IntoIterator<Item = f64>) -> (f64, f64) {
    values
        .into_iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), y| (lo.min(y), hi.max(y)))
}

fn padded(lo: f64, hi: f64) -> std::ops::Range<f64> {
    let pad = ((hi - lo) * 0.05).max(0.5);
    (lo - pad)..(hi + pad)
}

/// Runner position, extension and mode of a gait run in three stacked panels sharing
/// the time axis; the `s7` averages are marked on the runner trace and each step's
/// amplitude is written above it.
pub fn gait_png(run: &GaitRun, path: &Path) -> Result<(), Box<dyn Error + Send + Sync>> {
    let (w, h) = (1400u32, 1000u32);
    let root = BitMapBackend::new(path, (w, h)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(
        &format!(
            "InchwormPlant: open-loop gait, {} steps of {SAMPLES_PER_STEP} samples of {} ms",
            run.steps.len(),
            SAMPLE_PERIOD_S * 1e3
        ),
        (FONT, 26),
    )?;
    let (top, rest) = root.split_vertically(h * 42 / 100);
    let (mid, bottom) = rest.split_vertically(h * 30 / 100);

    let t_end = run.samples.last().map_or(1.0, |s| s.time);
    let step_starts: Vec<f64> =
        (0..run.steps.len()).map(|i| (i * SAMPLES_PER_STEP) as f64 * SAMPLE_PERIOD_S).collect();
    let um = |m: f64| m * 1e6;
    let grid = RGBColor(200, 200, 200);

    // Runner position.
    let runner: Vec<(f64, f64)> =
        run.samples.iter().map(|s| (s.time, um(s.out.runner_position))).collect();
    let (lo, hi) = extent(runner.iter().map(|p| p.1));
    let y_range = padded(lo, hi);
    let label_y = y_range.end - (y_range.end - y_range.start) * 0.04;
    let mut chart = ChartBuilder::on(&top)
        .margin(12)
        .x_label_area_size(28)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..t_end, y_range)?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .y_desc("runner position (µm)")
        .label_style((FONT, 16))
        .draw()?;
    for &t in &step_starts[1..] {
        chart.draw_series(LineSeries::new([(t, lo - 1e3), (t, hi + 1e3)], grid))?;
    }
    chart
        .draw_series(LineSeries::new(runner, BLUE.stroke_width(2)))?
        .label("runner position")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLUE.stroke_width(2)));
    let s7: Vec<(f64, f64)> = (0..run.steps.len())
        .map(|i| {
            // Middle of the s7 window (samples 95–99): the end of sample 97.
            let t = ((i * SAMPLES_PER_STEP + 97) as f64) * SAMPLE_PERIOD_S;
            (t, um(run.measurements(i).position_after()))
        })
        .collect();
    chart
        .draw_series(s7.iter().map(|&p| Circle::new(p, 5, RED.filled())))?
        .label("s7 (encoder, position after the step)")
        .legend(|(x, y)| Circle::new((x + 10, y), 5, RED.filled()));
    if run.steps.len() <= 20 {
        chart.draw_series(run.steps.iter().zip(&step_starts).map(|(s, &t)| {
            Text::new(
                format!("y = {:+}", s.amplitude()),
                (t + 0.01, label_y),
                (FONT, 16).into_font(),
            )
        }))?;
    }
    legend(&mut chart, SeriesLabelPosition::LowerRight)?;

    // Extension stack elongation.
    let ext: Vec<(f64, f64)> = run.samples.iter().map(|s| (s.time, um(s.out.extension))).collect();
    let (lo, hi) = extent(ext.iter().map(|p| p.1));
    let mut chart = ChartBuilder::on(&mid)
        .margin(12)
        .x_label_area_size(28)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..t_end, padded(lo, hi))?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .y_desc("extension (µm)")
        .label_style((FONT, 16))
        .draw()?;
    for &t in &step_starts[1..] {
        chart.draw_series(LineSeries::new([(t, lo - 1e3), (t, hi + 1e3)], grid))?;
    }
    chart.draw_series(LineSeries::new(ext, RGBColor(0, 140, 0).stroke_width(2)))?;

    // Mode, held over each sample.
    let mut chart = ChartBuilder::on(&bottom)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..t_end, 0i32..5i32)?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .y_labels(6)
        // 0 and 5 only frame the four modes.
        .y_label_formatter(&|m: &i32| {
            plant::mode(*m).map_or(String::new(), |m| format!("{m:?}").to_uppercase())
        })
        .x_desc("time (s)")
        .y_desc("mode")
        .label_style((FONT, 16))
        .draw()?;
    for &t in &step_starts[1..] {
        chart.draw_series(LineSeries::new([(t, 0), (t, 5)], grid))?;
    }
    let mut steps = Vec::with_capacity(2 * run.samples.len());
    for pair in run.samples.windows(2) {
        let m = pair[0].out.mode as i32;
        steps.push((pair[0].time, m));
        steps.push((pair[1].time, m));
    }
    chart.draw_series(LineSeries::new(steps, BLACK.stroke_width(2)))?;

    root.present()?;
    Ok(())
}

/// Closed-loop runs of one scenario: encoder position of each variant against the
/// reference (parked samples marked), and the disturbance estimates.
pub fn closed_loop_png(
    title: &str,
    names: &[&str],
    runs: &[LoopView],
    path: &Path,
) -> Result<(), Box<dyn Error + Send + Sync>> {
    let [root, top, bottom] = canvas(path, title, 62)?;
    let t_end = time_axis_end(runs.iter().map(|r| &r.time[..]));
    let um = 1e6;
    let pos = |r: &LoopView| -> Vec<(f64, f64)> {
        r.time.iter().zip(&r.encoder_position).map(|(&t, &x)| (t, x * um)).collect()
    };
    let (lo, hi) =
        extent(runs.iter().flat_map(|r| {
            pos(r).into_iter().map(|p| p.1).chain(r.reference.iter().map(|x| x * um))
        }));
    let mut chart = panel(&top, 0.0..t_end, padded(lo, hi), "", "encoder position (µm)")?;
    if let Some(r) = runs.first() {
        reference_line(&mut chart, r)?;
    }
    for (i, (r, name)) in runs.iter().zip(names).enumerate() {
        let c = COLORS[i % COLORS.len()];
        let settle = r
            .settle_time(1e-6)
            .map_or("not settled".to_string(), |t| format!("settled within 1 µm at {t:.2} s"));
        // The whole trace faintly (the runner moves micrometres inside every step; on long
        // runs that only paints a band), the parked samples, where the loop is judged, boldly.
        if t_end <= 30.0 {
            chart.draw_series(LineSeries::new(pos(r), c.mix(0.25)))?;
        }
        let parked: Vec<(f64, f64)> =
            r.parked().into_iter().map(|i| (r.time[i], r.encoder_position[i] * um)).collect();
        chart
            .draw_series(LineSeries::new(parked, c.stroke_width(2)))?
            .label(format!("{name} (parked samples): {settle}"))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    legend(&mut chart, SeriesLabelPosition::LowerRight)?;

    let (lo, hi) = extent(runs.iter().flat_map(|r| r.disturbance_estimate.iter().map(|x| x * um)));
    let mut chart =
        panel(&bottom, 0.0..t_end, padded(lo, hi), "time (s)", "disturbance estimate (µm)")?;
    for (i, r) in runs.iter().enumerate() {
        let c = COLORS[i % COLORS.len()];
        chart.draw_series(LineSeries::new(
            r.time.iter().zip(&r.disturbance_estimate).map(|(&t, &x)| (t, x * um)),
            c.stroke_width(2),
        ))?;
    }
    root.present()?;
    Ok(())
}

/// The figure of a controller-option scenario: position on top, |error| of the held samples
/// (log scale, nm) below.
pub fn options_png(
    title: &str,
    names: &[&str],
    runs: &[LoopView],
    path: &Path,
) -> Result<(), Box<dyn Error + Send + Sync>> {
    let [root, top, bottom] = canvas(path, title, 48)?;
    let t_end = time_axis_end(runs.iter().map(|r| &r.time[..]));
    let (lo, hi) = extent(
        runs.iter().flat_map(|r| r.encoder_position.iter().chain(&r.reference).map(|x| x * 1e6)),
    );
    let mut chart = panel(&top, 0.0..t_end, padded(lo, hi), "", "encoder position (µm)")?;
    if let Some(r) = runs.first() {
        reference_line(&mut chart, r)?;
    }
    for (i, (r, name)) in runs.iter().zip(names).enumerate() {
        let c = COLORS[i % COLORS.len()];
        chart
            .draw_series(LineSeries::new(
                r.time.iter().zip(&r.encoder_position).map(|(&t, &x)| (t, x * 1e6)),
                c.stroke_width(2),
            ))?
            .label(name.to_string())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    legend(&mut chart, SeriesLabelPosition::LowerRight)?;

    let mut chart = ChartBuilder::on(&bottom)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..t_end, (0.1f64..1e5f64).log_scale())?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .x_desc("time (s)")
        .y_desc("|error| at held samples (nm)")
        .label_style((FONT, 16))
        .draw()?;
    for (i, r) in runs.iter().enumerate() {
        let c = COLORS[i % COLORS.len()];
        let pts: Vec<(f64, f64)> = r
            .held()
            .into_iter()
            .map(|i| (r.time[i], (r.error(i).abs() * 1e9).clamp(0.1, 1e5)))
            .collect();
        chart.draw_series(pts.into_iter().map(|p| Circle::new(p, 1, c.filled())))?;
    }
    for (tol, label) in [(1e3, "1 µm"), (2.0, "2 nm")] {
        chart.draw_series(LineSeries::new([(0.0, tol), (t_end, tol)], BLACK.mix(0.5)))?;
        chart.draw_series(std::iter::once(Text::new(
            label,
            (t_end * 0.005, tol * 1.3),
            (FONT, 14),
        )))?;
    }
    root.present()?;
    Ok(())
}

/// An open-loop slew as the paper's Fig. 11 shows it: the runner position against time on
/// top, the advance of every gait below.
pub fn slew_png(
    title: &str,
    names: &[&str],
    runs: &[SlewView],
    path: &Path,
) -> Result<(), Box<dyn Error + Send + Sync>> {
    let [root, top, bottom] = canvas(path, title, 50)?;
    let t_end = time_axis_end(runs.iter().map(|r| &r.time[..]));
    let (lo, hi) = extent(runs.iter().flat_map(|r| r.position.iter().map(|x| x * 1e3)));
    let mut chart =
        panel(&top, 0.0..t_end, padded(lo.min(0.0), hi), "time (s)", "runner position (mm)")?;
    for (i, (r, name)) in runs.iter().zip(names).enumerate() {
        let c = COLORS[i % COLORS.len()];
        chart
            .draw_series(LineSeries::new(
                std::iter::once((0.0, 0.0))
                    .chain(r.time.iter().zip(&r.position).map(|(&t, &x)| (t, x * 1e3))),
                c.stroke_width(2),
            ))?
            .label(format!(
                "{name}: {:.2} mm after {} gaits",
                r.position.last().unwrap_or(&0.0) * 1e3,
                r.time.len()
            ))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    legend(&mut chart, SeriesLabelPosition::UpperLeft)?;

    let gaits = runs.iter().map(|r| r.advance.len()).max().unwrap_or(1) as f64;
    let (lo, hi) = extent(runs.iter().flat_map(|r| r.advance.iter().map(|x| x * 1e6)));
    let y = padded(lo.min(0.0), hi);
    let mut chart = panel(&bottom, 0.0..gaits + 1.0, y, "gait", "advance per gait (µm)")?;
    for (i, r) in runs.iter().enumerate() {
        let c = COLORS[i % COLORS.len()];
        chart.draw_series(LineSeries::new(
            r.advance.iter().enumerate().map(|(g, &a)| ((g + 1) as f64, a * 1e6)),
            c.stroke_width(2),
        ))?;
    }
    root.present()?;
    Ok(())
}

/// The recorded variables of an `inchworm run`, one panel each (at most 6), against time.
pub fn trace_png(
    title: &str,
    results: &Trace,
    path: &Path,
) -> Result<(), Box<dyn Error + Send + Sync>> {
    let n = results.names.len().clamp(1, 6);
    let (w, h) = (1400u32, 220 * n as u32 + 60);
    let root = BitMapBackend::new(path, (w, h)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(title, (FONT, 22))?;
    let panels = root.split_evenly((n, 1));
    let t_end = results.rows.last().map_or(1.0, |r| r.0).max(1e-9);
    for (i, (panel, name)) in panels.iter().zip(&results.names).enumerate() {
        let series: Vec<(f64, f64)> = results.rows.iter().map(|(t, v)| (*t, v[i])).collect();
        let (lo, hi) = extent(series.iter().map(|p| p.1));
        let pad = ((hi - lo) * 0.05).max(hi.abs().max(lo.abs()) * 1e-6).max(1e-12);
        let mut chart = ChartBuilder::on(panel)
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(110)
            .build_cartesian_2d(0.0..t_end, (lo - pad)..(hi + pad))?;
        // Values in metres are micro-scale, encoder counts large: either needs exponents.
        let big = hi.abs().max(lo.abs());
        let sci = big != 0.0 && !(1e-2..1e5).contains(&big);
        // A tick a rounding away from zero is zero.
        let fmt = |v: &f64| {
            let v = if v.abs() < big * 1e-9 { 0.0 } else { *v };
            if sci {
                format!("{v:.3e}")
            } else {
                format!("{v}")
            }
        };
        chart
            .configure_mesh()
            .light_line_style(WHITE)
            .y_desc(name.as_str())
            .x_desc("time (s)")
            .label_style((FONT, 14))
            .y_label_formatter(&fmt)
            .draw()?;
        chart.draw_series(LineSeries::new(series, BLUE.stroke_width(2)))?;
    }
    root.present()?;
    Ok(())
}

/// Visibility at 1.65 µm (top) and null depth at 10 µm (bottom) against baseline (log),
/// one line a series of `[baseline m, visibility, null depth]` points.
pub fn visibility_png(
    title: &str,
    series: &[(String, Vec<[f64; 3]>)],
    path: &Path,
) -> Result<(), Box<dyn Error + Send + Sync>> {
    const PALETTE: [RGBColor; 6] = [
        BLUE,
        RGBColor(220, 80, 0),
        RGBColor(0, 140, 0),
        RGBColor(120, 160, 255),
        RGBColor(250, 170, 110),
        RGBColor(110, 200, 110),
    ];
    let [root, top, bottom] = canvas(path, title, 50)?;
    let (lo, hi) = extent(series.iter().flat_map(|(_, p)| p.iter().map(|p| p[0])));
    let x = (lo.min(hi) * 0.8)..(hi.max(lo) * 1.25);
    // The null depth as its exponent: decades from 1e-7 to 1.
    let value = |panel: usize, p: &[f64; 3]| match panel {
        0 => p[1],
        _ => p[2].max(1e-7).log10(),
    };
    let areas = [
        (&top, "visibility at 1.65 µm", 0.0..1.05),
        (&bottom, "log10 of the null depth at 10 µm", -7.2..0.2),
    ];
    for (panel, (area, y_desc, y)) in areas.into_iter().enumerate() {
        let mut chart = ChartBuilder::on(area)
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(80)
            .build_cartesian_2d(x.clone().log_scale(), y)?;
        chart
            .configure_mesh()
            .light_line_style(WHITE)
            .x_desc("baseline (m)")
            .y_desc(y_desc)
            .label_style((FONT, 16))
            .draw()?;
        for (i, (name, points)) in series.iter().enumerate() {
            let c = PALETTE[i % PALETTE.len()];
            let pts: Vec<(f64, f64)> = points.iter().map(|p| (p[0], value(panel, p))).collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))?
                .label(name.as_str())
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c.stroke_width(2)));
            chart.draw_series(pts.into_iter().map(|p| Circle::new(p, 4, c.filled())))?;
        }
        // Where no line runs: between the two groups on top, under them below.
        let at = match panel {
            0 => SeriesLabelPosition::MiddleRight,
            _ => SeriesLabelPosition::LowerRight,
        };
        legend(&mut chart, at)?;
    }
    root.present()?;
    Ok(())
}
