//! The output-file contract of `inchworm run` (README, "Reliability"): every output is
//! checked before any work, distinct from the others and from every input, and written
//! through a temporary beside it renamed when complete: a refused or failed run leaves
//! every existing file as it was and no temporary behind.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_inchworm");

fn scratch(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("inchworm-outputs-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `inchworm run SYSTEM --stop-time 0.1 ARGS`.
fn run(system: &Path, args: &[&std::ffi::OsStr]) -> Output {
    Command::new(BIN)
        .arg("run")
        .arg(system)
        .args(["--stop-time", "0.1"])
        .args(args)
        .output()
        .unwrap()
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// A copy of the mirror mount's system in `dir`, for a run that must not touch it.
fn mount_system(dir: &Path) -> PathBuf {
    let ssp = dir.join("MirrorMount.ssp");
    std::fs::copy(inchworm_dist::path("MirrorMount.ssp"), &ssp).unwrap();
    ssp
}

fn refused(out: &Output, says: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains(says), "{stderr}");
}

#[test]
fn outputs_that_meet_each_other_or_an_input_are_refused_before_the_run() {
    let dir = scratch("meet");
    let ssp = mount_system(&dir);
    let before = std::fs::read(&ssp).unwrap();
    let same = dir.join("run.csv");
    std::fs::write(&same, "mine").unwrap();
    let o = run(&ssp, &["--out".as_ref(), same.as_os_str(), "--poses".as_ref(), same.as_os_str()]);
    refused(&o, "named as --out and as --poses");
    // The same file under another spelling.
    let other = dir.join(".").join("run.csv");
    let o = run(&ssp, &["--out".as_ref(), same.as_os_str(), "--poses".as_ref(), other.as_os_str()]);
    refused(&o, "named as --out and as --poses");
    let o = run(&ssp, &["--out".as_ref(), same.as_os_str(), "--poses".as_ref(), ssp.as_os_str()]);
    refused(&o, "the --poses would overwrite the input");
    #[cfg(unix)]
    {
        let link = dir.join("link.ssp");
        std::fs::hard_link(&ssp, &link).unwrap();
        let o = run(&ssp, &["--out".as_ref(), link.as_os_str()]);
        refused(&o, "the --out would overwrite the input");
        std::fs::remove_file(&link).unwrap();
    }
    assert_eq!(std::fs::read(&ssp).unwrap(), before, "the system is as it was");
    assert_eq!(std::fs::read_to_string(&same).unwrap(), "mine");
    assert_eq!(names(&dir), ["MirrorMount.ssp", "run.csv"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_refused_out_leaves_the_existing_poses_as_they_were() {
    let dir = scratch("refused-out");
    let ssp = mount_system(&dir);
    let poses = dir.join("poses.csv");
    std::fs::write(&poses, "my poses").unwrap();
    let folder = dir.join("a-folder");
    std::fs::create_dir(&folder).unwrap();
    let o =
        run(&ssp, &["--poses".as_ref(), poses.as_os_str(), "--out".as_ref(), folder.as_os_str()]);
    refused(&o, "the --out is a folder, not a file");
    assert_eq!(std::fs::read_to_string(&poses).unwrap(), "my poses");
    assert_eq!(names(&dir), ["MirrorMount.ssp", "a-folder", "poses.csv"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_completed_run_replaces_its_outputs_and_leaves_no_temporary() {
    let dir = scratch("completed");
    let ssp = mount_system(&dir);
    let (out, poses) = (dir.join("run.csv"), dir.join("poses.csv"));
    std::fs::write(&out, "old").unwrap();
    let o = run(&ssp, &["--out".as_ref(), out.as_os_str(), "--poses".as_ref(), poses.as_os_str()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(&out).unwrap();
    assert!(csv.starts_with("time,") && csv.lines().count() == 52, "{}", &csv[..40]);
    assert!(std::fs::read_to_string(&poses).unwrap().starts_with("time,"));
    assert_eq!(names(&dir), ["MirrorMount.ssp", "poses.csv", "run.csv"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A run stopped by SIGTERM part way (or before its first row, on a busy machine: either
/// way) leaves an existing `--out` as it was and no temporary.
#[cfg(unix)]
#[test]
fn a_stopped_run_leaves_the_existing_out_as_it_was() {
    let dir = scratch("stopped");
    let ssp = mount_system(&dir);
    let out = dir.join("run.csv");
    std::fs::write(&out, "old").unwrap();
    let mut child = Command::new(BIN)
        .arg("run")
        .arg(&ssp)
        .args(["--stop-time", "100000"])
        .arg("--out")
        .arg(&out)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(500));
    // SAFETY: signalling a child this test spawned and has not reaped.
    unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
    let status = child.wait().unwrap();
    assert!(!status.success());
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "old");
    assert_eq!(names(&dir), ["MirrorMount.ssp", "run.csv"]);
    let _ = std::fs::remove_dir_all(&dir);
}
