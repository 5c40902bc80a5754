//! Builds the C API (`crates/hil-protocol/ffi`: libinchworm_hil.a + the cbindgen header)
//! and compiles C programs against it with the system C compiler. Shared by the C tests of
//! this crate and of the bridge (which includes this file by path).
//!
//! The C programs include the committed header (`ffi/include/inchworm_hil.h`), the one
//! firmware engineers use; tests/c_api.rs keeps it equal to what cbindgen generates.
//!
//! The ffi crate is its own workspace, so it gets its own target directory under the
//! workspace's (`<target>/hil-ffi`) and never contends for the lock of the outer build.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

/// crates/hil-protocol, wherever this file is compiled from.
pub fn crate_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../hil-protocol")
}

pub fn target_dir() -> PathBuf {
    let workspace = crate_dir().join("../..");
    match std::env::var_os("CARGO_TARGET_DIR") {
        Some(dir) => {
            let dir = PathBuf::from(dir);
            if dir.is_absolute() {
                dir
            } else {
                workspace.join(dir)
            }
        }
        None => workspace.join("target"),
    }
    .join("hil-ffi")
}

/// The string value of `"key":"..."` in one line of cargo's JSON messages.
fn json_str<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    let start = line.find(&format!("\"{key}\":\""))? + key.len() + 4;
    let len = line[start..].find('"')?;
    Some(&line[start..start + len])
}

/// The committed header's directory, for `-I`.
pub fn include_dir() -> PathBuf {
    crate_dir().join("ffi/include")
}

/// Builds the staticlib; returns (directory of the generated header, path of
/// libinchworm_hil.a).
pub fn build_ffi(target: &Path) -> (PathBuf, PathBuf) {
    let manifest = crate_dir().join("ffi/Cargo.toml");
    let out = Command::new(env!("CARGO"))
        .args(["build", "--release", "--message-format=json-render-diagnostics", "--manifest-path"])
        .arg(&manifest)
        .arg("--target-dir")
        .arg(target)
        .env_remove("CARGO_TARGET_DIR")
        .output()
        .expect("run cargo");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "building the ffi crate failed:\n{}\n{stdout}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut header_dir = None;
    let mut lib = None;
    for line in stdout.lines().filter(|l| l.contains("inchworm-hil-ffi")) {
        if line.contains("\"reason\":\"build-script-executed\"") {
            header_dir = json_str(line, "out_dir").map(PathBuf::from);
        }
        if line.contains("\"reason\":\"compiler-artifact\"") {
            if let Some(i) = line.find("libinchworm_hil.a") {
                let start = line[..i].rfind('"').unwrap() + 1;
                lib = Some(PathBuf::from(&line[start..i + "libinchworm_hil.a".len()]));
            }
        }
    }
    let header_dir =
        header_dir.expect("cargo reported no build-script out_dir for inchworm-hil-ffi");
    let lib = lib.expect("cargo reported no libinchworm_hil.a");
    assert!(header_dir.join("inchworm_hil.h").is_file(), "no header in {}", header_dir.display());
    assert!(lib.is_file(), "{} missing", lib.display());
    (header_dir, lib)
}

/// Compiles `source` against the library and header into `<target>/c-test/<name>`.
pub fn compile(source: &Path, name: &str) -> PathBuf {
    let target = target_dir();
    let (_, lib) = build_ffi(&target);
    let exe = target.join("c-test").join(name);
    std::fs::create_dir_all(exe.parent().unwrap()).unwrap();
    let cc = std::env::var("CC").unwrap_or_else(|_| "gcc".to_string());
    let out = Command::new(&cc)
        .args(["-std=c99", "-Wall", "-Wextra", "-Werror", "-I"])
        .arg(include_dir())
        .arg(source)
        .arg(&lib)
        .args(["-lpthread", "-ldl", "-lm", "-o"])
        .arg(&exe)
        .output()
        .unwrap_or_else(|e| panic!("cannot run the C compiler {cc:?}: {e}"));
    assert!(
        out.status.success(),
        "compiling {} failed:\n{}{}",
        source.display(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    exe
}
