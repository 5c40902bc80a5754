//! `inchworm run` through the cache of unpacked FMUs (docs/ssp.md, The FMU cache): the first
//! run adds one entry per FMU of the system, a second run takes the same files and writes
//! the same bytes, a run with the cache off writes them too, no run leaves a temporary
//! folder behind; and the run's timing line gives load, loop and the loop's factor.

use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_inchworm");

fn scratch(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("inchworm-run-cache-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(d.join("tmp")).unwrap();
    d
}

/// `inchworm run` of the closed system into `dir/<out>`, with TMPDIR at `dir/tmp` and the
/// cache at `cache` (`off` for none); its stdout.
fn run(dir: &Path, out: &str, cache: &str) -> String {
    let o = Command::new(BIN)
        .arg("run")
        .arg(inchworm_dist::path("InchwormSystem.ssp"))
        .arg("--out")
        .arg(dir.join(out))
        .env("TMPDIR", dir.join("tmp"))
        .env("INCHWORM_FMU_CACHE", cache)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(o.status.success(), "{stdout}{}", String::from_utf8_lossy(&o.stderr));
    stdout
}

/// Every file under `dir` with its inode, sorted by path.
fn files(dir: &Path) -> Vec<(String, u64)> {
    let mut found = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                todo.push(p);
            } else {
                let rel = p.strip_prefix(dir).unwrap().to_string_lossy().into_owned();
                found.push((rel, std::fs::metadata(&p).unwrap().ino()));
            }
        }
    }
    found.sort();
    found
}

/// The timing line's numbers: load and loop seconds, the factor; checked against its format
/// `10 s simulated: load L s, loop T s (Fx real time); 13 variables, 5001 rows`.
fn timing(stdout: &str) -> (f64, f64, f64) {
    let line = stdout.lines().find(|l| l.starts_with("10 s simulated: ")).unwrap_or_else(|| {
        panic!("no timing line in:\n{stdout}");
    });
    let rest = line.strip_prefix("10 s simulated: load ").unwrap();
    let (load, rest) = rest.split_once(" s, loop ").unwrap();
    let (looped, rest) = rest.split_once(" s (").unwrap();
    let (factor, rest) = rest.split_once("x real time); ").unwrap();
    assert_eq!(rest, "13 variables, 5001 rows", "{line}");
    for seconds in [load, looped] {
        let (whole, decimals) = seconds.split_once('.').unwrap();
        assert!(whole.parse::<u32>().is_ok() && decimals.len() == 3, "{line}");
    }
    let (load, looped, factor): (f64, f64, f64) =
        (load.parse().unwrap(), looped.parse().unwrap(), factor.parse().unwrap());
    // The factor is the loop's: 10 simulated seconds over the loop's (rounded) seconds.
    if looped >= 0.01 {
        let ratio = factor / (10.0 / looped);
        assert!((0.9..1.1).contains(&ratio), "{line}");
    }
    (load, looped, factor)
}

#[test]
fn a_second_run_takes_the_cached_files_and_writes_the_same_rows() {
    let dir = scratch("reuse");
    let cache = dir.join("cache");
    let first = run(&dir, "first.csv", cache.to_str().unwrap());
    timing(&first);
    let entries: Vec<String> = std::fs::read_dir(&cache)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    // The plant, the controller and the reference FMUs of the closed system.
    assert_eq!(entries.len(), 3, "{entries:?}");
    assert!(entries.iter().all(|e| e.starts_with("v1-x86_64-linux-")), "{entries:?}");
    let before = files(&cache);
    assert!(before.iter().any(|(p, _)| p.ends_with("binaries/linux64/InchwormPlant.so")));

    let second = run(&dir, "second.csv", cache.to_str().unwrap());
    timing(&second);
    assert_eq!(files(&cache), before, "the second run rewrote the cache");
    let off = run(&dir, "off.csv", "off");
    timing(&off);
    assert_eq!(files(&cache), before);

    let csv = |name: &str| std::fs::read(dir.join(name)).unwrap();
    assert_eq!(csv("first.csv"), csv("second.csv"));
    assert_eq!(csv("first.csv"), csv("off.csv"));
    let left: Vec<_> = std::fs::read_dir(dir.join("tmp")).unwrap().collect();
    assert!(left.is_empty(), "left in TMPDIR: {left:?}");
    let _ = std::fs::remove_dir_all(&dir);
}
