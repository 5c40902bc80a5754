//! Generates `inchworm_hil.h` with cbindgen into OUT_DIR (never into the source tree,
//! so a build cannot dirty the checkout). cbindgen parses src/lib.rs and the modules it
//! declares (`with_src`), which keeps it from running `cargo metadata` inside the build.
//! The committed copy in include/ is compared with this one by the protocol crate's
//! tests/c_api.rs.

use std::{env, path::PathBuf};

fn main() {
    let dir = PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR"));
    let out = PathBuf::from(env::var("OUT_DIR").expect("OUT_DIR"));
    println!("cargo:rerun-if-changed=src");
    println!("cargo:rerun-if-changed=cbindgen.toml");
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml"))
        .unwrap_or_else(|e| panic!("cbindgen.toml: {e}"));
    let bindings = cbindgen::Builder::new()
        .with_config(config)
        .with_src(dir.join("src/lib.rs"))
        .generate()
        .unwrap_or_else(|e| panic!("cbindgen failed to generate inchworm_hil.h: {e}"));
    let header = out.join("inchworm_hil.h");
    bindings.write_to_file(&header);
}
