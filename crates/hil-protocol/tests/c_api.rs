//! Builds the C API (`crates/hil-protocol/ffi`: libinchworm_hil.a + the cbindgen header),
//! compiles tests/c/roundtrip.c against it with the system C compiler and runs it.
//! Fails if the library or header does not build, the committed header differs from the
//! generated one, the C program does not compile or link, or any of its checks fails.

mod ffi_build;

use std::process::Command;

use ffi_build::{build_ffi, compile, crate_dir, include_dir, target_dir};

/// Setting this variable makes the header test write the generated header over the
/// committed one instead of failing.
const BLESS: &str = "INCHWORM_HIL_BLESS";

#[test]
fn the_committed_header_is_what_cbindgen_generates() {
    let (header_dir, _) = build_ffi(&target_dir());
    let generated = std::fs::read(header_dir.join("inchworm_hil.h")).unwrap();
    let committed_path = include_dir().join("inchworm_hil.h");
    if std::env::var_os(BLESS).is_some() {
        std::fs::write(&committed_path, &generated).unwrap();
        return;
    }
    let committed = std::fs::read(&committed_path).unwrap_or_default();
    if committed != generated {
        let first = committed
            .split(|&b| b == b'\n')
            .zip(generated.split(|&b| b == b'\n'))
            .position(|(a, b)| a != b)
            .map_or_else(
                || "the end of the shorter file".to_string(),
                |i| format!("line {}", i + 1),
            );
        panic!(
            "crates/hil-protocol/ffi/include/inchworm_hil.h differs from the header cbindgen \
             generates from ffi/src/ (first at {first}).\n\
             Regenerate it with\n    \
             {BLESS}=1 cargo test --release -p inchworm-hil-protocol --test c_api\n\
             and commit the result."
        );
    }
}

#[test]
fn c_round_trip_through_static_library() {
    let target = target_dir();
    let (header_dir, _) = build_ffi(&target);
    let header = std::fs::read_to_string(header_dir.join("inchworm_hil.h")).unwrap();
    for item in [
        "#ifndef INCHWORM_HIL_H",
        "iw_encode",
        "iw_decode",
        "iw_crc32",
        "IW_ERR_CRC",
        "IwPacket",
        "IwWatchdog",
    ] {
        assert!(header.contains(item), "header lacks {item}");
    }

    let exe = compile(&crate_dir().join("tests/c/roundtrip.c"), "roundtrip");

    let run = Command::new(&exe).output().expect("run the C test");
    let stdout = String::from_utf8_lossy(&run.stdout);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "C round trip failed ({}):\n{stdout}{stderr}", run.status);
    assert_eq!(stdout.trim(), "inchworm_hil C round trip: all checks passed", "{stderr}");
    assert!(stderr.is_empty(), "{stderr}");
}
