//! The platforms every FMU carries a binary for, how each is built on one Debian machine,
//! and the cache that builds each once per change of its sources (docs/platforms.md).
//!
//! `fmu-build` alone builds the host's platform only, with the host's own toolchain and
//! linker (`host_target`): the FMUs then load on this machine and on systems with its
//! glibc or newer, and nothing but the Rust toolchain is needed. `fmu-build
//! --all-platforms` builds the five platforms below, which are what a release ships:
//!
//! - x86-64 Linux with rustup's toolchain, linked by `cargo-zigbuild` against glibc 2.17
//!   symbol versions (the `.2.17` suffix of the target), so the libraries load on any
//!   glibc from 2.17 (RHEL 7) on, not only on the build machine's.
//! - aarch64 Linux (also glibc 2.17), 64-bit Windows (MinGW-w64's linker) and both Macs
//!   (zig with Apple's libSystem stubs) with Debian's `rustc-web` / `cargo-web`, which build
//!   the standard library for the target from `rust-web-src` (`-Zbuild-std`), as rustup
//!   has no other target's standard library here.
//!
//! A platform's libraries are cached outside the clone under a key that hashes everything
//! that goes into them (`cache_key.rs`): the recipe below, the toolchain's versions, the
//! lock entries and manifest lines of the libraries' dependency tree, `.cargo/config.toml`
//! and every file of the workspace packages in that tree. A cache hit copies the libraries
//! and runs no compiler; any change to one of those inputs misses and builds that platform
//! once.

use std::path::{Path, PathBuf};
use std::process::Command;

use inchworm_fmi_abi::platform::{self, Platform};

/// Bumped whenever the build commands below change, so no cached library of an older
/// recipe is reused.
pub(crate) const RECIPE: &str = "fmu-build platforms 3";

/// The glibc whose symbol versions the Linux libraries and binary are linked against:
/// glibc 2.17 (RHEL/CentOS 7, 2012) is the oldest that zig links for both x86-64 and
/// aarch64 (the first glibc with an aarch64 port).
pub const GLIBC_FLOOR: &str = "2.17";

/// How one platform's libraries are linked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Linker {
    /// The toolchain's default linker (`cc`), against the build machine's own libc.
    Host,
    /// `cargo zigbuild` (zig as the C linker), against glibc `GLIBC_FLOOR` on Linux.
    Zig,
    /// A GCC cross linker from Debian.
    Gcc(&'static str),
}

/// One platform fmu-build builds.
#[derive(Clone, Copy, Debug)]
pub struct Target {
    pub platform: &'static Platform,
    /// Built with Debian's `rustc-web` and `-Zbuild-std` instead of rustup's toolchain.
    pub build_std: bool,
    pub linker: Linker,
}

impl Target {
    /// What `--target` says: the Rust triple, with the glibc version on Linux for zig.
    pub fn cargo_target(&self) -> String {
        let triple = self.platform.rust_target;
        if self.linker == Linker::Zig && self.platform.os == "linux" {
            format!("{triple}.{GLIBC_FLOOR}")
        } else {
            triple.to_string()
        }
    }

    fn out_dir(&self, target_dir: &Path) -> PathBuf {
        self.cargo_dir(target_dir).join(self.platform.rust_target).join("release")
    }

    /// Debian's toolchain builds in a folder of its own, so the two compilers never
    /// invalidate each other's build scripts.
    fn cargo_dir(&self, target_dir: &Path) -> PathBuf {
        if self.build_std {
            target_dir.join("rustc-web")
        } else {
            target_dir.to_path_buf()
        }
    }

    pub(crate) fn cargo(&self) -> String {
        if self.build_std {
            DEBIAN_CARGO.into()
        } else {
            std::env::var("CARGO").unwrap_or_else(|_| "cargo".into())
        }
    }
}

const DEBIAN_CARGO: &str = "/usr/bin/cargo";
pub(crate) const DEBIAN_RUSTC: &str = "/usr/bin/rustc";

fn row(fmi3: &str) -> &'static Platform {
    platform::PLATFORMS.iter().find(|p| p.fmi3 == fmi3).expect("a row of the platform table")
}

/// Every platform, the host first.
pub fn targets() -> Vec<Target> {
    let t = |fmi3, build_std, linker| Target { platform: row(fmi3), build_std, linker };
    vec![
        t("x86_64-linux", false, Linker::Zig),
        t("aarch64-linux", true, Linker::Zig),
        t("x86_64-windows", true, Linker::Gcc("x86_64-w64-mingw32-gcc")),
        t("x86_64-darwin", true, Linker::Zig),
        t("aarch64-darwin", true, Linker::Zig),
    ]
}

/// The host's platform built with the host's own linker (`fmu-build` without
/// `--all-platforms`); none where no FMI platform is this machine's.
pub fn host_target() -> Option<Target> {
    Some(Target { platform: platform::host()?, build_std: false, linker: Linker::Host })
}

/// The environment of every build command: the venv's `bin/` (cargo-zigbuild, and the
/// python that has `ziglang`) ahead of the caller's PATH.
pub(crate) fn path_with_venv(root: &Path) -> std::ffi::OsString {
    let venv = root.join(".venv").join("bin");
    let mut paths = vec![venv];
    if let Some(p) = std::env::var_os("PATH") {
        paths.extend(std::env::split_paths(&p));
    }
    std::env::join_paths(paths).expect("PATH entries without separators")
}

fn command(root: &Path, target: &Target, target_dir: &Path) -> Command {
    let mut cmd = Command::new(target.cargo());
    cmd.current_dir(root).env("PATH", path_with_venv(root));
    cmd.env("CARGO_TARGET_DIR", target.cargo_dir(target_dir));
    if target.build_std {
        // Debian's cargo with Debian's rustc, whatever rustup puts first on PATH; the
        // standard library is built from rust-web-src, which needs the nightly flag.
        cmd.env("RUSTC", DEBIAN_RUSTC).env("RUSTC_BOOTSTRAP", "1");
        cmd.env_remove("RUSTUP_TOOLCHAIN").env_remove("CARGO");
    }
    cmd.arg(if target.linker == Linker::Zig { "zigbuild" } else { "build" });
    if let Linker::Gcc(linker) = target.linker {
        let var = format!(
            "CARGO_TARGET_{}_LINKER",
            target.platform.rust_target.to_uppercase().replace('-', "_")
        );
        cmd.env(var, linker);
    }
    if target.platform.os == "macos" {
        // Cargo strips debug information on macOS with `rust-objcopy`, which Debian's
        // rustc-web does not ship; the release profile has no debug information to strip.
        cmd.env("CARGO_PROFILE_RELEASE_STRIP", "false");
    }
    // The FMUs' hot path crosses crates (the export layer, the model glue, the plant and
    // the controller): whole-program optimization inlines across them, ~580 of the ~12 000
    // instructions of a closed-loop step through both FMUs (docs/plant-solver.md). Floating
    // point is unchanged: Rust never reassociates or contracts, so the results keep their bits.
    cmd.env("CARGO_PROFILE_RELEASE_LTO", "fat").env("CARGO_PROFILE_RELEASE_CODEGEN_UNITS", "1");
    cmd.args(["--release", "--target", &target.cargo_target()]);
    if target.build_std {
        cmd.arg("-Zbuild-std=std,panic_abort,panic_unwind");
        // The build folder is shared by every clone (see `build`): with times alone, a
        // worktree whose sources are older than another's last build took that build's
        // crates as fresh. Checksums make a different source a rebuild, whatever its time.
        cmd.arg("-Zchecksum-freshness");
    }
    cmd
}

/// One output to build for a platform: a cdylib of a package, or a binary.
#[derive(Clone, Copy, Debug)]
pub enum Output {
    Library { package: &'static str, stem: &'static str },
    Binary { package: &'static str, name: &'static str },
}

/// The file cargo writes `output` to for `target`.
pub fn file_name(target: &Target, output: &Output) -> String {
    let p = target.platform;
    match output {
        Output::Library { stem, .. } => format!("{}{stem}.{}", p.lib_prefix, p.lib_ext),
        Output::Binary { name, .. } => {
            format!("{name}{}", if p.os == "windows" { ".exe" } else { "" })
        }
    }
}

/// Reads `outputs` for `target` from `dir/<FMI 3.0 tuple>/`, where a release workflow's
/// native build jobs put them (.github/workflows/release.yml).
pub fn prebuilt(dir: &Path, target: &Target, outputs: &[Output]) -> Result<Vec<Vec<u8>>, String> {
    let d = dir.join(target.platform.fmi3);
    outputs
        .iter()
        .map(|o| {
            let p = d.join(file_name(target, o));
            std::fs::read(&p).map_err(|e| format!("{}: {e}", p.display()))
        })
        .collect()
}

/// Builds `outputs` for `target` (or takes them from the cache) and returns the bytes of
/// each, in order.
pub fn build(
    root: &Path,
    target_dir: &Path,
    target: &Target,
    label: &str,
    outputs: &[Output],
) -> Result<Vec<Vec<u8>>, String> {
    let files: Vec<String> = outputs.iter().map(|o| file_name(target, o)).collect();
    let key = crate::cache_key::cache_key(root, target, outputs)?;
    let entry =
        cache_dir().map(|d| d.join(format!("{}-{label}-{}", target.platform.fmi3, &key[..16])));
    if let Some(entry) = &entry {
        if let Ok(found) = files.iter().map(|f| std::fs::read(entry.join(f))).collect() {
            println!(
                "fmu-build: {label} for {} from the cache ({})",
                target.platform.fmi3,
                entry.display()
            );
            return Ok(found);
        }
    }
    // A cross target's miss builds in the cache's own build folder when there is a cache,
    // not in the clone's target folder: the standard library and the dependencies of every
    // cross target are then compiled once per machine and toolchain, and a change of the
    // FMU sources in a fresh clone (CI) recompiles only the workspace's own crates. Clones
    // and worktrees share that folder, so cargo must judge freshness by the sources'
    // contents, not their times (see `command`); the host target keeps the clone's.
    let shared = cache_dir().map(|d| d.join("build")).filter(|_| target.build_std);
    let target_dir = shared.as_deref().unwrap_or(target_dir);
    let start = std::time::Instant::now();
    let libraries: Vec<&str> = outputs
        .iter()
        .filter_map(|o| match o {
            Output::Library { package, .. } => Some(*package),
            Output::Binary { .. } => None,
        })
        .collect();
    if !libraries.is_empty() {
        let mut cmd = command(root, target, target_dir);
        cmd.arg("--lib");
        for p in &libraries {
            cmd.args(["-p", p]);
        }
        run(cmd, target)?;
    }
    for o in outputs {
        if let Output::Binary { package, name } = o {
            let mut cmd = command(root, target, target_dir);
            cmd.args(["-p", package, "--bin", name]);
            run(cmd, target)?;
        }
    }
    let secs = start.elapsed().as_secs_f64();
    println!("fmu-build: built {label} for {} in {secs:.0} s", target.platform.fmi3);
    let out = target.out_dir(target_dir);
    let found: Vec<Vec<u8>> = files
        .iter()
        .map(|f| std::fs::read(out.join(f)).map_err(|e| format!("{}: {e}", out.join(f).display())))
        .collect::<Result<_, _>>()?;
    if let Some(entry) = entry {
        store(&entry, &files, &found);
    }
    Ok(found)
}

/// zig 0.15.2 answers `zig cc -target <arch>-linux-gnu.2.17 --version` with this line on
/// standard error (ziglang/zig#24343, fixed after 0.15.2), then the version; cc-rs runs
/// `--version` to recognise zig when a build script compiles C (`crates/fmi-import`'s
/// logger, in `dist/bin/inchworm`) and passes the line on as a cargo warning. The C is
/// compiled and linked against the glibc floor all the same, so the line is dropped from
/// the build's output rather than read as a failure; a newer zig makes the filter moot.
fn is_zig_version_noise(line: &str) -> bool {
    line.contains(&format!("zig: error: version '.{GLIBC_FLOOR}' in target triple '"))
        && line.ends_with("' is invalid")
}

fn run(mut cmd: Command, target: &Target) -> Result<(), String> {
    let cannot = |cmd: &Command, e: std::io::Error| {
        format!(
            "cannot run {:?} for {} ({e}): run scripts/setup.sh, which installs the toolchains",
            cmd.get_program(),
            target.platform.fmi3
        )
    };
    let status = if target.linker == Linker::Zig {
        use std::io::{BufRead, IsTerminal, Write};
        if std::io::stderr().is_terminal() {
            cmd.arg("--color=always");
        }
        let mut child =
            cmd.stderr(std::process::Stdio::piped()).spawn().map_err(|e| cannot(&cmd, e))?;
        let mut err = std::io::stderr().lock();
        for line in std::io::BufReader::new(child.stderr.take().expect("piped")).lines() {
            let Ok(line) = line else { break };
            if !is_zig_version_noise(&line) {
                let _ = writeln!(err, "{line}");
            }
        }
        child.wait().map_err(|e| cannot(&cmd, e))?
    } else {
        cmd.status().map_err(|e| cannot(&cmd, e))?
    };
    if status.success() {
        Ok(())
    } else {
        Err(format!("the build for {} failed ({status})", target.platform.fmi3))
    }
}

/// `$INCHWORM_BINARY_CACHE`, else `$XDG_CACHE_HOME/inchworm/binaries`, else
/// `~/.cache/inchworm/binaries`; none (always build) if none of them is set.
pub fn cache_dir() -> Option<PathBuf> {
    if let Some(d) = std::env::var_os("INCHWORM_BINARY_CACHE") {
        return Some(PathBuf::from(d));
    }
    let base = std::env::var_os("XDG_CACHE_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))?;
    Some(base.join("inchworm").join("binaries"))
}

/// How many entries of one platform the cache keeps (several worktrees or branches share
/// one cache); the oldest beyond that are removed when a new one is stored.
const KEPT_PER_PLATFORM: usize = 4;

fn store(entry: &Path, files: &[String], data: &[Vec<u8>]) {
    let Some(parent) = entry.parent() else { return };
    let tmp = entry.with_extension(format!("partial{}", std::process::id()));
    let written = std::fs::create_dir_all(&tmp).is_ok()
        && files.iter().zip(data).all(|(f, d)| std::fs::write(tmp.join(f), d).is_ok())
        && std::fs::rename(&tmp, entry).is_ok();
    if !written {
        let _ = std::fs::remove_dir_all(&tmp);
        eprintln!("fmu-build: could not store {} in the cache (built anyway)", entry.display());
        return;
    }
    let name = entry.file_name().and_then(|n| n.to_str()).unwrap_or_default();
    let prefix = &name[..name.len().saturating_sub(16)];
    let mut same: Vec<(std::time::SystemTime, PathBuf)> = std::fs::read_dir(parent)
        .into_iter()
        .flatten()
        .filter_map(Result::ok)
        .filter(|e| {
            let n = e.file_name();
            let n = n.to_string_lossy();
            n.starts_with(prefix) && n.len() == name.len()
        })
        .filter_map(|e| Some((e.metadata().ok()?.modified().ok()?, e.path())))
        .collect();
    same.sort();
    while same.len() > KEPT_PER_PLATFORM {
        let _ = std::fs::remove_dir_all(same.remove(0).1);
    }
}

/// A Mach-O universal ("fat") file of thin 64-bit Mach-O `slices`: FMI 2.0 has one macOS
/// folder, `darwin64`, for both processors. Each slice is aligned to 2^14 bytes (the arm64
/// page size), as Apple's `lipo` does.
pub fn universal_macho(slices: &[&[u8]]) -> Result<Vec<u8>, String> {
    const ALIGN: u32 = 14;
    let mut header = Vec::new();
    header.extend(0xcafe_babe_u32.to_be_bytes());
    header.extend((slices.len() as u32).to_be_bytes());
    let mut offset = 1usize << ALIGN;
    let mut body = Vec::new();
    for s in slices {
        if s.len() < 12 || s[..4] != 0xfeed_facf_u32.to_le_bytes() {
            return Err("a slice is not a little-endian 64-bit Mach-O file".into());
        }
        let (cpu, sub) = (&s[4..8], &s[8..12]);
        header.extend(u32::from_le_bytes(cpu.try_into().unwrap()).to_be_bytes());
        header.extend(u32::from_le_bytes(sub.try_into().unwrap()).to_be_bytes());
        header.extend((offset as u32).to_be_bytes());
        header.extend((s.len() as u32).to_be_bytes());
        header.extend(ALIGN.to_be_bytes());
        body.push((offset, *s));
        offset += s.len().next_multiple_of(1 << ALIGN);
    }
    let mut out = header;
    for (at, s) in body {
        out.resize(at, 0);
        out.extend_from_slice(s);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_platform_has_a_row_and_linux_is_linked_against_the_floor() {
        let t = targets();
        assert_eq!(t[0].platform, platform::host().unwrap(), "the host first");
        let tuples: Vec<_> = t.iter().map(|t| t.platform.fmi3).collect();
        assert_eq!(
            tuples,
            ["x86_64-linux", "aarch64-linux", "x86_64-windows", "x86_64-darwin", "aarch64-darwin"]
        );
        assert_eq!(t[0].cargo_target(), "x86_64-unknown-linux-gnu.2.17");
        assert_eq!(t[1].cargo_target(), "aarch64-unknown-linux-gnu.2.17");
        assert_eq!(t[2].cargo_target(), "x86_64-pc-windows-gnu");
        assert_eq!(t[4].cargo_target(), "aarch64-apple-darwin");
        let dir = Path::new("/t");
        assert_eq!(t[2].out_dir(dir), Path::new("/t/rustc-web/x86_64-pc-windows-gnu/release"));
        assert_eq!(t[0].out_dir(dir), Path::new("/t/x86_64-unknown-linux-gnu/release"));
        let lib = Output::Library { package: "x", stem: "p" };
        assert_eq!(file_name(&t[2], &lib), "p.dll");
        assert_eq!(file_name(&t[4], &lib), "libp.dylib");
        assert_eq!(file_name(&t[2], &Output::Binary { package: "x", name: "b" }), "b.exe");
        let host = host_target().unwrap();
        assert_eq!((host.platform, host.build_std), (t[0].platform, false));
        assert_eq!(host.cargo_target(), "x86_64-unknown-linux-gnu", "no glibc suffix, no zig");
        assert_eq!(host.out_dir(dir), t[0].out_dir(dir));
    }

    #[test]
    fn only_zigs_version_line_for_the_floor_is_dropped() {
        let noise = "warning: inchworm-fmi-import@0.1.0: zig: error: version '.2.17' in target triple 'x86_64-unknown-linux-gnu.2.17' is invalid";
        assert!(is_zig_version_noise(noise));
        assert!(!is_zig_version_noise("error: could not compile `inchworm-plant`"));
        assert!(!is_zig_version_noise(&noise.replace("2.17", "2.99")));
    }

    #[test]
    fn a_universal_file_holds_each_slice_at_its_aligned_offset() {
        let thin = |cpu: u32, len: usize| {
            let mut v = 0xfeed_facf_u32.to_le_bytes().to_vec();
            v.extend(cpu.to_le_bytes());
            v.extend(3u32.to_le_bytes());
            v.resize(len, 0xab);
            v
        };
        let (x86, arm) = (thin(0x0100_0007, 20_000), thin(0x0100_000c, 100));
        let fat = universal_macho(&[&x86, &arm]).unwrap();
        let be = |at: usize| u32::from_be_bytes(fat[at..at + 4].try_into().unwrap());
        assert_eq!((be(0), be(4)), (0xcafe_babe, 2));
        assert_eq!((be(8), be(12), be(16), be(20), be(24)), (0x0100_0007, 3, 16384, 20_000, 14));
        assert_eq!((be(28), be(36), be(40)), (0x0100_000c, 49152, 100));
        assert_eq!(&fat[16384..36384], &x86[..]);
        assert_eq!(&fat[49152..], &arm[..]);
        assert!(universal_macho(&[b"not a mach-o file"]).is_err());
    }
}
