//! `inchworm sweep`: the plan is reproducible to the bit (splitmix64 and the library's own
//! ln/cos/exp), a run on a reset system equals a run on a freshly loaded one, a failing run
//! is a row with its error, and the nominal Fig. 5 metrics are the scenario's.

use std::path::{Path, PathBuf};

use std::sync::Arc;

use inchworm_cosim::master::{self, Coupling, InputTable, Options};
use inchworm_cosim::sweep::exec::{self, Setup, Worker};
use inchworm_cosim::sweep::metrics::{Metrics, Reductions};
use inchworm_cosim::sweep::plan::{self, Axis, Plan, Row, SplitMix64};
use inchworm_cosim::sweep::{json_line, results_csv};
use inchworm_fmu_models::{ControllerFmu, PlantFmu, PlantParams, ReferenceFmu};
use inchworm_scenarios::metrics::{LoopMetrics, Metric};

fn ssp() -> PathBuf {
    inchworm_dist::path("InchwormSystemOpen.ssp")
}

/// The plant's variable `name` as the systems record it.
fn plant(name: &str) -> String {
    format!("plant.{name}")
}

fn ulps(a: f64, b: f64) -> u64 {
    (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs()
}

#[test]
fn splitmix64_matches_the_reference_outputs() {
    // Vigna's splitmix64.c from state 0.
    let mut r = SplitMix64::new(0);
    assert_eq!(r.next_u64(), 0xe220_a839_7b1d_cdaf);
    assert_eq!(r.next_u64(), 0x6e78_9e6a_a1b9_65f4);
    assert_eq!(r.next_u64(), 0x06c4_5d18_8009_454f);
}

#[test]
fn own_ln_cos_exp_are_within_four_ulp_of_libm() {
    let mut r = SplitMix64::new(7);
    let mut worst = [0u64; 3];
    for _ in 0..200_000 {
        let u = r.uniform();
        if u > 0.0 {
            // Logarithms of (0, 1) over many octaves, as Box–Muller takes them.
            let x = u * u * u;
            worst[0] = worst[0].max(ulps(plan::ln(x), x.ln()));
            // libm on the same exactly reduced argument (libm's own 2πu for u near 1 is
            // rounded by up to 4e-16 rad, more than the series' error).
            let q = (u * 4.0 + 0.5).floor();
            let theta = (u - q * 0.25) * (2.0 * std::f64::consts::PI);
            let c = [theta.cos(), -theta.sin(), -theta.cos(), theta.sin()][q as usize % 4];
            assert!((plan::cos_2pi(u) - (2.0 * std::f64::consts::PI * u).cos()).abs() < 1e-15);
            if c.abs() > 1e-3 {
                worst[1] = worst[1].max(ulps(plan::cos_2pi(u), c));
            }
        }
        let y = (u - 0.5) * 60.0;
        worst[2] = worst[2].max(ulps(plan::exp(y), y.exp()));
    }
    assert!(worst.iter().all(|&w| w <= 4), "worst ulps ln, cos, exp: {worst:?}");
    assert_eq!(plan::ln(1.0), 0.0);
    assert_eq!(plan::exp(0.0), 1.0);
    assert!(plan::ln(0.0).is_nan() && plan::ln(-1.0).is_nan());
    assert_eq!(plan::exp(1000.0), f64::INFINITY);
}

#[test]
fn the_same_seed_gives_the_same_plan_bits() {
    let sweeps = [
        plan::parse_sample("plant.T_em=normal(8.8,0.22)").unwrap(),
        plan::parse_sample("plant.k_p=lognormal(17.2,0.05)").unwrap(),
        plan::parse_sample("plant.F_d0=uniform(157.5,192.5)").unwrap(),
    ];
    let p = Plan::build(&sweeps, 3, 42).unwrap();
    // Pinned: a change of the stream, the order of the draws or a transform shows here.
    let bits: Vec<Vec<u64>> =
        p.rows.iter().map(|r| r.values.iter().map(|v| v.to_bits()).collect()).collect();
    let again = Plan::build(&sweeps, 3, 42).unwrap();
    assert_eq!(p, again);
    let text = p.to_csv();
    assert_eq!(Plan::parse(&text).unwrap(), p, "the CSV reads back to the same bits");
    // The stream by hand: sample 0 is normal (2 outputs), lognormal (2), uniform (1).
    let mut r = SplitMix64::new(42);
    let z = r.normal();
    let z2 = r.normal();
    let u = r.uniform();
    assert_eq!(p.rows[0].values[0].to_bits(), (8.8 + 0.22 * z).to_bits());
    assert_eq!(p.rows[0].values[1].to_bits(), plan::exp(17.2 + 0.05 * z2).to_bits());
    assert_eq!(p.rows[0].values[2].to_bits(), (157.5 + 35.0 * u).to_bits());
    assert_eq!(bits.len(), 3);
    assert_eq!(text.lines().next(), Some("run,sample,plant.T_em,plant.k_p,plant.F_d0"));
}

#[test]
fn normal_draws_have_the_moments_asked_for() {
    let sweeps = [plan::parse_sample("x=normal(3e7,1.5e6)").unwrap()];
    let p = Plan::build(&sweeps, 20_000, 9).unwrap();
    let v: Vec<f64> = p.rows.iter().map(|r| r.values[0]).collect();
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt();
    // 4 standard errors: 1.5e6/√20000 ≈ 1.06e4 for the mean, ≈ 0.5 % for the sd.
    assert!((mean - 3e7).abs() < 4.3e4, "mean {mean}");
    assert!((sd / 1.5e6 - 1.0).abs() < 0.02, "sd {sd}");
    let inside = v.iter().filter(|x| (**x - 3e7).abs() < 1.5e6).count() as f64 / v.len() as f64;
    assert!((inside - 0.6827).abs() < 0.015, "within 1 sd: {inside}");
}

#[test]
fn grids_are_a_cartesian_product_times_the_samples() {
    let g = plan::parse_grid("plant.T_em=8.0:9.6:5").unwrap();
    assert_eq!(g.axis, Axis::Grid(vec![8.0, 8.4, 8.8, 9.2, 9.6]));
    let h = plan::parse_grid("plant.F_d0=150;175").unwrap();
    let s = plan::parse_sample("plant.k_p=uniform(2.9e7,3.1e7)").unwrap();
    let p = Plan::build(&[g, h, s], 3, 1).unwrap();
    assert_eq!(p.rows.len(), 5 * 2 * 3);
    assert_eq!(p.names, ["plant.T_em", "plant.F_d0", "plant.k_p"]);
    // Run 7 = grid point 2 (T_em 8.4, F_d0 150), sample 1.
    assert_eq!((p.rows[7].run, p.rows[7].sample), (7, 1));
    assert_eq!(&p.rows[7].values[..2], &[8.4, 150.0]);
    // Common random numbers: the same draw at every grid point.
    assert_eq!(p.rows[1].values[2], p.rows[7].values[2]);
    for bad in ["plant.T_em=1:2", "plant.T_em=1:2:0", "x"] {
        assert!(plan::parse_grid(bad).is_err(), "{bad}");
    }
    for bad in ["x=normal(1)", "x=gamma(1,2)", "x=uniform(2,1)", "x=normal(0,-1)"] {
        assert!(plan::parse_sample(bad).is_err(), "{bad}");
    }
}

fn fig5_setup<S: AsRef<str>>(metrics: &[S]) -> Setup {
    Setup {
        system: ssp(),
        options: Options {
            stop_time: Some(10.0),
            step_size: None,
            coupling: Coupling::Jacobi,
            params: vec![],
            parameter_set: Some("full-control".into()),
            input: Some(
                InputTable::steps(ControllerFmu::REFERENCE.name(), &[(0.0, 100e-6)]).unwrap(),
            ),
            outputs: vec![],
        },
        metrics: Arc::new(LoopMetrics::parse(metrics).unwrap()),
    }
}

fn loop_metrics() -> [String; 6] {
    [
        "settle:1e-6".into(),
        "rms:6:10".into(),
        "disturbance".into(),
        "slips".into(),
        format!("min:{}", plant(PlantFmu::ENCODER_POSITION.name())),
        format!("max:{}", plant(PlantFmu::RUNNER_POSITION.name())),
    ]
}

/// The metrics of one row on a freshly loaded system, through `master::run`: its whole
/// trace fed to the reducer a sweep feeds row by row (`Metrics::compute`), so a sweep row
/// that differs is the run's difference (a reset that missed a state), not the metrics'.
fn fresh(setup: &Setup, names: &[String], row: &Row) -> Vec<Option<f64>> {
    let mut opts = setup.options.clone();
    opts.params.extend(names.iter().zip(&row.values).map(|(n, v)| (n.clone(), format!("{v}"))));
    opts.outputs = setup.metrics.recorded();
    let trace = master::run(&setup.system, &opts, |_| {}).unwrap();
    setup.metrics.compute(&trace).unwrap()
}

#[test]
fn nominal_fig5_metrics_are_the_scenarios() {
    let setup = fig5_setup(&loop_metrics());
    let p = Plan::build(&[plan::parse_grid("plant.T_em=8.8;8.8").unwrap()], 1, 0).unwrap();
    let out = exec::run_plan(&setup, &p, 1, |_| {});
    // `inchworm scenario fig5`, full control: settles within 1 µm at 0.788 s, parked RMS
    // 3.027 nm in [6, 10) s, final disturbance estimate 4.658 µm.
    for o in &out {
        assert_eq!(o.error, None);
        let m: Vec<f64> = o.metrics.iter().map(|v| v.unwrap()).collect();
        assert!((m[0] - 0.788).abs() < 1e-9, "settle {}", m[0]);
        assert!((m[1] * 1e9 - 3.027).abs() < 5e-4, "rms {}", m[1]);
        assert!((m[2] * 1e6 - 4.658).abs() < 5e-4, "disturbance {}", m[2]);
        assert_eq!(m[3], 0.0, "no slips");
        assert_eq!(m[4], 0.0, "the encoder starts at 0");
        assert!(m[5] > 100e-6 && m[5] < 110e-6, "overshoot {}", m[5]);
    }
    assert_eq!(out[0].metrics, out[1].metrics, "a reset run repeats the first");
}

#[test]
fn the_closed_system_sweeps_to_the_open_systems_loop_metrics() {
    // InchwormSystem.ssp records the reference as its reference component's output, not as
    // a system input: the loop metrics read it there (they failed every run before).
    let closed = inchworm_dist::path("InchwormSystem.ssp");
    let metrics = LoopMetrics::parse(&loop_metrics()).unwrap();
    let input = ControllerFmu::REFERENCE.name();
    assert_eq!(metrics.clone().for_system(&ssp()).unwrap().reference, input);
    let metrics = metrics.for_system(&closed).unwrap();
    let output = format!("reference.{}", ReferenceFmu::REFERENCE.name());
    assert_eq!(metrics.reference, output);
    assert_eq!(metrics.recorded()[0], output);
    let fig5 = fig5_setup(&loop_metrics());
    let options = Options { input: None, ..fig5.options };
    let setup = Setup { system: closed, options, metrics: Arc::new(metrics) };
    let names: Vec<String> = vec![plant(PlantParams::T_EM.name())];
    let rows: Vec<Row> = [8.8, 9.2]
        .iter()
        .enumerate()
        .map(|(i, &v)| Row { run: i, sample: 0, values: vec![v] })
        .collect();
    let plan = Plan { names: names.clone(), rows: rows.clone() };
    let out = exec::run_plan(&setup, &plan, 1, |_| {});
    // The open system fed the same step by its system input.
    let open = fig5_setup(&loop_metrics());
    for (o, r) in out.iter().zip(&rows) {
        assert_eq!(o.error, None, "row {}", r.run);
        let bits = |v: &[Option<f64>]| -> Vec<Option<u64>> {
            v.iter().map(|x| x.map(f64::to_bits)).collect()
        };
        assert_eq!(bits(&o.metrics), bits(&fresh(&open, &names, r)), "row {}", r.run);
        assert_eq!(bits(&o.metrics), bits(&fresh(&setup, &names, r)), "row {}", r.run);
    }
    let settle = out[0].metrics[0].unwrap();
    assert!((settle - 0.788).abs() < 1e-9, "settle {settle}");
    assert_ne!(out[0].metrics, out[1].metrics, "T_em reaches the plant");
}

#[test]
fn a_reset_system_runs_like_a_freshly_loaded_one_and_a_failure_is_a_row() {
    let setup = fig5_setup(&loop_metrics());
    let names: Vec<String> =
        [PlantParams::T_EM, PlantParams::F_D0].map(|f| plant(f.name())).to_vec();
    let rows: Vec<Row> = [(8.5, 190.0), (9.2, 160.0), (-1.0, 175.0), (8.8, 175.0), (9.0, 180.0)]
        .iter()
        .enumerate()
        .map(|(i, &(a, b))| Row { run: i, sample: i, values: vec![a, b] })
        .collect();
    let mut w = Worker::new(&setup);
    let out: Vec<_> = rows.iter().map(|r| w.run(&names, r)).collect();
    // Loaded for run 0, reset for 1; T_em < 0 refused before the FMUs see it; reset for 3 and 4.
    assert_eq!(w.loads, 1);
    let err = out[2].error.as_deref().unwrap();
    assert_eq!(err, "parameter plant.T_em = -1 is outside its range [0.001, 1000]");
    assert!(out[2].metrics.is_empty());
    for i in [0, 1, 3, 4] {
        assert_eq!(out[i].error, None, "run {i}");
        assert_eq!(out[i].metrics, fresh(&setup, &names, &rows[i]), "run {i}");
    }
    assert_ne!(out[0].metrics, out[1].metrics, "the parameters do reach the plant");
    let metrics = &setup.metrics.names();
    let table = results_csv(&names, metrics, &out);
    let lines: Vec<&str> = table.lines().collect();
    assert_eq!(lines.len(), 6);
    assert!(lines[3].starts_with("2,2,-1,175,,,,,,,failed,\""), "{}", lines[3]);
    assert!(lines[1].ends_with(",ok,"));
    let j = json_line(&names, metrics, &out[2]);
    assert!(j.starts_with("{\"run\":2,\"sample\":2,\"params\":{\"plant.T_em\":-1,\"plant.F_d0\":175},\"metrics\":{\"settle:1e-6\":null"), "{j}");
    assert!(j.contains("\"status\":\"failed\""));
}

#[test]
fn a_value_the_fmu_refuses_fails_its_row_and_the_next_loads_anew() {
    // Each radius is in its declared range, but the plant wants them strictly increasing.
    let setup = fig5_setup(&["settle:1e-6"]);
    let names = vec![plant(PlantFmu::var(PlantParams::PLAY_RADIUS).name())];
    let rows: Vec<Row> = [0.1, 100.0, 0.1]
        .iter()
        .enumerate()
        .map(|(i, &v)| Row { run: i, sample: i, values: vec![v] })
        .collect();
    let mut w = Worker::new(&setup);
    let out: Vec<_> = rows.iter().map(|r| w.run(&names, r)).collect();
    assert_eq!(out[0].error, None);
    let err = out[1].error.as_deref().unwrap();
    assert!(err.contains("fmi2ExitInitializationMode returned fmi2Error"), "{err}");
    assert_eq!(out[2], exec::Outcome { run: 2, sample: 2, ..out[0].clone() });
    // Run 0 loads; run 1's refused reset is retried on a fresh load (a reset may fail for
    // the previous run's sake), which refuses it too; run 2 starts on a fresh load.
    assert_eq!(w.loads, 3);
}

#[test]
fn parallel_results_equal_serial_ones() {
    let setup = fig5_setup(&["settle:1e-6", "disturbance"]);
    let sweeps = [
        plan::parse_sample(&format!("{}=normal(8.8,0.15)", plant(PlantParams::T_EM.name())))
            .unwrap(),
        plan::parse_sample(&format!("{}=normal(3e7,5e5)", plant(PlantParams::K_P.name()))).unwrap(),
    ];
    let p = Plan::build(&sweeps, 8, 3).unwrap();
    let one = exec::run_plan(&setup, &p, 1, |_| {});
    let mut seen = 0;
    let two = exec::run_plan(&setup, &p, 2, |d| seen = d);
    assert_eq!(seen, 8);
    assert_eq!(one, two);
    assert!(one.iter().all(|o| o.error.is_none()));
}

#[test]
fn metric_flags_parse_or_say_why_not() {
    assert!(Metric::parse("settle").is_ok());
    assert!(Metric::parse("final:plant.mode").is_ok());
    for bad in ["settle:-1", "rms:10:6", "rms:6", "final:", "median:x", "a,b"] {
        assert!(Metric::parse(bad).is_err(), "{bad}");
    }
    // The engine's own metrics read any system; the actuator's are not among them.
    let r = Reductions::parse(&["final:a.x", "max:b.y", "min:a.x"]).unwrap();
    assert_eq!(r.recorded(), ["a.x", "b.y"]);
    assert!(Reductions::parse(&["settle"]).is_err());
}

/// `final:`, `min:` and `max:` of every variable a plain run of `system` records: a
/// difference anywhere in the outputs shows in one of them.
fn every_output(system: &Path, input: &Option<InputTable>) -> Arc<dyn Metrics> {
    let opts = Options {
        stop_time: Some(0.02),
        step_size: None,
        coupling: Coupling::Jacobi,
        params: vec![],
        parameter_set: None,
        input: input.clone(),
        outputs: vec![],
    };
    let sim = master::System::load(system).unwrap().initialise(&opts).unwrap();
    let names = sim.record_names().to_vec();
    assert!(!names.is_empty(), "{}: records nothing", system.display());
    Arc::new(LoopMetrics::new(
        names
            .iter()
            .flat_map(|n| {
                ["final", "min", "max"].map(|k| Metric::parse(&format!("{k}:{n}")).unwrap())
            })
            .collect(),
    ))
}

#[test]
fn every_shipped_system_sweeps_to_what_run_gives_row_for_row() {
    // (system, a parameter of it to sweep, whether it has a system input to feed).
    let t_em = PlantParams::T_EM.name();
    let systems = [
        ("InchwormSystem.ssp", plant(t_em), false),
        ("InchwormSystemOpen.ssp", plant(t_em), true),
        ("MirrorMount.ssp", format!("plant_b.{t_em}"), false),
        ("fmi3/InchwormSystemOpen.ssp", plant(t_em), true),
        ("fmi3/InchwormSystemMixed.ssp", plant(t_em), false),
    ];
    // Repeated and shuffled: a value seen before, after another, must still give the row a
    // fresh load gives (a reset that misses any state shows as a repeat that differs).
    let values = [8.8, 8.8, 9.4, 8.8, 8.2, 9.4, 8.8];
    for (file, param, open) in systems {
        let system = inchworm_dist::path(file);
        assert!(system.is_file(), "{}: run `cargo run --release -p fmu-build`", system.display());
        let input = open
            .then(|| InputTable::steps(ControllerFmu::REFERENCE.name(), &[(0.0, 100e-6)]).unwrap());
        let setup = Setup {
            system: system.clone(),
            options: Options {
                stop_time: Some(0.2),
                step_size: None,
                coupling: Coupling::Jacobi,
                params: vec![],
                parameter_set: None,
                input: input.clone(),
                outputs: vec![],
            },
            metrics: every_output(&system, &input),
        };
        let names = vec![param.clone()];
        let rows: Vec<Row> = values
            .iter()
            .enumerate()
            // Run ids out of order too: the plan is data.
            .map(|(i, &v)| Row { run: 100 - i, sample: 0, values: vec![v] })
            .collect();
        let plan = Plan { names: names.clone(), rows: rows.clone() };
        let expected: Vec<Vec<Option<f64>>> =
            rows.iter().map(|r| fresh(&setup, &names, r)).collect();
        for jobs in [1, 2] {
            let out = exec::run_plan(&setup, &plan, jobs, |_| {});
            for (i, (o, e)) in out.iter().zip(&expected).enumerate() {
                assert_eq!(o.error, None, "{file}, {jobs} worker(s), row {i}");
                let bits = |v: &[Option<f64>]| -> Vec<Option<u64>> {
                    v.iter().map(|x| x.map(f64::to_bits)).collect()
                };
                assert_eq!(
                    bits(&o.metrics),
                    bits(e),
                    "{file}, {jobs} worker(s), row {i} ({param} = {}) differs from `inchworm run`",
                    values[i]
                );
            }
        }
        // The parameter does reach the system, or equal rows would prove nothing.
        assert_ne!(expected[0], expected[2], "{file}: {param} changes nothing");
    }
}

/// A name from pieces a user or an attacker might type: letters, dots, brackets, spaces,
/// non-ASCII, commas, quotes, control characters, the plan's own column names.
fn random_name(r: &mut SplitMix64) -> String {
    const PIECES: [&str; 16] = [
        "plant", ".", "T_em", "[1]", " ", "é", "µ", "x", ",", "\"", "\u{7}", "\t", "run", "sample",
        "\u{a0}", "\n",
    ];
    let n = 1 + (r.next_u64() % 4) as usize;
    (0..n).map(|_| PIECES[(r.next_u64() % PIECES.len() as u64) as usize]).collect()
}

/// A number as a user might write it: any finite bits, small integers, signed zero.
fn random_value(r: &mut SplitMix64) -> String {
    match r.next_u64() % 4 {
        0 => {
            let v = f64::from_bits(r.next_u64());
            if v.is_finite() {
                format!("{v:e}")
            } else {
                "1e308".into()
            }
        }
        1 => format!("{}", (r.next_u64() % 2001) as i64 - 1000),
        2 => "-0".into(),
        _ => format!("{}", r.uniform() * 10.0),
    }
}

#[test]
fn whatever_grid_writes_plan_reads_back_to_the_bit() {
    let mut r = SplitMix64::new(2024);
    let (mut accepted, mut refused) = (0, 0);
    for _ in 0..3000 {
        let axes = 1 + (r.next_u64() % 3) as usize;
        let mut sweeps = Vec::new();
        let mut ok = true;
        for _ in 0..axes {
            let name = random_name(&mut r);
            let spec = if r.next_u64().is_multiple_of(2) {
                let n = 1 + r.next_u64() % 5;
                format!("{}:{}:{n}", random_value(&mut r), random_value(&mut r))
            } else {
                let k = 1 + r.next_u64() % 4;
                (0..k).map(|_| random_value(&mut r)).collect::<Vec<_>>().join(";")
            };
            match plan::parse_grid(&format!("{name}={spec}")) {
                Ok(s) => sweeps.push(s),
                Err(_) => ok = false,
            }
        }
        let Ok(p) = Plan::build(&sweeps, 1, 0) else {
            refused += 1;
            continue;
        };
        if !ok || sweeps.is_empty() {
            refused += 1;
            continue;
        }
        accepted += 1;
        let text = p.to_csv();
        let back = Plan::parse(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
        assert_eq!(back.names, p.names, "{text}");
        assert_eq!(back.rows.len(), p.rows.len());
        for (a, b) in back.rows.iter().zip(&p.rows) {
            assert_eq!((a.run, a.sample), (b.run, b.sample));
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&a.values), bits(&b.values), "{text}");
        }
        // One row by its run index reads back alone, the same.
        let k = p.rows.len() / 2;
        let one = Plan::read(text.as_bytes(), Some(&[p.rows[k].run])).unwrap();
        assert_eq!(one.rows, vec![p.rows[k].clone()]);
    }
    // Both sides of the rule are exercised: names it must refuse, and plans it must keep.
    assert!(accepted > 300 && refused > 300, "accepted {accepted}, refused {refused}");
}

#[test]
fn plan_sizes_are_checked_before_anything_is_allocated() {
    let g = |t: &str| plan::parse_grid(t).unwrap();
    let e = Plan::build(&[g("a=1:2:1000"), g("b=1:2:1000"), g("c=1:2:2")], 1, 0)
        .unwrap_err()
        .to_string();
    assert_eq!(e, "1000 × 1000 × 2 = 2000000 runs: more than the 1000000 a sweep may have");
    let s = plan::parse_sample("c=uniform(0,1)").unwrap();
    let e = Plan::build(&[g("a=1:2:1000"), s], usize::MAX, 0).unwrap_err().to_string();
    assert!(e.starts_with("1000 × 18446744073709551615 samples runs overflows"), "{e}");
    let e = Plan::parse("run,sample,a\n0,0,1\n0,1,2\n").unwrap_err().to_string();
    assert_eq!(e, "plan line 3: the run index 0 is given twice");
    assert!(Plan::parse("run,sample,a,a\n").unwrap_err().to_string().contains("a column twice"));
    let e = Plan::read("run,sample,a\n5,0,1\n".as_bytes(), Some(&[4])).unwrap_err().to_string();
    assert_eq!(e, "no row with run index 4");
}
