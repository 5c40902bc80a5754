//! The HIL bridge with the packaged FMUs: the controller FMU on the controller side, the
//! plant FMU in the virtual board, over UDP loopback. In lock-step the encoder trace is the
//! co-simulation's (the master on `InchwormSystem.ssp`, Jacobi) sample for sample; the `inchworm`
//! binary does the same as two processes, with the FMI 2.0 controller through
//! Co-Simulation and the FMI 3.0 one through Scheduled Execution; `inchworm replay` finds
//! no divergence in its log and finds a changed one.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use inchworm::bridge::FmuCompensator;
use inchworm::closed_loop::{recorded, LoopView, REFERENCE};
use inchworm::master::{self, Coupling, InputTable, Options};
use inchworm_bridge::runlog::{read_log, LogWriter, Record, MAGIC};

#[path = "support/lockstep.rs"]
mod lockstep;

#[path = "support/real_time.rs"]
mod real_time;
use real_time::{turn, RealTime};

const BIN: &str = env!("CARGO_BIN_EXE_inchworm");

use inchworm_dist::path as fmu;

/// The closed loop through the FMUs by the master, the reference `rows` held piecewise
/// constant, as the bridge runs it.
fn cosimulation(rows: &[(f64, f64)], seconds: f64) -> LoopView {
    let opts = Options {
        stop_time: Some(seconds),
        step_size: Some(0.002),
        coupling: Coupling::Jacobi,
        params: vec![],
        parameter_set: None,
        input: Some(InputTable::steps(REFERENCE, rows).unwrap()),
        outputs: recorded(),
    };
    LoopView::new(&master::run(&fmu("InchwormSystemOpen.ssp"), &opts, |_| {}).unwrap()).unwrap()
}

fn reference(t: f64) -> f64 {
    if t < 2.0 {
        100e-6
    } else {
        40e-6
    }
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("iw-bridge-fmu-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn lockstep_bridge_with_the_fmus_reproduces_the_cosimulation_exactly() {
    let _rt = RealTime::enter();
    let seconds = 4.0;
    let cosim = cosimulation(&[(0.0, 100e-6), (2.0, 40e-6)], seconds);

    let dir = scratch("lockstep");
    let log_path = dir.join("controller.log");
    let mut comp = FmuCompensator::load(&fmu("InchwormController.fmu"), &[]).unwrap();
    let ticks = (seconds / 0.002) as u64;
    let (report, _) =
        lockstep::lockstep(&fmu("InchwormPlant.fmu"), &mut comp, &reference, ticks, &log_path);

    let bridge: Vec<i64> = report.encoder.iter().map(|&c| i64::from(c)).collect();
    assert_eq!(bridge.len(), cosim.encoder_counts.len());
    let first = bridge.iter().zip(&cosim.encoder_counts).position(|(a, b)| a != b);
    assert_eq!(
        first, None,
        "the bridge's encoder trace leaves the co-simulation's at sample {first:?}"
    );
    assert!(cosim.settle_time(1e-6).is_some(), "the scenario moves and settles");

    // The log replays through a fresh controller FMU without a single divergent code.
    let out = Command::new(BIN)
        .args([
            "replay",
            log_path.to_str().unwrap(),
            "--fmu",
            fmu("InchwormController.fmu").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{text}");
    assert!(
        text.contains(&format!("replayed {} samples", ticks)) && text.contains("no divergence"),
        "{text}"
    );
    // Meta, the samples, the DISARM event and the end record.
    assert!(
        text.contains(&format!(
            "{} complete records ({} controller samples, 1 events); end record: completed: {} ticks, disarmed",
            ticks + 3,
            ticks,
            ticks
        )),
        "{text}"
    );

    // A log whose encoder counts were changed (CRCs recomputed, so it reads as intact)
    // replays with divergences, and the command says where.
    let contents = read_log(&log_path).unwrap();
    let mut w = LogWriter::create(&dir.join("changed.log")).unwrap();
    for r in contents.records {
        let r = match r {
            Record::Controller(mut s) if (500..600).contains(&s.tick) => {
                s.counts += 200;
                Record::Controller(s)
            }
            other => other,
        };
        w.write(&r).unwrap();
    }
    drop(w);
    let out = Command::new(BIN)
        .args([
            "replay",
            dir.join("changed.log").to_str().unwrap(),
            "--fmu",
            fmu("InchwormController.fmu").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!out.status.success());
    assert!(text.contains("samples diverge; first at tick"), "{text}");

    // A log cut short by a crash replays what is whole and says it is not the whole run:
    // cut inside the end record, and cut exactly at the boundary before it.
    let bytes = std::fs::read(&log_path).unwrap();
    assert!(bytes.starts_with(MAGIC));
    let end_len = 3 + 4 + "completed: 2000 ticks, disarmed".len() + 4;
    let boundary = bytes.len() - end_len;
    for (name, cut, says) in [
        ("cut.log", bytes.len() - 7, format!("then a record cut short at byte {boundary}")),
        ("boundary.log", boundary, "; no end record".to_string()),
    ] {
        std::fs::write(dir.join(name), &bytes[..cut]).unwrap();
        let out = Command::new(BIN)
            .args([
                "replay",
                dir.join(name).to_str().unwrap(),
                "--fmu",
                fmu("InchwormController.fmu").to_str().unwrap(),
            ])
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout).to_string()
            + &String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(3), "{name}: {text}");
        assert!(
            text.contains("2002 complete records (2000 controller samples, 1 events)"),
            "{name}: {text}"
        );
        assert!(text.contains(&says), "{name}: {text}");
        assert!(text.contains("no end record: the run did not finish cleanly"), "{name}: {text}");
        assert!(text.contains("exit status 3: the log is incomplete"), "{name}: {text}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_bridge_as_two_processes_gives_the_cosimulation_trace() {
    let _rt = RealTime::enter();
    let seconds = 3.0;
    let ticks = (seconds / 0.002) as usize;
    // The reference from a CSV, as an operator gives it: 100 µm, then 40 µm from 1.5 s.
    let cosim = cosimulation(&[(0.0, 100e-6), (1.5, 40e-6)], seconds);
    let port = std::net::UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let addr = format!("127.0.0.1:{port}");
    let dir = scratch("processes");
    // Two sessions, each from the plant's start: the FMI 2.0 controller (Co-Simulation),
    // then the FMI 3.0 one, which `--interface auto` drives through Scheduled Execution.
    let board = Command::new(BIN)
        .args([
            "bridge",
            "--role",
            "board",
            "--lockstep",
            "--fresh-plant-per-session",
            "--watchdog",
            "50",
            "--addr",
            &addr,
            "--fmu",
            fmu("InchwormPlant.fmu").to_str().unwrap(),
        ])
        .args(["--log", dir.join("board.log").to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let reference = dir.join("reference.csv");
    std::fs::write(&reference, "time,reference\n0,100e-6\n1.5,40e-6\n").unwrap();
    let controller = |controller: &str, csv: &Path, log: &Path| {
        let out = Command::new(BIN)
            .args([
                "bridge",
                "--role",
                "controller",
                "--lockstep",
                "--addr",
                &addr,
                "--duration",
                &seconds.to_string(),
            ])
            .args(["--reference", reference.to_str().unwrap()])
            .args(["--fmu", fmu(controller).to_str().unwrap(), "--out", csv.to_str().unwrap()])
            .args(["--log", log.to_str().unwrap()])
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout).to_string()
            + &String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{text}");
        let counts: Vec<i64> = std::fs::read_to_string(csv)
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
            .collect();
        (counts, text)
    };
    let (cs, cs_text) =
        controller("InchwormController.fmu", &dir.join("cs.csv"), &dir.join("cs.log"));
    let (se, se_text) =
        controller("fmi3/InchwormController.fmu", &dir.join("se.csv"), &dir.join("se.log"));
    // SIGTERM: the board stops at its next period and flushes its log.
    unsafe { libc::kill(board.id() as i32, libc::SIGTERM) };
    let board_out = board.wait_with_output().unwrap();
    let board_text = String::from_utf8_lossy(&board_out.stdout).to_string()
        + &String::from_utf8_lossy(&board_out.stderr);
    assert!(board_out.status.success(), "{board_text}");
    assert!(board_text.contains(&format!("board: {} steps", 2 * ticks)), "{board_text}");
    assert!(cs_text.contains("(Co-Simulation, a 2 ms step every tick)"), "{cs_text}");
    assert!(se_text.contains("(Scheduled Execution, sample_clock every tick)"), "{se_text}");
    assert_eq!(cs, cosim.encoder_counts, "Co-Simulation");
    assert_eq!(se, cosim.encoder_counts, "Scheduled Execution");
    // The board's log holds one sample per step, each with the codes it applied.
    let log = read_log(&dir.join("board.log")).unwrap();
    let samples = log.records.iter().filter(|r| matches!(r, Record::Board(_))).count();
    assert_eq!(samples, 2 * ticks);

    // The Scheduled Execution run logged every tick of gait_step (clockUpdate) as an
    // event, and its log replays through either interface without a divergence.
    let se_log = read_log(&dir.join("se.log")).unwrap();
    let clocks = se_log
        .records
        .iter()
        .filter(
            |r| matches!(r, Record::Event { text, .. } if text == "output clock gait_step ticked"),
        )
        .count();
    assert!(clocks >= 3, "the gait ran: {clocks} gait steps");
    assert!(
        se_text.contains(&format!("output clock ticks: {clocks} (each an event of the run log)")),
        "{se_text}"
    );
    assert!(
        se_log.records.iter().any(|r| matches!(r, Record::Meta(m) if m.contains("interface=se\n"))),
        "the meta record names the interface"
    );
    for (controller, interface) in
        [("fmi3/InchwormController.fmu", "se"), ("InchwormController.fmu", "cs")]
    {
        let out = Command::new(BIN)
            .args(["replay", dir.join("se.log").to_str().unwrap()])
            .args(["--fmu", fmu(controller).to_str().unwrap()])
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout).to_string()
            + &String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{interface}: {text}");
        assert!(
            text.contains(&format!(
                "replayed {ticks} samples ({} events, 0 discontinuities)",
                clocks + 1
            )) && text.contains(&format!("({interface})"))
                && text.contains("no divergence"),
            "{interface}: {text}"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_bridge_arguments_are_refused_clearly() {
    let _turn = turn();
    let run = |args: &[&str]| {
        let out = Command::new(BIN).args(args).output().unwrap();
        assert!(!out.status.success(), "{args:?}");
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    let e = run(&[
        "bridge",
        "--role",
        "board",
        "--fmu",
        "/nonexistent/Plant.fmu",
        "--addr",
        "127.0.0.1:0",
    ]);
    assert!(e.contains("/nonexistent/Plant.fmu"), "{e}");
    let e = run(&[
        "bridge",
        "--role",
        "controller",
        "--addr",
        "no-such-host.invalid:1",
        "--duration",
        "1",
    ]);
    assert!(e.contains("board address no-such-host.invalid:1"), "{e}");
    let e = run(&["bridge", "--role", "board", "--param", "F_d0", "--addr", "127.0.0.1:0"]);
    assert!(e.contains("--param F_d0: expected NAME=VALUE"), "{e}");
    let e = run(&[
        "bridge",
        "--role",
        "board",
        "--param",
        "no_such=1",
        "--addr",
        "127.0.0.1:0",
        "--fmu",
        fmu("InchwormPlant.fmu").to_str().unwrap(),
    ]);
    assert!(e.contains("no_such"), "{e}");
    let e = run(&["bridge", "--role", "controller", "--overrun", "maybe"]);
    assert!(e.contains("overrun policy `maybe`"), "{e}");
    // Refused before anything starts, naming the flag and the range, not a panicking
    // thread (inf) nor an immediate success (negative, zero).
    for role in ["board", "controller"] {
        for d in ["inf", "NaN", "-5", "0", "-inf", "1e10", "soon"] {
            let e = run(&["bridge", "--role", role, "--addr", "127.0.0.1:9", "--duration", d]);
            assert!(
                e.contains(&format!("invalid value '{d}' for '--duration <DURATION>'"))
                    && e.contains("--duration takes a finite number of seconds, 0 < D ≤ 1e9"),
                "{role} {d}: {e}"
            );
        }
    }
    let e = run(&["bridge", "--role", "controller", "--allow", "127.0.0.1"]);
    assert!(e.contains("--allow and --fresh-plant-per-session are board options"), "{e}");
    let e = run(&["bridge", "--role", "board", "--allow", "localhost"]);
    assert!(e.contains("--allow localhost: expected an IP address"), "{e}");
    let dir = scratch("args");
    std::fs::write(dir.join("x.log"), b"not a log").unwrap();
    let e = run(&["replay", dir.join("x.log").to_str().unwrap()]);
    assert!(e.contains("not an inchworm bridge log"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_killed_controller_leaves_a_readable_log_the_board_safe_and_a_restart_gets_in() {
    let _rt = RealTime::enter();
    // Real time, two processes. The controller is killed (SIGKILL: no clean-up at all)
    // once its log holds 250 samples (an event, not a guess at how long start-up takes):
    // its log must read back whole up to the kill, lack at most the one DAC frame that was
    // on the wire (docs/hil-protocol.md, "Run log"), and replay without divergence; the
    // board must latch its safe state within its watchdog's 25 periods of silence (50 ms:
    // room for a machine with every core busy, where even a SCHED_FIFO loop can wake
    // milliseconds late), and a controller started again at once must get a new session
    // from the same board.
    let port = std::net::UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let addr = format!("127.0.0.1:{port}");
    let dir = scratch("killed");
    let board = Command::new(BIN)
        .args([
            "bridge",
            "--role",
            "board",
            "--addr",
            &addr,
            "--duration",
            "30",
            "--watchdog",
            "25",
            "--fmu",
            fmu("InchwormPlant.fmu").to_str().unwrap(),
        ])
        .args(["--log", dir.join("board.log").to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let log = dir.join("controller.log");
    let mut controller = controller_process(&addr, "30", &[], Some(&log)).spawn().unwrap();
    wait_for_samples(&log, 250, &mut controller);
    controller.kill().unwrap();
    controller.wait().unwrap();
    let restart = controller_process(&addr, "0.5", &[], None).output().unwrap();
    let restart_text = String::from_utf8_lossy(&restart.stdout).to_string()
        + &String::from_utf8_lossy(&restart.stderr);
    assert!(restart.status.success(), "{restart_text}");
    assert!(restart_text.contains("250 ticks in"), "{restart_text}");
    unsafe { libc::kill(board.id() as i32, libc::SIGTERM) };
    let board_out = wait_bounded(board, std::time::Duration::from_secs(30));
    let board_text = String::from_utf8_lossy(&board_out.stdout).to_string()
        + &String::from_utf8_lossy(&board_out.stderr);
    assert!(board_out.status.success(), "{board_text}");
    let latch = board_text
        .lines()
        .find(|l| l.starts_with("safe state at tick"))
        .unwrap_or_else(|| panic!("no latch reported:\n{board_text}"));
    assert!(latch.contains("(25 periods after the last valid frame): Silence"), "{latch}");
    assert!(board_text.contains("\nsessions: 2\n"), "{board_text}");
    assert!(
        board_text.contains(
            "1 ARM; ended: safe state latched: Silence: no valid DAC frame for 25 periods (watchdog)\n"
        ),
        "{board_text}"
    );

    let contents = read_log(&log).unwrap();
    let seqs: Vec<u16> = contents
        .records
        .iter()
        .filter_map(|r| if let Record::Controller(c) = r { Some(c.seq) } else { None })
        .collect();
    assert!(seqs.len() >= 250, "{} samples logged before the kill", seqs.len());
    assert!(!contents.complete());
    // The newest DAC frame the board took in session 1 is at most one past the newest
    // sample in the controller's log: the kill lost at most the frame in flight.
    let board_log = read_log(&dir.join("board.log")).unwrap();
    let board_seq = board_log
        .records
        .iter()
        .take_while(|r| !matches!(r, Record::Event { text, .. } if text.starts_with("session 2:")))
        .filter_map(|r| if let Record::Board(b) = r { Some(b.dac_seq) } else { None })
        .max()
        .unwrap();
    let logged = *seqs.last().unwrap();
    assert!(
        board_seq == logged || board_seq == logged.wrapping_add(1),
        "the board took DAC frame {board_seq}, the controller's log ends at {logged}"
    );
    let out = Command::new(BIN)
        .args([
            "replay",
            log.to_str().unwrap(),
            "--fmu",
            fmu("InchwormController.fmu").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{text}");
    assert!(text.contains("no end record: the run did not finish cleanly"), "{text}");
    assert!(text.contains("no divergence in the samples there are"), "{text}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Waits (bounded) until the run log at `path` of the running `controller` holds `n`
/// controller samples; fails with the controller's output if it exits first.
fn wait_for_samples(path: &Path, n: usize, controller: &mut std::process::Child) {
    let t0 = std::time::Instant::now();
    loop {
        let got = read_log(path)
            .map_or(0, |c| c.records.iter().filter(|r| matches!(r, Record::Controller(_))).count());
        if got >= n {
            return;
        }
        if let Some(status) = controller.try_wait().unwrap() {
            let mut text = String::new();
            if let Some(mut out) = controller.stdout.take() {
                let _ = std::io::Read::read_to_string(&mut out, &mut text);
            }
            if let Some(mut err) = controller.stderr.take() {
                let _ = std::io::Read::read_to_string(&mut err, &mut text);
            }
            panic!("the controller exited ({status}) after {got} of {n} samples:\n{text}");
        }
        assert!(t0.elapsed() < std::time::Duration::from_secs(30), "{got} of {n} samples in 30 s");
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
}

/// `inchworm bridge --role controller` in real time against `addr`, with room in the
/// dead-link limit for a machine busy with other builds.
fn controller_process(addr: &str, duration: &str, extra: &[&str], log: Option<&Path>) -> Command {
    let mut c = Command::new(BIN);
    c.args(["bridge", "--role", "controller", "--addr", addr, "--duration", duration])
        .args(["--dead-after", "25", "--fmu", fmu("InchwormController.fmu").to_str().unwrap()])
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    if let Some(l) = log {
        c.args(["--log", l.to_str().unwrap()]);
    }
    c
}

/// Waits up to `limit` for `child` to exit; kills it (and fails) if it does not.
fn wait_bounded(
    mut child: std::process::Child,
    limit: std::time::Duration,
) -> std::process::Output {
    let t0 = std::time::Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t0.elapsed() > limit {
            let _ = child.kill();
            let out = child.wait_with_output().unwrap();
            panic!(
                "the process did not exit within {limit:?}:\n{}{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

#[test]
fn one_board_serves_a_stray_three_sessions_and_a_killed_controllers_restart() {
    let _rt = RealTime::enter();
    // A board started once, in real time, serves a stray datagram, three controller runs
    // in a row, a controller killed with SIGKILL and its immediate restart, none of which
    // may lock a later controller out.
    use std::io::BufRead;
    let port = std::net::UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let addr = format!("127.0.0.1:{port}");
    let dir = scratch("acceptance");
    let board_log = dir.join("board.log");
    let mut board = Command::new(BIN)
        .args(["bridge", "--role", "board", "--addr", &addr, "--duration", "60"])
        .args(["--watchdog", "25", "--fmu", fmu("InchwormPlant.fmu").to_str().unwrap()])
        .args(["--log", board_log.to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The board's socket is bound before it prints its first line; the stray must arrive
    // after that to be counted.
    let mut stdout = std::io::BufReader::new(board.stdout.take().unwrap());
    let mut first = String::new();
    stdout.read_line(&mut first).unwrap();
    assert!(first.starts_with("virtual board:"), "{first}");
    let rest = std::thread::spawn(move || {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut stdout, &mut s).unwrap();
        s
    });
    let stray = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    stray.send_to(b"a stray datagram", &addr).unwrap();

    let limit = std::time::Duration::from_secs(30);
    for run in 1..=3 {
        let out = wait_bounded(controller_process(&addr, "0.5", &[], None).spawn().unwrap(), limit);
        let text = String::from_utf8_lossy(&out.stdout).to_string()
            + &String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "run {run}: {text}");
        assert!(text.contains("250 ticks in"), "run {run}: {text}");
    }
    let killed_log = dir.join("killed.log");
    let mut killed = controller_process(&addr, "30", &[], Some(&killed_log)).spawn().unwrap();
    // Killed once it is well into its run: 100 samples logged (bounded wait).
    wait_for_samples(&killed_log, 100, &mut killed);
    killed.kill().unwrap();
    killed.wait().unwrap();
    let out = wait_bounded(controller_process(&addr, "0.5", &[], None).spawn().unwrap(), limit);
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "restart: {text}");
    assert!(text.contains("250 ticks in"), "restart: {text}");

    unsafe { libc::kill(board.id() as i32, libc::SIGTERM) };
    let board_out = wait_bounded(board, limit);
    let text = rest.join().unwrap() + &String::from_utf8_lossy(&board_out.stderr);
    assert!(board_out.status.success(), "{text}");
    let summary: Vec<&str> = text
        .lines()
        .filter(|l| {
            l.starts_with("session") || l.starts_with("source") || l.starts_with("safe state")
        })
        .collect();
    assert_eq!(summary[0], "sessions: 5", "{text}");
    let disarmed = "1 ARM; ended: disarmed";
    let silence = "Silence: no valid DAC frame for 25 periods (watchdog)";
    for (i, end) in [
        disarmed.to_string(),
        disarmed.to_string(),
        disarmed.to_string(),
        format!("1 ARM; ended: safe state latched: {silence}"),
        "1 ARM; open at the board's stop (disarmed)".to_string(),
    ]
    .iter()
    .enumerate()
    {
        let line = summary[i + 1];
        assert!(
            line.starts_with(&format!("session {}: controller 127.0.0.1:", i + 1))
                && line.ends_with(end),
            "session {}: {line}\n{text}",
            i + 1
        );
    }
    let peer5 = summary[5].split(' ').nth(3).unwrap();
    let stray_line = format!(
        "source {}: 1 malformed, 0 foreign, 0 HELLO refused, 0 not allowed",
        stray.local_addr().unwrap()
    );
    let sources: Vec<&str> = summary.iter().copied().filter(|l| l.starts_with("source")).collect();
    assert!(sources.contains(&stray_line.as_str()), "{text}");
    // The restart may have raced the old session's watchdog (50 ms): then its early HELLOs
    // were refused, and only those.
    for l in sources.iter().filter(|l| **l != stray_line) {
        assert!(
            l.starts_with(&format!("source {peer5}: 0 malformed, 0 foreign, "))
                && l.ends_with(" HELLO refused, 0 not allowed")
                && sources.len() == 2,
            "{l}\n{text}"
        );
    }
    let latches: Vec<&str> =
        summary.iter().copied().filter(|l| l.starts_with("safe state")).collect();
    assert_eq!(latches.len(), 1, "one latch, the killed controller's:\n{text}");
    assert!(
        latches[0].ends_with(&format!("(25 periods after the last valid frame): {silence}")),
        "{text}"
    );
    assert!(text.contains("final state Disarmed"), "{text}");

    // The board's log holds the same summary and ends in order.
    let log = read_log(&board_log).unwrap();
    assert!(log.complete(), "{:?}", log.end());
    let events: Vec<String> = log
        .records
        .iter()
        .filter_map(|r| if let Record::Event { text, .. } = r { Some(text.clone()) } else { None })
        .collect();
    for line in summary.iter().filter(|l| !l.starts_with("safe state")) {
        assert!(events.iter().any(|e| e == line), "{line} not in the board log");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn without_real_time_privileges_the_bridge_warns_and_runs() {
    let _turn = turn();
    // No CAP_SYS_NICE / CAP_IPC_LOCK, an rtprio limit of 0 and a 64 KiB memlock limit: both
    // requests are refused, each with a warning, and the real-time loop runs anyway.
    // SAFETY: geteuid has no preconditions.
    let root = unsafe { libc::geteuid() } == 0;
    let unprivileged = |args: &[&str]| {
        let mut c = Command::new("prlimit");
        c.args(["--rtprio=0", "--memlock=65536:65536"]);
        if root {
            // Root keeps both capabilities whatever the limits say: drop them for the child.
            c.args([
                "setpriv",
                "--bounding-set=-sys_nice,-ipc_lock",
                "--inh-caps=-sys_nice,-ipc_lock",
            ]);
        }
        c.arg(BIN).args(args);
        c
    };
    let port = std::net::UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let addr = format!("127.0.0.1:{port}");
    // Under the default scheduler a machine with every core busy stalls these loops for
    // tens of milliseconds (that is what the privileges are for): the watchdog and the
    // dead-link limit get 500 ms, since the subject here is the set-up. The board runs
    // until it is told to stop, after the controller's run, however long start-up takes.
    let board = unprivileged(&[
        "bridge",
        "--role",
        "board",
        "--addr",
        &addr,
        "--duration",
        "60",
        "--watchdog",
        "250",
        "--fmu",
        fmu("InchwormPlant.fmu").to_str().unwrap(),
    ])
    .stdout(Stdio::piped())
    .stderr(Stdio::piped())
    .spawn()
    .expect("prlimit and setpriv (util-linux)");
    let out = unprivileged(&[
        "bridge",
        "--role",
        "controller",
        "--addr",
        &addr,
        "--duration",
        "1",
        "--dead-after",
        "250",
        "--fmu",
        fmu("InchwormController.fmu").to_str().unwrap(),
    ])
    .output()
    .unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    // prlimit execs setpriv, which execs the board: the pid is the board's.
    unsafe { libc::kill(board.id() as i32, libc::SIGTERM) };
    let board_out = wait_bounded(board, std::time::Duration::from_secs(30));
    let board_text = String::from_utf8_lossy(&board_out.stdout).to_string()
        + &String::from_utf8_lossy(&board_out.stderr);
    for t in [&text, &board_text] {
        assert!(t.contains("warning: memory not locked (mlockall:"), "{t}");
        assert!(t.contains("warning: SCHED_FIFO priority 80 refused"), "{t}");
    }
    assert!(out.status.success(), "{text}");
    assert!(text.contains("500 ticks in"), "{text}");
    assert!(
        board_out.status.success() && board_text.contains("final state Disarmed"),
        "{board_text}"
    );
}

/// The run log and the CSV are checked before any work: neither may be an input (the FMU,
/// the reference table) or the other, and a refused run leaves every file as it was, with
/// no temporary beside it. A failed run (no board answers) leaves an earlier log as it
/// was.
#[test]
fn a_log_or_csv_over_an_input_or_each_other_is_refused_before_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let reference = d.join("reference.csv");
    std::fs::write(&reference, "time,reference\n0,100e-6\n").unwrap();
    let old_log = d.join("old.log");
    std::fs::write(&old_log, "an earlier run's log").unwrap();
    let fmu_copy = d.join("InchwormController.fmu");
    std::fs::copy(fmu("InchwormController.fmu"), &fmu_copy).unwrap();
    let fmu_bytes = std::fs::read(&fmu_copy).unwrap();
    let log = std::ffi::OsStr::new("--log");
    let csv = std::ffi::OsStr::new("--out");
    let cases: [(Vec<&std::ffi::OsStr>, &str); 3] = [
        (vec![log, fmu_copy.as_os_str()], "would overwrite the input"),
        (vec![log, reference.as_os_str()], "would overwrite the input"),
        (vec![log, old_log.as_os_str(), csv, old_log.as_os_str()], "written over each other"),
    ];
    for (extra, says) in cases {
        let out = Command::new(BIN)
            .args(["bridge", "--role", "controller", "--lockstep", "--addr", "127.0.0.1:9"])
            .args(["--duration", "0.1"])
            .arg("--fmu")
            .arg(&fmu_copy)
            .arg("--reference")
            .arg(&reference)
            .args(&extra)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && stderr.contains(says), "{extra:?}: {stderr}");
    }
    let failed = Command::new(BIN)
        .args(["bridge", "--role", "controller", "--addr", "127.0.0.1:9", "--duration", "0.1"])
        .args(["--dead-after", "5"])
        .arg("--fmu")
        .arg(&fmu_copy)
        .arg("--log")
        .arg(&old_log)
        .output()
        .unwrap();
    assert!(!failed.status.success(), "{}", String::from_utf8_lossy(&failed.stdout));
    assert_eq!(std::fs::read(&fmu_copy).unwrap(), fmu_bytes);
    assert_eq!(std::fs::read_to_string(&old_log).unwrap(), "an earlier run's log");
    assert_eq!(std::fs::read_to_string(&reference).unwrap(), "time,reference\n0,100e-6\n");
    let mut names: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into())
        .collect();
    names.sort();
    assert_eq!(names, ["InchwormController.fmu", "old.log", "reference.csv"]);
}
