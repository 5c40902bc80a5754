//! The FMI 3.0 FMUs: `dist/fmi3/<Model>.fmu` from the `*-fmu3` cdylibs, their
//! `modelDescription.xml` committed in `modelDescription/fmi3/`, and two SSPs over them:
//! `dist/fmi3/InchwormSystem.ssp` (both FMUs FMI 3.0) and
//! `dist/fmi3/InchwormSystemMixed.ssp` (the FMI 3.0 plant with the FMI 2.0 controller).
//! The system description is the FMI 2.0 one: SSP names components and variables, not the
//! FMI version.

use std::path::{Path, PathBuf};

use inchworm_fmi_export::fmi3::model_description::model_description;
use inchworm_fmi_export::{model_description as md2, Model};

struct Fmu3 {
    identifier: &'static str,
    package: &'static str,
    lib_stem: &'static str,
    model_description: fn() -> String,
    documentation: fn() -> String,
}

fn fmu3<M: Model>(package: &'static str, lib_stem: &'static str) -> Fmu3 {
    Fmu3 {
        identifier: M::info().model_identifier,
        package,
        lib_stem,
        model_description: model_description::<M>,
        documentation: md2::documentation::<M>,
    }
}

fn fmus() -> [Fmu3; 2] {
    [
        fmu3::<inchworm_fmu_models::PlantFmu>("inchworm-plant-fmu3", "inchworm_plant_fmu3"),
        fmu3::<inchworm_fmu_models::ControllerFmu>(
            "inchworm-controller-fmu3",
            "inchworm_controller_fmu3",
        ),
    ]
}

/// The host's FMI 3.0 platform tuple and shared-library naming, from the one platform table.
fn platform() -> Result<(&'static str, &'static str, &'static str), String> {
    let (os, arch) = (std::env::consts::OS, std::env::consts::ARCH);
    inchworm_fmi_abi::platform::of(os, arch)
        .map(|p| (p.fmi3, p.lib_prefix, p.lib_ext))
        .ok_or_else(|| format!("no FMI 3.0 platform tuple for {os}/{arch}"))
}

fn build(root: &Path, fmus: &[Fmu3]) -> Result<(), String> {
    super::build_libraries(root, fmus.iter().map(|f| f.package), "FMI 3.0 FMU libraries")
}

fn package(root: &Path, f: &Fmu3) -> Result<PathBuf, String> {
    let (platform, prefix, ext) = platform()?;
    let lib = super::target_dir(root).join("release").join(format!("{prefix}{}.{ext}", f.lib_stem));
    let binary = std::fs::read(&lib).map_err(|e| format!("{}: {e}", lib.display()))?;
    let xml = (f.model_description)();
    let md_dir = root.join("modelDescription").join("fmi3");
    std::fs::create_dir_all(&md_dir).map_err(|e| format!("{}: {e}", md_dir.display()))?;
    let md_path = md_dir.join(format!("{}.xml", f.identifier));
    std::fs::write(&md_path, &xml).map_err(|e| format!("{}: {e}", md_path.display()))?;

    let dist = root.join("dist").join("fmi3");
    std::fs::create_dir_all(&dist).map_err(|e| format!("{}: {e}", dist.display()))?;
    let out = dist.join(format!("{}.fmu", f.identifier));
    let docs = (f.documentation)();
    let entries: [(String, &[u8]); 3] = [
        ("modelDescription.xml".into(), xml.as_bytes()),
        (format!("binaries/{platform}/{}.{ext}", f.identifier), &binary),
        ("documentation/index.html".into(), docs.as_bytes()),
    ];
    super::write_zip(&out, &entries)?;
    Ok(out)
}

/// `spec` as `dist/fmi3/<name>.ssp`, with the FMUs named in `fmi3` taken from `dist/fmi3/`
/// and the others (FMI 2.0) from `dist/`.
fn package_system(
    root: &Path,
    name: &str,
    spec: &super::ssp::SystemSpec,
    fmi3: &[&str],
) -> Result<PathBuf, String> {
    let (d2, d3) = (root.join("dist"), root.join("dist").join("fmi3"));
    let path = |id: &str| {
        let dir = if fmi3.contains(&id) { &d3 } else { &d2 };
        dir.join(format!("{id}.fmu"))
    };
    let out = d3.join(format!("{name}.ssp"));
    super::write_system(spec, &path, &out)?;
    Ok(out)
}

/// Builds and packages everything FMI 3.0; call after the FMI 2.0 FMUs are in `dist/`.
pub fn package_all(root: &Path) -> Result<Vec<PathBuf>, String> {
    let fmus = fmus();
    build(root, &fmus)?;
    let mut written = Vec::new();
    for f in &fmus {
        written.push(package(root, f)?);
    }
    // Both FMUs FMI 3.0: the open loop (plant and controller, the reference from the
    // system input), the same as `dist/InchwormSystemOpen.ssp`.
    let both = ["InchwormPlant", "InchwormController"];
    written.push(package_system(root, "InchwormSystem", &super::ssp::open_system(), &both)?);
    // The closed loop with the FMI 3.0 plant and the FMI 2.0 controller and reference, the
    // same as `dist/InchwormSystem.ssp`.
    let closed = super::ssp::closed_system();
    written.push(package_system(root, "InchwormSystemMixed", &closed, &["InchwormPlant"])?);
    Ok(written)
}
