//! `cargo run --release -p fmu-build`: builds each FMU's shared library, generates its
//! `modelDescription.xml` and documentation from the variable table, writes the committed
//! copy in `modelDescription/` and packages `dist/<Model>.fmu`.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

use inchworm_fmi_export::{model_description, Model};

mod fmi3;
mod ssp;

/// One FMU to package: its model, the cargo package of its cdylib and the library stem.
struct Fmu {
    identifier: &'static str,
    package: &'static str,
    lib_stem: &'static str,
    model_description: fn() -> String,
    documentation: fn() -> String,
}

fn fmu<M: Model>(package: &'static str, lib_stem: &'static str) -> Fmu {
    Fmu {
        identifier: M::info().model_identifier,
        package,
        lib_stem,
        model_description: model_description::model_description::<M>,
        documentation: model_description::documentation::<M>,
    }
}

/// The host's FMI 2.0 platform folder and shared-library naming, from the one platform table.
fn platform() -> Result<(&'static str, &'static str, &'static str), String> {
    let (os, arch) = (std::env::consts::OS, std::env::consts::ARCH);
    inchworm_fmi_abi::platform::of(os, arch)
        .and_then(|p| Some((p.fmi2?, p.lib_prefix, p.lib_ext)))
        .ok_or_else(|| format!("no FMI 2.0 platform folder for {os}/{arch}"))
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

fn build(root: &Path, fmus: &[Fmu]) -> Result<(), String> {
    build_libraries(root, fmus.iter().map(|f| f.package), "FMU libraries")
}

/// `cargo build --release --lib` of the named packages, in one cargo call.
fn build_libraries<'a>(
    root: &Path,
    packages: impl Iterator<Item = &'a str>,
    what: &str,
) -> Result<(), String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(root).args(["build", "--release", "--lib"]);
    for p in packages {
        cmd.args(["-p", p]);
    }
    let status = cmd.status().map_err(|e| format!("cannot run cargo: {e}"))?;
    if !status.success() {
        return Err(format!("cargo build of the {what} failed ({status})"));
    }
    Ok(())
}

fn package(root: &Path, f: &Fmu) -> Result<PathBuf, String> {
    let (platform, prefix, ext) = platform()?;
    let lib = target_dir(root).join("release").join(format!("{prefix}{}.{ext}", f.lib_stem));
    let binary = std::fs::read(&lib).map_err(|e| format!("{}: {e}", lib.display()))?;
    let xml = (f.model_description)();
    let md_dir = root.join("modelDescription");
    std::fs::create_dir_all(&md_dir).map_err(|e| format!("{}: {e}", md_dir.display()))?;
    let md_path = md_dir.join(format!("{}.xml", f.identifier));
    std::fs::write(&md_path, &xml).map_err(|e| format!("{}: {e}", md_path.display()))?;

    let dist = root.join("dist");
    std::fs::create_dir_all(&dist).map_err(|e| format!("{}: {e}", dist.display()))?;
    let out = dist.join(format!("{}.fmu", f.identifier));
    let docs = (f.documentation)();
    let entries: [(String, &[u8]); 3] = [
        ("modelDescription.xml".into(), xml.as_bytes()),
        (format!("binaries/{platform}/{}.{ext}", f.identifier), &binary),
        ("documentation/index.html".into(), docs.as_bytes()),
    ];
    write_zip(&out, &entries)?;
    Ok(out)
}

/// Writes `zip` entries to `out` through a temporary file renamed at the end, so a master
/// never reads a half-written archive.
fn write_zip(out: &Path, entries: &[(String, &[u8])]) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", out.display());
    let tmp = out.with_extension("partial");
    let file = std::fs::File::create(&tmp).map_err(|e| err(&e))?;
    let mut zip = zip::ZipWriter::new(file);
    let opts = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated);
    for (name, data) in entries {
        zip.start_file(name.as_str(), opts).map_err(|e| err(&e))?;
        zip.write_all(data).map_err(|e| err(&e))?;
    }
    zip.finish().map_err(|e| err(&e))?;
    std::fs::rename(&tmp, out).map_err(|e| err(&e))
}

/// `dist/<system>.ssp` from the packaged FMUs: the SSD, each FMU once, every parameter set.
fn package_system(root: &Path, spec: &ssp::SystemSpec) -> Result<PathBuf, String> {
    let dist = root.join("dist");
    let out = dist.join(format!("{}.ssp", spec.name));
    write_system(spec, &|id| dist.join(format!("{id}.fmu")), &out)?;
    Ok(out)
}

/// Writes the `.ssp` of `spec` to `out`, each FMU read from `fmu_path(identifier)`.
fn write_system(
    spec: &ssp::SystemSpec,
    fmu_path: &dyn Fn(&str) -> PathBuf,
    out: &Path,
) -> Result<(), String> {
    let mut fmus = Vec::new();
    for id in spec.fmus() {
        let p = fmu_path(id);
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

fn main() -> ExitCode {
    let root = workspace_root();
    let fmus = [
        fmu::<inchworm_fmu_models::PlantFmu>("inchworm-plant-fmu", "inchworm_plant_fmu"),
        fmu::<inchworm_fmu_models::ControllerFmu>(
            "inchworm-controller-fmu",
            "inchworm_controller_fmu",
        ),
        fmu::<inchworm_fmu_models::ReferenceFmu>(
            "inchworm-reference-fmu",
            "inchworm_reference_fmu",
        ),
        fmu::<inchworm_fmu_models::MountFmu>("inchworm-mount-fmu", "inchworm_mount_fmu"),
    ];
    let run = || -> Result<(), String> {
        build(&root, &fmus)?;
        for f in &fmus {
            let out = package(&root, f)?;
            println!("fmu-build: wrote {}", out.display());
        }
        for spec in [ssp::closed_system(), ssp::open_system(), ssp::mirror_mount()] {
            let out = package_system(&root, &spec)?;
            println!("fmu-build: wrote {}", out.display());
        }
        for out in fmi3::package_all(&root)? {
            println!("fmu-build: wrote {}", out.display());
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
