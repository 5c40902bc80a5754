//! Builds the small Model Exchange FMU of `me_fmu.c` (FMI 2.0 or FMI 3.0) into an `.fmu`
//! with the system C compiler, for the importer's and the master's tests (each includes
//! this file with `#[path]`). Its variables: `x` (the state, vr 0), `der(x)` (1), `a` (2),
//! `u` (the input, 3), `level` (4), `period` (5), `jump` (6), `crossings` (7), `ticks` (8),
//! `mode` (9).
#![allow(dead_code)]

use std::io::Write;
use std::path::{Path, PathBuf};

/// Which standard the FMU is built for; `Fmi2Cs`: FMI 2.0 with a Co-Simulation
/// interface as well.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Standard {
    Fmi2,
    Fmi2Cs,
    Fmi3,
}

const SOURCE: &str = include_str!("me_fmu.c");

/// Writes `dir/<name>.fmu` of the given standard and returns its path.
pub fn build(dir: &Path, name: &str, standard: Standard) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let c = dir.join(format!("{name}.c"));
    let so = dir.join(format!("{name}.so"));
    std::fs::write(&c, SOURCE).unwrap();
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let mut cmd = std::process::Command::new(&cc);
    cmd.args(["-shared", "-fPIC", "-O2", "-fvisibility=hidden", "-o"]).arg(&so).arg(&c);
    if standard == Standard::Fmi3 {
        cmd.arg("-DFMI3");
    }
    let status = cmd.arg("-lm").status().unwrap_or_else(|e| panic!("cannot run {cc}: {e}"));
    assert!(status.success(), "{cc} failed on {}", c.display());
    let (folder, xml) = match standard {
        Standard::Fmi2 => (inchworm_fmi_import::fmi2_platform().0, fmi2_description(name, false)),
        Standard::Fmi2Cs => (inchworm_fmi_import::fmi2_platform().0, fmi2_description(name, true)),
        Standard::Fmi3 => (inchworm_fmi_import::fmi3_platform().0, fmi3_description(name)),
    };
    let fmu = dir.join(format!("{name}.fmu"));
    let mut w = zip::ZipWriter::new(std::fs::File::create(&fmu).unwrap());
    let options = zip::write::SimpleFileOptions::default();
    w.start_file("modelDescription.xml", options).unwrap();
    w.write_all(xml.as_bytes()).unwrap();
    w.start_file(format!("binaries/{folder}/{name}.so"), options).unwrap();
    w.write_all(&std::fs::read(&so).unwrap()).unwrap();
    w.finish().unwrap();
    fmu
}

/// (name, causality, variability, start) of the Real variables after `x` and `der(x)`.
const PARAMETERS: [(&str, &str, &str, &str); 5] = [
    ("a", "parameter", "fixed", "1"),
    ("u", "input", "continuous", "0"),
    ("level", "parameter", "fixed", "0.5"),
    ("period", "parameter", "fixed", "0.25"),
    ("jump", "parameter", "fixed", "0"),
];

fn fmi2_description(name: &str, cs: bool) -> String {
    let cs = if cs {
        format!(
            r#"<CoSimulation modelIdentifier="{name}" canHandleVariableCommunicationStepSize="true"/>"#
        )
    } else {
        String::new()
    };
    let mut v = String::from(
        r#"<ScalarVariable name="x" valueReference="0" causality="output" variability="continuous" initial="exact"><Real start="1"/></ScalarVariable>
<ScalarVariable name="der(x)" valueReference="1" causality="local" variability="continuous"><Real derivative="1"/></ScalarVariable>
"#,
    );
    for (i, (n, c, var, s)) in PARAMETERS.iter().enumerate() {
        v += &format!(
            r#"<ScalarVariable name="{n}" valueReference="{}" causality="{c}" variability="{var}"><Real start="{s}"/></ScalarVariable>
"#,
            i + 2
        );
    }
    v += r#"<ScalarVariable name="crossings" valueReference="7" causality="output" variability="discrete"><Integer/></ScalarVariable>
<ScalarVariable name="ticks" valueReference="8" causality="output" variability="discrete"><Integer/></ScalarVariable>
<ScalarVariable name="mode" valueReference="9" causality="parameter" variability="fixed"><Integer start="0"/></ScalarVariable>
"#;
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="{name}" guid="{{me-test}}" numberOfEventIndicators="1">
<ModelExchange modelIdentifier="{name}" providesDirectionalDerivative="true"/>{cs}
<ModelVariables>
{v}</ModelVariables>
<ModelStructure>
<Outputs><Unknown index="1"/><Unknown index="8"/><Unknown index="9"/></Outputs>
<Derivatives><Unknown index="2"/></Derivatives>
</ModelStructure>
</fmiModelDescription>
"#
    )
}

fn fmi3_description(name: &str) -> String {
    let mut v = String::from(
        r#"<Float64 name="x" valueReference="0" causality="output" variability="continuous" initial="exact" start="1"/>
<Float64 name="der(x)" valueReference="1" causality="local" variability="continuous" derivative="0"/>
"#,
    );
    for (i, (n, c, var, s)) in PARAMETERS.iter().enumerate() {
        v += &format!(
            r#"<Float64 name="{n}" valueReference="{}" causality="{c}" variability="{var}" start="{s}"/>
"#,
            i + 2
        );
    }
    v += r#"<Int32 name="crossings" valueReference="7" causality="output" variability="discrete"/>
<Int32 name="ticks" valueReference="8" causality="output" variability="discrete"/>
<Int32 name="mode" valueReference="9" causality="parameter" variability="fixed" start="0"/>
"#;
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="3.0" modelName="{name}" instantiationToken="{{me-test}}">
<ModelExchange modelIdentifier="{name}" providesDirectionalDerivatives="true"/>
<ModelVariables>
{v}</ModelVariables>
<ModelStructure>
<Output valueReference="0"/><Output valueReference="7"/><Output valueReference="8"/>
<ContinuousStateDerivative valueReference="1"/>
<EventIndicator valueReference="0"/>
</ModelStructure>
</fmiModelDescription>
"#
    )
}

const WIDE_SOURCE: &str = include_str!("wide_me_fmu.c");

/// Writes `dir/<name>.fmu`: the FMI 2.0 Model Exchange FMU of `wide_me_fmu.c` with `nx`
/// continuous states (`x0`, the first, an output) and `numberOfEventIndicators` `nz` in its
/// description. `binary`: the C compiler's extra flags (`-DSLOW`), or `None` for an FMU of
/// a description alone (one a master must refuse before loading a library). The binary
/// has no event indicators: an `nz` other than 0 is for a description a master refuses.
pub fn build_wide(dir: &Path, name: &str, nx: usize, nz: u64, binary: Option<&[&str]>) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let mut v = String::new();
    for i in 0..nx {
        let causality = if i == 0 { "output" } else { "local" };
        v += &format!(
            "<ScalarVariable name=\"x{i}\" valueReference=\"{i}\" causality=\"{causality}\" variability=\"continuous\" initial=\"exact\"><Real start=\"1\"/></ScalarVariable>\n"
        );
    }
    let mut derivatives = String::new();
    for i in 0..nx {
        v += &format!(
            "<ScalarVariable name=\"der(x{i})\" valueReference=\"{}\" causality=\"local\" variability=\"continuous\"><Real derivative=\"{}\"/></ScalarVariable>\n",
            nx + i,
            i + 1
        );
        derivatives += &format!("<Unknown index=\"{}\"/>", nx + i + 1);
    }
    let xml = format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="{name}" guid="{{wide}}" numberOfEventIndicators="{nz}">
<ModelExchange modelIdentifier="{name}" providesDirectionalDerivative="true"/>
<ModelVariables>
{v}</ModelVariables>
<ModelStructure>
<Outputs><Unknown index="1"/></Outputs>
<Derivatives>{derivatives}</Derivatives>
</ModelStructure>
</fmiModelDescription>
"#
    );
    let fmu = dir.join(format!("{name}.fmu"));
    let mut w = zip::ZipWriter::new(std::fs::File::create(&fmu).unwrap());
    let options = zip::write::SimpleFileOptions::default();
    w.start_file("modelDescription.xml", options).unwrap();
    w.write_all(xml.as_bytes()).unwrap();
    if let Some(flags) = binary {
        let c = dir.join(format!("{name}.c"));
        let so = dir.join(format!("{name}.so"));
        std::fs::write(&c, WIDE_SOURCE).unwrap();
        let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
        let mut cmd = std::process::Command::new(&cc);
        cmd.args(["-shared", "-fPIC", "-O2", "-fvisibility=hidden", "-o"]).arg(&so).arg(&c);
        cmd.arg(format!("-DNX={nx}")).args(flags);
        let status = cmd.status().unwrap_or_else(|e| panic!("cannot run {cc}: {e}"));
        assert!(status.success(), "{cc} failed on {}", c.display());
        let folder = inchworm_fmi_import::fmi2_platform().0;
        w.start_file(format!("binaries/{folder}/{name}.so"), options).unwrap();
        w.write_all(&std::fs::read(&so).unwrap()).unwrap();
    }
    w.finish().unwrap();
    fmu
}
