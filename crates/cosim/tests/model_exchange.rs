//! Model Exchange components in the master, on the small FMU of `tests/support/me_fmu.c`
//! (x' = -a x + u, a state event at x = level, a time event every `period` with a jump
//! of x by `jump`): the trace against the exact solution, the same FMU run as
//! Co-Simulation, an SSP that mixes both interfaces, and the hostile cases.

#[path = "../../../tests/support/me_fmu.rs"]
mod me_fmu;

use std::io::Write;
use std::path::{Path, PathBuf};

use inchworm_cosim::model_exchange::Tolerance;
use inchworm_cosim::{master, Coupling, Interfaces, Options, System, Trace};
use me_fmu::Standard;

fn scratch(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("inchworm-cosim-me-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn options(stop: f64, h: f64, params: &[(&str, &str)], outputs: &[&str]) -> Options {
    Options {
        stop_time: Some(stop),
        step_size: Some(h),
        coupling: Coupling::Jacobi,
        params: params.iter().map(|(n, v)| (n.to_string(), v.to_string())).collect(),
        parameter_set: None,
        input: None,
        outputs: outputs.iter().map(|s| s.to_string()).collect(),
    }
}

fn run(path: &Path, interfaces: &Interfaces, o: &Options) -> Result<Trace, inchworm_cosim::Error> {
    let sim = System::load_as(path, interfaces)?.initialise(o)?;
    let mut trace = Trace::new(sim.record_names().to_vec());
    sim.run_into(
        |t, row| {
            trace.push(t, row.to_vec());
            Ok::<(), inchworm_cosim::Error>(())
        },
        |_| {},
    )?;
    Ok(trace)
}

fn column(trace: &Trace, name: &str) -> impl Iterator<Item = (f64, f64)> {
    let values = trace.column(name).unwrap_or_else(|| panic!("no column {name}"));
    trace.times().into_iter().zip(values)
}

/// x(t) of x' = -a x with x(0) = 1 and x jumping by `jump` at each multiple of `period`.
fn exact(t: f64, a: f64, period: f64, jump: f64) -> f64 {
    let mut x = 1.0;
    let mut from = 0.0;
    let mut k = 1.0;
    // Events at k·period strictly before t (one at t is handled after the sample at t).
    while k * period < t - 1e-12 {
        x = x * (-a * (k * period - from)).exp() + jump;
        from = k * period;
        k += 1.0;
    }
    x * (-a * (t - from)).exp()
}

#[test]
fn an_me_only_fmu_is_integrated_to_the_exact_solution_with_its_events() {
    for standard in [Standard::Fmi2, Standard::Fmi3] {
        let dir = scratch(&format!("exact-{standard:?}"));
        let fmu = me_fmu::build(&dir, "Decay", standard);
        let o = options(1.0, 1e-3, &[("a", "3"), ("jump", "0.5")], &["x", "crossings", "ticks"]);
        let trace = run(&fmu, &Interfaces::default(), &o).unwrap();
        assert_eq!(trace.times().len(), 1001);
        let worst = column(&trace, "x")
            .map(|(t, x)| (x - exact(t, 3.0, 0.25, 0.5)).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-6, "{standard:?}: max |x - exact| = {worst:e}");
        // The ticks at 0.25, 0.5, 0.75 are seen in the row after the one at their time.
        let ticks: Vec<(f64, f64)> = column(&trace, "ticks").collect();
        assert_eq!(ticks[250].1, 0.0, "{standard:?}");
        assert_eq!(ticks[251].1, 1.0, "{standard:?}");
        assert_eq!(ticks[1000].1, 3.0, "{standard:?}");
        // x crosses 0.5 downward at ln(2)/3 = 0.2310 s; each jump lifts it over 0.5 (the
        // FMU counts only downward crossings), and it comes down again inside a step: at
        // 0.25 + ln((e^{-0.75} + 0.5) / 0.5) / 3 = 0.4717 s after the first jump.
        let crossings: Vec<f64> = column(&trace, "crossings").map(|(_, c)| c).collect();
        assert_eq!((crossings[231], crossings[232]), (0.0, 1.0), "{standard:?}: ln 2 / 3");
        assert_eq!((crossings[251], crossings[471], crossings[472]), (1.0, 1.0, 2.0));
        assert_eq!(crossings[1000], 4.0, "{standard:?}");
    }
}

#[test]
fn the_same_fmu_run_as_me_gives_its_cs_trace() {
    let dir = scratch("me-vs-cs");
    let fmu = me_fmu::build(&dir, "Decay", Standard::Fmi2Cs);
    let o = options(2.0, 1e-3, &[("a", "40"), ("jump", "0.25"), ("u", "0.5")], &["x", "ticks"]);
    let cs = run(&fmu, &Interfaces::default(), &o).unwrap();
    let me = Interfaces { model_exchange: vec!["fmu".into()], ..Interfaces::default() };
    let sim = System::load_as(&fmu, &me).unwrap().initialise(&o).unwrap();
    assert_eq!(sim.model_exchange_stats().len(), 1, "the FMU runs as ME when asked");
    let me = run(&fmu, &me, &o).unwrap();
    let worst = column(&cs, "x")
        .zip(column(&me, "x"))
        .map(|((_, a), (_, b))| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-7, "max |x_ME - x_CS| = {worst:e}");
    let ticks = |t: &Trace| column(t, "ticks").map(|(_, v)| v).collect::<Vec<_>>();
    assert_eq!(ticks(&cs), ticks(&me));
}

/// An SSP of two components of `fmu`: `up.x` feeds `down.u`.
fn two_component_ssp(dir: &Path, fmu: &Path) -> PathBuf {
    let ssd = r#"<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" version="1.0" name="Chain">
  <ssd:System name="Chain">
    <ssd:Elements>
      <ssd:Component name="up" type="application/x-fmu-sharedlibrary" source="resources/Decay.fmu">
        <ssd:Connectors><ssd:Connector name="x" kind="output"><ssc:Real/></ssd:Connector></ssd:Connectors>
      </ssd:Component>
      <ssd:Component name="down" type="application/x-fmu-sharedlibrary" source="resources/Decay.fmu">
        <ssd:Connectors><ssd:Connector name="u" kind="input"><ssc:Real/></ssd:Connector></ssd:Connectors>
      </ssd:Component>
    </ssd:Elements>
    <ssd:Connections>
      <ssd:Connection startElement="up" startConnector="x" endElement="down" endConnector="u"/>
    </ssd:Connections>
  </ssd:System>
</ssd:SystemStructureDescription>
"#;
    let path = dir.join("Chain.ssp");
    let mut w = zip::ZipWriter::new(std::fs::File::create(&path).unwrap());
    let o = zip::write::SimpleFileOptions::default();
    w.start_file("SystemStructure.ssd", o).unwrap();
    w.write_all(ssd.as_bytes()).unwrap();
    w.start_file("resources/Decay.fmu", o).unwrap();
    w.write_all(&std::fs::read(fmu).unwrap()).unwrap();
    w.finish().unwrap();
    path
}

#[test]
fn an_ssp_mixes_me_and_cs_components_in_both_couplings() {
    let dir = scratch("mixed");
    let fmu = me_fmu::build(&dir, "Decay", Standard::Fmi2Cs);
    let ssp = two_component_ssp(&dir, &fmu);
    let params = [("up.a", "5"), ("down.a", "20"), ("up.jump", "0.25")];
    for coupling in [Coupling::Jacobi, Coupling::GaussSeidel] {
        let mut o = options(1.0, 1e-3, &params, &["up.x", "down.x"]);
        o.coupling = coupling;
        let cs = run(&ssp, &Interfaces::default(), &o).unwrap();
        for me in [vec!["down"], vec!["up"], vec!["*"]] {
            let interfaces = Interfaces {
                model_exchange: me.iter().map(|s| s.to_string()).collect(),
                ..Interfaces::default()
            };
            let sim = System::load_as(&ssp, &interfaces).unwrap().initialise(&o).unwrap();
            let names: Vec<String> =
                sim.model_exchange_stats().into_iter().map(|(n, _)| n).collect();
            let expected: Vec<&str> = if me == ["*"] { vec!["up", "down"] } else { me.clone() };
            assert_eq!(names, expected);
            let mixed = run(&ssp, &interfaces, &o).unwrap();
            for name in ["up.x", "down.x"] {
                let worst = column(&cs, name)
                    .zip(column(&mixed, name))
                    .map(|((_, a), (_, b))| (a - b).abs())
                    .fold(0.0, f64::max);
                assert!(worst < 1e-7, "{coupling:?}, ME {me:?}: {name} differs by {worst:e}");
            }
        }
    }
    let e = System::load_as(
        &ssp,
        &Interfaces { model_exchange: vec!["nobody".into()], ..Interfaces::default() },
    )
    .err()
    .unwrap()
    .to_string();
    assert!(e.contains("no component named `nobody` to run as Model Exchange"), "{e}");
}

#[test]
fn hostile_fmus_end_the_run_with_a_defined_error() {
    for standard in [Standard::Fmi2, Standard::Fmi3] {
        let dir = scratch(&format!("hostile-{standard:?}"));
        let fmu = me_fmu::build(&dir, "Decay", standard);
        let fmi = if standard == Standard::Fmi3 { "fmi3" } else { "fmi2" };
        let error = |mode: &str| {
            let o = options(0.1, 1e-3, &[("mode", mode)], &["x"]);
            run(&fmu, &Interfaces::default(), &o).expect_err("refused").to_string()
        };
        let e = error("1");
        let call =
            if fmi == "fmi3" { "fmi3GetContinuousStateDerivatives" } else { "fmi2GetDerivatives" };
        assert!(e.contains(&format!("Decay: {call} returned {fmi}Error at t = 0")), "{e}");
        let e = error("2");
        assert!(
            e.starts_with("component fmu: at t = 0 s: the derivative 0 is NaN (not finite)"),
            "{e}"
        );
        let e = error("3");
        let update =
            if fmi == "fmi3" { "fmi3UpdateDiscreteStates" } else { "fmi2NewDiscreteStates" };
        assert_eq!(
            e,
            format!("component fmu: at t = 0 s: the event iteration did not converge: {update} still asked for another pass after 1000")
        );
    }
}

#[test]
fn a_checkpoint_of_an_me_fmu_without_fmu_state_is_refused_naming_the_call() {
    let dir = scratch("checkpoint");
    let fmu = me_fmu::build(&dir, "Decay", Standard::Fmi2);
    let o = options(0.01, 1e-3, &[], &["x"]);
    let mut sim = System::load(&fmu).unwrap().initialise(&o).unwrap();
    sim.step().unwrap();
    let e = sim.checkpoint().err().unwrap().to_string();
    assert!(e.contains("fmi2GetFMUstate is not available"), "{e}");
    // The run goes on after the refusal.
    sim.step().unwrap();
    assert_eq!(master::run(&fmu, &o, |_| {}).unwrap().times().len(), 11);
}

/// The description's sizes are checked before the FMU is unpacked: these FMUs hold no
/// binary at all, and the refusal is a [`inchworm_cosim::Error::TooLarge`] naming the
/// count and the cap.
#[test]
fn descriptions_past_the_size_caps_are_refused_before_unpacking() {
    use inchworm_cosim::limits::{MAX_CONTINUOUS_STATES, MAX_EVENT_INDICATORS};
    let dir = scratch("caps");
    let cases = [
        (MAX_CONTINUOUS_STATES + 1, 0, "continuous states"),
        (30_000, 0, "continuous states"),
        (1, MAX_EVENT_INDICATORS as u64 + 1, "event indicators"),
        (1, 100_000_000_000, "event indicators"),
    ];
    for (i, (nx, nz, what)) in cases.into_iter().enumerate() {
        let fmu = me_fmu::build_wide(&dir, &format!("Wide{i}"), nx, nz, None);
        let e = System::load(&fmu).err().expect("refused");
        assert!(matches!(e, inchworm_cosim::Error::TooLarge { .. }), "{e:?}");
        let count = if what == "event indicators" { nz.to_string() } else { nx.to_string() };
        let e = e.to_string();
        assert!(
            e.starts_with(&format!(
                "component fmu: the model description declares {count} {what}, more than the "
            )),
            "{e}"
        );
    }
    // At the cap, an FMU is taken (here as far as loading it; what integrating it costs is
    // in docs/model-exchange.md).
    let fmu = me_fmu::build_wide(&dir, "AtCap", MAX_CONTINUOUS_STATES, 0, Some(&[]));
    let sim = System::load(&fmu).unwrap().initialise(&options(1e-3, 1e-3, &[], &["x0"])).unwrap();
    assert_eq!(sim.model_exchange_stats().len(), 1);
    // An SSP's component is refused by its name.
    let wide = me_fmu::build_wide(&dir, "Decay", 30_000, 0, None);
    let e = System::load(&two_component_ssp(&dir, &wide)).err().unwrap().to_string();
    assert!(
        e.starts_with("component up: the model description declares 30000 continuous states"),
        "{e}"
    );
}

/// What a 1000-state FMU (the cap) costs: `cargo test --release -p inchworm-cosim --test
/// model_exchange -- --ignored --nocapture cost`.
#[test]
#[ignore = "a measurement: seconds of CPU"]
fn cost_of_an_me_fmu_by_its_states() {
    let dir = scratch("cost");
    for nx in [100, 250, 500, 1000] {
        let fmu = me_fmu::build_wide(&dir, &format!("Wide{nx}"), nx, 0, Some(&[]));
        let o = options(0.1, 0.01, &[], &["x0"]);
        let t = std::time::Instant::now();
        let sim = System::load(&fmu).unwrap().initialise(&o).unwrap();
        let end = sim.run_into(|_, _| Ok::<(), inchworm_cosim::Error>(()), |_| {}).unwrap();
        let s = t.elapsed().as_secs_f64();
        eprintln!("{nx} states: 10 steps of 10 ms in {s:.3} s wall: {}", end.model_exchange[0].1);
    }
}

#[test]
fn non_finite_numbers_from_the_fmu_are_refused_naming_the_call() {
    for standard in [Standard::Fmi2, Standard::Fmi3] {
        let dir = scratch(&format!("non-finite-{standard:?}"));
        let fmu = me_fmu::build(&dir, "Decay", standard);
        let fmi = if standard == Standard::Fmi3 { "fmi3" } else { "fmi2" };
        let error = |mode: &str| {
            let o = options(0.1, 1e-3, &[("mode", mode)], &["x", "ticks"]);
            run(&fmu, &Interfaces::default(), &o).expect_err("refused")
        };
        let e = error("4");
        assert!(matches!(e, inchworm_cosim::Error::FmuValue { .. }), "{e:?}");
        let update =
            if fmi == "fmi3" { "fmi3UpdateDiscreteStates" } else { "fmi2NewDiscreteStates" };
        assert_eq!(
            e.to_string(),
            format!("component fmu: at t = 0 s: {update} returned the next event time (nextEventTime, defined) = NaN: not a finite number")
        );
        let e = error("5").to_string();
        assert_eq!(
            e,
            format!("component fmu: at t = 0 s: {fmi}GetNominalsOfContinuousStates returned the nominal of state 0 = NaN: a state's nominal must be a finite number in [1e-100, 1e100]")
        );
    }
}

#[test]
fn tolerances_and_steps_out_of_range_are_refused_naming_who_gave_them() {
    let dir = scratch("ranges");
    let fmu = me_fmu::build(&dir, "Decay", Standard::Fmi2);
    for (rtol, atol, given) in [
        (f64::INFINITY, 1e-11, "rtol"),
        (f64::NAN, 1e-11, "rtol"),
        (0.0, 1e-11, "rtol"),
        (1e-9, 5e-324, "atol"),
        (1e-9, f64::INFINITY, "atol"),
        (1e-9, -1e-11, "atol"),
    ] {
        let interfaces =
            Interfaces { tolerance: Tolerance { rtol, atol }, ..Interfaces::default() };
        let e = System::load_as(&fmu, &interfaces).err().expect("refused");
        assert!(matches!(e, inchworm_cosim::Error::OutOfRange { .. }), "{e:?}");
        let e = e.to_string();
        assert!(e.starts_with(&format!("the Model Exchange tolerance's {given} = ")), "{e}");
    }
    // A step too short for the ME integrator to make anything of.
    let o = options(1e-12, 1e-13, &[], &["x"]);
    let e = System::load(&fmu).unwrap().initialise(&o).err().unwrap().to_string();
    assert!(e.starts_with("the step size of a run with a Model Exchange component = 1e-13: the communication step must be a finite number in"), "{e}");
}

#[test]
fn interface_names_the_run_does_not_have_are_refused() {
    let dir = scratch("names");
    let fmu = me_fmu::build(&dir, "Decay", Standard::Fmi2Cs);
    let me = |names: &[&str], cs: &[&str]| Interfaces {
        model_exchange: names.iter().map(|s| s.to_string()).collect(),
        co_simulation: cs.iter().map(|s| s.to_string()).collect(),
        ..Interfaces::default()
    };
    let e = System::load_as(&fmu, &me(&["plant"], &[])).err().expect("refused");
    assert!(matches!(e, inchworm_cosim::Error::NoSuchComponent { .. }), "{e:?}");
    assert_eq!(
        e.to_string(),
        "--interface plant=me: no component named `plant` to run as Model Exchange: a single FMU is one component, named `fmu`"
    );
    let e = System::load_as(&fmu, &me(&[], &["plant"])).err().unwrap().to_string();
    assert!(e.starts_with("--interface plant=cs: no component named `plant`"), "{e}");
    let e = System::load_as(&fmu, &me(&["fmu"], &["fmu"])).err().unwrap().to_string();
    assert!(
        e.contains("asked to run both as Model Exchange (me) and as Co-Simulation (cs)"),
        "{e}"
    );
    // `fmu=cs` keeps the Co-Simulation under `*`.
    let o = options(0.01, 1e-3, &[], &["x"]);
    let sim = System::load_as(&fmu, &me(&["*"], &["fmu"])).unwrap().initialise(&o).unwrap();
    assert!(sim.model_exchange_stats().is_empty());
    let ssp = two_component_ssp(&dir, &fmu);
    let e = System::load_as(&ssp, &me(&[], &["nobody"])).err().unwrap().to_string();
    assert!(e.ends_with("--interface nobody=cs: no component named `nobody` to run as Co-Simulation: the components are `up`, `down`"), "{e}");
}

/// A stop asked for in the middle of one long communication step ends the run there: the
/// FMU's oscillator needs minutes of its slow derivatives to finish the step.
#[test]
fn a_stop_flag_ends_an_me_integration_inside_its_step() {
    let dir = scratch("stop");
    let fmu = me_fmu::build_wide(&dir, "Slow", 2, 0, Some(&["-DSLOW"]));
    let o = options(100.0, 100.0, &[], &["x0"]);
    let stop = inchworm_cosim::StopFlag::new();
    let sim = System::load(&fmu).unwrap().initialise(&o).unwrap().stop_when(stop.clone());
    let start = std::time::Instant::now();
    let mut setter = None;
    let r = sim.run_into(
        |t, _| {
            if t == 0.0 {
                // Set once the step is under way (the flag is checked before it starts).
                let stop = stop.clone();
                setter = Some(std::thread::spawn(move || {
                    std::thread::sleep(std::time::Duration::from_millis(300));
                    stop.set();
                }));
            }
            Ok::<(), inchworm_cosim::Error>(())
        },
        |_| {},
    );
    let e = r.expect_err("stopped");
    assert!(e.is_stopped(), "{e}");
    let took = start.elapsed().as_secs_f64();
    assert!(took < 30.0, "stopped after {took} s");
    setter.unwrap().join().unwrap();
}
