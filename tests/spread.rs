//! `inchworm run --spread`: every actuator of `dist/MirrorMount.ssp` reduced to the sweep's
//! metrics, one CSV row an actuator, with the nominal device's figures.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_inchworm");

/// A folder of this test's own: the tests of this file run at once, in one process.
fn scratch(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("inchworm-spread-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `inchworm run SYSTEM --out DIR/run.csv --spread DIR/spread`.
fn run_spread(system: &str, dir: &Path) -> Output {
    Command::new(BIN)
        .arg("run")
        .arg(inchworm_dist::path(system))
        .arg("--out")
        .arg(dir.join("run.csv"))
        .arg("--spread")
        .arg(dir.join("spread"))
        .output()
        .unwrap()
}

#[test]
fn the_mirror_mounts_three_actuators_settle_and_hold_as_the_nominal_loop() {
    let dir = scratch("mirror");
    let out = run_spread("MirrorMount.ssp", &dir);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("disturbance (um) over 3 actuators"), "{stdout}");
    assert!(dir.join("spread/spread.png").is_file());
    let csv = std::fs::read_to_string(dir.join("spread/actuators.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("actuator,settle:1e-6,rms:6:10,disturbance"));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let names: Vec<&str> = rows.iter().map(|r| r[0]).collect();
    assert_eq!(names, ["plant_a", "plant_b", "plant_c"]);
    for r in &rows {
        let v: Vec<f64> = r[1..].iter().map(|x| x.parse().unwrap()).collect();
        // fia20 under the default controller: the Fig. 5 loop's settle time (0.788 s, on
        // the 0.2 s lattice of the iterations), a few nm of holding error, the brake
        // disturbance of the 20 µm device.
        assert!((v[0] - 0.788).abs() < 1e-9, "{r:?}");
        assert!(v[1] > 1e-9 && v[1] < 10e-9, "{r:?}");
        assert!((v[2] - 4.7e-6).abs() < 0.05e-6, "{r:?}");
    }
    // b and c are the mirror images of each other under a tip: the same rows.
    assert_eq!(rows[1][1..], rows[2][1..]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_run_without_an_actuator_is_refused_before_it_starts() {
    let dir = scratch("no-actuator");
    let out = run_spread("InchwormMount.fmu", &dir);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("--spread: no actuator recorded"), "{stderr}");
    assert!(!dir.join("spread").exists() && !dir.join("run.csv").exists());
    let _ = std::fs::remove_dir_all(&dir);
}
