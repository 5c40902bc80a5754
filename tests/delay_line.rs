//! `inchworm delay-line` (docs/delay-line.md): the command's files and figures, its refusals,
//! and the largest path rate each gait follows.

use std::process::Command;

use inchworm_controller::Params;
use inchworm_scenarios::delay_line::{follows, gaits, Following};

const BIN: &str = env!("CARGO_BIN_EXE_inchworm");

#[test]
fn a_run_writes_its_csv_and_plot_and_says_its_figures() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(BIN)
        .args(["delay-line", "--controller", "analog", "--duration", "4", "--param", "space=true"])
        .arg("--out")
        .arg(dir.path())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("visibility") && stdout.contains("locked throughout"), "{stdout}");
    let csv = std::fs::read_to_string(dir.path().join("delay-line.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("time,path,cart_path,inchworm_path,fine_path,residual,locked"));
    assert_eq!(lines.count(), 2001, "one row a 2 ms sample from t = 0 to 4 s");
    let png = std::fs::read(dir.path().join("delay-line.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
}

#[test]
fn bad_input_is_refused_by_name_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    for (args, says) in [
        (
            &["--param", "baseline_length=0"][..],
            "baseline_length = 0: must be finite, within [1e-3",
        ),
        (&["--param", "baseline_length=NaN"], "baseline_length = NaN: must be finite"),
        (&["--param", "latitude=40", "--param", "declination=-60"], "below the horizon"),
        (&["--param", "nope=1"], "unknown parameter `nope`"),
        (&["--controller", "fast"], "unknown controller `fast`; known: stepping, deadband, analog"),
        (&["--param", "fine_loop_type=3"], "fine_loop_type = 3: must be finite, within [1e0, 2e0]"),
    ] {
        let out = Command::new(BIN)
            .arg("delay-line")
            .args(args)
            .arg("--out")
            .arg(dir.path().join("out"))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(stderr.contains(says), "{args:?}: {stderr}");
        assert!(!dir.path().join("out").join("delay-line.csv").exists(), "{args:?}");
    }
}

/// The gait's speed limit: 0.2 s steps of the 20 µm device keep up with 0.1 mm/s of
/// optical path (0.05 mm/s of runner: a baseline of 1.4 m at most), not with 0.2 mm/s;
/// 20 ms steps keep up with 0.8 mm/s. Between steps the fringes come back only below
/// about a third of that: each step's brake disturbance moves the path by micrometres.
#[test]
fn each_gait_follows_the_rates_it_can_step() {
    let [(_, slow), _, (_, fast)] = <[_; 3]>::try_from(gaits()).ok().unwrap();
    let up = |c: &Params, rate| follows(c, rate, 8.0, Following::KeepsUp).unwrap();
    assert!(up(&slow, 0.1e-3));
    assert!(!up(&slow, 0.2e-3));
    assert!(up(&fast, 0.8e-3));
    let fringes = |c: &Params, rate| follows(c, rate, 8.0, Following::Fringes).unwrap();
    assert!(fringes(&slow, 0.03e-3));
    assert!(!fringes(&slow, 0.1e-3));
}

/// `InchwormDelayLine.ssp` run by the master on its 2 ms Jacobi grid is the library's loop
/// (`system::run`): the plant's runner at every communication point and the delay line's
/// residual one sample later (the FMU shows a sample after the step that takes it), bit
/// for bit.
#[test]
fn the_delay_line_system_runs_the_library_loop_bit_for_bit() {
    use inchworm_delay_line::system::{self, DelayLineParams};
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("line.csv");
    let out = Command::new(BIN)
        .arg("run")
        .arg(inchworm_dist::path("InchwormDelayLine.ssp"))
        .args([
            "--stop-time",
            "3",
            "--output",
            "plant.runner_position",
            "--output",
            "delay_line.residual",
        ])
        .arg("--out")
        .arg(&csv)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("time,plant.runner_position,delay_line.residual"));
    let rows: Vec<Vec<f64>> =
        lines.map(|l| l.split(',').map(|x| x.parse().unwrap()).collect()).collect();
    let lib = system::run(
        &DelayLineParams::default(),
        inchworm_plant::PlantParams::fia20(),
        inchworm_controller::Params::default(),
        3.0,
    )
    .unwrap();
    assert_eq!(rows.len(), lib.time.len(), "one row a sample, t = 0 to 3 s");
    for k in 0..rows.len() - 1 {
        assert_eq!(rows[k][1].to_bits(), lib.runner[k].to_bits(), "runner at sample {k}");
        assert_eq!(rows[k + 1][2].to_bits(), lib.residual[k].to_bits(), "residual of sample {k}");
    }
    // The loop takes out the millimetres of sidereal path (the cart and the runner) to
    // micrometres, and the tracker holds the fringes but while the gait steps.
    let after = 1000..lib.residual.len();
    let moved = lib.path.last().unwrap().abs();
    let rms = inchworm_delay_line::fringes::rms(&lib.residual[after.clone()]);
    let locked =
        lib.locked[after.clone()].iter().filter(|l| **l).count() as f64 / after.len() as f64;
    assert!(moved > 1e-3 && rms < 10e-6 && locked > 0.8, "{moved} {rms} {locked}");
}

/// Visibility against baseline (the survey's figure): with the cart the baseline does not
/// matter, the controller mode does; without it the gait's speed limit is the baseline's.
#[test]
fn with_the_cart_the_baseline_does_not_matter_without_it_the_gait_s_speed_does() {
    use inchworm_scenarios::delay_line::{baseline_sweep, visibility_series, BASELINES};
    let series = visibility_series(&baseline_sweep(8.0).unwrap());
    let names: Vec<&str> = series.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        [
            "stepping, ground",
            "deadband, ground",
            "analog, ground",
            "stepping, ground without cart",
            "deadband, ground without cart",
            "analog, ground without cart",
        ]
    );
    let v = |i: usize| -> Vec<f64> { series[i].1.iter().map(|p| p[1]).collect() };
    for (i, points) in series.iter().map(|(_, p)| p).enumerate() {
        let baselines: Vec<f64> = points.iter().map(|p| p[0]).collect();
        assert_eq!(baselines, BASELINES, "{}", names[i]);
    }
    for (i, name) in names.iter().enumerate().take(3) {
        let (lo, hi) = v(i).iter().fold((1.0f64, 0.0f64), |(l, h), x| (l.min(*x), h.max(*x)));
        assert!(hi - lo < 0.03, "{name}: {:?}", v(i));
    }
    assert!(v(2).iter().all(|x| *x > 0.9) && v(0).iter().all(|x| *x < 0.8), "{:?}", v(2));
    let (stepping, analog) = (v(3), v(5));
    assert!(analog[0] > 0.85 && stepping[0] < 0.5, "1 m: {analog:?} {stepping:?}");
    assert!(analog[1] < analog[0] && analog[2] < 0.2, "{analog:?}");
}
