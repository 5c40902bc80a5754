//! Where the tests, benches and examples find what `cargo run --release -p fmu-build`
//! packages: the FMUs and SSP systems of `dist/`. One place, so every test that needs a
//! built `dist/` finds the same folder (`INCHWORM_DIST` points them all elsewhere, at an
//! installed or a downloaded set) and says the same thing when it is missing.

use std::path::{Path, PathBuf};

/// The variable that points the tests at another `dist/`.
pub const VAR: &str = "INCHWORM_DIST";

/// The folder: `$INCHWORM_DIST` when it is set, else the workspace's `dist/`.
pub fn dir() -> PathBuf {
    match std::env::var_os(VAR) {
        Some(d) if !d.is_empty() => PathBuf::from(d),
        _ => Path::new(env!("CARGO_MANIFEST_DIR")).join("../../dist"),
    }
}

/// `dist/<name>` (`fmi3/InchwormPlant.fmu`, `InchwormSystem.ssp`, …).
///
/// # Panics
/// If there is no such file, naming it and the command that builds it: the tests that call
/// this check the packaged files and cannot pass without them.
pub fn path(name: &str) -> PathBuf {
    let p = dir().join(name);
    assert!(
        p.is_file(),
        "{} is missing: build the FMUs first with `cargo run --release -p fmu-build` \
         (or point {VAR} at a folder that has them)",
        p.display()
    );
    p
}
