//! The packaged FMUs and systems the master's tests run (tests/master.rs,
//! tests/master_no_alloc.rs include this file with `#[path]`).

use std::path::{Path, PathBuf};

/// `dist/<name>`, which `cargo run --release -p fmu-build` writes.
pub fn dist(name: &str) -> PathBuf {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("dist").join(name);
    assert!(
        p.is_file(),
        "{} is missing: run `cargo run --release -p fmu-build` first",
        p.display()
    );
    p
}
