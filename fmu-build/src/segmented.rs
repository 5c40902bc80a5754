//! `fmu-build segmented --rings R [--no-centre] [--seed S] [--cophase] [--controller C]
//! --out FILE.ssp`: the SSP of a hexagonal segmented mirror, generated from the FMUs'
//! variable tables like the shipped systems (docs/segmented.md). Each segment is one mount of `ssp::mount` (three
//! reference → controller → plant chains and the mount kinematics), its components
//! prefixed `seg{k}_`; every plant's first (and only) binding, `default`, holds its
//! actuator's draw of the brake disturbance `F_d0`, the transducer ratio `T_em` (the
//! scale factor) and the environment stiffness `k_e`, seeded. Segments share no
//! connection, so each is an independent subsystem that `inchworm run --jobs` steps on a
//! thread of its own. With `--cophase` every segment starts from a seeded random error
//! (its mount's offsets) and is commanded to the phased mirror; `--controller` binds
//! every controller to the stepping gait, the deadband or analog mode.
//!
//! A subcommand of fmu-build, not of `inchworm`: the SSD is written from the typed
//! variable tables of `inchworm-fmu-models` by the same code as the shipped systems, and
//! the `inchworm` command is a master that knows no model's names.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use inchworm_fmi_export::{Value, Var};
use inchworm_fmu_models::mount::{actuator_positions, ANGLE_A_DEG, RADIUS};
use inchworm_fmu_models::{ControllerFmu, ControllerParams, MountFmu, PlantFmu};
// The seeded draws, shared with the plain-Rust loop of `inchworm-phasing`'s examples.
use inchworm_scenarios::segmented::{draws, errors, Draw};

use crate::ssp::{self, binding, Binding, SystemSpec};

pub const COMMAND: &str = "segmented";

/// The most rings: 16 rings with the centre are 817 segments, an ELT-class primary.
pub const MAX_RINGS: u32 = 16;

/// What to generate.
#[derive(Clone, Debug, PartialEq)]
pub struct Mirror {
    pub rings: u32,
    /// Whether the central segment is there (none: a secondary's shadow or a Cassegrain
    /// hole, as JWST's 18 = 2 rings without it).
    pub centre: bool,
    pub seed: u64,
    /// Each segment from a drawn error to the phased mirror, instead of the mount's
    /// command of `MirrorMount.ssp`.
    pub cophase: bool,
    pub controller: Control,
}

/// How every controller of the mirror moves its runner.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Control {
    /// The paper's stepping gait at every iteration: the FMU's defaults, no binding.
    Stepping,
    /// No step while the error is within [`DEADBAND`]: the gait halts once there.
    Deadband,
    /// Analog mode near the target (the controller's `analog_range`, default 2.5 µm).
    Analog,
}

impl Control {
    pub const NAMES: [(&'static str, Control); 3] = [
        ("stepping", Control::Stepping),
        ("deadband", Control::Deadband),
        ("analog", Control::Analog),
    ];

    pub fn name(self) -> &'static str {
        Control::NAMES
            .iter()
            .find(|(_, c)| *c == self)
            .map(|(n, _)| *n)
            .expect("every variant named")
    }

    /// Every controller's first (and only) binding, `default`; none for the stepping gait.
    fn bindings(self) -> Vec<Binding> {
        let named = |v: Var<ControllerFmu>, x| vec![(v.name().to_string(), x)];
        match self {
            Control::Stepping => vec![],
            Control::Deadband => {
                vec![binding(
                    "default",
                    named(ControllerFmu::var(ControllerParams::DEADBAND), Value::Real(DEADBAND)),
                )]
            }
            Control::Analog => {
                vec![binding(
                    "default",
                    named(ControllerFmu::var(ControllerParams::ANALOG), Value::Boolean(true)),
                )]
            }
        }
    }
}

/// The deadband of [`Control::Deadband`], the segmented mirrors' (docs/segments.md has
/// what it leaves the coronagraph).
pub use inchworm_phasing::cophasing::DEADBAND;

impl Mirror {
    /// 3R(R+1) + 1 segments with the centre, 3R(R+1) without: the count of
    /// python/inchworm_segments and hcipy, in their order (the centre, then ring by ring).
    pub fn segments(&self) -> usize {
        let r = self.rings as usize;
        3 * r * (r + 1) + usize::from(self.centre)
    }
}

/// The mirror's system: one mount a segment, each plant bound to its draw.
pub fn system(m: &Mirror) -> SystemSpec {
    let n = m.segments();
    let all = draws(m.seed, 3 * n);
    let errors = errors(m.seed, n);
    let mut components = Vec::new();
    let mut connections = Vec::new();
    for (k, d) in all.chunks(3).enumerate() {
        let plant = |d: &Draw| {
            let named =
                |v: inchworm_fmi_export::Var<PlantFmu>, x| (v.name().to_string(), Value::Real(x));
            vec![binding(
                "default",
                vec![
                    named(PlantFmu::var(inchworm_plant::PlantParams::F_D0), d.f_d0),
                    named(PlantFmu::var(inchworm_plant::PlantParams::T_EM), d.t_em),
                    named(PlantFmu::var(inchworm_plant::PlantParams::K_E), d.k_e),
                ],
            )]
        };
        let plants = [plant(&d[0]), plant(&d[1]), plant(&d[2])];
        let mut segment = if m.cophase {
            cophased(&format!("seg{k}_"), plants, errors[k])
        } else {
            ssp::mount(&format!("seg{k}_"), plants)
        };
        for x in ssp::MIRROR_CHAINS {
            let name = format!("seg{k}_controller_{x}");
            let c = segment.0.iter_mut().find(|c| c.name == name).expect("the mount's controller");
            c.bindings = m.controller.bindings();
        }
        let (c, l) = segment;
        components.extend(c);
        connections.extend(l);
    }
    let centre = if m.centre { "with" } else { "without" };
    let cophase = if m.cophase {
        "; each segment from a drawn error (its mount's offsets) commanded to the phased mirror"
    } else {
        ""
    };
    let control = match m.controller {
        Control::Stepping => String::new(),
        c => format!("; controllers: {}", c.name()),
    };
    SystemSpec {
        name: "SegmentedMirror",
        description: format!(
            "Hexagonal segmented mirror, {} ring(s) {centre} the centre: {n} segments, each an InchwormMount on three InchwormReference, InchwormController, InchwormPlant chains; each plant's {}, {}, {} drawn with seed {}{cophase}{control} (fmu-build segmented)",
            m.rings,
            PlantFmu::var(inchworm_plant::PlantParams::F_D0).name(),
            PlantFmu::var(inchworm_plant::PlantParams::T_EM).name(),
            PlantFmu::var(inchworm_plant::PlantParams::K_E).name(),
            m.seed,
        ),
        components,
        connectors: vec![],
        connections,
        stop_time: 10.0,
    }
}

/// One segment of the co-phasing mirror: the mount of [`ssp::mount`] whose optic starts
/// at `error` (piston, tip, tilt: the mount's offsets) and whose three references command,
/// from t = 0, the runner positions that undo it: the phased mirror, every pose zero.
fn cophased(
    prefix: &str,
    plants: [Vec<Binding>; 3],
    error: [f64; 3],
) -> (Vec<ssp::Component>, Vec<ssp::Connection>) {
    let (mut components, connections) = ssp::mount(prefix, plants);
    let z = actuator_positions(-error[0], -error[1], -error[2], RADIUS, ANGLE_A_DEG);
    for (i, x) in ssp::MIRROR_CHAINS.iter().enumerate() {
        let name = format!("{prefix}reference_{x}");
        let r = components.iter_mut().find(|c| c.name == name).expect("the mount's reference");
        r.bindings = vec![binding("default", ssp::reference_table(&[(0.0, z[i])], 0.0))];
    }
    let offsets = [MountFmu::PISTON_OFFSET, MountFmu::TIP_OFFSET, MountFmu::TILT_OFFSET];
    let mount = components.last_mut().expect("the mount is the last component");
    mount.bindings = vec![binding(
        "default",
        offsets.iter().zip(error).map(|(v, e)| (v.name().to_string(), Value::Real(e))).collect(),
    )];
    (components, connections)
}

const USAGE: &str = "fmu-build segmented --rings R [--no-centre] [--seed S] [--cophase] [--controller stepping|deadband|analog] --out FILE.ssp";

/// The options, or why not.
pub fn parse(args: &[String]) -> Result<(Mirror, PathBuf), String> {
    let mut m =
        Mirror { rings: 0, centre: true, seed: 1, cophase: false, controller: Control::Stepping };
    let mut out = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |what: &str| it.next().ok_or(format!("{a} needs {what} ({USAGE})"));
        match a.as_str() {
            "--rings" => {
                let v = value("a ring count")?;
                m.rings = v
                    .parse()
                    .ok()
                    .filter(|r| (1..=MAX_RINGS).contains(r))
                    .ok_or(format!("--rings {v}: a whole number from 1 to {MAX_RINGS}"))?;
            }
            "--seed" => {
                let v = value("a seed")?;
                m.seed = v.parse().map_err(|_| format!("--seed {v}: a whole number >= 0"))?;
            }
            "--no-centre" => m.centre = false,
            "--cophase" => m.cophase = true,
            "--controller" => {
                let v = value("stepping, deadband or analog")?;
                m.controller = Control::NAMES
                    .iter()
                    .find(|(n, _)| *n == v.as_str())
                    .map(|(_, c)| *c)
                    .ok_or(format!("--controller {v}: stepping, deadband or analog"))?;
            }
            "--out" => out = Some(PathBuf::from(value("a file")?)),
            other => return Err(format!("unknown argument `{other}` ({USAGE})")),
        }
    }
    if m.rings == 0 {
        return Err(format!("give --rings ({USAGE})"));
    }
    let out = out.ok_or(format!("give --out ({USAGE})"))?;
    Ok((m, out))
}

/// The subcommand: writes the SSP with `write(spec, out)` and says what it wrote.
pub fn main(
    args: &[String],
    write: impl FnOnce(&SystemSpec, &Path) -> Result<(), String>,
) -> ExitCode {
    let (m, out) = match parse(args) {
        Ok(x) => x,
        Err(e) => {
            eprintln!("fmu-build segmented: {e}");
            return ExitCode::from(2);
        }
    };
    let spec = system(&m);
    match write(&spec, &out) {
        Ok(()) => {
            println!(
                "fmu-build segmented: wrote {} ({} segments, {} actuators, {} components, seed {}{})",
                out.display(),
                m.segments(),
                3 * m.segments(),
                spec.components.len(),
                m.seed,
                if m.cophase { ", co-phasing" } else { "" }
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("fmu-build segmented: {e}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use inchworm_scenarios::segmented::{ANGLE_ERROR, PISTON_ERROR};

    /// One ring with the centre, the mount's command, the stepping gait.
    fn mirror(seed: u64) -> Mirror {
        Mirror { rings: 1, centre: true, seed, cophase: false, controller: Control::Stepping }
    }

    #[test]
    fn ring_counts_with_and_without_the_centre() {
        let count = |rings, centre| Mirror { rings, centre, ..mirror(1) }.segments();
        assert_eq!([count(1, true), count(2, true), count(3, true)], [7, 19, 37]);
        assert_eq!([count(2, false), count(16, true)], [18, 817]);
    }

    #[test]
    fn each_segment_is_a_mount_whose_plants_hold_their_draws() {
        let m = Mirror { centre: false, ..mirror(3) };
        let spec = system(&m);
        assert_eq!(spec.components.len(), 6 * 10);
        let d = draws(3, 18);
        let plant = spec.components.iter().find(|c| c.name == "seg5_plant_c").unwrap();
        assert_eq!(plant.bindings.len(), 1);
        assert_eq!(plant.bindings[0].set, "default");
        let values = &plant.bindings[0].values;
        assert_eq!(
            values[0],
            (
                PlantFmu::var(inchworm_plant::PlantParams::F_D0).name().to_string(),
                Value::Real(d[17].f_d0)
            )
        );
        assert_eq!(
            values[1],
            (
                PlantFmu::var(inchworm_plant::PlantParams::T_EM).name().to_string(),
                Value::Real(d[17].t_em)
            )
        );
        assert_eq!(
            values[2],
            (
                PlantFmu::var(inchworm_plant::PlantParams::K_E).name().to_string(),
                Value::Real(d[17].k_e)
            )
        );
        // Segments share no connection: every one stays within its own prefix.
        for (a, _, b, _) in &spec.connections {
            let seg =
                |e: &Option<String>| e.as_ref().unwrap().split('_').next().unwrap().to_string();
            assert_eq!(seg(a), seg(b));
        }
        let ssd = spec.system_description();
        assert!(ssd.contains("resources/seg0_plant_a.default.ssv"));
        assert!(ssd.contains(r#"<ssd:Component name="seg5_mount""#));
    }

    #[test]
    fn cophasing_segments_start_at_their_errors_and_command_the_phased_mirror() {
        let e = errors(5, 300);
        assert_eq!(&e[..7], &errors(5, 7)[..], "the first segments whatever the count");
        assert_ne!(e[0], errors(6, 1)[0]);
        for [p, tip, tilt] in &e {
            assert!(
                p.abs() <= PISTON_ERROR && tip.abs() <= ANGLE_ERROR && tilt.abs() <= ANGLE_ERROR
            );
        }
        // Uniform on ±h: RMS h/√3 (300 draws: within 10 %).
        let rms = |i: usize| (e.iter().map(|x| x[i] * x[i]).sum::<f64>() / 300.0).sqrt();
        assert!((rms(0) / (PISTON_ERROR / 3f64.sqrt()) - 1.0).abs() < 0.1, "{}", rms(0));
        assert!((rms(2) / (ANGLE_ERROR / 3f64.sqrt()) - 1.0).abs() < 0.1, "{}", rms(2));

        let m = Mirror { cophase: true, controller: Control::Deadband, ..mirror(5) };
        let spec = system(&m);
        let find = |name: &str| spec.components.iter().find(|c| c.name == name).unwrap();
        let mount = &find("seg6_mount").bindings[0];
        let offsets = [MountFmu::PISTON_OFFSET, MountFmu::TIP_OFFSET, MountFmu::TILT_OFFSET];
        for (i, v) in offsets.iter().enumerate() {
            assert_eq!(mount.values[i], (v.name().to_string(), Value::Real(e[6][i])));
        }
        // The three references hold the runner positions whose pose is minus the error.
        let z: Vec<f64> = ssp::MIRROR_CHAINS
            .iter()
            .map(|x| {
                let values = &find(&format!("seg6_reference_{x}")).bindings[0].values;
                let (name, v) = values.last().unwrap();
                assert_eq!(name, &inchworm_fmu_models::ReferenceFmu::POSITIONS_1.element(0).name());
                match v {
                    Value::Real(z) => *z,
                    other => panic!("{other:?}"),
                }
            })
            .collect();
        let pose = inchworm_fmu_models::mount::pose([z[0], z[1], z[2]], RADIUS, ANGLE_A_DEG);
        for i in 0..3 {
            assert!((pose[i] + e[6][i]).abs() < 1e-18, "{i}: {} against {}", pose[i], e[6][i]);
        }
        let deadband = &find("seg3_controller_b").bindings;
        assert_eq!(deadband.len(), 1);
        assert_eq!(
            deadband[0].values,
            [(
                ControllerFmu::var(ControllerParams::DEADBAND).name().to_string(),
                Value::Real(DEADBAND)
            )]
        );
        let analog = system(&Mirror { controller: Control::Analog, ..m.clone() });
        let c = analog.components.iter().find(|c| c.name == "seg0_controller_a").unwrap();
        assert_eq!(
            c.bindings[0].values,
            [(
                ControllerFmu::var(ControllerParams::ANALOG).name().to_string(),
                Value::Boolean(true)
            )]
        );
        // Without --cophase and --controller: the mount's command, the FMUs' defaults.
        let plain = system(&mirror(5));
        let c = plain.components.iter().find(|c| c.name == "seg0_controller_a").unwrap();
        assert!(c.bindings.is_empty());
        assert!(plain
            .components
            .iter()
            .find(|c| c.name == "seg0_mount")
            .unwrap()
            .bindings
            .is_empty());
    }

    #[test]
    fn options_are_checked() {
        let p = |v: &[&str]| parse(&v.iter().map(|s| s.to_string()).collect::<Vec<_>>());
        let (m, out) = p(&["--rings", "3", "--seed", "9", "--out", "m.ssp"]).unwrap();
        assert_eq!((m, out), (Mirror { rings: 3, ..mirror(9) }, "m.ssp".into()));
        assert!(!p(&["--rings", "2", "--no-centre", "--out", "a.ssp"]).unwrap().0.centre);
        assert!(p(&["--rings", "17", "--out", "a.ssp"]).unwrap_err().contains("1 to 16"));
        assert!(p(&["--rings", "0", "--out", "a.ssp"]).is_err());
        assert!(p(&["--out", "a.ssp"]).unwrap_err().contains("--rings"));
        assert!(p(&["--rings", "1"]).unwrap_err().contains("--out"));
        assert!(p(&["--rings", "1", "--out", "a", "--fast"]).unwrap_err().contains("--fast"));
        let (m, _) =
            p(&["--rings", "1", "--cophase", "--controller", "analog", "--out", "a"]).unwrap();
        assert_eq!((m.cophase, m.controller), (true, Control::Analog));
        assert!(p(&["--rings", "1", "--controller", "pid", "--out", "a"])
            .unwrap_err()
            .contains("stepping, deadband or analog"));
    }

    /// Every row of the SSP `path` run to `stop` s, as the CSV bytes `inchworm run` writes:
    /// on this thread as one system (`jobs` 1), or split into `jobs` parts on threads.
    fn trace(path: &Path, stop: f64, jobs: usize) -> (Vec<u8>, Vec<String>) {
        use inchworm_cosim::master::{Coupling, Interfaces, Options, Parallel, System};
        use inchworm_cosim::{trace, Error, StopFlag};
        let opts = Options {
            stop_time: Some(stop),
            step_size: None,
            coupling: Coupling::Jacobi,
            params: vec![],
            parameter_set: None,
            input: None,
            outputs: vec![],
        };
        let (mut csv, mut rows) = (Vec::new(), trace::RowWriter::new());
        let mut sink = |t: f64, row: &[f64]| -> Result<(), Error> {
            rows.write(&mut csv, t, row).map_err(|e| Error::Config(e.to_string()))
        };
        let names = if jobs == 1 {
            let sim = System::load(path).unwrap().initialise(&opts).unwrap();
            let names = sim.record_names().to_vec();
            sim.run_into(&mut sink, |_| {}).unwrap();
            names
        } else {
            let parallel = Parallel::new(path, &Interfaces::default(), &opts, jobs).unwrap();
            assert_eq!(parallel.split().parts.len(), jobs);
            let names = parallel.record_names().to_vec();
            parallel.run_into(&StopFlag::new(), &mut sink, |_| {}).unwrap();
            names
        };
        (csv, names)
    }

    #[test]
    fn the_seven_segment_mirror_runs_to_the_same_bytes_on_one_thread_and_two() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("mirror.ssp");
        let spec = system(&mirror(1));
        crate::write_system(&crate::workspace_root(), &spec, &[], &path)
            .unwrap_or_else(|e| panic!("{e}: run `cargo run --release -p fmu-build` first"));
        let (one, names) = trace(&path, 1.0, 1);
        let (two, names_two) = trace(&path, 1.0, 2);
        assert_eq!(names, names_two);
        assert_eq!(one.len(), two.len());
        assert!(one == two, "the rows of --jobs 2 differ from those of one thread");
        // 501 rows; every segment's mount has reached the 30 µm piston within 1 µm, each
        // on its own actuators' draws (no two segments the same trajectory).
        let text = String::from_utf8(one).unwrap();
        let rows: Vec<Vec<f64>> =
            text.lines().map(|l| l.split(',').map(|x| x.parse().unwrap()).collect()).collect();
        assert_eq!(rows.len(), 501);
        let piston = |k: usize| {
            let name = format!("seg{k}_mount.{}", inchworm_fmu_models::MountFmu::PISTON.name());
            let i = names.iter().position(|n| *n == name).unwrap() + 1;
            rows.iter().map(|r| r[i]).collect::<Vec<f64>>()
        };
        let pistons: Vec<Vec<f64>> = (0..7).map(piston).collect();
        for (k, p) in pistons.iter().enumerate() {
            let end = p[500];
            assert!((end - ssp::MIRROR_PISTON).abs() < 1e-6, "segment {k}: piston {end} m at 1 s");
            assert!(pistons[..k].iter().all(|q| q != p), "segment {k} moves as an earlier one");
        }
    }

    #[test]
    fn the_37_segment_mirror_runs_to_the_same_bytes_on_one_thread_and_two() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("mirror37.ssp");
        let spec = system(&Mirror { rings: 3, ..mirror(1) });
        crate::write_system(&crate::workspace_root(), &spec, &[], &path)
            .unwrap_or_else(|e| panic!("{e}: run `cargo run --release -p fmu-build` first"));
        let (one, names) = trace(&path, 0.4, 1);
        let (two, names_two) = trace(&path, 0.4, 2);
        assert_eq!(names, names_two);
        // The last segment's components are in the run.
        assert!(names.iter().any(|n| n.starts_with("seg36_")), "no seg36_ column in {names:?}");
        assert_eq!(one.iter().filter(|&&b| b == b'\n').count(), 201);
        assert!(one == two, "the rows of --jobs 2 differ from those of one thread");
    }
}
