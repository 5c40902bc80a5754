//! Builds the C API (`crates/hil-protocol/ffi`: libinchworm_hil.a + the cbindgen header),
//! compiles tests/c/roundtrip.c against it with the system C compiler and runs it.
//! Fails if the library or header does not build, the C program does not compile or
//! link, or any of its checks fails.

mod ffi_build;

use std::process::Command;

use ffi_build::{build_ffi, compile, crate_dir, target_dir};

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
