//! What each FMU carries as evidence, besides its binaries: the documentation with the
//! model's figures, reference results in `extra/org.fmi-standard.fmi-ls-ref/` (the layout
//! of the Reference-FMUs: the input, the reference output and the options, listed in the
//! layered standard's `fmi-ls-manifest.xml`), and the compatibility-information tree
//! `dist/cross-check/` (the FMI cross-check's vendor layout
//! `fmus/<FMI version>/cs/<platform>/<tool>/<version>/<Model>/`).
//!
//! The reference results are committed under `fmu-build/reference/<Model>/`, recorded
//! with FMPy by `scripts/reference_results.py`; tests/python/test_reference_results.py
//! simulates every FMU in FMPy from them and requires the same output.

use std::path::{Path, PathBuf};

/// The layered standard's folder inside an FMU.
pub const LS_REF: &str = "extra/org.fmi-standard.fmi-ls-ref";

/// The exporting tool's name and version in the compatibility tree.
const TOOL: &str = "inchworm";

/// The figures of docs/img that show what a model does, with their captions.
fn figures(identifier: &str) -> &'static [(&'static str, &'static str)] {
    const FIG5: (&str, &str) = (
        "fig5.png",
        "Fig. 5 of the paper: the plant and controller FMUs in a 2 ms Jacobi loop, full control against feedback only (inchworm scenario fig5)",
    );
    const STAIRCASE: (&str, &str) = (
        "staircase.png",
        "Figs. 6-7: the reference staircase, prefilter on (inchworm scenario staircase)",
    );
    match identifier {
        "InchwormPlant" | "InchwormPlantFull" => &[
            FIG5,
            (
                "stall.png",
                "Fig. 11: open-loop slews of 600 full gaits from rest, gamma 0 and 10 (inchworm scenario stall)",
            ),
            STAIRCASE,
        ],
        "InchwormController" => &[
            FIG5,
            STAIRCASE,
            ("fastgait.png", "The 50 Hz gait against the paper's (inchworm scenario fastgait)"),
        ],
        "InchwormReference" => &[FIG5, STAIRCASE],
        "InchwormMount" => &[(
            "mirror.png",
            "Three actuator chains and the mount: piston 30 um, then tip 4 urad (inchworm scenario mirror)",
        )],
        "InchwormDelayLine" => &[(
            "delay-line.png",
            "A 10 m baseline on the ground, analog mode and the fine stage: path, cart, inchworm, fine stage and residual (inchworm delay-line --controller analog --duration 10)",
        )],
        _ => &[],
    }
}

/// The reference-result files of a model: (file name, bytes, MIME type, role, description).
pub struct ReferenceFile {
    pub name: String,
    pub data: Vec<u8>,
    mime: &'static str,
    role: &'static str,
    description: &'static str,
}

/// The committed reference results of `identifier` (`_in.csv` only where the model has
/// inputs).
pub fn reference_files(root: &Path, identifier: &str) -> Result<Vec<ReferenceFile>, String> {
    let dir = root.join("fmu-build").join("reference").join(identifier);
    let parts: [(&str, &str, &str, &str, bool); 3] = [
        ("_in.csv", "text/csv", "input", "Input of the reference experiment", false),
        ("_ref.csv", "text/csv", "result", "Output of the reference experiment (FMPy)", true),
        (
            "_ref.opt",
            "text/plain",
            "options",
            "Start time, stop time, step size and tolerance of the reference experiment",
            true,
        ),
    ];
    let mut out = Vec::new();
    for (suffix, mime, role, description, required) in parts {
        let name = format!("{identifier}{suffix}");
        match std::fs::read(dir.join(&name)) {
            Ok(data) => out.push(ReferenceFile { name, data, mime, role, description }),
            Err(_) if !required => {}
            Err(e) => {
                return Err(format!(
                    "{}: {e} (record it with scripts/reference_results.py)",
                    dir.join(&name).display()
                ))
            }
        }
    }
    Ok(out)
}

/// `fmi-ls-manifest.xml` of the reference results.
pub fn manifest(files: &[ReferenceFile]) -> String {
    let mut s = String::from(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<fmiReferences\n    xmlns:fmi-ls=\"http://fmi-standard.org/fmi-ls-manifest\"\n    fmi-ls:fmi-ls-name=\"org.fmi-standard.fmi-ls-ref\"\n    fmi-ls:fmi-ls-version=\"1.0.0-alpha.1\"\n    fmi-ls:fmi-ls-description=\"Reference results of the model, recorded by the exporter with FMPy\">\n",
    );
    for f in files {
        s.push_str(&format!(
            "    <Related type=\"{}\" source=\"{}\" role=\"{}\" description=\"{}\"/>\n",
            f.mime, f.name, f.role, f.description
        ));
    }
    s.push_str("</fmiReferences>\n");
    s
}

/// The FMU's `documentation/` entries: `index.html` (the generated variable documentation
/// with a section of figures and one on the reference results) and the figures.
pub fn documentation(
    root: &Path,
    identifier: &str,
    generated: &str,
    files: &[ReferenceFile],
) -> Result<Vec<(String, Vec<u8>)>, String> {
    let mut section = String::from("<h2>Figures</h2>\n");
    let mut entries = Vec::new();
    for (file, caption) in figures(identifier) {
        let path = root.join("docs").join("img").join(file);
        let data = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        section.push_str(&format!(
            "<figure><img src=\"{file}\" alt=\"{caption}\" style=\"max-width:100%\"/><figcaption>{caption}</figcaption></figure>\n"
        ));
        entries.push((format!("documentation/{file}"), data));
    }
    section.push_str(&format!(
        "<h2>Reference results</h2>\n<p>In <code>{LS_REF}/</code> (listed in its <code>fmi-ls-manifest.xml</code>): "
    ));
    let names: Vec<String> = files.iter().map(|f| format!("<code>{}</code>", f.name)).collect();
    section.push_str(&names.join(", "));
    section.push_str(". Simulate with the options of the <code>_ref.opt</code> file and the inputs of the <code>_in.csv</code> file (where there is one) and compare with the <code>_ref.csv</code> file; FMPy gives it exactly.</p>\n");
    let html = match generated.rfind("</body>") {
        Some(at) => format!("{}{section}{}", &generated[..at], &generated[at..]),
        None => format!("{generated}{section}"),
    };
    entries.insert(0, ("documentation/index.html".into(), html.into_bytes()));
    Ok(entries)
}

/// Writes one model's folder of the compatibility tree: the FMU, the reference files and
/// a ReadMe; returns the folder.
pub fn cross_check_folder(
    dist: &Path,
    fmi_version: &str,
    platform: &str,
    identifier: &str,
    fmu: &Path,
    files: &[ReferenceFile],
) -> Result<PathBuf, String> {
    let dir = dist
        .join("cross-check")
        .join("fmus")
        .join(fmi_version)
        .join("cs")
        .join(platform)
        .join(TOOL)
        .join(env!("CARGO_PKG_VERSION"))
        .join(identifier);
    let err = |p: &Path, e: std::io::Error| format!("{}: {e}", p.display());
    std::fs::create_dir_all(&dir).map_err(|e| err(&dir, e))?;
    let to = dir.join(format!("{identifier}.fmu"));
    std::fs::copy(fmu, &to).map_err(|e| err(&to, e))?;
    for f in files {
        let to = dir.join(&f.name);
        std::fs::write(&to, &f.data).map_err(|e| err(&to, e))?;
    }
    let readme = format!(
        "# {identifier} (FMI {fmi_version} Co-Simulation)\n\n\
         Exported by {TOOL} {version} (fmu-build). The FMU carries binaries for every platform of\n\
         docs/platforms.md; this folder is filed under `{platform}`, where CI simulates it.\n\n\
         - `{identifier}.fmu`: the model\n\
         {input}\
         - `{identifier}_ref.csv`: the reference output, recorded with FMPy\n\
         - `{identifier}_ref.opt`: start and stop time, step size (the communication step), tolerance\n\n\
         The same files are inside the FMU, in `{LS_REF}/`.\n",
        version = env!("CARGO_PKG_VERSION"),
        input = if files.iter().any(|f| f.role == "input") {
            format!("- `{identifier}_in.csv`: the inputs (a repeated time marks a step)\n")
        } else {
            String::new()
        },
    );
    let to = dir.join("ReadMe.md");
    std::fs::write(&to, readme).map_err(|e| err(&to, e))?;
    Ok(dir)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(name: &str, role: &'static str) -> ReferenceFile {
        ReferenceFile { name: name.into(), data: vec![], mime: "text/csv", role, description: "d" }
    }

    #[test]
    fn the_manifest_lists_each_file_with_its_role() {
        let m = manifest(&[file("M_in.csv", "input"), file("M_ref.csv", "result")]);
        assert!(m.contains("fmi-ls:fmi-ls-name=\"org.fmi-standard.fmi-ls-ref\""));
        assert!(m.contains("<Related type=\"text/csv\" source=\"M_in.csv\" role=\"input\""));
        assert!(m.contains("<Related type=\"text/csv\" source=\"M_ref.csv\" role=\"result\""));
        assert_eq!(m.matches("<Related").count(), 2);
    }

    #[test]
    fn every_model_has_figures_that_exist_and_the_documentation_links_them() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
        for id in [
            "InchwormPlant",
            "InchwormPlantFull",
            "InchwormController",
            "InchwormReference",
            "InchwormMount",
        ] {
            assert!(!figures(id).is_empty(), "{id}");
            let files = [file(&format!("{id}_ref.csv"), "result")];
            let docs =
                documentation(root, id, "<html><body><p>x</p></body></html>", &files).unwrap();
            let html = String::from_utf8(docs[0].1.clone()).unwrap();
            assert!(html.ends_with("</body></html>"), "{html}");
            for (f, _) in figures(id) {
                assert!(html.contains(&format!("<img src=\"{f}\"")), "{id}: {f}");
                assert!(docs
                    .iter()
                    .any(|(n, d)| *n == format!("documentation/{f}") && d.starts_with(b"\x89PNG")));
            }
            assert!(html.contains(&format!("<code>{id}_ref.csv</code>")));
        }
    }
}
