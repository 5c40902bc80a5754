//! The controller's options beyond the paper as scenarios, each against the baseline.

use super::*;

// ---- The controller's options of docs/model.md §4.2, beyond the paper: analog mode, the
// 50 Hz gait, both, and the brake-disturbance map. ----

/// The scenarios of the controller's options, one per feature and one combining two.
pub const CONTROLLER_OPTIONS: [&str; 4] = ["analog", "fastgait", "combined", "bdmap"];

pub fn is_controller_option(name: &str) -> bool {
    CONTROLLER_OPTIONS.contains(&name)
}

/// The 50 Hz gait: 10 samples of 2 ms per step.
pub fn fast_gait() -> Params {
    Params { samples_per_step: 10, ..Params::default() }
}

/// Analog mode near the target, with the 5 Hz gait for large moves.
pub fn analog() -> Params {
    Params { analog: true, ..Params::default() }
}

/// The analog scenario's reference (µm): 100 µm, +100 nm at 10 s, +1 µm at 11 s, a walk
/// of +1 µm every 0.2 s from 12 s to 16 s (re-centrings), a 40 µm jump at 20 s.
fn analog_reference() -> InputTable {
    let mut rows = vec![(0.0, 100.0), (10.0, 100.1), (11.0, 101.1)];
    rows.extend((1..=20).map(|k| (12.0 + 0.2 * (k - 1) as f64, 101.1 + k as f64)));
    rows.push((20.0, 161.1));
    let rows: Vec<(f64, f64)> = rows.into_iter().map(|(t, um)| (t, um * 1e-6)).collect();
    InputTable::steps(closed_loop::REFERENCE, &rows).expect("times increase")
}

pub(super) fn controller_options(name: &str) -> Option<Scenario> {
    let fia20 = PlantParams::fia20;
    Some(match name {
        "analog" => Scenario {
            name: "analog",
            title: "Analog mode near the target: hold in DRIVE, 100 nm and 1 µm changes, a 20 µm walk (re-centring), a 40 µm jump",
            duration: 25.0,
            reference: analog_reference(),
            variants: vec![
                closed("baseline", fia20(), Params::default()),
                closed("analog", fia20(), analog()),
            ],
            regulation: vec![(6.0, 10.0), (23.0, 25.0)],
        },
        "fastgait" => Scenario {
            name: "fastgait",
            title: "A 2 mm move: the 5 Hz gait (100 samples per step) and the 50 Hz gait (10)",
            duration: 40.0,
            reference: constant(2e-3),
            variants: vec![
                closed("5 Hz gait", fia20(), Params::default()),
                closed("50 Hz gait", fia20(), fast_gait()),
            ],
            regulation: vec![(30.0, 40.0)],
        },
        "combined" => Scenario {
            name: "combined",
            title: "A 2 mm move, then 100 nm and 1 µm changes: baseline and the 50 Hz gait with analog mode",
            duration: 30.0,
            reference: InputTable::steps(
                closed_loop::REFERENCE,
                &[(0.0, 2e-3), (25.0, 2.0001e-3), (26.0, 2.0011e-3)],
            )
            .expect("times increase"),
            variants: vec![
                closed("baseline", fia20(), Params::default()),
                closed("50 Hz gait + analog", fia20(), Params { analog: true, ..fast_gait() }),
            ],
            regulation: vec![(23.0, 25.0), (27.0, 30.0)],
        },
        "bdmap" => Scenario {
            name: "bdmap",
            title: "Figs. 6-7 staircase: the disturbance from the latest estimate, and from the map (with the single integrator)",
            duration: 700.0,
            reference: staircase(),
            variants: vec![
                closed("latest estimate", fia20(), Params { prefilter: true, ..Params::default() }),
                closed("map + single integrator", fia20(), Params {
                    prefilter: true,
                    disturbance_map: true,
                    use_disturbance_map: true,
                    single_integrator: true,
                    ..Params::default()
                }),
            ],
            regulation: staircase_regulation(),
        },
        _ => return None,
    })
}

/// What a controller-option scenario adds to its traces: for `bdmap`, the map learned over the
/// staircase, as CSV and a figure, and the residuals of the coming step's disturbance
/// over the staircase and over a 2 mm slew after it (printed). Nothing for the others.
pub fn write_extras(name: &str, out: &Path) -> Result<(), super::Error> {
    if name != "bdmap" {
        return Ok(());
    }
    let p = Params { prefilter: true, ..Params::default() };
    let fia20 = PlantParams::fia20;
    let table = staircase();
    let st =
        closed_loop::disturbance_map_run(fia20(), p.clone(), |t| table.value(0, t), 700.0, 100.0)?;
    let slew = |t: f64| if t < 700.0 { table.value(0, t) } else { 2.02e-3 };
    let sl = closed_loop::disturbance_map_run(fia20(), p, slew, 725.0, 700.0)?;
    for (what, r) in [("staircase (from 100 s)", &st), ("2 mm slew after it", &sl)] {
        println!(
            "  BD of the coming step, {what}, {} steps: RMS residual {:.4} µm with the latest estimate, {:.4} µm with the map",
            r.steps,
            r.rms_last * 1e6,
            r.rms_map * 1e6
        );
    }
    let csv = out.join("bdmap_map.csv");
    let mut text = String::from("ext_cmd,bd_map_staircase\n");
    for (c, b) in &st.curve {
        text.push_str(&format!("{c},{b:e}\n"));
    }
    inchworm_cosim::output::write(&csv, text.as_bytes())
        .map_err(|source| super::Error::Write { path: csv.clone(), source })?;
    println!("wrote {}", csv.display());
    let png = out.join("bdmap_map.png");
    map_png(&st, &png).map_err(|source| super::Error::Plot { path: png.clone(), source })?;
    println!("wrote {}", png.display());
    Ok(())
}

fn map_png(
    r: &closed_loop::MapRun,
    path: &Path,
) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    use plotters::prelude::*;
    let orange = RGBColor(220, 80, 0);
    let root = BitMapBackend::new(path, (1000, 650)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(
        "Brake disturbance against the extension command: every step of the staircase, and the map at its end",
        ("sans-serif", 18),
    )?;
    let mut chart = ChartBuilder::on(&root)
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(-1.05f64..1.05f64, 3.5f64..6.0f64)?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .x_desc("EXT_cmd (fraction of a full step; negative backward)")
        .y_desc("BD (µm)")
        .label_style(("sans-serif", 14))
        .draw()?;
    chart
        .draw_series(
            r.pairs.iter().map(|&(c, b)| Circle::new((c, b * 1e6), 2, BLUE.mix(0.3).filled())),
        )?
        .label(format!("measured BD, {} steps", r.pairs.len()))
        .legend(|(x, y)| Circle::new((x + 10, y), 3, BLUE.filled()));
    chart
        .draw_series(LineSeries::new(
            r.curve.iter().map(|&(c, b)| (c, b * 1e6)),
            orange.stroke_width(3),
        ))?
        .label(format!(
            "map at the end; coming-step residual {:.4} µm (latest estimate {:.4} µm)",
            r.rms_map * 1e6,
            r.rms_last * 1e6
        ))
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], orange.stroke_width(3)));
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 13))
        .draw()?;
    root.present()?;
    Ok(())
}

/// Settling (within 1 µm and 2 nm), holding RMS and slew rate, judged on the held samples
/// (step boundaries and analog hold, [`LoopView::held`]).
pub(super) fn options_summary(s: &Scenario, v: &Variant, r: &LoopView) -> String {
    let settle = |tol: f64| {
        r.held_settle_time(tol, 0.0).map_or("not settled".to_string(), |t| format!("{t:.3} s"))
    };
    let rms: Vec<String> =
        s.regulation.iter().map(|&(a, b)| format!("{:.3}", r.held_rms(a, b) * 1e9)).collect();
    let target = r.reference.first().copied().unwrap_or(0.0);
    let slew = r
        .slew_rate(target)
        .filter(|_| target > 1e-3)
        .map_or(String::new(), |v| format!("; slew {:.0} µm/s (10-90 %)", v * 1e6));
    format!(
        "{:<22} within 1 µm from {}, within 2 nm from {}; held RMS in regulation {} nm{slew}",
        v.name,
        settle(1e-6),
        settle(2e-9),
        rms.join(" / ")
    )
}

/// The figure of a controller-option scenario, re-exported where the scenarios' callers
/// find it.
pub use crate::plot::options_png;

#[cfg(test)]
mod controller_option_tests {
    use super::*;

    #[test]
    fn every_controller_option_is_a_scenario_with_a_distinct_variant() {
        for n in CONTROLLER_OPTIONS {
            let s = by_name(n).unwrap_or_else(|| panic!("{n}"));
            assert!(names().contains(&n) && is_controller_option(s.name));
            assert_eq!(s.variants.len(), 2);
        }
        let r = analog_reference();
        assert!((r.value(0, 16.0) - 121.1e-6).abs() < 1e-15);
        assert!((r.value(0, 20.0) - 161.1e-6).abs() < 1e-15);
    }
}
