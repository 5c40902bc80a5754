//! `cargo run --release -p fmu-build`: builds each FMU's shared library, generates its
//! `modelDescription.xml` and documentation from the variable table, writes the committed
//! copies under `modelDescription/` and packages `dist/<Model>.fmu` (FMI 2.0),
//! `dist/fmi3/<Model>.fmu` (FMI 3.0) and the SSP systems over them.
//!
//! Which platforms' binaries the FMUs carry (docs/platforms.md):
//! - no option: the host's only, built with the host's toolchain and linker: what
//!   `scripts/run.sh` needs, with nothing but the Rust toolchain installed;
//! - `--all-platforms`: x86-64 and aarch64 Linux (glibc 2.17), Windows and both Macs, and
//!   `dist/bin/inchworm` for the host against glibc 2.17: what `scripts/test.sh` tests and
//!   a release ships, with the toolchains `scripts/setup.sh` installs;
//! - `--platforms LIST`: some of those five, built as `--all-platforms` builds them;
//! - `--prebuilt DIR` (with `--all-platforms` or `--platforms`): packages libraries built
//!   elsewhere (the release workflow's native jobs) instead of building them.
//!
//! `cargo run --release -p fmu-build -- --check` builds nothing and writes nothing: it
//! generates every committed file again (model descriptions of both standards, the system
//! descriptions and their parameter sets) and fails, naming each file, where the committed
//! copy differs. `scripts/test.sh` runs it before anything regenerates the files, so an
//! edited description or a table changed without its description fails CI. It reads only
//! regular files, never through a symbolic link, each up to 1 MiB (`check.rs`);
//! `--check --root DIR` checks the repository at `DIR` instead of this workspace.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use inchworm_cosim::output::{self, Pending};
use inchworm_fmi_abi::platform::Platform;
use inchworm_fmi_export::{fmi3, model_description, Model};

mod cache_key;
mod check;
mod evidence;
mod modelica;
mod platforms;
mod python;
mod segmented;
mod ssp;

use platforms::{Output, Target};

/// The FMI version of one packaged FMU: the one place where the two standards' files and
/// folders differ.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Standard {
    Fmi2,
    Fmi3,
}

impl Standard {
    /// The folder below `dist/` and below `modelDescription/`.
    fn subdir(self) -> &'static str {
        match self {
            Standard::Fmi2 => "",
            Standard::Fmi3 => "fmi3",
        }
    }

    /// The `binaries/` folder of a platform (FMI 2.0 names fewer platforms than FMI 3.0).
    fn binaries_folder(self, p: &Platform) -> Option<&'static str> {
        match self {
            Standard::Fmi2 => p.fmi2,
            Standard::Fmi3 => Some(p.fmi3),
        }
    }
}

/// One FMU to package: its model, the standard, the cargo package of its cdylib and the
/// library stem.
struct Fmu {
    standard: Standard,
    identifier: &'static str,
    package: &'static str,
    lib_stem: &'static str,
    model_description: fn() -> String,
    documentation: fn() -> String,
    /// The table's declarations hold together (names, value references, units).
    declarations: fn() -> Result<(), String>,
}

fn fmu<M: Model>(standard: Standard, package: &'static str, lib_stem: &'static str) -> Fmu {
    Fmu {
        standard,
        identifier: M::info().model_identifier,
        package,
        lib_stem,
        model_description: match standard {
            Standard::Fmi2 => model_description::model_description::<M>,
            Standard::Fmi3 => fmi3::model_description::model_description::<M>,
        },
        documentation: model_description::documentation::<M>,
        declarations: model_description::check_declarations::<M>,
    }
}

fn fmus() -> Vec<Fmu> {
    use inchworm_fmu_models::{
        ControllerFmu, DelayLineFmu, MountFmu, PlantFmu, PlantFullFmu, ReferenceFmu,
    };
    use Standard::{Fmi2, Fmi3};
    vec![
        fmu::<PlantFmu>(Fmi2, "inchworm-plant-fmu", "inchworm_plant_fmu"),
        fmu::<PlantFullFmu>(Fmi2, "inchworm-plant-full-fmu", "inchworm_plant_full_fmu"),
        fmu::<ControllerFmu>(Fmi2, "inchworm-controller-fmu", "inchworm_controller_fmu"),
        fmu::<ReferenceFmu>(Fmi2, "inchworm-reference-fmu", "inchworm_reference_fmu"),
        fmu::<MountFmu>(Fmi2, "inchworm-mount-fmu", "inchworm_mount_fmu"),
        fmu::<DelayLineFmu>(Fmi2, "inchworm-delay-line-fmu", "inchworm_delay_line_fmu"),
        fmu::<PlantFmu>(Fmi3, "inchworm-plant-fmu3", "inchworm_plant_fmu3"),
        fmu::<PlantFullFmu>(Fmi3, "inchworm-plant-full-fmu3", "inchworm_plant_full_fmu3"),
        fmu::<ControllerFmu>(Fmi3, "inchworm-controller-fmu3", "inchworm_controller_fmu3"),
    ]
}

/// One SSP to package: where it goes, its specification and which of its FMUs are taken
/// from `dist/fmi3/` (the others are FMI 2.0, from `dist/`).
struct System {
    standard: Standard,
    spec: ssp::SystemSpec,
    /// The archive's name, if not the specification's.
    name: Option<&'static str>,
    fmi3: &'static [&'static str],
}

fn systems() -> Vec<System> {
    let fmi2 = |spec| System { standard: Standard::Fmi2, spec, name: None, fmi3: &[] };
    vec![
        fmi2(ssp::closed_system()),
        fmi2(ssp::open_system()),
        fmi2(ssp::mirror_mount()),
        fmi2(ssp::delay_line()),
        // Both FMUs FMI 3.0: the open loop (the reference from the system input), the same
        // system as `dist/InchwormSystemOpen.ssp`, under the same name in `dist/fmi3/`.
        System {
            standard: Standard::Fmi3,
            spec: ssp::open_system(),
            name: None,
            fmi3: &["InchwormPlant", "InchwormController"],
        },
        // The closed loop with the FMI 3.0 plant and the FMI 2.0 controller and reference,
        // the same system as `dist/InchwormSystem.ssp`.
        System {
            standard: Standard::Fmi3,
            spec: ssp::closed_system(),
            name: Some("InchwormSystemMixed"),
            fmi3: &["InchwormPlant"],
        },
    ]
}

/// Every file that is generated and committed, as (path relative to the workspace root,
/// text): the model descriptions of both standards, and for each FMI 2.0 system its
/// `SystemStructure.ssd` and parameter sets (the FMI 3.0 systems reuse those
/// specifications unchanged, so their texts are the same), the Python packages'
/// variable names, and the Modelica package's declarations and example.
fn committed_files(fmus: &[Fmu], systems: &[System]) -> Vec<(PathBuf, String)> {
    let mut files = Vec::new();
    for f in fmus {
        let path = Path::new("modelDescription")
            .join(f.standard.subdir())
            .join(format!("{}.xml", f.identifier));
        files.push((path, (f.model_description)()));
    }
    for s in systems.iter().filter(|s| s.standard == Standard::Fmi2) {
        let dir = Path::new("modelDescription").join("ssp").join(s.spec.name);
        files.push((dir.join("SystemStructure.ssd"), s.spec.system_description()));
        for (path, text) in s.spec.parameter_files() {
            files.push((dir.join(path), text));
        }
    }
    let built =
        |standard| fmus.iter().filter(move |f| f.standard == standard).map(|f| f.identifier);
    let built = [built(Standard::Fmi2).collect(), built(Standard::Fmi3).collect()];
    files.push((PathBuf::from(python::MODULE), python::module(&built)));
    files.push((PathBuf::from(modelica::INTERFACE), modelica::interface()));
    files.push((PathBuf::from(modelica::EXAMPLES), modelica::examples()));
    files
}

/// Writes the generated files under `root`, none through a committed link (which could
/// point outside the repository).
fn write_committed(root: &Path, files: &[(PathBuf, String)]) -> Result<(), String> {
    for (path, text) in files {
        check::no_links(root, path)?;
        let path = root.join(path);
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
        std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    Ok(())
}

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("fmu-build lives in the workspace")
        .to_path_buf()
}

fn target_dir(root: &Path) -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .map(|p| if p.is_absolute() { p } else { root.join(p) })
        .unwrap_or_else(|| root.join("target"))
}

/// The libraries of every FMU for one platform, in the order of `fmus()`.
struct Built {
    target: Target,
    libraries: Vec<Vec<u8>>,
}

/// Builds (or takes from the cache) every FMU's library for each of `targets`, and with
/// `binary` the `inchworm` binary for the host (if one of `targets`), which goes to
/// `dist/bin/inchworm`.
///
/// With `prebuilt`, builds nothing: every platform's libraries are read from
/// `prebuilt/<FMI 3.0 tuple>/` (the release workflow's native jobs), and no binary is written.
fn build(
    root: &Path,
    fmus: &[Fmu],
    targets: &[Target],
    prebuilt: Option<&Path>,
    binary: bool,
) -> Result<Vec<Built>, String> {
    let dir = target_dir(root);
    let libs: Vec<Output> =
        fmus.iter().map(|f| Output::Library { package: f.package, stem: f.lib_stem }).collect();
    let mut built = Vec::new();
    for t in targets {
        let libraries = match prebuilt {
            Some(p) => platforms::prebuilt(p, t, &libs)?,
            None => platforms::build(root, &dir, t, "fmus", &libs)?,
        };
        built.push(Built { target: *t, libraries });
    }
    let host = targets.iter().find(|t| Some(t.platform) == inchworm_fmi_abi::platform::host());
    if let (Some(host), None, true) = (host, prebuilt, binary) {
        let bin = platforms::build(
            root,
            &dir,
            host,
            "inchworm",
            &[Output::Binary { package: "inchworm", name: "inchworm" }],
        )?;
        let out = root.join("dist").join("bin");
        std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
        let path = out.join("inchworm");
        // Through a new file renamed over the old, so a running `inchworm` is not touched.
        let err = |e: std::io::Error| format!("{}: {e}", path.display());
        let mut pending = Pending::new(&path).map_err(err)?;
        pending.write_all(&bin[0]).map_err(err)?;
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::Permissions::from_mode(0o755);
            std::fs::set_permissions(pending.path(), mode).map_err(err)?;
        }
        pending.commit().map_err(err)?;
        println!("fmu-build: wrote {}", path.display());
    }
    Ok(built)
}

fn dist_dir(root: &Path, standard: Standard) -> PathBuf {
    root.join("dist").join(standard.subdir())
}

/// `binaries/<folder>/<identifier>.<ext>` of every platform the standard names, with the
/// library of FMU number `index`; where two platforms share a folder (FMI 2.0's
/// `darwin64`), one universal Mach-O file of both.
fn binary_entries(
    f: &Fmu,
    index: usize,
    built: &[Built],
) -> Result<Vec<(String, Vec<u8>)>, String> {
    let mut folders: Vec<(&str, &Platform, Vec<&[u8]>)> = Vec::new();
    for b in built {
        let Some(folder) = f.standard.binaries_folder(b.target.platform) else { continue };
        match folders.iter_mut().find(|(name, ..)| *name == folder) {
            Some((_, _, slices)) => slices.push(&b.libraries[index]),
            None => folders.push((folder, b.target.platform, vec![&b.libraries[index]])),
        }
    }
    folders
        .into_iter()
        .map(|(folder, p, slices)| {
            let bytes = if slices.len() > 1 {
                platforms::universal_macho(&slices)?
            } else {
                slices[0].to_vec()
            };
            Ok((format!("binaries/{folder}/{}.{}", f.identifier, p.lib_ext), bytes))
        })
        .collect()
}

/// The FMI version's folder name in the compatibility tree and the platform it is filed
/// under there (the one CI runs it on).
fn cross_check_names(standard: Standard) -> (&'static str, &'static str) {
    match standard {
        Standard::Fmi2 => ("2.0", "linux64"),
        Standard::Fmi3 => ("3.0", "x86_64-linux"),
    }
}

/// Writes `dist/<subdir>/<Model>.fmu` (model description, every platform's binary, the
/// documentation with figures, the reference results) and its compatibility-tree folder.
fn package(root: &Path, f: &Fmu, index: usize, built: &[Built]) -> Result<PathBuf, String> {
    let xml = (f.model_description)();
    let dist = dist_dir(root, f.standard);
    std::fs::create_dir_all(&dist).map_err(|e| format!("{}: {e}", dist.display()))?;
    let out = dist.join(format!("{}.fmu", f.identifier));
    let refs = evidence::reference_files(root, f.identifier)?;
    let mut entries: Vec<(String, Vec<u8>)> =
        vec![("modelDescription.xml".into(), xml.into_bytes())];
    entries.extend(binary_entries(f, index, built)?);
    entries.extend(evidence::documentation(root, f.identifier, &(f.documentation)(), &refs)?);
    let ls = evidence::LS_REF;
    entries.push((format!("{ls}/fmi-ls-manifest.xml"), evidence::manifest(&refs).into_bytes()));
    for r in &refs {
        entries.push((format!("{ls}/{}", r.name), r.data.clone()));
    }
    let entries: Vec<(String, &[u8])> =
        entries.iter().map(|(n, d)| (n.clone(), d.as_slice())).collect();
    write_zip(&out, &entries)?;
    let (version, platform) = cross_check_names(f.standard);
    evidence::cross_check_folder(&root.join("dist"), version, platform, f.identifier, &out, &refs)?;
    Ok(out)
}

/// Writes `zip` entries to `out` through a uniquely named temporary beside it, renamed at
/// the end (`inchworm_cosim::output`), so a master never reads a half-written archive and
/// a failed write leaves `out` as it was and no temporary behind.
fn write_zip(out: &Path, entries: &[(String, &[u8])]) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", out.display());
    output::check(&[("output", out)], &[]).map_err(|e| e.to_string())?;
    let mut pending = Pending::new(out).map_err(|e| err(&e))?;
    let mut zip = zip::ZipWriter::new(pending.file());
    let opts = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated);
    for (name, data) in entries {
        zip.start_file(name.as_str(), opts).map_err(|e| err(&e))?;
        zip.write_all(data).map_err(|e| err(&e))?;
    }
    zip.finish().map_err(|e| err(&e))?;
    pending.commit().map_err(|e| err(&e))
}

/// The `.ssp` of one system: the SSD, each FMU once, every parameter set.
fn package_system(root: &Path, s: &System) -> Result<PathBuf, String> {
    let out = system_path(root, s);
    write_system(root, &s.spec, s.fmi3, &out)?;
    Ok(out)
}

/// Writes `spec` as the `.ssp` `out`, its FMUs taken from `dist/` (`dist/fmi3/` those of
/// `fmi3`).
fn write_system(
    root: &Path,
    spec: &ssp::SystemSpec,
    fmi3: &[&str],
    out: &Path,
) -> Result<(), String> {
    let mut fmus = Vec::new();
    for id in spec.fmus() {
        let standard = if fmi3.contains(&id) { Standard::Fmi3 } else { Standard::Fmi2 };
        let p = dist_dir(root, standard).join(format!("{id}.fmu"));
        fmus.push((id, std::fs::read(&p).map_err(|e| format!("{}: {e}", p.display()))?));
    }
    let ssd = spec.system_description();
    let sets = spec.parameter_files();
    let mut entries: Vec<(String, &[u8])> = vec![("SystemStructure.ssd".into(), ssd.as_bytes())];
    for (id, bytes) in &fmus {
        entries.push((format!("resources/{id}.fmu"), bytes));
    }
    for (path, text) in &sets {
        entries.push((path.clone(), text.as_bytes()));
    }
    write_zip(out, &entries)
}

/// Where the `.ssp` of `s` goes: `dist/` or `dist/fmi3/`, under its archive's name.
fn system_path(root: &Path, s: &System) -> PathBuf {
    let name = s.name.unwrap_or(s.spec.name);
    dist_dir(root, s.standard).join(format!("{name}.ssp"))
}

/// Removes every `.ssp` in `dist/` and `dist/fmi3/` that is not one of `written`, so no
/// renamed or removed system stays beside the ones this build wrote (the folders hold
/// only fmu-build's output). Returns the removed files.
fn remove_stale_systems(root: &Path, written: &[PathBuf]) -> Result<Vec<PathBuf>, String> {
    let mut removed = Vec::new();
    for standard in [Standard::Fmi2, Standard::Fmi3] {
        let dir = dist_dir(root, standard);
        let entries = match std::fs::read_dir(&dir) {
            Ok(e) => e,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
            Err(e) => return Err(format!("{}: {e}", dir.display())),
        };
        for entry in entries {
            let path = entry.map_err(|e| format!("{}: {e}", dir.display()))?.path();
            let is_ssp = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("ssp"));
            if is_ssp && path.is_file() && !written.contains(&path) {
                std::fs::remove_file(&path).map_err(|e| format!("{}: {e}", path.display()))?;
                removed.push(path);
            }
        }
    }
    removed.sort();
    Ok(removed)
}

/// The platforms the FMUs carry binaries for.
#[derive(Debug, PartialEq)]
enum Selection {
    /// The host's, with the host's linker (`platforms::host_target`).
    Host,
    /// Every platform of `platforms::targets`.
    All,
    /// These FMI 3.0 tuples of `platforms::targets`.
    Listed(Vec<String>),
}

/// What the command line asks for.
#[derive(Debug, PartialEq)]
struct Args {
    check: bool,
    /// The repository whose committed files `--check` compares (default: this workspace).
    root: Option<PathBuf>,
    /// Package the libraries found here instead of building them.
    prebuilt: Option<PathBuf>,
    platforms: Selection,
}

fn parse_args(args: &[String]) -> Result<Args, String> {
    let mut out = Args { check: false, root: None, prebuilt: None, platforms: Selection::Host };
    let chosen = |out: &mut Args, s: Selection| {
        if out.platforms != Selection::Host {
            return Err("give one of --all-platforms and --platforms".to_string());
        }
        out.platforms = s;
        Ok(())
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--check" => out.check = true,
            "--root" => out.root = Some(PathBuf::from(it.next().ok_or("--root needs a folder")?)),
            "--prebuilt" => {
                out.prebuilt = Some(PathBuf::from(it.next().ok_or("--prebuilt needs a folder")?))
            }
            "--platforms" => {
                let list = it
                    .next()
                    .ok_or("--platforms needs a list, e.g. x86_64-linux,x86_64-windows")?;
                let known: Vec<_> = platforms::targets().iter().map(|t| t.platform.fmi3).collect();
                let list: Vec<String> = list.split(',').map(str::to_string).collect();
                if let Some(bad) = list.iter().find(|p| !known.contains(&p.as_str())) {
                    return Err(format!("unknown platform `{bad}` (known: {})", known.join(", ")));
                }
                chosen(&mut out, Selection::Listed(list))?;
            }
            "--all-platforms" => chosen(&mut out, Selection::All)?,
            other => {
                return Err(format!(
                "unknown argument `{other}` (options: --check [--root DIR], --all-platforms, --platforms LIST, --prebuilt DIR)"
            ))
            }
        }
    }
    if out.prebuilt.is_some() && out.platforms == Selection::Host {
        return Err("--prebuilt packages a release's libraries: give --all-platforms or --platforms LIST with it".into());
    }
    if out.root.is_some() && !out.check {
        return Err("--root is for --check only: the build writes into this workspace".into());
    }
    Ok(out)
}

fn main() -> ExitCode {
    let root = workspace_root();
    let argv: Vec<String> = std::env::args().skip(1).collect();
    if argv.first().is_some_and(|a| a == segmented::COMMAND) {
        return segmented::main(&argv[1..], |spec, out| write_system(&root, spec, &[], out));
    }
    let (fmus, systems) = (fmus(), systems());
    if let Some(e) = fmus.iter().find_map(|f| (f.declarations)().err()) {
        eprintln!("fmu-build: {e}");
        return ExitCode::FAILURE;
    }
    let files = committed_files(&fmus, &systems);
    let args = match parse_args(&argv) {
        Ok(a) => a,
        Err(e) => {
            eprintln!("fmu-build: {e}");
            return ExitCode::from(2);
        }
    };
    if args.check {
        let checked = args.root.as_deref().unwrap_or(&root);
        let found = check::drift(checked, &files);
        if found.is_empty() {
            println!("fmu-build --check: {} generated files match the committed ones", files.len());
            return ExitCode::SUCCESS;
        }
        for f in &found {
            eprintln!("fmu-build --check: {f}");
        }
        eprintln!(
            "fmu-build --check: {} problems with the committed generated files in {}; `cargo run --release -p fmu-build` writes them from the variable tables (remove links first), then commit them",
            found.len(),
            checked.join(check::GENERATED_DIR).display()
        );
        return ExitCode::FAILURE;
    }
    let targets: Vec<Target> = match &args.platforms {
        Selection::Host => match platforms::host_target() {
            Some(t) => vec![t],
            None => {
                eprintln!("fmu-build: this machine is none of the FMUs' platforms; build them with --all-platforms (docs/platforms.md)");
                return ExitCode::FAILURE;
            }
        },
        Selection::All => platforms::targets(),
        Selection::Listed(l) => platforms::targets()
            .into_iter()
            .filter(|t| l.iter().any(|p| p == t.platform.fmi3))
            .collect(),
    };
    let host_only = args.platforms == Selection::Host;
    let run = || -> Result<(), String> {
        let built = build(&root, &fmus, &targets, args.prebuilt.as_deref(), !host_only)?;
        write_committed(&root, &files)?;
        // The compatibility tree is written whole every time, so no removed model stays.
        let _ = std::fs::remove_dir_all(root.join("dist").join("cross-check"));
        for (i, f) in fmus.iter().enumerate() {
            println!("fmu-build: wrote {}", package(&root, f, i, &built)?.display());
        }
        let mut written = Vec::new();
        for s in &systems {
            written.push(package_system(&root, s)?);
            println!("fmu-build: wrote {}", written[written.len() - 1].display());
        }
        for path in remove_stale_systems(&root, &written)? {
            println!("fmu-build: removed {} (no longer built)", path.display());
        }
        if host_only {
            println!(
                "fmu-build: the FMUs carry the {} binaries only, linked against this machine's C library; `fmu-build --all-platforms` builds all five platforms (docs/platforms.md)",
                targets[0].platform.fmi3
            );
        }
        Ok(())
    };
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fmu-build: {e}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests;
