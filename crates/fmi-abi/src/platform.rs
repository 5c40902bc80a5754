//! Where an FMU keeps the binary for each platform: FMI 2.0's folder names (section 2.4,
//! `binaries/<platform>`) and FMI 3.0's `<arch>-<os>` tuples (section 2.5.1.1), with the
//! shared-library naming of each operating system. One table, read by the packager and
//! the importer alike; a new platform is a row here.

/// One operating system and processor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Platform {
    /// `std::env::consts::OS`.
    pub os: &'static str,
    /// `std::env::consts::ARCH`.
    pub arch: &'static str,
    /// The FMI 2.0 folder, where FMI 2.0 names one. FMI 2.0 has no name for 64-bit ARM
    /// Linux; `darwin64` is the folder of both Mac processors, as the Reference-FMUs ship
    /// universal binaries there.
    pub fmi2: Option<&'static str>,
    /// The FMI 3.0 platform tuple.
    pub fmi3: &'static str,
    /// File-name prefix of a shared library as the linker writes it (`lib` on Unix).
    pub lib_prefix: &'static str,
    /// Shared-library extension, without the dot.
    pub lib_ext: &'static str,
    /// The Rust target triple fmu-build compiles this platform's library for (the GNU
    /// toolchain on Windows: MinGW-w64, which builds and tests on Linux).
    pub rust_target: &'static str,
}

const fn row(
    os: &'static str,
    arch: &'static str,
    fmi2: Option<&'static str>,
    fmi3: &'static str,
    lib_prefix: &'static str,
    lib_ext: &'static str,
    rust_target: &'static str,
) -> Platform {
    Platform { os, arch, fmi2, fmi3, lib_prefix, lib_ext, rust_target }
}

/// Every platform the project knows how to name.
pub const PLATFORMS: [Platform; 7] = [
    row(
        "linux",
        "x86_64",
        Some("linux64"),
        "x86_64-linux",
        "lib",
        "so",
        "x86_64-unknown-linux-gnu",
    ),
    row("linux", "x86", Some("linux32"), "x86-linux", "lib", "so", "i686-unknown-linux-gnu"),
    row("linux", "aarch64", None, "aarch64-linux", "lib", "so", "aarch64-unknown-linux-gnu"),
    row(
        "macos",
        "x86_64",
        Some("darwin64"),
        "x86_64-darwin",
        "lib",
        "dylib",
        "x86_64-apple-darwin",
    ),
    row(
        "macos",
        "aarch64",
        Some("darwin64"),
        "aarch64-darwin",
        "lib",
        "dylib",
        "aarch64-apple-darwin",
    ),
    row("windows", "x86_64", Some("win64"), "x86_64-windows", "", "dll", "x86_64-pc-windows-gnu"),
    row("windows", "x86", Some("win32"), "x86-windows", "", "dll", "i686-pc-windows-gnu"),
];

/// The row of an operating system and processor, as `std::env::consts` names them.
pub fn of(os: &str, arch: &str) -> Option<&'static Platform> {
    PLATFORMS.iter().find(|p| p.os == os && p.arch == arch)
}

/// The row of the machine this code runs on.
pub fn host() -> Option<&'static Platform> {
    of(std::env::consts::OS, std::env::consts::ARCH)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_row_is_unique_and_named_both_ways() {
        for (i, a) in PLATFORMS.iter().enumerate() {
            for b in &PLATFORMS[i + 1..] {
                assert!((a.os, a.arch) != (b.os, b.arch), "{a:?} twice");
                assert_ne!(a.fmi3, b.fmi3, "FMI 3.0 tuple of {a:?} and {b:?}");
            }
            assert_eq!(a.fmi3.split_once('-').map(|(arch, _)| arch), Some(a.arch));
        }
        assert_eq!(of("linux", "x86_64").and_then(|p| p.fmi2), Some("linux64"));
        assert_eq!(of("linux", "aarch64").map(|p| (p.fmi2, p.fmi3)), Some((None, "aarch64-linux")));
        assert_eq!(of("windows", "x86_64").map(|p| (p.lib_prefix, p.lib_ext)), Some(("", "dll")));
        for p in &PLATFORMS {
            // The triple names the same processor and system as the row.
            let arch = if p.arch == "x86" { "i686" } else { p.arch };
            assert!(p.rust_target.starts_with(&format!("{arch}-")), "{p:?}");
            let os = if p.os == "macos" { "apple-darwin" } else { p.os };
            assert!(p.rust_target.contains(os), "{p:?}");
        }
    }
}
