//! `fmu-build --check --root DIR` on a scratch copy of the committed generated files,
//! tampered the ways a commit can tamper with them: each is one named error line and an
//! exit status of 1, within seconds, never a hang or an exhausted memory.

#![cfg(unix)]

use std::os::unix::fs::symlink;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Far above what the check takes (milliseconds) even on a loaded machine; a walk that
/// follows links or a read of `/dev/zero` does not end within it.
const LIMIT: Duration = Duration::from_secs(60);

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let (src, dst) = (e.path(), to.join(e.file_name()));
        if e.file_type().unwrap().is_dir() {
            copy_tree(&src, &dst);
        } else {
            std::fs::copy(&src, &dst).unwrap();
        }
    }
}

/// The generated module of the Python packages' variable names.
const PYTHON_NAMES: &str = "python/inchworm_variables/inchworm_variables/__init__.py";

/// The Modelica package's generated declarations and example.
const MODELICA: [&str; 2] =
    ["modelica/Inchworm/PlantInterface.mo", "modelica/Inchworm/Examples.mo"];

/// A scratch repository with a copy of the committed generated files: `modelDescription/`,
/// the Python packages' variable names and the Modelica package's generated files.
fn committed_copy() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    copy_tree(&workspace_root().join("modelDescription"), &dir.path().join("modelDescription"));
    for file in std::iter::once(PYTHON_NAMES).chain(MODELICA) {
        let copy = dir.path().join(file);
        std::fs::create_dir_all(copy.parent().unwrap()).unwrap();
        std::fs::copy(workspace_root().join(file), copy).unwrap();
    }
    dir
}

/// The exit code and the standard error of `fmu-build --check --root root`, killed and
/// failed if it runs past `LIMIT`.
fn check(root: &Path) -> (i32, String) {
    let start = Instant::now();
    let mut child = Command::new(env!("CARGO_BIN_EXE_fmu-build"))
        .args(["--check", "--root"])
        .arg(root)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > LIMIT {
            child.kill().unwrap();
            child.wait().unwrap();
            panic!("fmu-build --check still running after {LIMIT:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut stderr).unwrap();
    (status.code().expect("an exit code, not a signal"), stderr)
}

/// Asserts a failed check whose errors are exactly `expected` (each the start of one line
/// of standard error), then the summary line.
fn fails_with(root: &Path, expected: &[&str]) {
    let (code, stderr) = check(root);
    assert!((1..=127).contains(&code), "exit {code}: {stderr}");
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), expected.len() + 1, "{stderr}");
    for (line, start) in lines.iter().zip(expected) {
        assert!(line.starts_with(&format!("fmu-build --check: {start}")), "{line}");
    }
    assert!(lines[expected.len()].contains("problems with the committed generated files"));
}

#[test]
fn the_untouched_copy_passes() {
    let dir = committed_copy();
    let (code, stderr) = check(dir.path());
    assert_eq!(code, 0, "{stderr}");
}

#[test]
fn two_self_links_are_named_not_walked() {
    let dir = committed_copy();
    let md = dir.path().join("modelDescription");
    symlink(".", md.join("a")).unwrap();
    symlink(".", md.join("b")).unwrap();
    fails_with(
        dir.path(),
        &[
            "modelDescription/a is a symbolic link (to .): --check reads only regular files",
            "modelDescription/b is a symbolic link (to .)",
        ],
    );
}

#[test]
fn a_generated_file_linked_to_dev_zero_is_refused_unread() {
    let dir = committed_copy();
    let plant = dir.path().join("modelDescription/InchwormPlant.xml");
    std::fs::remove_file(&plant).unwrap();
    symlink("/dev/zero", &plant).unwrap();
    fails_with(
        dir.path(),
        &["modelDescription/InchwormPlant.xml is a symbolic link (to /dev/zero)"],
    );
}

#[test]
fn links_out_of_the_repository_are_refused_even_to_the_right_text() {
    let dir = committed_copy();
    let outside = tempfile::tempdir().unwrap();
    let md = dir.path().join("modelDescription");
    // The controller's file and the FMI 3.0 folder, each a link to an exact copy outside.
    let controller = md.join("InchwormController.xml");
    std::fs::copy(&controller, outside.path().join("InchwormController.xml")).unwrap();
    std::fs::remove_file(&controller).unwrap();
    symlink(outside.path().join("InchwormController.xml"), &controller).unwrap();
    copy_tree(&md.join("fmi3"), &outside.path().join("fmi3"));
    std::fs::remove_dir_all(md.join("fmi3")).unwrap();
    symlink(outside.path().join("fmi3"), md.join("fmi3")).unwrap();
    let to = outside.path().display().to_string();
    fails_with(
        dir.path(),
        &[
            &format!("modelDescription/InchwormController.xml is a symbolic link (to {to}/"),
            &format!("modelDescription/fmi3 is a symbolic link (to {to}/fmi3)"),
        ],
    );
}

#[test]
fn an_oversized_file_is_refused_unread() {
    let dir = committed_copy();
    let plant = std::fs::OpenOptions::new()
        .write(true)
        .open(dir.path().join("modelDescription/InchwormPlant.xml"))
        .unwrap();
    // Sparse: 1 GiB of length without the disk.
    plant.set_len(1 << 30).unwrap();
    fails_with(
        dir.path(),
        &["modelDescription/InchwormPlant.xml is larger than 1048576 bytes (1 MiB"],
    );
}

#[test]
fn an_edited_python_names_module_is_named() {
    let dir = committed_copy();
    let path = dir.path().join(PYTHON_NAMES);
    let text = std::fs::read_to_string(&path).unwrap();
    let at = text.lines().position(|l| l == "    DAC_EXTENSION = \"dac_extension\"").unwrap();
    std::fs::write(&path, text.replacen("\"dac_extension\"", "\"dac_extention\"", 1)).unwrap();
    let line = format!("{PYTHON_NAMES} differs from the generated text from line {}", at + 1);
    fails_with(dir.path(), &[line.as_str()]);
}

#[test]
fn a_modelica_declaration_edited_away_from_the_table_is_named() {
    let dir = committed_copy();
    let path = dir.path().join(MODELICA[0]);
    let text = std::fs::read_to_string(&path).unwrap();
    let at = text.lines().position(|l| l.contains(" k_p(")).unwrap();
    std::fs::write(&path, text.replacen("= 3e7 ", "= 3.1e7 ", 1)).unwrap();
    let line = format!("{} differs from the generated text from line {}", MODELICA[0], at + 1);
    fails_with(dir.path(), &[line.as_str()]);
}
