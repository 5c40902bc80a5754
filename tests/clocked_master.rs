//! The master's FMI 3.0 clocks on every shipped system: the controller run with event mode
//! (`--interface controller=cs-events`) or in Scheduled Execution (`controller=se`) writes
//! the CSV of today's plain Co-Simulation byte for byte, at master steps of 2, 1 and
//! 0.1 ms (Jacobi; the open system at 3 and 4 ms too, ticks inside the steps): the sample
//! clock's ticks, not the master step, decide when the controller samples. The systems are `InchwormSystem.ssp` (Fig. 5 with full control and
//! feedback only, the staircase with the prefilter), `MirrorMount.ssp` (three controllers),
//! `fmi3/InchwormSystemOpen.ssp` (Fig. 5 on the system input) and
//! `fmi3/InchwormSystemMixed.ssp`. Those that ship the FMI 2.0 controller, which has no
//! clocks, run their clocked variants with the FMI 3.0 controller in its place (the same
//! model: traces of FMI 2.0 and 3.0 are equal) and are held to the shipped system's plain
//! run. And the refusals: Scheduled Execution of an FMU without it, clocks of an FMI 2.0
//! FMU, an unknown component.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use inchworm_cosim::master::{Interfaces, Options, System};
use inchworm_cosim::Trace;
use inchworm_scenarios::scenario::{by_name, Drive};

use inchworm_dist::path as dist;

/// The stop time: into Fig. 5's move, where the gait steps and the estimator updates.
const STOP: f64 = 1.0;
const STEPS: [f64; 3] = [0.002, 0.001, 0.0001];

/// `ssp` with its FMI 2.0 controller replaced by the FMI 3.0 one, in a folder of this test.
fn with_fmi3_controller(ssp: &Path, tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("inchworm-clocked-{}-{tag}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join(ssp.file_name().unwrap());
    let fmi3 = std::fs::read(dist("fmi3/InchwormController.fmu")).unwrap();
    let mut zin = zip::ZipArchive::new(std::fs::File::open(ssp).unwrap()).unwrap();
    let mut zout = zip::ZipWriter::new(std::fs::File::create(&out).unwrap());
    let mut swapped = 0;
    for i in 0..zin.len() {
        let mut entry = zin.by_index(i).unwrap();
        let name = entry.name().to_owned();
        let mut bytes = Vec::new();
        entry.read_to_end(&mut bytes).unwrap();
        if name == "resources/InchwormController.fmu" {
            bytes.clone_from(&fmi3);
            swapped += 1;
        }
        zout.start_file(name, zip::write::SimpleFileOptions::default()).unwrap();
        zout.write_all(&bytes).unwrap();
    }
    zout.finish().unwrap();
    assert_eq!(swapped, 1, "{}: one controller FMU", ssp.display());
    out
}

/// The run's CSV and the ticks of each clocked component's output clocks.
fn run(ssp: &Path, interfaces: &Interfaces, opts: &Options) -> (Vec<u8>, Vec<(String, u64)>) {
    let mut sim = System::load_as(ssp, interfaces).unwrap().initialise(opts).unwrap();
    let mut trace = Trace::new(sim.record_names().to_vec());
    trace.push(0.0, sim.sample().unwrap());
    for _ in 0..sim.n_steps() {
        sim.step().unwrap();
        let row = sim.sample().unwrap();
        trace.push(sim.time(), row);
    }
    let ticks = sim.output_clock_ticks();
    sim.terminate().unwrap();
    let mut csv = Vec::new();
    trace.write_csv(&mut csv).unwrap();
    (csv, ticks)
}

fn clocked(components: &[&str], se: bool) -> Interfaces {
    let names = components.iter().map(|c| c.to_string()).collect();
    match se {
        true => Interfaces { scheduled_execution: names, ..Interfaces::default() },
        false => Interfaces { event_mode: names, ..Interfaces::default() },
    }
}

/// Plain, event mode and Scheduled Execution of `clocked_ssp`'s `controllers` give the CSV
/// of `plain_ssp`'s plain run at every step of [`STEPS`], and the output clock `gait_step`
/// ticks alike in both clocked runs.
fn check(what: &str, plain_ssp: &Path, clocked_ssp: &Path, controllers: &[&str], opts: &Options) {
    check_at(what, (plain_ssp, clocked_ssp), controllers, opts, (&STEPS, STOP));
}

/// [`check`] at the master steps `steps`, to `stop`.
fn check_at(
    what: &str,
    (plain_ssp, clocked_ssp): (&Path, &Path),
    controllers: &[&str],
    opts: &Options,
    (steps, stop): (&[f64], f64),
) {
    for &h in steps {
        let o = Options { stop_time: Some(stop), step_size: Some(h), ..opts.clone() };
        let (plain, none) = run(plain_ssp, &Interfaces::default(), &o);
        assert!(none.is_empty());
        let lines = plain.iter().filter(|&&b| b == b'\n').count();
        assert_eq!(lines as f64, (stop / h).round() + 2.0, "{what} at {h} s: the rows");
        let (events, event_ticks) = run(clocked_ssp, &clocked(controllers, false), &o);
        let (se, se_ticks) = run(clocked_ssp, &clocked(controllers, true), &o);
        assert!(events == plain, "{what} at {h} s: event mode differs from plain Co-Simulation");
        assert!(
            se == plain,
            "{what} at {h} s: Scheduled Execution differs from plain Co-Simulation"
        );
        assert_eq!(event_ticks, se_ticks, "{what} at {h} s: gait_step");
        assert_eq!(event_ticks.len(), controllers.len());
        assert!(event_ticks.iter().all(|(_, n)| *n >= 1), "{what} at {h} s: {event_ticks:?}");
    }
}

fn controller_params(scenario: &str) -> Vec<(String, Options)> {
    let s = by_name(scenario).unwrap();
    s.variants
        .iter()
        .map(|v| match &v.drive {
            Drive::Controller(p) => (v.name.clone(), s.closed_options(&v.plant, p)),
            Drive::OpenLoopSlew => unreachable!("{scenario} is a closed loop"),
        })
        .collect()
}

#[test]
fn fig5_both_variants_and_the_staircase_on_the_closed_systems() {
    for ssp in ["InchwormSystem.ssp", "fmi3/InchwormSystemMixed.ssp"] {
        let shipped = dist(ssp);
        let swapped = with_fmi3_controller(&shipped, "closed");
        let mut variants = controller_params("fig5");
        assert_eq!(variants.len(), 2, "full control and feedback only");
        variants.extend(controller_params("staircase"));
        for (name, opts) in variants {
            check(&format!("{ssp}, {name}"), &shipped, &swapped, &["controller"], &opts);
        }
        std::fs::remove_dir_all(swapped.parent().unwrap()).unwrap();
    }
}

#[test]
fn fig5_on_the_open_fmi3_system() {
    let ssp = dist("fmi3/InchwormSystemOpen.ssp");
    let s = by_name("fig5").unwrap();
    for v in &s.variants {
        let Drive::Controller(p) = &v.drive else { unreachable!() };
        let (what, opts) = (format!("open, {}", v.name), s.options(&v.plant, p));
        check(&what, &ssp, &ssp, &["controller"], &opts);
        // Steps that are not divisors of the 2 ms sample: ticks inside the steps (at
        // 4 ms, one a step; at 3 ms, every other step), the same bytes again.
        check_at(&what, (&ssp, &ssp), &["controller"], &opts, (&[0.004, 0.003], 0.6));
    }
}

#[test]
fn the_mirror_with_three_clocked_controllers() {
    let shipped = dist("MirrorMount.ssp");
    let swapped = with_fmi3_controller(&shipped, "mirror");
    let opts = Options {
        stop_time: None,
        step_size: None,
        coupling: inchworm_cosim::master::Coupling::Jacobi,
        params: vec![],
        parameter_set: None,
        input: None,
        outputs: inchworm_scenarios::scenario::mirror_recorded(),
    };
    let controllers = ["controller_a", "controller_b", "controller_c"];
    check("mirror", &shipped, &swapped, &controllers, &opts);
    std::fs::remove_dir_all(swapped.parent().unwrap()).unwrap();
}

fn error(ssp: &Path, interfaces: &Interfaces) -> String {
    match System::load_as(ssp, interfaces) {
        Ok(_) => panic!("{} loaded with {interfaces:?}", ssp.display()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn clocks_asked_of_fmus_without_them_are_refused_with_the_reason() {
    // The shipped InchwormSystem.ssp's controller is FMI 2.0: no clocks.
    let ssp = dist("InchwormSystem.ssp");
    let e = error(&ssp, &clocked(&["controller"], true));
    assert!(e.contains("component controller"), "{e}");
    assert!(
        e.contains("does not offer Scheduled Execution: its modelDescription.xml lacks <ScheduledExecution> (FMI 2.0 has no clocks, event mode in Co-Simulation nor Scheduled Execution)"),
        "{e}"
    );
    let e = error(&ssp, &clocked(&["controller"], false));
    assert!(e.contains("does not offer Co-Simulation with event mode"), "{e}");
    // The FMI 3.0 plant has neither.
    let open = dist("fmi3/InchwormSystemOpen.ssp");
    let e = error(&open, &clocked(&["plant"], true));
    assert!(e.contains("InchwormPlant: the FMU (fmiVersion 3.0) does not offer Scheduled Execution: its modelDescription.xml lacks <ScheduledExecution>"), "{e}");
    // A component the system does not have, and one asked two interfaces.
    let e = error(&open, &clocked(&["ctrl"], true));
    assert!(e.contains("--interface ctrl=se: no component named `ctrl` to run as Scheduled Execution: the components are `plant`, `controller`"), "{e}");
    let both = Interfaces {
        event_mode: vec!["controller".into()],
        scheduled_execution: vec!["controller".into()],
        ..Interfaces::default()
    };
    let e = error(&open, &both);
    assert!(e.contains("`controller` is asked to run both as Co-Simulation with event mode (cs-events) and as Scheduled Execution (se)"), "{e}");
}

/// `inchworm run --interface controller=cs-events|se`: the CSV written is plain
/// Co-Simulation's; an interface without a component, or an unknown one, is refused.
#[test]
fn inchworm_run_takes_the_clocked_interfaces() {
    let dir = std::env::temp_dir().join(format!("inchworm-clocked-{}-cli", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let input = dir.join("reference.csv");
    std::fs::write(&input, "time,reference\n0,1e-4\n").unwrap();
    let ssp = dist("fmi3/InchwormSystemOpen.ssp");
    let run = |interface: Option<&str>, out: &str| {
        let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_inchworm"));
        cmd.arg("run").arg(&ssp).args(["--stop-time", "0.4", "--step-size", "0.001"]);
        cmd.arg("--input").arg(&input).arg("--out").arg(dir.join(out));
        if let Some(i) = interface {
            cmd.args(["--interface", i]);
        }
        cmd.output().unwrap()
    };
    let plain = run(None, "plain.csv");
    assert!(plain.status.success(), "{}", String::from_utf8_lossy(&plain.stderr));
    let plain = std::fs::read(dir.join("plain.csv")).unwrap();
    for (interface, out) in [("controller=cs-events", "events.csv"), ("controller=se", "se.csv")] {
        let o = run(Some(interface), out);
        assert!(o.status.success(), "{interface}: {}", String::from_utf8_lossy(&o.stderr));
        assert!(std::fs::read(dir.join(out)).unwrap() == plain, "{interface}: the CSV differs");
    }
    let refused = |interface: &str| {
        let o = run(Some(interface), "refused.csv");
        assert!(!o.status.success(), "{interface} ran");
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let e = refused("se");
    assert!(e.contains("--interface se: name the component to run as `se`: COMPONENT=se"), "{e}");
    let e = refused("controller=clocked");
    assert!(e.contains("`clocked` is not an interface (me, cs, cs-events or se)"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A sweep's reset (`fmi3Reset`, then the same initialization) puts a clocked component
/// back at its first tick: the second run's rows are the first's, bit for bit, in both
/// clocked interfaces; a checkpoint of a clocked run is refused with the reason.
#[test]
fn a_reset_repeats_a_clocked_run_and_a_checkpoint_is_refused() {
    let ssp = dist("fmi3/InchwormSystemOpen.ssp");
    let s = by_name("fig5").unwrap();
    let Drive::Controller(p) = &s.variants[0].drive else { unreachable!() };
    let opts = Options { stop_time: Some(0.5), ..s.options(&s.variants[0].plant, p) };
    for se in [false, true] {
        let mut sim = System::load_as(&ssp, &clocked(&["controller"], se))
            .unwrap()
            .initialise(&opts)
            .unwrap();
        let rows = |sim: &mut inchworm_cosim::Simulation| -> Vec<u64> {
            let mut bits: Vec<u64> = sim.sample().unwrap().iter().map(|v| v.to_bits()).collect();
            for _ in 0..sim.n_steps() {
                sim.step().unwrap();
                bits.extend(sim.sample().unwrap().iter().map(|v| v.to_bits()));
            }
            bits
        };
        let first = rows(&mut sim);
        let e = sim.checkpoint().err().unwrap().to_string();
        assert!(e.contains("component controller: runs its clocks with event mode or in Scheduled Execution: a checkpoint of it is not taken"), "{e}");
        sim.reset(&opts).unwrap();
        assert_eq!(rows(&mut sim), first, "se {se}: the run after the reset");
    }
}

/// `inchworm run` of the clocked controller with `fmu=cs-events` or `fmu=se` bounds its work
/// by the rules of the plain driver: steps of 1e17 s and 1e300 s (5e19 and 5e302 ticks of
/// the 2 ms sample clock) are refused at once with the reason and write nothing, and a run
/// of a million ticks a step stops within 1 s of SIGTERM or SIGINT (the master checks the
/// run's stop flag between two ticks), saying so, with exit status 128 + the signal's
/// number and nothing left in its TMPDIR. A run refused before its first step writes no
/// CSV; one interrupted writes the rows it computed (the output contract of a new file).
#[test]
fn inchworm_run_bounds_the_clocked_drivers_and_honours_signals_inside_a_step() {
    let dir = std::env::temp_dir().join(format!("inchworm-clocked-{}-bounds", std::process::id()));
    let tmp = dir.join("tmp");
    std::fs::create_dir_all(&tmp).unwrap();
    let fmu = dist("fmi3/InchwormController.fmu");
    let out = dir.join("out.csv");
    let run = |interface: &str, stop: &str, step: &str| {
        let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_inchworm"));
        cmd.arg("run").arg(&fmu).args(["--interface", interface, "--stop-time", stop]);
        cmd.args(["--step-size", step]).arg("--out").arg(&out);
        cmd.env("TMPDIR", &tmp).env("INCHWORM_FMU_CACHE", "off");
        cmd.stderr(std::process::Stdio::piped()).stdout(std::process::Stdio::null());
        cmd
    };
    let leftovers = || std::fs::read_dir(&tmp).unwrap().count();
    let wait = |child: &mut std::process::Child, limit: f64| {
        let start = std::time::Instant::now();
        loop {
            if let Some(s) = child.try_wait().unwrap() {
                break (s, start.elapsed().as_secs_f64());
            }
            if start.elapsed().as_secs_f64() > limit {
                let _ = child.kill();
                panic!("the run went on for {limit} s");
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
    };
    let stderr = |child: &mut std::process::Child| {
        let mut s = String::new();
        child.stderr.take().unwrap().read_to_string(&mut s).unwrap();
        s
    };
    for interface in ["fmu=cs-events", "fmu=se"] {
        for stop in ["1e17", "1e300"] {
            let mut child = run(interface, stop, stop).spawn().unwrap();
            let (status, _) = wait(&mut child, 60.0);
            let e = stderr(&mut child);
            assert_eq!(status.code(), Some(1), "{interface} {stop}: {e}");
            assert!(e.contains("past the 2^53 ticks this master counts exactly"), "{e}");
            assert!(!out.exists() && leftovers() == 0, "{interface} {stop}: left files");
        }
        for (signal, name) in [(libc::SIGTERM, "SIGTERM"), (libc::SIGINT, "SIGINT")] {
            // Ten steps of 2000 s, each a million ticks.
            let mut child = run(interface, "20000", "2000").spawn().unwrap();
            // The run takes about 6 s; its handlers are installed first thing.
            std::thread::sleep(std::time::Duration::from_millis(700));
            assert!(child.try_wait().unwrap().is_none(), "{interface}: ended before the signal");
            // SAFETY: a plain kill(2) of the child this test spawned.
            assert_eq!(unsafe { libc::kill(child.id() as libc::pid_t, signal) }, 0);
            let (status, after) = wait(&mut child, 60.0);
            let e = stderr(&mut child);
            assert_eq!(status.code(), Some(128 + signal), "{interface} {name}: {e}");
            assert!(e.contains(&format!("interrupted by {name}")), "{e}");
            assert!(after < 1.0, "{interface}: {after:.3} s from {name} to the exit");
            eprintln!("{interface}: {name} to the exit: {:.1} ms", after * 1e3);
            assert_eq!(leftovers(), 0, "{interface} {name}: left files in TMPDIR");
            std::fs::remove_file(&out).unwrap();
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
