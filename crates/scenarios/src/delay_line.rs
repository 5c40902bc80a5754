//! The interferometer's delay line on the inchworm (`inchworm delay-line`,
//! docs/delay-line.md): one run of `inchworm_delay_line::system` as CSV and PNG, the
//! designer's survey (ground on 10 m and 100 m baselines and space; stepping, deadband and
//! analog; with and without the fine stage) and the largest path rate each gait follows.

use inchworm_controller::Params;
use inchworm_cosim::Trace;
use inchworm_delay_line::fine_stage::FineStageParams;
use inchworm_delay_line::geometry::EARTH_ROTATION_RATE;
use inchworm_delay_line::system::{self, DelayLineParams, Figures, Run};
use inchworm_delay_line::tracker::TrackerParams;
use inchworm_plant::PlantParams;

pub use inchworm_delay_line::system::Error;

/// The inchworm's controller modes of the survey.
pub const MODES: [&str; 3] = ["stepping", "deadband", "analog"];

/// The controller of mode `name` (the paper's gait; with a 50 nm deadband; analog mode
/// near the target, docs/model.md §4.2).
pub fn controller(name: &str) -> Option<Params> {
    let d = Params::default();
    match name {
        "stepping" => Some(d),
        "deadband" => Some(Params { deadband: 50e-9, ..d }),
        "analog" => Some(Params { analog: true, ..d }),
        _ => None,
    }
}

/// The gaits whose largest rate the survey measures: the paper's 0.2 s steps, 20 ms steps
/// (the 50 Hz gait the paper expects to be attainable, §7) and 40 ms steps.
pub fn gaits() -> Vec<(&'static str, Params)> {
    let d = Params::default();
    vec![
        ("0.2 s steps (the paper's gait)", d.clone()),
        ("40 ms steps", Params { samples_per_step: 20, ..d.clone() }),
        ("20 ms steps (50 Hz)", Params { samples_per_step: 10, ..d }),
    ]
}

/// One run of the survey and its figures.
#[derive(Clone, Debug)]
pub struct Row {
    pub regime: &'static str,
    pub baseline: f64,
    pub mode: &'static str,
    pub fine: bool,
    pub sidereal_rate: f64,
    pub end_of_stroke: Option<f64>,
    pub figures: Figures,
}

/// One run of `duration` s on the ground (`space` false) or in space, on a baseline of
/// `baseline` m, the controller of `mode`, with the fine stage or without, with the cart
/// or without (ground), every other parameter at its default.
fn case(
    (regime, space, baseline): (&'static str, bool, f64),
    mode: &'static str,
    fine: bool,
    cart: bool,
    duration: f64,
) -> Result<Row, Error> {
    let d = DelayLineParams::default();
    let p = DelayLineParams {
        space,
        baseline_length: baseline,
        cart,
        fine: FineStageParams { enabled: fine, ..d.fine },
        ..d
    };
    let c = controller(mode).expect("a survey mode");
    let r = system::run(&p, PlantParams::fia20(), c, duration)?;
    Ok(Row {
        regime,
        baseline,
        mode,
        fine,
        sidereal_rate: r.sidereal_rate,
        end_of_stroke: r.end_of_stroke,
        figures: r.figures(),
    })
}

/// The survey's runs, each `duration` s.
pub fn survey(duration: f64) -> Result<Vec<Row>, Error> {
    let mut rows = Vec::new();
    let regimes: [(&str, bool, f64); 3] =
        [("ground", false, 10.0), ("ground", false, 100.0), ("space", true, 10.0)];
    for regime in regimes {
        for mode in MODES {
            for fine in [true, false] {
                rows.push(case(regime, mode, fine, true, duration)?);
            }
        }
    }
    Ok(rows)
}

/// The baselines of the visibility against baseline (m).
pub const BASELINES: [f64; 7] = [1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0];

/// Visibility against baseline on the ground, with the fine stage: each controller mode
/// with the cart (`regime` "ground") and without ("ground without cart": the inchworm takes the whole
/// sidereal path), on every baseline of [`BASELINES`], each run `duration` s. A run whose
/// runner reaches the end of its stroke has lost the fringes for good.
pub fn baseline_sweep(duration: f64) -> Result<Vec<Row>, Error> {
    let mut rows = Vec::new();
    for (regime, cart) in [("ground", true), ("ground without cart", false)] {
        for mode in MODES {
            for b in BASELINES {
                rows.push(case((regime, false, b), mode, true, cart, duration)?);
            }
        }
    }
    Ok(rows)
}

/// The series of [`baseline_sweep`]'s rows to draw: one a regime and mode, each point a
/// baseline with its visibility at 1.65 µm and its null depth at 10 µm (0 and 1 when the
/// runner reached the end of its stroke: no fringes).
pub fn visibility_series(rows: &[Row]) -> Vec<(String, Vec<[f64; 3]>)> {
    let mut out: Vec<(String, Vec<[f64; 3]>)> = Vec::new();
    for r in rows {
        let name = format!("{}, {}", r.mode, r.regime);
        let f = &r.figures;
        let point = match r.end_of_stroke {
            Some(_) => [r.baseline, 0.0, 1.0],
            None => [r.baseline, f.visibility_h, f.null_n],
        };
        match out.last_mut() {
            Some((n, points)) if *n == name => points.push(point),
            _ => out.push((name, vec![point])),
        }
    }
    out
}

/// What "follows a rate" asks of the inchworm.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Following {
    /// It keeps up: its lag does not grow (the mean residual of the last 2 s of the run is
    /// within 1 µm of that of the 2 s after the first 2 s) and the runner stays in its
    /// stroke.
    KeepsUp,
    /// It also keeps the fringes between steps: over the last 2 s the median of the
    /// residual's size is within half the tracker's coherence length (a stepping gait
    /// loses them during each step, its brake disturbance moving the path by micrometres).
    Fringes,
}

/// Whether the inchworm alone (no cart, no fine stage, no disturbance, an ideal tracker)
/// follows a sidereal path of `rate` m/s for `duration` s (≥ 8 s) as `how` asks. The path
/// is that of an east-west baseline of `rate/ω⊕` on the equator, a star on the celestial
/// equator at transit, where the rate is the most the baseline gives and constant to 1
/// part in 10⁶ over the run.
pub fn follows(
    controller: &Params,
    rate: f64,
    duration: f64,
    how: Following,
) -> Result<bool, Error> {
    let d = DelayLineParams::default();
    let p = DelayLineParams {
        space: false,
        cart: false,
        disturbances: false,
        baseline_length: rate / EARTH_ROTATION_RATE,
        baseline_azimuth: 90.0,
        baseline_elevation: 0.0,
        latitude: 0.0,
        declination: 0.0,
        hour_angle: 0.0,
        // The rate is the question here, not the stroke: a metre of it.
        stroke: 1.0,
        tracker: TrackerParams { noise: false, ..d.tracker },
        fine: FineStageParams { enabled: false, ..d.fine },
        ..d
    };
    let r = system::run(&p, PlantParams::fia20(), controller.clone(), duration.max(8.0))?;
    if r.end_of_stroke.is_some() {
        return Ok(false);
    }
    let per_2s = (2.0 / inchworm_controller::SAMPLE_PERIOD) as usize;
    let x = &r.residual;
    let last = &x[x.len() - per_2s..];
    Ok(match how {
        Following::KeepsUp => {
            let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
            (mean(last) - mean(&x[per_2s..2 * per_2s])).abs() < 1e-6
        }
        Following::Fringes => {
            let mut size: Vec<f64> = last.iter().map(|v| v.abs()).collect();
            size.sort_by(f64::total_cmp);
            let half = p.tracker.wavelength * p.tracker.wavelength / p.tracker.bandwidth / 2.0;
            size[size.len() / 2] < half
        }
    })
}

/// The largest path rate (m/s) `controller` follows as `how` asks, by bisection in log
/// rate between 1 µm/s and 10 mm/s to 2 % (0 below, 10 mm/s above).
pub fn max_rate(controller: &Params, duration: f64, how: Following) -> Result<f64, Error> {
    let (mut lo, mut hi) = (1e-6_f64, 1e-2_f64);
    if !follows(controller, lo, duration, how)? {
        return Ok(0.0);
    }
    if follows(controller, hi, duration, how)? {
        return Ok(hi);
    }
    while hi / lo > 1.02 {
        let mid = (lo * hi).sqrt();
        if follows(controller, mid, duration, how)? {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(lo)
}

/// The survey as CSV.
pub fn write_survey_csv(rows: &[Row], w: &mut dyn std::io::Write) -> std::io::Result<()> {
    writeln!(w, "regime,baseline_m,mode,fine_stage,sidereal_rate_m_s,tracker_rms_m,science_jitter_m,science_offset_m,visibility_1_65um,visibility_10um,null_10um,lost_samples,end_of_stroke_s")?;
    for r in rows {
        let f = &r.figures;
        writeln!(
            w,
            "{},{},{},{},{:e},{:e},{:e},{:e},{},{},{:e},{},{}",
            r.regime,
            r.baseline,
            r.mode,
            r.fine,
            r.sidereal_rate,
            f.tracker_rms,
            f.science_jitter,
            f.science_offset,
            f.visibility_h,
            f.visibility_n,
            f.null_n,
            f.lost,
            r.end_of_stroke.map_or(String::new(), |t| t.to_string())
        )?;
    }
    Ok(())
}

/// The survey as a Markdown table (the README's and docs/delay-line.md's).
pub fn survey_table(rows: &[Row]) -> String {
    let mut s = String::from(
        "| regime | baseline | inchworm | fine stage | residual RMS (tracker) | jitter in 50 ms frames | V at 1.65 µm | V at 10 µm | null at 10 µm | samples lost |\n|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let f = &r.figures;
        s += &format!(
            "| {} | {} m | {} | {} | {:.1} nm | {:.1} nm | {:.3} | {:.4} | {:.1e} | {} |\n",
            r.regime,
            r.baseline,
            r.mode,
            if r.fine { "yes" } else { "no" },
            f.tracker_rms * 1e9,
            f.science_jitter * 1e9,
            f.visibility_h,
            f.visibility_n,
            f.null_n,
            f.lost
        );
    }
    s
}

/// A run as a trace for the plots and the CSV, named as InchwormDelayLine.fmu's outputs:
/// the path, the cart's, the inchworm's and the fine stage's optical paths and the
/// residual (m), and the lock (1 locked).
pub fn trace(run: &Run) -> Trace {
    let names = ["path", "cart_path", "inchworm_path", "fine_path", "residual", "locked"];
    let mut t = Trace::new(names.iter().map(|s| s.to_string()).collect());
    for k in 0..run.time.len() {
        t.push(
            run.time[k],
            vec![
                run.path[k],
                run.cart[k],
                2.0 * run.runner[k],
                run.fine[k],
                run.residual[k],
                f64::from(u8::from(run.locked[k])),
            ],
        );
    }
    t
}

/// What the run's plot shows, panel by panel: the path, the cart's, the inchworm's and
/// the fine stage's optical paths, and the residual (m); the lock stays in the CSV.
pub fn plot_trace(run: &Run) -> Trace {
    let full = trace(run);
    let keep = full.names.len() - 1;
    let mut t = Trace::new(full.names[..keep].to_vec());
    for (time, row) in &full.rows {
        t.push(*time, row[..keep].to_vec());
    }
    t
}
