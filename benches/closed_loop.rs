//! `cargo bench -p inchworm --bench closed_loop`: the closed loop over 600 s of the
//! Figs. 6–7 staircase (prefilter on, 2 ms Jacobi), five ways in this one run:
//!
//! * the Rust master stepping both FMUs (the loop of `inchworm run` on
//!   dist/InchwormSystemOpen.ssp, its rows streamed to a sink);
//! * the crates coupled directly (no FMI), recording the scenario's full row every step;
//! * a plain Jacobi loop in C on the same FMUs' FMI 2.0 libraries (`benches/fmu_jacobi.c`,
//!   compiled here with the system `cc`): the FMUs through the bare C API, no master;
//! * a plain Jacobi loop in FMPy on the same FMUs (`benches/fmpy_jacobi.py`, through the
//!   repository's `.venv/bin/python`; skipped, with the reason printed, without it);
//! * a speed anchor in C (`benches/rk4_anchor.c`, compiled here with the system `cc`):
//!   fixed-step RK4 of the plant's quiet 14-state linear system alone, checked against
//!   its exact propagation.
//!
//! The master, C and FMPy loops are timed from the first step to the last, their systems
//! loaded and initialised before (the master's set-up time is printed apart); the direct
//! coupling builds its two structs inside its time, which is nothing beside 600 s of steps.
//!
//! Each loop's wall time and its own CPU time (this thread's for the Rust loops, the
//! loop's for the others): on a loaded machine the wall time adds the waits for a core,
//! which fall unevenly on a 1 s run and a 20 s one, so the ratios are taken on CPU time
//! and the wall ratios printed beside them. The master, the direct coupling, the C loop and
//! the anchor take turns, best of `REPEATS` each (FMPy's minutes-long loop runs once). Prints real-time factors, per-step costs, the ratios against the issue's
//! targets and the load average, and checks that the three loops end on the same encoder
//! count.
//!
//! For a profile, `CLOSED_LOOP_ONLY=master` (or `direct`) runs that loop alone, once, over
//! `CLOSED_LOOP_SECONDS` (default 600) of the staircase: under `valgrind --tool=callgrind`,
//! two durations' difference is the cost of the steps between them (docs/plant-solver.md).

use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Instant;

use inchworm_controller::Params;
use inchworm_cosim::master::{Options, System};
use inchworm_plant::linear::{ix, system_matrix, Matrix, Vector, N};
use inchworm_plant::{Mode, PlantParams};
use inchworm_scenarios::closed_loop::run as direct;
use inchworm_scenarios::scenario::{self, Scenario};

const DURATION: f64 = 600.0;
const H: f64 = 0.002;
const REPEATS: usize = 3;
/// The anchor's RK4 step: 5 µs, the largest of the plant bench's RK4 steps that stays
/// within 1 count of the tight gait trace (the 4 kHz stack mode needs it).
const RK4_STEP: f64 = 5e-6;
/// Simulated seconds of the anchor: enough to time, short of the 600 s it would take minutes for.
const RK4_SECONDS: f64 = 20.0;

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|l| l.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}

/// CPU time (s) this thread has used.
fn thread_cpu() -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes into the timespec it is given.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime(CLOCK_THREAD_CPUTIME_ID)");
    ts.tv_sec as f64 + 1e-9 * ts.tv_nsec as f64
}

/// One run of one loop: its wall and CPU seconds for `sim_s` simulated, and the final
/// encoder count (none for the anchor, which has no encoder).
struct Timed {
    wall: f64,
    cpu: f64,
    sim_s: f64,
    final_count: Option<i64>,
}

impl Timed {
    /// Times `f`, which returns the final encoder count.
    fn of(sim_s: f64, f: impl FnOnce() -> i64) -> Timed {
        let (t, c) = (Instant::now(), thread_cpu());
        let count = f();
        Timed {
            wall: t.elapsed().as_secs_f64(),
            cpu: thread_cpu() - c,
            sim_s,
            final_count: Some(count),
        }
    }

    /// Simulated seconds per CPU second.
    fn speed(&self) -> f64 {
        self.sim_s / self.cpu
    }

    fn print(&self, what: &str, note: &str) {
        println!(
            "  {what:<34} {:>7.3} s CPU {:>7.3} s wall | {:>6.0}x real time (CPU; {:>5.0}x wall) | {:>6.2} us CPU per 2 ms step | {note}",
            self.cpu,
            self.wall,
            self.speed(),
            self.sim_s / self.wall,
            self.cpu / (self.sim_s / H) * 1e6,
        );
    }
}

/// The master's loop, `inchworm run`'s, over `sim_s`: rows streamed to a sink (here
/// keeping the last). Loading and initialising the system (unzipping the FMUs, which in
/// CI's `dist/` carry every platform's library, instantiating, initialisation mode) are
/// timed apart, since the FMPy loop leaves its own out too; their wall seconds come second.
fn master_loop(ssp: &Path, opts: &Options, sim_s: f64) -> (Timed, f64) {
    let start = Instant::now();
    let sim = System::load(ssp).and_then(|s| s.initialise(opts)).expect("system");
    let setup = start.elapsed().as_secs_f64();
    let timed = Timed::of(sim_s, || {
        let mut last = 0.0;
        sim.run_into(
            |_, row| {
                last = row[0];
                Ok::<(), inchworm_cosim::Error>(())
            },
            |_| {},
        )
        .expect("master run");
        last as i64
    });
    (timed, setup)
}

/// The crates coupled directly over `seconds`.
fn direct_loop(s: &Scenario, controller: &Params, seconds: f64) -> i64 {
    let d = direct(PlantParams::fia20(), controller.clone(), |t| s.reference.value(0, t), seconds)
        .expect("direct run");
    *d.column(inchworm_scenarios::closed_loop::ENCODER_COUNTS).unwrap().last().unwrap() as i64
}

/// The FMPy loop, or why it did not run.
fn fmpy(root: &Path, dist: &Path) -> Result<Timed, String> {
    let python = root.join(".venv/bin/python");
    if !python.is_file() {
        return Err(format!("{} missing (scripts/setup.sh makes it)", python.display()));
    }
    let out = Command::new(&python)
        .arg(root.join("benches/fmpy_jacobi.py"))
        .arg(dist)
        .arg(DURATION.to_string())
        .output()
        .map_err(|e| format!("{}: {e}", python.display()))?;
    if !out.status.success() {
        return Err(format!(
            "benches/fmpy_jacobi.py failed: {}",
            String::from_utf8_lossy(&out.stderr).lines().last().unwrap_or("")
        ));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let f: Vec<f64> = text.split_whitespace().skip(1).filter_map(|x| x.parse().ok()).collect();
    match f[..] {
        [sim_s, wall, count, cpu] => {
            Ok(Timed { wall, cpu, sim_s, final_count: Some(count as i64) })
        }
        _ => Err(format!("benches/fmpy_jacobi.py printed `{}`", text.trim())),
    }
}

/// The C Jacobi loop (`benches/fmu_jacobi.c`, compiled here with the system `cc`): the
/// same FMUs' FMI 2.0 libraries stepped by a plain loop in C, no master between; the
/// FMUs unpacked into temporary folders first (removed when it is dropped).
struct CLoop {
    exe: std::path::PathBuf,
    /// What the program reads on its standard input: libraries, GUIDs, value references.
    input: String,
    _unpacked: Vec<inchworm_fmi_import::archive::Unpacked>,
}

impl CLoop {
    fn new(root: &Path, dist: &Path) -> Result<CLoop, String> {
        use inchworm_fmi_import::archive;
        use inchworm_fmi_import::{ModelDescription, VarType};
        let exe = Path::new(env!("CARGO_TARGET_TMPDIR")).join("fmu_jacobi");
        let cc = Command::new("cc")
            .args(["-O2", "-std=c99", "-o"])
            .arg(&exe)
            .arg(root.join("benches/fmu_jacobi.c"))
            .arg("-ldl")
            .output()
            .map_err(|e| format!("cc: {e}"))?;
        if !cc.status.success() {
            return Err(format!("cc failed: {}", String::from_utf8_lossy(&cc.stderr)));
        }
        // This host's FMI 2.0 platform folder and library extension (`linux64`, `so`).
        let (folder, ext) = inchworm_fmi_import::fmi2_platform();
        let mut input = String::new();
        let mut unpacked = Vec::new();
        let mut descriptions = Vec::new();
        for name in ["InchwormPlant.fmu", "InchwormController.fmu"] {
            let path = dist.join(name);
            let text = archive::read_description(&path).map_err(|e| format!("{name}: {e}"))?;
            let md = ModelDescription::parse(&text).map_err(|e| format!("{name}: {e}"))?;
            let id = &md.co_simulation.as_ref().ok_or("no Co-Simulation")?.model_identifier;
            let u = archive::unpack_with(&path, &archive::Limits::DEFAULT)
                .map_err(|e| format!("{name}: {e}"))?;
            let lib = u.dir().join("binaries").join(folder).join(format!("{id}.{ext}"));
            let resources = u.dir().join("resources");
            input += &format!("{}\n{}\nfile://{}\n", lib.display(), md.guid, resources.display());
            unpacked.push(u);
            descriptions.push(md);
        }
        let vr = |md: &ModelDescription, name: &str, ty: VarType| -> Result<u32, String> {
            match md.variable(name) {
                Some(v) if v.ty == ty => Ok(v.vr),
                _ => Err(format!("{}: no {ty} variable {name}", md.model_name)),
            }
        };
        let (plant, ctrl) = (&descriptions[0], &descriptions[1]);
        use inchworm_fmu_models::{ControllerFmu as C, ControllerParams, PlantFmu as P};
        let dac = P::DAC_INPUTS.map(|v| v.name());
        let counts = P::ENCODER_COUNTS.name();
        for n in dac {
            input += &format!("{}\n", vr(plant, n, VarType::Real)?);
        }
        input += &format!("{}\n", vr(plant, counts, VarType::Integer)?);
        for n in dac {
            input += &format!("{}\n", vr(ctrl, n, VarType::Real)?);
        }
        input += &format!("{}\n", vr(ctrl, C::ENCODER_COUNTS.name(), VarType::Integer)?);
        input += &format!("{}\n", vr(ctrl, C::REFERENCE.name(), VarType::Real)?);
        let prefilter = C::var(ControllerParams::PREFILTER).name();
        input += &format!("{}\n", vr(ctrl, prefilter, VarType::Boolean)?);
        input += &format!("{DURATION}\n");
        Ok(CLoop { exe, input, _unpacked: unpacked })
    }

    /// One run of the loop over `DURATION`.
    fn run(&self) -> Result<Timed, String> {
        let exe = &self.exe;
        let (out, v) = run_program(exe, &self.input)?;
        match v[..] {
            [wall, cpu, count] if out.status.success() => {
                Ok(Timed { wall, cpu, sim_s: DURATION, final_count: Some(count as i64) })
            }
            _ => Err(format!(
                "{} failed ({}): {}",
                exe.display(),
                out.status,
                String::from_utf8_lossy(&out.stderr).trim()
            )),
        }
    }
}

/// Runs `exe` with `input` on its standard input: its output and the numbers it printed.
fn run_program(exe: &Path, input: &str) -> Result<(std::process::Output, Vec<f64>), String> {
    let mut child = Command::new(exe)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("{}: {e}", exe.display()))?;
    let stdin = child.stdin.take().expect("piped");
    (&stdin).write_all(input.as_bytes()).map_err(|e| e.to_string())?;
    drop(stdin);
    let out = child.wait_with_output().map_err(|e| e.to_string())?;
    let v = String::from_utf8_lossy(&out.stdout)
        .split_whitespace()
        .filter_map(|x| x.parse().ok())
        .collect();
    Ok((out, v))
}

/// The C anchor (`benches/rk4_anchor.c`): RK4 of the quiet plant over `RK4_SECONDS`, and
/// the exact propagation its end state is checked against.
struct Anchor {
    exe: std::path::PathBuf,
    input: String,
    exact: Vector,
}

impl Anchor {
    fn new(root: &Path) -> Result<Anchor, String> {
        let exe = Path::new(env!("CARGO_TARGET_TMPDIR")).join("rk4_anchor");
        let cc = Command::new("cc")
            .args(["-O3", "-march=native", "-std=c99", "-o"])
            .arg(&exe)
            .arg(root.join("benches/rk4_anchor.c"))
            .output()
            .map_err(|e| format!("cc: {e}"))?;
        if !cc.status.success() {
            return Err(format!("cc failed: {}", String::from_utf8_lossy(&cc.stderr)));
        }
        let p = PlantParams::fia20();
        // HOLD, every hysteresis element sticking: the quiet step's system.
        let a = system_matrix(&p, Mode::Hold, p.play_weight.iter().sum());
        // From rest, the extension channel commanded to 5 V: the stack's ringing transient.
        let mut z0 = Vector::zeros();
        z0[ix::ONE] = 1.0;
        z0[ix::UX] = 5.0;
        let steps = (RK4_SECONDS / RK4_STEP).round() as u64;
        let mut input = String::new();
        for i in 0..N {
            for j in 0..N {
                input += &format!("{:e} ", a[(i, j)]);
            }
        }
        for v in z0.iter() {
            input += &format!("{v:e} ");
        }
        input += &format!("{RK4_STEP:e} {steps}\n");
        // The exact propagation: e^{A 2 ms} applied once per 2 ms step.
        let phi: Matrix = (a * H).exp();
        let mut exact = z0;
        for _ in 0..(RK4_SECONDS / H).round() as u64 {
            exact = phi * exact;
        }
        Ok(Anchor { exe, input, exact })
    }

    /// One run: its times and the largest deviation of its end state from the exact
    /// propagation, relative to the state's size.
    fn run(&self) -> Result<(Timed, f64), String> {
        let exe = &self.exe;
        let (out, v) = run_program(exe, &self.input)?;
        if !out.status.success() || v.len() != N + 2 {
            return Err(format!("{} failed ({})", exe.display(), out.status));
        }
        let z = &self.exact;
        let dev = (0..N).map(|i| (v[i + 2] - z[i]).abs()).fold(0.0, f64::max) / z.amax();
        Ok((Timed { wall: v[0], cpu: v[1], sim_s: RK4_SECONDS, final_count: None }, dev))
    }
}

fn main() {
    // The package is the workspace root: dist/ and .venv/ live there.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dist = root.join("dist");
    let ssp = dist.join("InchwormSystemOpen.ssp");
    assert!(ssp.is_file(), "build the FMUs and the SSP first: cargo run --release -p fmu-build");
    let load_before = load_average();
    let s = scenario::by_name("staircase").expect("a scenario");
    let controller = Params { prefilter: true, ..Params::default() };
    // The staircase scenario's options, cut to 600 s and to the one column compared, so
    // the master records no more than the FMPy loop does.
    let mut opts = s.options(&PlantParams::fia20(), &controller);
    opts.stop_time = Some(DURATION);
    opts.outputs = vec![inchworm_scenarios::closed_loop::ENCODER_COUNTS.into()];

    if let Ok(only) = std::env::var("CLOSED_LOOP_ONLY") {
        let seconds: f64 = std::env::var("CLOSED_LOOP_SECONDS")
            .map(|v| v.parse().expect("CLOSED_LOOP_SECONDS: seconds"))
            .unwrap_or(DURATION);
        opts.stop_time = Some(seconds);
        let t = match only.as_str() {
            "master" => master_loop(&ssp, &opts, seconds).0,
            "direct" => Timed::of(seconds, || direct_loop(&s, &controller, seconds)),
            _ => panic!("CLOSED_LOOP_ONLY: master or direct, not `{only}`"),
        };
        t.print(&only, &format!("final encoder {}", t.final_count.expect("a count")));
        return;
    }

    let keep_best = |best: &mut Option<Timed>, t: Timed| {
        if best.as_ref().is_none_or(|b| t.cpu < b.cpu) {
            *best = Some(t);
        }
    };
    let (c_prepared, anchor_prepared) = (CLoop::new(root, &dist), Anchor::new(root));
    let (mut master, mut coupled, mut setup) = (None, None, f64::INFINITY);
    let (mut c_best, mut anchor_best) = (None, None);
    let (mut c_error, mut anchor_error, mut deviation) = (None, None, 0.0f64);
    // The four loops in turn, so a busy spell of the machine falls on all of them alike.
    for _ in 0..REPEATS {
        let (t, load) = master_loop(&ssp, &opts, DURATION);
        keep_best(&mut master, t);
        setup = setup.min(load);
        keep_best(&mut coupled, Timed::of(DURATION, || direct_loop(&s, &controller, DURATION)));
        match c_prepared.as_ref().map_err(Clone::clone).and_then(CLoop::run) {
            Ok(t) => keep_best(&mut c_best, t),
            Err(why) => c_error = Some(why),
        }
        match anchor_prepared.as_ref().map_err(Clone::clone).and_then(Anchor::run) {
            Ok((t, dev)) => {
                deviation = deviation.max(dev);
                keep_best(&mut anchor_best, t);
            }
            Err(why) => anchor_error = Some(why),
        }
    }
    let (master, coupled) = (master.expect("runs"), coupled.expect("runs"));
    let c_loop = c_error.map_or_else(|| c_best.ok_or_else(|| "no run".to_string()), Err);
    let anchor = anchor_error.map_or_else(
        || anchor_best.map(|t| (t, deviation)).ok_or_else(|| "no run".to_string()),
        Err,
    );
    let fmpy = fmpy(root, &dist);
    let load_after = load_average();

    println!(
        "closed loop, {DURATION:.0} s of the Figs. 6-7 staircase, prefilter on, 2 ms Jacobi (master, direct, C loop and anchor: best of {REPEATS} alternating runs; FMPy: one)"
    );
    let count = |t: &Timed| format!("final encoder {}", t.final_count.expect("a count"));
    master.print(
        "Rust master, both FMUs (SSP)",
        &format!("{}; loading and initialising apart: {:.1} ms wall", count(&master), setup * 1e3),
    );
    coupled.print("crates coupled directly (no FMI)", &count(&coupled));
    match &c_loop {
        Ok(c) => c.print("C Jacobi loop, same FMUs", &count(c)),
        Err(why) => println!("  C Jacobi loop: not run: {why}"),
    }
    match &fmpy {
        Ok(f) => f.print("FMPy Jacobi loop, same FMUs", &count(f)),
        Err(why) => println!("  FMPy Jacobi loop: not run: {why}"),
    }
    match &anchor {
        Ok((a, dev)) => a.print(
            "C RK4 anchor (quiet plant, 5 us)",
            &format!(
                "{RK4_SECONDS:.0} s simulated, end state within {dev:.1e} of the exact propagation"
            ),
        ),
        Err(why) => println!("  C RK4 anchor: not run: {why}"),
    }
    println!("ratios (CPU time; wall time in brackets):");
    println!(
        "  master: {:.0}x real time, {:.2} of the 5000x target; {:.2} us per step more than the direct coupling, {:.2}x its time ({:.2}x)",
        master.speed(),
        master.speed() / 5000.0,
        (master.cpu - coupled.cpu) / (DURATION / H) * 1e6,
        master.cpu / coupled.cpu,
        master.wall / coupled.wall
    );
    if let Ok(c) = &c_loop {
        println!(
            "  master vs the C Jacobi loop: {:.2}x its time ({:.2}x), {:+.3} us per step; C loop: {:.0}x real time, {:.2} of the 5000x target",
            master.cpu / c.cpu,
            master.wall / c.wall,
            (master.cpu - c.cpu) / (DURATION / H) * 1e6,
            c.speed(),
            c.speed() / 5000.0
        );
    }
    if let Ok(f) = &fmpy {
        println!(
            "  master vs the FMPy loop: {:.1}x faster ({:.1}x), target 15x",
            master.speed() / f.speed(),
            f.wall / master.wall
        );
    }
    if let Ok((a, _)) = &anchor {
        println!(
            "  master (both FMUs, events and all) vs the C RK4 of the quiet plant alone: {:.1}x faster per simulated second ({:.1}x); target 100x (a master step at most 0.01 of the anchor's)",
            master.speed() / a.speed(),
            (a.wall / a.sim_s) / (master.wall / master.sim_s)
        );
        if let Ok(c) = &c_loop {
            println!(
                "  C Jacobi loop vs the C RK4 anchor: {:.1}x faster per simulated second ({:.1}x)",
                c.speed() / a.speed(),
                (a.wall / a.sim_s) / (c.wall / c.sim_s)
            );
        }
    }
    println!("machine load average (1, 5, 15 min): {load_before} before, {load_after} after");

    if let Ok(f) = &fmpy {
        assert_eq!(f.final_count, master.final_count, "FMPy and the Rust master disagree");
    }
    if let Ok(c) = &c_loop {
        assert_eq!(c.final_count, master.final_count, "the C loop and the Rust master disagree");
    }
    assert_eq!(
        master.final_count, coupled.final_count,
        "the master and the direct coupling disagree"
    );
    if let Ok((_, dev)) = anchor {
        assert!(dev < 1e-6, "the C RK4 anchor strays from the exact propagation: {dev:e}");
    }
}
