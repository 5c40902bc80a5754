//! The project's packaged FMUs through the import layer: both load, the plant FMU steps
//! exactly as the plant model run directly, a model description full of vendor
//! annotations and unknown attributes still loads, and every bad file, name or value is
//! refused with a message that says what is wrong.

mod common;

use common::{dist, plant_variant, replace_once, scratch};
use inchworm_fmi_import::{Causality, CsFmu, FmuError, Status, VarType, Variability};
use inchworm_fmu_models::{ControllerFmu, ControllerParams, PlantFmu};
use inchworm_plant::{Dac, Plant, PlantParams};

const H: f64 = 0.002;

#[test]
fn both_fmus_load_with_their_variables() {
    let plant = CsFmu::load(&dist("InchwormPlant.fmu"), "plant", false).unwrap();
    assert_eq!(plant.model_name(), "InchwormPlant");
    assert_eq!(plant.fmi_version(), "2.0");
    assert!(plant.guid().starts_with('{') && plant.guid().len() > 30, "{}", plant.guid());
    assert!(plant.binary_version().starts_with("2."));
    assert_eq!(plant.default_step_size(), Some(0.002));
    assert_eq!(
        plant.vrs_of(&PlantFmu::DAC_INPUTS.map(|v| v.name()), VarType::Real).unwrap(),
        [1, 2, 3]
    );
    assert_eq!(plant.var_of(PlantFmu::ENCODER_COUNTS.name(), VarType::Integer).unwrap().vr, 10);
    // 47 of the interface and 30 locals: the model's states it reports (the stack's nodes,
    // the runner's velocity, the channels), the reduced formulation's two runner states, the
    // 11 derivatives and the 5 event indicators.
    assert_eq!(plant.variables().count(), 77);
    assert_eq!(plant.names_with_causality("local").len(), 30);
    let dac = plant.variables().find(|v| v.name == Dac::EARTH.name()).unwrap();
    assert_eq!(
        (dac.causality, dac.variability, dac.start.as_deref()),
        (Causality::Input, Variability::Continuous, Some("0"))
    );
    assert_eq!(plant.names_with_causality("input"), PlantFmu::DAC_INPUTS.map(|v| v.name()));
    assert_eq!(plant.causality(PlantFmu::ENCODER_COUNTS.name()).as_deref(), Some("output"));

    let ctrl = CsFmu::load(&dist("InchwormController.fmu"), "controller", false).unwrap();
    assert_eq!(ctrl.model_name(), "InchwormController");
    assert_eq!(ctrl.variables().count(), 71);
    assert_eq!(ctrl.vrs_of(&[ControllerFmu::REFERENCE.name()], VarType::Real).unwrap(), [2]);
    assert_eq!(
        ctrl.vrs_of(&[ControllerFmu::ENCODER_COUNTS.name()], VarType::Integer).unwrap(),
        [1]
    );
    assert_eq!(
        ctrl.vrs_of(
            &[ControllerParams::FEEDFORWARD.name(), ControllerParams::PREFILTER.name()],
            VarType::Boolean
        )
        .unwrap(),
        [100, 101]
    );
    assert_eq!(ctrl.causality(ControllerFmu::SCALE_WEIGHTS[2].name()).as_deref(), Some("output"));
    // Two instances of one FMU at once, each with its own unpacked copy.
    let plant2 = CsFmu::load(&dist("InchwormPlant.fmu"), "plant2", false).unwrap();
    assert_ne!(plant.unpacked_dir(), plant2.unpacked_dir());
}

/// Runs the plant FMU `n` steps of 2 ms with `dac` held, returning (encoder counts, runner
/// position) after every step.
fn run_fmu(fmu: &mut CsFmu, dac: Dac, n: usize) -> Vec<(i64, f64)> {
    let inputs = fmu.vrs_of(&PlantFmu::DAC_INPUTS.map(|v| v.name()), VarType::Real).unwrap();
    let enc = fmu.var_of(PlantFmu::ENCODER_COUNTS.name(), VarType::Integer).unwrap().vr;
    let runner = fmu.var_of(PlantFmu::RUNNER_POSITION.name(), VarType::Real).unwrap().vr;
    fmu.enter_initialization(None, 0.0, None).unwrap();
    fmu.exit_initialization().unwrap();
    (0..n)
        .map(|_| {
            fmu.set_real(&inputs, &[dac.earth, dac.nonearth, dac.extension]).unwrap();
            fmu.do_step(H).unwrap();
            let (mut c, mut x) = ([0], [0.0]);
            fmu.get_integer(&[enc], &mut c).unwrap();
            fmu.get_real(&[runner], &mut x).unwrap();
            (i64::from(c[0]), x[0])
        })
        .collect()
}

fn run_direct(dac: Dac, n: usize) -> Vec<(i64, f64)> {
    let mut p = Plant::new(PlantParams::fia20()).unwrap();
    (0..n)
        .map(|_| {
            p.step(dac, H).unwrap();
            let o = p.outputs();
            (o.encoder_counts, o.runner_position)
        })
        .collect()
}

fn assert_same(fmu: &[(i64, f64)], direct: &[(i64, f64)]) {
    assert_eq!(fmu.len(), direct.len());
    for (k, (a, b)) in fmu.iter().zip(direct).enumerate() {
        assert_eq!(a.0, b.0, "encoder counts after step {}", k + 1);
        assert!(
            (a.1 - b.1).abs() <= 1e-15 * b.1.abs().max(1e-300),
            "runner position after step {}: {} vs {}",
            k + 1,
            a.1,
            b.1
        );
    }
}

#[test]
fn the_plant_fmu_steps_as_the_plant_run_directly() {
    // 1 s at 2 ms with the extension DAC at 5 V.
    let dac = Dac { extension: 5.0, ..Dac::default() };
    let mut fmu = CsFmu::load(&dist("InchwormPlant.fmu"), "plant", false).unwrap();
    let through = run_fmu(&mut fmu, dac, 500);
    assert_same(&through, &run_direct(dac, 500));
    assert!((fmu.time() - 1.0).abs() < 1e-12, "time {}", fmu.time());
    fmu.terminate().unwrap();
    // With every DAC at 0 V nothing moves.
    let mut fmu = CsFmu::load(&dist("InchwormPlant.fmu"), "plant", false).unwrap();
    let idle = run_fmu(&mut fmu, Dac::default(), 100);
    assert!(idle.iter().all(|&(c, _)| c == 0), "{:?}", &idle[..5]);
    assert_same(&idle, &run_direct(Dac::default(), 100));
}

#[test]
fn the_unpacked_copy_is_removed_on_drop() {
    let fmu = CsFmu::load(&dist("InchwormPlant.fmu"), "plant", false).unwrap();
    let dir = fmu.unpacked_dir().to_path_buf();
    assert!(fmu.library_path().is_file() && fmu.library_path().starts_with(&dir));
    drop(fmu);
    assert!(!dir.exists(), "{} still exists", dir.display());
}

#[test]
fn only_what_a_run_reads_is_unpacked() {
    let dir = scratch("run-entries");
    let path = dir.join("five_platforms.fmu");
    let mut entries = common::entries(&dist("InchwormPlant.fmu"));
    // This host's library and two foreign ones, whichever platforms dist/ was built for.
    entries.retain(|(n, _)| !n.starts_with("binaries/") || n.starts_with("binaries/linux64/"));
    entries.push(("binaries/win64/InchwormPlant.dll".into(), vec![7; 4096]));
    entries.push(("binaries/x86_64-windows/InchwormPlant.dll".into(), vec![7; 4096]));
    entries.push(("resources/table.csv".into(), b"t,x\n0,1\n".to_vec()));
    entries.push(("sources/model.c".into(), b"int x;".to_vec()));
    common::write_zip(&path, &entries);
    let fmu = CsFmu::load(&path, "plant", false).unwrap();
    let root = fmu.unpacked_dir();
    let mut found = Vec::new();
    let mut todo = vec![root.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            let rel = p.strip_prefix(root).unwrap().to_string_lossy().replace('\\', "/");
            if p.is_dir() {
                todo.push(p);
                found.push(format!("{rel}/"));
            } else {
                found.push(rel);
            }
        }
    }
    found.sort();
    assert_eq!(
        found,
        [
            "binaries/",
            "binaries/linux64/",
            "binaries/linux64/InchwormPlant.so",
            "binaries/win64/",
            "binaries/x86_64-windows/",
            "modelDescription.xml",
            "resources/",
            "resources/table.csv",
        ]
    );
    let _ = std::fs::remove_dir_all(&dir);
}
#[test]
fn vendor_annotations_and_unknown_attributes_are_tolerated() {
    let dir = scratch("tolerant");
    let path = plant_variant(
        &dir,
        "annotated.fmu",
        |md| {
            let md = replace_once(
                md,
                r#"<Real unit="V" min="0" max="10" start="0"/>"#,
                r#"<Real unit="V" min="0" max="10" start="0" vendorUnit="volt"/>
      <Annotations><Tool name="Vendor"><x a="1"/></Tool></Annotations>"#,
            );
            let md = replace_once(
                &md,
                "<ModelVariables>",
                r#"<VendorAnnotations><Tool name="Vendor"><Something deep="yes"><ScalarVariable name="not_a_variable"/></Something></Tool></VendorAnnotations>
  <ModelVariables>"#,
            );
            let md = replace_once(
                &md,
                "<CoSimulation ",
                r#"<CoSimulation canHandleMultipleSetPerTimeInstant="true" fooBar="1" "#,
            );
            let md =
                replace_once(&md, "<fmiModelDescription ", r#"<fmiModelDescription fooBar="1" "#);
            let md = replace_once(&md, "<ScalarVariable ", r#"<ScalarVariable fooBar="1" "#);
            replace_once(&md, r#"<Unit name="s">"#, r#"<Unit name="s" fooBar="1">"#)
        },
        |n, b| Some((n.to_owned(), b)),
    );
    let mut fmu = CsFmu::load(&path, "annotated", false).unwrap();
    assert_eq!(fmu.variables().count(), 77);
    assert!(fmu.var("not_a_variable").is_err());
    let dac = Dac { extension: 5.0, ..Dac::default() };
    assert_same(&run_fmu(&mut fmu, dac, 50), &run_direct(dac, 50));
    drop(fmu);
    let _ = std::fs::remove_dir_all(&dir);
}

fn load_err(path: &std::path::Path) -> String {
    match CsFmu::load(path, "bad", false) {
        Ok(_) => panic!("{} loaded although it should not", path.display()),
        Err(e) => {
            let e = e.to_string();
            eprintln!("refused: {e}");
            e
        }
    }
}

#[test]
fn bad_files_are_refused_clearly() {
    let dir = scratch("refusals");

    let missing = dir.join("nowhere.fmu");
    assert!(matches!(CsFmu::load(&missing, "x", false), Err(FmuError::Missing(_))));
    let e = load_err(&missing);
    assert!(e.contains("nowhere.fmu") && e.contains("no such FMU file"), "{e}");

    let random = dir.join("random.fmu");
    std::fs::write(
        &random,
        (0..4096u32).map(|i| (i.wrapping_mul(2654435761) >> 13) as u8).collect::<Vec<_>>(),
    )
    .unwrap();
    let e = load_err(&random);
    assert!(e.contains("random.fmu") && e.contains("not a zip archive"), "{e}");

    let no_md = dir.join("no_md.fmu");
    common::write_zip(
        &no_md,
        &[
            ("binaries/linux64/x.so".into(), b"x".to_vec()),
            ("documentation/index.html".into(), b"<html/>".to_vec()),
        ],
    );
    let e = load_err(&no_md);
    assert!(e.contains("no modelDescription.xml"), "{e}");

    let slip = dir.join("slip.fmu");
    let mut entries = common::entries(&dist("InchwormPlant.fmu"));
    entries.push(("../../evil.txt".into(), b"gotcha".to_vec()));
    common::write_zip(&slip, &entries);
    let e = load_err(&slip);
    assert!(e.contains("../../evil.txt") && e.contains("outside the archive"), "{e}");

    let no_bin = plant_variant(
        &dir,
        "no_binary.fmu",
        |m| m.to_owned(),
        |n, b| (!n.starts_with("binaries/")).then(|| (n.to_owned(), b)),
    );
    let e = load_err(&no_bin);
    assert!(
        e.contains("no binary for linux64") && e.contains("binaries/linux64/InchwormPlant.so"),
        "{e}"
    );

    let other_platforms = plant_variant(
        &dir,
        "other_platforms.fmu",
        |m| m.to_owned(),
        // The FMU carries every platform: its Windows and macOS binaries go, and the Linux
        // one takes the Windows one's place.
        |n, b| match n {
            "binaries/linux64/InchwormPlant.so" => {
                Some(("binaries/win64/InchwormPlant.dll".into(), b))
            }
            n if n.starts_with("binaries/") => None,
            n => Some((n.to_owned(), b)),
        },
    );
    let mut e2 = common::entries(&other_platforms);
    e2.push(("binaries/darwin64/InchwormPlant.dylib".into(), b"not really".to_vec()));
    common::write_zip(&other_platforms, &e2);
    let e = load_err(&other_platforms);
    assert!(
        e.contains("no binary for linux64") && e.contains("it carries: darwin64, win64"),
        "{e}"
    );

    let garbage = plant_variant(
        &dir,
        "garbage_binary.fmu",
        |m| m.to_owned(),
        |n, b| {
            Some((
                n.to_owned(),
                if n.ends_with(".so") {
                    b"this is not a shared library at all, just text".to_vec()
                } else {
                    b
                },
            ))
        },
    );
    let e = load_err(&garbage);
    assert!(e.contains("cannot load the FMU's binary") && e.contains("InchwormPlant.so"), "{e}");
    // The dlopen message itself.
    assert!(e.contains("invalid ELF header") || e.contains("too short"), "{e}");

    let truncated = plant_variant(
        &dir,
        "truncated_binary.fmu",
        |m| m.to_owned(),
        |n, mut b| {
            if n.ends_with(".so") {
                b.truncate(b.len() / 3);
            }
            Some((n.to_owned(), b))
        },
    );
    // dlopen would map the missing pages and die of SIGBUS: refused before that.
    let e = load_err(&truncated);
    assert!(
        e.contains("cannot load the FMU's binary binaries/linux64/InchwormPlant.so")
            && e.contains("truncated"),
        "{e}"
    );

    // fmiVersion 3.0 is read as FMI 3.0 (src/fmi3.rs): a relabelled FMI 2.0 file is
    // refused for what FMI 3.0 requires of it.
    let fmi3 = plant_variant(
        &dir,
        "fmi3.fmu",
        |m| replace_once(m, r#"fmiVersion="2.0""#, r#"fmiVersion="3.0""#),
        |n, b| Some((n.to_owned(), b)),
    );
    let e = load_err(&fmi3);
    assert!(
        e.contains("<fmiModelDescription> lacks the required attribute instantiationToken"),
        "{e}"
    );
    let fmi1 = plant_variant(
        &dir,
        "fmi1.fmu",
        |m| replace_once(m, r#"fmiVersion="2.0""#, r#"fmiVersion="1.0""#),
        |n, b| Some((n.to_owned(), b)),
    );
    let e = load_err(&fmi1);
    assert!(e.contains(r#"fmiVersion="1.0""#) && e.contains("only FMI 2.0 and FMI 3.0"), "{e}");

    let bad_vr = plant_variant(
        &dir,
        "bad_vr.fmu",
        |m| replace_once(m, r#"valueReference="3""#, r#"valueReference="three""#),
        |n, b| Some((n.to_owned(), b)),
    );
    let e = load_err(&bad_vr);
    assert!(
        e.contains("line ")
            && e.contains(&format!(
                r#"name="{}"> valueReference="three" is not an unsigned 32-bit integer"#,
                Dac::EXTENSION.name()
            )),
        "{e}"
    );

    let dup = plant_variant(
        &dir,
        "dup.fmu",
        |m| {
            let name = |n: &str| format!(r#"name="{n}""#);
            replace_once(m, &name(Dac::NONEARTH.name()), &name(Dac::EARTH.name()))
        },
        |n, b| Some((n.to_owned(), b)),
    );
    let e = load_err(&dup);
    assert!(e.contains(&format!("a second variable named `{}`", Dac::EARTH.name())), "{e}");

    let no_cs = plant_variant(
        &dir,
        "no_cs.fmu",
        |m| {
            let start = m.find("<CoSimulation").unwrap();
            let end = start + m[start..].find("/>").unwrap() + 2;
            format!("{}{}", &m[..start], &m[end..])
        },
        |n, b| Some((n.to_owned(), b)),
    );
    let e = load_err(&no_cs);
    assert!(e.contains("InchwormPlant") && e.contains("no Co-Simulation interface"), "{e}");

    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_names_and_types_are_refused_clearly() {
    let mut fmu = CsFmu::load(&dist("InchwormPlant.fmu"), "plant", false).unwrap();
    let e = fmu.var("nope").unwrap_err().to_string();
    assert!(
        e.contains("`nope`") && e.contains("InchwormPlant") && e.contains("no variable named"),
        "{e}"
    );
    let (earth, counts) = (Dac::EARTH.name(), PlantFmu::ENCODER_COUNTS.name());
    let e = fmu.var_of(earth, VarType::Integer).unwrap_err().to_string();
    assert!(e.contains(&format!("`{earth}` is Real, expected Integer")), "{e}");
    let e = fmu.vrs_of(&[earth, counts], VarType::Real).unwrap_err().to_string();
    assert!(e.contains(&format!("`{counts}` is Integer, expected Real")), "{e}");
    assert!(fmu.real("nope").is_err());

    // A refused call: a NaN input is fmi2Error, named with the call and the time.
    fmu.enter_initialization(None, 0.0, None).unwrap();
    fmu.exit_initialization().unwrap();
    fmu.do_step(H).unwrap();
    match fmu.set_real(&[1], &[f64::NAN]) {
        Err(FmuError::Call { function: "fmi2SetReal", status: Status::Error, time, .. }) => {
            assert_eq!(time, H)
        }
        other => panic!("{other:?}"),
    }
    let e = fmu.set_real(&[1], &[f64::NAN]).unwrap_err().to_string();
    assert!(e.contains("InchwormPlant: fmi2SetReal returned fmi2Error at t = 0.002 s"), "{e}");
    // The instance goes on after a refused call.
    fmu.set_real(&[1], &[0.0]).unwrap();
    fmu.do_step(H).unwrap();
    // Strings: the plant has none, and says so through the status.
    let mut s = [String::new()];
    assert!(fmu.get_string(&[1], &mut s).is_err());
}

/// Builds `source` into a shared library with the system C compiler (gcc is a build
/// requirement of this crate anyway: it compiles the logger).
fn c_library(dir: &std::path::Path, source: &str) -> Vec<u8> {
    let c = dir.join("lib.c");
    let so = dir.join("lib.so");
    std::fs::write(&c, source).unwrap();
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let status = std::process::Command::new(&cc)
        .args(["-shared", "-fPIC", "-o"])
        .arg(&so)
        .arg(&c)
        .status()
        .unwrap_or_else(|e| panic!("cannot run {cc}: {e}"));
    assert!(status.success());
    std::fs::read(so).unwrap()
}

/// Every function a CS import resolves besides fmi2GetTypesPlatform and fmi2GetVersion,
/// for the stub libraries of the tests below.
// The state functions too: the plant declares canGetAndSetFMUstate and canSerializeFMUstate,
// and a binary that declares them without exporting them is refused.
const STUB_FUNCTIONS: [&str; 29] = [
    "fmi2GetFMUstate",
    "fmi2SetFMUstate",
    "fmi2FreeFMUstate",
    "fmi2SerializedFMUstateSize",
    "fmi2SerializeFMUstate",
    "fmi2DeSerializeFMUstate",
    "fmi2SetDebugLogging",
    "fmi2Instantiate",
    "fmi2FreeInstance",
    "fmi2SetupExperiment",
    "fmi2EnterInitializationMode",
    "fmi2ExitInitializationMode",
    "fmi2Terminate",
    "fmi2Reset",
    "fmi2GetReal",
    "fmi2GetInteger",
    "fmi2GetBoolean",
    "fmi2GetString",
    "fmi2SetReal",
    "fmi2SetInteger",
    "fmi2SetBoolean",
    "fmi2SetString",
    "fmi2DoStep",
    "fmi2CancelStep",
    "fmi2GetStatus",
    "fmi2GetRealStatus",
    "fmi2GetIntegerStatus",
    "fmi2GetBooleanStatus",
    "fmi2GetStringStatus",
];

#[cfg(target_os = "linux")]
#[test]
fn incomplete_or_foreign_binaries_are_refused_clearly() {
    let dir = scratch("binaries");
    let with_binary = |name: &str, so: Vec<u8>| {
        plant_variant(
            &dir,
            name,
            |m| m.to_owned(),
            move |n, b| Some((n.to_owned(), if n.ends_with(".so") { so.clone() } else { b })),
        )
    };
    let partial = c_library(
        &dir,
        r#"const char *fmi2GetTypesPlatform(void) { return "default"; }
           const char *fmi2GetVersion(void) { return "2.0"; }
           int fmi2SetDebugLogging(void *c, int on, unsigned long n, const char **cats) { return 0; }"#,
    );
    let e = load_err(&with_binary("partial.fmu", partial));
    assert!(e.contains("binaries/linux64/InchwormPlant.so does not export fmi2Instantiate"), "{e}");

    let mut all = String::new();
    for f in STUB_FUNCTIONS {
        all.push_str(&format!("void *{f}(void) {{ return 0; }}\n"));
    }
    let fmi3ish = c_library(&dir, &format!("{all}const char *fmi2GetTypesPlatform(void) {{ return \"default\"; }}\nconst char *fmi2GetVersion(void) {{ return \"3.0\"; }}\n"));
    let e = load_err(&with_binary("version.fmu", fmi3ish));
    assert!(e.contains("fmi2GetVersion returned \"3.0\""), "{e}");
    let odd = c_library(&dir, &format!("{all}const char *fmi2GetTypesPlatform(void) {{ return \"odd\"; }}\nconst char *fmi2GetVersion(void) {{ return \"2.0\"; }}\n"));
    let e = load_err(&with_binary("platform.fmu", odd));
    assert!(e.contains("fmi2GetTypesPlatform returned \"odd\""), "{e}");
    // fmi2Instantiate returning NULL.
    let null = c_library(&dir, &format!("{all}const char *fmi2GetTypesPlatform(void) {{ return \"default\"; }}\nconst char *fmi2GetVersion(void) {{ return \"2.0\"; }}\n"));
    let e = load_err(&with_binary("null.fmu", null));
    assert!(e.contains("fmi2Instantiate returned NULL for instance `bad`"), "{e}");
    // Declared in modelDescription.xml, missing in the binary.
    let stateless = c_library(&dir, &format!("{}const char *fmi2GetTypesPlatform(void) {{ return \"default\"; }}\nconst char *fmi2GetVersion(void) {{ return \"2.0\"; }}\n", all.replace("void *fmi2SerializeFMUstate(void) { return 0; }\n", "")));
    let e = load_err(&with_binary("stateless.fmu", stateless));
    assert!(e.contains("modelDescription.xml declares canSerializeFMUstate=\"true\" but the FMU's binary binaries/linux64/InchwormPlant.so does not export fmi2SerializeFMUstate"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A stub binary whose fmi2DoStep returns fmi2Fatal and whose fmi2FreeInstance appends a
/// line to `marker`: the instance is freed exactly once on drop, and never after fmi2Fatal.
#[cfg(target_os = "linux")]
#[test]
fn free_once_and_nothing_after_fatal() {
    let dir = scratch("fatal");
    let marker = dir.join("frees.txt");
    let mut src = String::from("#include <stdio.h>\nstatic int component;\n");
    // fmi2Instantiate, fmi2DoStep and fmi2FreeInstance get real bodies below.
    for f in STUB_FUNCTIONS
        .iter()
        .filter(|f| !matches!(**f, "fmi2Instantiate" | "fmi2DoStep" | "fmi2FreeInstance"))
    {
        src.push_str(&format!("int {f}(void) {{ return 0; }}\n"));
    }
    src.push_str(&format!(
        r#"const char *fmi2GetTypesPlatform(void) {{ return "default"; }}
const char *fmi2GetVersion(void) {{ return "2.0"; }}
void *fmi2Instantiate(void) {{ return &component; }}
int fmi2DoStep(void *c, double t, double h, int no_prior) {{ return 4; }}
void fmi2FreeInstance(void *c) {{ FILE *f = fopen("{}", "a"); if (f) {{ fputs(c == &component ? "free\n" : "wrong\n", f); fclose(f); }} }}
"#,
        marker.display()
    ));
    let so = c_library(&dir, &src);
    let path = plant_variant(
        &dir,
        "stub.fmu",
        |m| m.to_owned(),
        move |n, b| Some((n.to_owned(), if n.ends_with(".so") { so.clone() } else { b })),
    );
    let frees = || std::fs::read_to_string(&marker).unwrap_or_default();

    let mut fmu = CsFmu::load(&path, "stub", false).unwrap();
    fmu.enter_initialization(None, 0.0, None).unwrap();
    fmu.terminate().unwrap();
    drop(fmu);
    assert_eq!(frees(), "free\n");

    let mut fmu = CsFmu::load(&path, "stub", false).unwrap();
    fmu.enter_initialization(None, 0.0, None).unwrap();
    fmu.exit_initialization().unwrap();
    match fmu.do_step(0.1) {
        Err(FmuError::Call { function: "fmi2DoStep", status: Status::Fatal, time, .. }) => {
            assert_eq!(time, 0.0)
        }
        other => panic!("{other:?}"),
    }
    let e = fmu.set_real(&[1], &[1.0]).unwrap_err().to_string();
    assert!(e.contains("fmi2SetReal refused: fmi2DoStep returned fmi2Fatal earlier"), "{e}");
    assert!(matches!(fmu.terminate(), Err(FmuError::AfterFatal { .. })));
    let unpacked = fmu.unpacked_dir().to_path_buf();
    drop(fmu);
    assert_eq!(frees(), "free\n", "fmi2FreeInstance must not be called after fmi2Fatal");
    assert!(!unpacked.exists());
    let _ = std::fs::remove_dir_all(&dir);
}
