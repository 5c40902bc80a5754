//! The Model Exchange interface of the layer, on the toy (`x` the continuous state, a
//! reset at `x = LEVEL`), written once and run for FMI 2.0 and FMI 3.0: the ME state
//! machine, which inputs may change between events, the arrays and their checks, NaN
//! states, the event update with its jump, failures, and state round trips; and the
//! generated `<ModelExchange>`, `derivative=` and indicator declarations.

#[macro_use]
mod toy;

use inchworm_fmi_export::api::Fmi2;
use inchworm_fmi_export::entry::Array;
use inchworm_fmi_export::fmi3::api::Fmi3;
use inchworm_fmi_export::fmi3::model_description as description3;
use inchworm_fmi_export::testing::{Harness, Master};
use inchworm_fmi_export::{model_description, EventUpdate, State};
use toy::*;

type H<S> = Harness<Toy, S>;

const OK: i32 = 0;
const ERROR: i32 = 3;
const FATAL: i32 = 4;

for_both!(
    calls_follow_the_model_exchange_state_machine,
    discrete_inputs_wait_for_event_mode,
    arrays_are_checked_and_nan_states_refused,
    the_right_hand_side_is_the_co_simulation_step,
    a_state_event_jumps_and_the_integrator_is_told,
    failures_in_event_mode_end_as_in_a_step,
    state_round_trips_replay_bit_for_bit,
    directional_derivatives_are_the_exact_partials,
    an_event_update_past_the_stop_time_is_refused,
);

/// A defined stop time holds in Model Exchange as in a step: a time past it is taken (an
/// integrator evaluates its last step past the end and interpolates back), an event update
/// there is refused with the reason and leaves the instance as it was, and at the stop
/// time (up to rounding) it runs.
fn an_event_update_past_the_stop_time_is_refused<S: Master>() {
    let h = H::<S>::new_me("stop");
    assert_eq!((h.experiment(0.0, Some(1.0)), h.enter(), h.exit()), (OK, OK, OK));
    assert_eq!(h.enter_continuous_time_mode(), OK);
    assert_eq!(h.set_time(2.0), OK, "an integrator's look-ahead");
    assert_eq!(h.set_states(&[0.25]), OK);
    assert_eq!(h.enter_event_mode(), OK);
    assert_eq!(h.update().0, ERROR);
    let experiment =
        if S::NAME_IN_MESSAGE { "fmi3EnterInitializationMode" } else { "fmi2SetupExperiment" };
    let want = format!("an event update at 2 s is past the stop time 1 set in {experiment}");
    assert!(h.saw(ERROR, &[S::UPDATE, &want]), "{:?}", h.logged());
    assert_eq!(h.set_time(1.0 + 1e-12), OK);
    assert_eq!(h.update().0, OK, "at the stop time up to rounding: {:?}", h.logged());
    assert_eq!(x(&h), 0.25, "the refusal changed nothing");
    // Without a stop time, an update anywhere.
    let free = H::<S>::init_me("free");
    assert_eq!(free.set_time(1e300), OK);
    assert_eq!(free.update().0, OK);
}

fn x<S: Master>(h: &H<S>) -> f64 {
    h.array(Array::States, 1).1[0]
}

fn calls_follow_the_model_exchange_state_machine<S: Master>() {
    let h = H::<S>::new_me("order");
    let refused = |state: State, call: &str| {
        let want = format!("illegal call sequence: not allowed in state {}", S::state_name(state));
        assert!(h.saw(ERROR, &[call, &want]), "{call} in {state:?}: {:?}", h.logged());
    };
    assert_eq!(h.set_time(0.0), ERROR);
    refused(State::Instantiated, if S::NAME_IN_MESSAGE { "fmi3SetTime" } else { "fmi2SetTime" });
    assert_eq!(h.array(Array::Derivatives, 1).0, ERROR, "not before the model is built");
    assert_eq!(h.array(Array::Nominals, 1), (OK, vec![X_NOMINAL]), "nominals are constants");
    assert_eq!((h.setup(), h.enter(), h.exit()), (OK, OK, OK));
    // Exit from initialization enters event mode, where Co-Simulation calls have no place.
    assert_eq!(h.step(0.0, 0.01), ERROR);
    refused(State::EventMode, S::DO_STEP);
    assert_eq!(h.set_states(&[1.0]), ERROR, "states are the integrator's, between events");
    refused(State::EventMode, S::SET_STATES);
    assert_eq!(h.completed_step().0, ERROR);
    assert_eq!(h.update(), (OK, EventUpdate::default(), false), "x = 0: nothing to do");
    assert_eq!(h.enter_continuous_time_mode(), OK);
    assert_eq!(h.update().0, ERROR);
    refused(State::ContinuousTimeMode, S::UPDATE);
    assert_eq!(h.enter_continuous_time_mode(), ERROR);
    assert_eq!((h.set_time(0.5), h.set_states(&[1.5])), (OK, OK));
    assert_eq!(h.completed_step(), (OK, [false, false]), "no step events, never terminates");
    assert_eq!(h.real(X), (OK, 1.5));
    assert_eq!(h.array(Array::Derivatives, 1), (OK, vec![-1.5]), "u = 0, k = 1");
    assert_eq!(h.enter_event_mode(), OK);
    assert_eq!(h.enter_event_mode(), OK, "allowed in event mode too");
    assert_eq!(h.terminate(), OK);
    assert_eq!(h.array(Array::States, 1), (OK, vec![1.5]), "readable after terminate");
    assert_eq!(h.set_time(1.0), ERROR);
    assert_eq!(h.reset(), OK);
    assert_eq!((h.setup(), h.enter(), h.exit()), (OK, OK, OK));
    assert_eq!(h.step(0.0, 0.01), ERROR, "reset keeps the interface");
    assert_eq!(h.array(Array::States, 1), (OK, vec![0.0]), "and starts afresh");
    // A Co-Simulation instance of the same FMU has none of the Model Exchange calls.
    let cs = H::<S>::init("cs");
    assert_eq!(
        (cs.set_time(0.0), cs.enter_event_mode(), cs.array(Array::States, 1).0),
        (ERROR, ERROR, ERROR)
    );
    assert!(
        cs.saw(
            ERROR,
            &["not supported: a Co-Simulation instance has no event mode (hasEventMode is false) and no continuous states"]
        ),
        "{:?}",
        cs.logged()
    );
}

fn discrete_inputs_wait_for_event_mode<S: Master>() {
    let h = H::<S>::init_me("inputs");
    assert_eq!(h.enter_continuous_time_mode(), OK);
    assert_eq!(h.set_real(U, 3.0), OK, "a continuous input changes between events");
    assert_eq!(h.set_integer(GAIN, 2), ERROR);
    let mode = S::state_name(State::ContinuousTimeMode);
    let want = format!("gain (Input, Discrete) cannot be set in state {mode}");
    assert!(h.saw(ERROR, &[&want]), "{:?}", h.logged());
    assert_eq!(h.set_boolean(HOLD, true), ERROR);
    assert_eq!(h.set_real(K, 2.0), ERROR, "a fixed parameter never");
    assert_eq!(h.array(Array::Derivatives, 1), (OK, vec![3.0]), "gain still 1");
    assert_eq!(h.enter_event_mode(), OK);
    assert_eq!((h.set_integer(GAIN, 2), h.set_boolean(HOLD, false)), (OK, OK));
    assert_eq!(h.array(Array::Derivatives, 1), (OK, vec![6.0]));
    assert_eq!(h.set_real(U, f64::NAN), ERROR, "the NaN rule holds in event mode");
    assert_eq!(h.real(U), (OK, 3.0));
}

fn arrays_are_checked_and_nan_states_refused<S: Master>() {
    let h = H::<S>::init_me("arrays");
    h.take_logged();
    assert_eq!(h.array(Array::Derivatives, 2).0, ERROR);
    assert!(h.saw(ERROR, &["2 state derivatives asked for, this FMU has 1"]), "{:?}", h.logged());
    let (s, v) = h.array(Array::EventIndicators, 2);
    assert_eq!(s, ERROR);
    assert!(v.iter().all(|v| v.is_nan()), "nothing written on a refusal");
    assert!(h.saw(ERROR, &["2 event indicators asked for, this FMU has 1"]), "{:?}", h.logged());
    assert_eq!(h.array(Array::EventIndicators, 1), (OK, vec![-LEVEL]));
    let null = unsafe { S::continuous_array::<Toy>(h.c, Array::States, std::ptr::null_mut(), 1) };
    assert_eq!(null, ERROR);
    assert!(h.saw(ERROR, &["the array of continuous states is NULL"]));
    assert_eq!(h.enter_continuous_time_mode(), OK);
    assert_eq!(h.set_states(&[2.5]), OK);
    h.take_logged();
    assert_eq!(h.set_states(&[f64::NAN]), ERROR);
    let want = format!(
        "{}: state 0 (x) = NaN refused: continuous states must be finite; keeping all",
        S::SET_STATES
    );
    assert_eq!(h.take_logged(), [h.line(ERROR, "logStatusError", &want)]);
    assert_eq!(h.set_states(&[f64::INFINITY]), ERROR);
    assert_eq!(x(&h), 2.5, "the last finite states kept");
    assert_eq!(h.set_states(&[1.0, 2.0]), ERROR);
    assert_eq!(h.set_time(f64::NAN), ERROR);
    assert!(h.saw(ERROR, &["time NaN is not finite"]));
    assert_eq!(h.completed_step(), (OK, [false, false]), "the refusals changed nothing");
}

/// An explicit Euler master over ME takes exactly the toy's Co-Simulation steps: the
/// right-hand side is the equation the step integrates.
fn the_right_hand_side_is_the_co_simulation_step<S: Master>() {
    const DT: f64 = 0.01;
    let cs = H::<S>::init("cs");
    let me = H::<S>::init_me("me");
    assert_eq!((cs.set_real(U, 4.0), me.set_real(U, 4.0)), (OK, OK));
    assert_eq!(me.enter_continuous_time_mode(), OK);
    for k in 0..50 {
        assert_eq!(cs.step(k as f64 * DT, DT), OK);
        let (s, dx) = me.array(Array::Derivatives, 1);
        assert_eq!(s, OK);
        let next = x(&me) + DT * dx[0];
        assert_eq!((me.set_time((k + 1) as f64 * DT), me.set_states(&[next])), (OK, OK));
        assert_eq!(me.completed_step(), (OK, [false, false]));
        assert_eq!(x(&me).to_bits(), cs.real(X).1.to_bits(), "step {k}");
    }
    assert!((x(&me) - 4.0 * (1.0 - 0.99f64.powi(50))).abs() < 1e-12, "{}", x(&me));
}

/// x' = 8 - x from 0 crosses LEVEL = 5 at t = ln(8/3); the master finds the sign change,
/// enters event mode, and the update resets x to 0 and says so.
fn a_state_event_jumps_and_the_integrator_is_told<S: Master>() {
    const DT: f64 = 1e-4;
    let h = H::<S>::init_me("event");
    assert_eq!(h.set_real(U, 8.0), OK);
    assert_eq!(h.update(), (OK, EventUpdate::default(), false));
    assert_eq!(h.enter_continuous_time_mode(), OK);
    assert_eq!(h.set_debug_logging(true, &["logEvents"]), OK);
    let mut crossings = Vec::new();
    let mut z = h.array(Array::EventIndicators, 1).1[0];
    for k in 1..=20_000 {
        let t = k as f64 * DT;
        let dx = h.array(Array::Derivatives, 1).1[0];
        assert_eq!((h.set_time(t), h.set_states(&[x(&h) + DT * dx])), (OK, OK));
        let now = h.array(Array::EventIndicators, 1).1[0];
        if (z < 0.0) != (now < 0.0) && now >= 0.0 {
            assert_eq!(h.enter_event_mode(), OK);
            let (s, u, term) = h.update();
            assert_eq!(
                (s, u, term),
                (OK, EventUpdate { states_changed: true, next_event_time: None }, false)
            );
            assert_eq!(x(&h), 0.0, "the jump");
            assert_eq!(
                h.update(),
                (OK, EventUpdate::default(), false),
                "one update is the fixed point"
            );
            assert_eq!(h.enter_continuous_time_mode(), OK);
            crossings.push(t);
        }
        z = h.array(Array::EventIndicators, 1).1[0];
    }
    let period = (8.0f64 / 3.0).ln();
    assert_eq!(crossings.len(), 2, "{crossings:?}");
    for (i, t) in crossings.iter().enumerate() {
        assert!(
            (t - (i + 1) as f64 * period).abs() < 5.0 * DT,
            "reset {i} at {t}, exact {}",
            (i + 1) as f64 * period
        );
    }
    assert_eq!(h.integer(STEPS), (OK, 2), "steps counts the resets");
    assert!(h.saw(OK, &["logEvents", "reset 2 at t = "]), "{:?}", h.logged());
}

fn failures_in_event_mode_end_as_in_a_step<S: Master>() {
    let h = H::<S>::init_me("fail");
    assert_eq!(h.set_real(U, FAIL), OK);
    let (s, _, term) = h.update();
    assert_eq!((s, term), (ERROR, true), "terminateSimulation on a model failure");
    assert!(h.saw(ERROR, &[S::UPDATE, "the toy fails on u = 7"]), "{:?}", h.logged());
    assert_eq!(h.enter_continuous_time_mode(), ERROR);
    refused_in_error::<S>(&h);
    assert_eq!(h.array(Array::States, 1), (OK, vec![0.0]), "states stay readable in Error");
    let p = H::<S>::init_me("panic");
    assert_eq!(p.set_real(U, PANIC), OK);
    assert_eq!(p.update().0, FATAL);
    assert_eq!(p.array(Array::States, 1).0, ERROR, "only freeing after Fatal");
}

fn refused_in_error<S: Master>(h: &H<S>) {
    let want = format!("not allowed in state {}", S::state_name(State::Error));
    assert!(h.saw(ERROR, &[&want]), "{:?}", h.logged());
}

fn state_round_trips_replay_bit_for_bit<S: Master>() {
    const DT: f64 = 0.01;
    let euler = |h: &H<S>, k0: usize, n: usize| -> Vec<u64> {
        (k0..k0 + n)
            .map(|k| {
                let dx = h.array(Array::Derivatives, 1).1[0];
                assert_eq!(h.set_time((k + 1) as f64 * DT), OK);
                assert_eq!(h.set_states(&[x(h) + DT * dx]), OK);
                x(h).to_bits()
            })
            .collect()
    };
    let h = H::<S>::init_me("trip");
    assert_eq!(h.set_real(U, 3.0), OK);
    assert_eq!(h.enter_continuous_time_mode(), OK);
    euler(&h, 0, 20);
    let saved = h.get_state();
    let blob = h.serialize();
    let first = euler(&h, 20, 30);
    assert_eq!(h.set_state(saved), OK);
    assert_eq!(euler(&h, 20, 30), first, "restored in place");
    let other = H::<S>::new_me("other");
    assert_eq!(other.deserialize(&blob), OK, "{:?}", other.logged());
    assert_eq!(other.set_time(20.0 * DT), OK, "restored in continuous-time mode");
    assert_eq!(euler(&other, 20, 30), first, "restored from bytes");
    assert_eq!(h.free_state(saved), OK);
    // A Co-Simulation state has no place in the Model Exchange state machine, nor back.
    let cs = H::<S>::init("cs");
    assert_eq!(other.deserialize(&cs.serialize()), ERROR);
    let want = format!(
        "serialized state was saved in state {}, which Model Exchange has not",
        S::state_name(State::StepComplete)
    );
    assert!(other.saw(ERROR, &[&want]), "{:?}", other.logged());
    assert_eq!(cs.deserialize(&blob), ERROR);
    assert!(cs.saw(ERROR, &["ContinuousTimeMode, which Co-Simulation has not"]));
}

/// `J seed` from the model's partials, against finite differences of the derivatives, and
/// the checks of its arguments.
fn directional_derivatives_are_the_exact_partials<S: Master>() {
    let h = H::<S>::init_me("jacobian");
    assert_eq!((h.set_real(U, 3.0), h.set_integer(GAIN, 2)), (OK, OK));
    assert_eq!(h.enter_continuous_time_mode(), OK);
    assert_eq!(h.set_states(&[1.5]), OK);
    let j = |seed: &[f64]| h.directional(&[DER_X, X, ABOVE_LEVEL], &[X, U], seed);
    assert_eq!(j(&[1.0, 0.0]), (OK, vec![-1.0, 1.0, 1.0]));
    assert_eq!(j(&[0.0, 1.0]), (OK, vec![2.0, 0.0, 0.0]));
    assert_eq!(j(&[0.5, -2.0]), (OK, vec![-4.5, 0.5, 0.5]));
    let der = |x: f64| {
        assert_eq!(h.set_states(&[x]), OK);
        h.array(Array::Derivatives, 1).1[0]
    };
    let eps = 1e-6;
    let fd = (der(1.5 + eps) - der(1.5 - eps)) / (2.0 * eps);
    assert!((fd - (-1.0)).abs() < 1e-9, "finite differences {fd}");
    h.take_logged();
    assert_eq!(h.directional(&[STEPS], &[X], &[1.0]).0, ERROR);
    assert!(h.saw(ERROR, &["value reference 11 (steps) is"]), "{:?}", h.logged());
    assert_eq!(h.directional(&[DER_X], &[K], &[1.0]).0, ERROR);
    assert!(h.saw(ERROR, &["no derivative of 13 with respect to 100"]), "{:?}", h.logged());
    assert_eq!(h.directional(&[DER_X], &[X], &[f64::NAN]).0, ERROR);
    assert!(h.saw(ERROR, &["seed NaN is not finite"]));
    // Co-Simulation instances have them too; a model without them says so.
    let cs = H::<S>::init("cs");
    assert_eq!(cs.directional(&[DER_X], &[U], &[1.0]), (OK, vec![1.0]));
    let none = Harness::<CsToy, S>::init("none");
    assert_eq!(none.directional(&[DER_X], &[U], &[1.0]).0, ERROR);
    assert!(
        none.saw(ERROR, &["not supported: providesDirectionalDerivative", "is false"]),
        "{:?}",
        none.logged()
    );
}

#[test]
fn the_descriptions_declare_model_exchange_from_the_table() {
    let two = model_description::model_description::<Toy>();
    for part in [
        r#"numberOfEventIndicators="1""#,
        r#"<ModelExchange modelIdentifier="Toy" completedIntegratorStepNotNeeded="true" canNotUseMemoryManagementFunctions="true" needsExecutionTool="false" canBeInstantiatedOnlyOncePerProcess="false" canGetAndSetFMUstate="true" canSerializeFMUstate="true" providesDirectionalDerivative="true"/>"#,
        "<Real unit=\"V/s\" derivative=\"4\"/>",
        "    <Derivatives>\n      <Unknown index=\"7\"/>\n    </Derivatives>\n    <InitialUnknowns>\n      <Unknown index=\"4\"/>\n      <Unknown index=\"5\"/>\n      <Unknown index=\"6\"/>\n      <Unknown index=\"7\"/>\n    </InitialUnknowns>",
    ] {
        assert!(two.contains(part), "{part}\n{two}");
    }
    assert!(two.find("<ModelExchange") < two.find("<CoSimulation"), "the schema's order");
    let three = description3::model_description::<Toy>();
    for part in [
        r#"<ModelExchange modelIdentifier="Toy" needsExecutionTool="false" canBeInstantiatedOnlyOncePerProcess="false" canGetAndSetFMUState="true" canSerializeFMUState="true" providesDirectionalDerivatives="true" providesAdjointDerivatives="false" providesPerElementDependencies="false" needsCompletedIntegratorStep="false" providesEvaluateDiscreteStates="false"/>"#,
        r#"<Float64 name="der(x)" valueReference="13" description="dx/dt" causality="local" variability="continuous" initial="calculated" unit="V/s" derivative="10"/>"#,
        "    <Output valueReference=\"12\"/>\n    <ContinuousStateDerivative valueReference=\"13\"/>\n    <InitialUnknown valueReference=\"10\"/>",
        "    <InitialUnknown valueReference=\"13\"/>\n    <EventIndicator valueReference=\"14\"/>\n  </ModelStructure>",
    ] {
        assert!(three.contains(part), "{part}\n{three}");
    }
    for xml in [
        model_description::model_description::<CsToy>(),
        description3::model_description::<CsToy>(),
    ] {
        assert!(
            !xml.contains("<ModelExchange")
                && !xml.contains("<Derivatives>")
                && !xml.contains("EventIndicator valueReference")
        );
    }
    assert_ne!(model_description::guid::<Toy>(), model_description::guid::<CsToy>());
}
