//! Every behaviour of the export layer, written once and run for FMI 2.0 and FMI 3.0
//! through the one harness ([`Harness<Toy, S>`]): call order, NULL and foreign pointers,
//! NaN, ranges, unknown references, parameters, step checks, logging categories, state
//! round trips, corrupt and forged blobs, the Error and Fatal states, long strings from
//! outside, and threads. What only one standard has is at the end.

#[macro_use]
mod toy;

use std::ffi::{c_void, CString};

use inchworm_fmi_export::api::Fmi2;
use inchworm_fmi_export::fmi3::api::Fmi3;
use inchworm_fmi_export::testing::{
    assert_every_entry_point_refuses as refuses, categories_of, payload_of, with_payload, Harness,
    Master,
};
use inchworm_fmi_export::{model_description, Clip};
use toy::*;

type H<S> = Harness<Toy, S>;

const OK: i32 = 0;
const WARNING: i32 = 1;
const ERROR: i32 = 3;
const FATAL: i32 = 4;
const DT: f64 = 0.01;

for_both!(
    calls_out_of_order_are_refused_and_logged,
    null_and_foreign_pointers_are_refused_without_a_crash,
    every_entry_point_refuses_another_model_s_instance_and_junk,
    nan_is_refused_and_the_last_value_kept,
    out_of_range_inputs_are_clamped_with_a_warning,
    rounding_past_a_limit_is_the_limit_without_a_warning,
    clamp_warnings_are_bounded_and_counted,
    unknown_references_wrong_types_and_unsettable_variables_are_errors,
    bad_parameters_fail_initialization_and_reset_recovers,
    step_time_size_and_stop_time_are_checked,
    debug_logging_enables_exactly_the_named_categories,
    unknown_or_null_log_categories_are_refused_and_change_nothing,
    logging_on_at_instantiation_enables_every_category,
    a_model_failure_moves_to_error_and_a_saved_state_recovers,
    a_panic_is_contained_and_ends_the_instance,
    state_round_trips_replay_bit_for_bit,
    corrupt_truncated_and_foreign_blobs_are_refused,
    forged_blobs_with_a_valid_checksum_are_validated,
    long_strings_from_outside_are_cut_in_messages,
    instances_on_threads_match_serial_runs,
);

/// `n` steps from sample `k0` under drive `u`; x after each.
fn run<S: Master>(h: &H<S>, k0: usize, n: usize, u: f64) -> Vec<u64> {
    assert_eq!(h.set_real(U, u), OK);
    (k0..k0 + n)
        .map(|k| {
            assert_eq!(h.step(k as f64 * DT, DT), OK, "{:?}", h.logged());
            h.real(X).1.to_bits()
        })
        .collect()
}

fn calls_out_of_order_are_refused_and_logged<S: Master>() {
    let h = H::<S>::new("order");
    assert_eq!(h.step(0.0, DT), ERROR);
    let state = S::state_name(inchworm_fmi_export::State::Instantiated);
    let want = format!("{}: illegal call sequence: not allowed in state {state}", S::DO_STEP);
    assert_eq!(h.take_logged(), [h.line(ERROR, "logStatusError", &want)]);
    assert_eq!(h.exit(), ERROR);
    assert_eq!(h.terminate(), ERROR);
    assert_eq!(h.real(X).0, ERROR, "no getting before initialization");
    // The refusals changed nothing: the normal sequence still works.
    assert_eq!((h.setup(), h.enter()), (OK, OK));
    assert_eq!(h.enter(), ERROR);
    assert_eq!(h.exit(), OK);
    assert_eq!(h.step(0.0, DT), OK);
    assert_eq!(h.terminate(), OK);
    assert_eq!(h.step(DT, DT), ERROR);
    assert!(h.saw(ERROR, &[S::DO_STEP, "Terminated"]), "{:?}", h.logged());
    assert_eq!(h.real(X).0, OK, "getters stay allowed after terminate");
    assert_eq!(h.reset(), OK);
    assert_eq!((h.setup(), h.enter()), (OK, OK), "reset returns to Instantiated");
}

fn null_and_foreign_pointers_are_refused_without_a_crash<S: Master>() {
    let h = H::<S>::init("pointers");
    let mut junk = [0u64; 16];
    let foreign = junk.as_mut_ptr() as *mut c_void;
    let mut x = 0.0;
    unsafe {
        assert_eq!(S::get_reals::<Toy>(std::ptr::null_mut(), &X, 1, &mut x), ERROR);
        assert_eq!(S::step::<Toy>(foreign, 0.0, DT), ERROR);
        S::free::<Toy>(std::ptr::null_mut());
        S::free::<Toy>(foreign);
        assert_eq!(S::get_reals::<Toy>(h.c, &X, 1, std::ptr::null_mut()), ERROR);
        assert_eq!(S::get_reals::<Toy>(h.c, std::ptr::null(), 1, &mut x), ERROR);
        assert_eq!(S::get_reals::<Toy>(h.c, std::ptr::null(), 0, std::ptr::null_mut()), OK);
    }
    assert!(h.saw(ERROR, &[S::GET_REAL, S::VALUE_ARGS, "is NULL"]), "{:?}", h.logged());
    assert_eq!(h.set_state(foreign), ERROR);
    assert!(h.saw(ERROR, &["was not created by", S::FMU_STATE]), "{:?}", h.logged());
    assert_eq!(h.free_state(foreign), ERROR);
    assert_eq!(h.free_state(std::ptr::null_mut()), OK, "freeing NULL is allowed");
    assert_eq!(h.step(0.0, DT), OK, "the refusals changed nothing");
}

/// Every function of the standard that takes an instance, given an instance of another
/// model of this library (the registry keeps them apart by type), or junk: an error, the
/// free a no-op, and the foreign instance untouched. Getters included, which once read a
/// foreign instance as their own.
fn every_entry_point_refuses_another_model_s_instance_and_junk<S: Master>() {
    let toy = H::<S>::init("toy");
    let other = Harness::<CsToy, S>::init("other");
    let toy_me = H::<S>::init_me("toy_me");
    let mut junk = [0u64; 64];
    let junk = junk.as_mut_ptr() as *mut c_void;
    // FMI 2.0 has 41 functions taking an instance, FMI 3.0 71.
    let all = if S::PREFIX == "fmi2" { 41 } else { 71 };
    unsafe {
        assert_eq!(refuses::<S, Toy>(other.c, "an instance of another model"), all);
        assert_eq!(refuses::<S, CsToy>(toy.c, "an instance of another model"), all);
        assert_eq!(
            refuses::<S, CsToy>(toy_me.c, "a Model Exchange instance of another model"),
            all
        );
        assert_eq!(refuses::<S, Toy>(junk, "junk"), all);
    }
    assert_eq!((toy.step(0.0, DT), other.step(0.0, DT)), (OK, OK), "both left alone");
    assert_eq!(toy_me.enter_continuous_time_mode(), OK);
    assert!(toy.logged().is_empty() && other.logged().is_empty(), "{:?}", other.logged());
}

fn nan_is_refused_and_the_last_value_kept<S: Master>() {
    let h = H::<S>::init("nan");
    assert_eq!(h.set_real(U, 4.0), OK);
    h.take_logged();
    assert_eq!(h.set_real(U, f64::NAN), ERROR);
    let want = format!("{}: u = NaN refused: drive volts must be finite; keeping 4 V", S::SET_REAL);
    assert_eq!(h.take_logged(), [h.line(ERROR, "logStatusError", &want)]);
    assert_eq!(h.real(U), (OK, 4.0));
    assert_eq!(h.set_real(U, f64::NEG_INFINITY), ERROR);
    assert_eq!(h.step(0.0, DT), OK, "a refused input leaves the instance usable");
    // A parameter is held to finite values too, before initialization.
    let p = H::<S>::new("nan-param");
    assert_eq!(p.set_real(K, f64::INFINITY), ERROR);
    assert!(p.saw(ERROR, &["k = inf refused: must be finite; keeping 1 1/s"]), "{:?}", p.logged());
}

fn out_of_range_inputs_are_clamped_with_a_warning<S: Master>() {
    let h = H::<S>::init("range");
    assert_eq!(h.set_real(U, 12.5), WARNING);
    let want =
        format!("{}: u = 12.5 V is outside the drive range 0-10 V, clamped to 10 V", S::SET_REAL);
    assert_eq!(h.take_logged(), [h.line(WARNING, "logStatusWarning", &want)]);
    assert_eq!(h.real(U), (OK, 10.0));
    assert_eq!(h.set_real(U, -0.5), WARNING);
    assert_eq!(h.real(U).1.to_bits(), 0.0f64.to_bits());
    // -0 is inside [0, 10]: kept as it came, sign and all.
    assert_eq!(h.set_real(U, -0.0), OK);
    assert_eq!(h.real(U).1.to_bits(), (-0.0f64).to_bits());
    // Several values in one call: each stands alone, the call reports the worst.
    assert_eq!(h.set_reals(&[U, K, U], &[1.0, 2.0, 11.0]), ERROR, "k is fixed by now");
    assert_eq!(h.real(U), (OK, 10.0));
    assert_eq!(h.set_reals(&[U, U], &[f64::NAN, 3.0]), ERROR);
    assert_eq!(h.real(U), (OK, 3.0));
}

/// FMPy interpolates inputs linearly and hands 10.000000000000002 V for 10 V: a few ulps
/// past a limit is the limit, stored as it, and nothing to warn of.
fn rounding_past_a_limit_is_the_limit_without_a_warning<S: Master>() {
    let h = H::<S>::init("rounding");
    h.take_logged();
    for (given, stored) in [(10.000000000000002, 10.0f64), (10.0 + 1e-11, 10.0), (-1e-12, 0.0)] {
        assert_eq!(h.set_real(U, given), OK, "u = {given:e}");
        assert_eq!(h.real(U).1.to_bits(), stored.to_bits(), "u = {given:e} stored as {stored}");
    }
    assert_eq!(h.take_logged(), Vec::<String>::new(), "no warning for rounding");
    // Past 1e-12 of the 10 V range it is a value out of range again.
    assert_eq!(h.set_real(U, 10.0 + 2e-11), WARNING);
    assert!(
        h.saw(WARNING, &["is outside the drive range 0-10 V, clamped to 10 V"]),
        "{:?}",
        h.logged()
    );
    assert_eq!(h.real(U), (OK, 10.0));
}

/// A master that holds an input out of range at every step: the first three clamps are
/// warned of in full, then the 10th, 100th, …, and Terminate logs the total; the others
/// return OK, unlogged, and still store the clamped value. Reset counts anew.
fn clamp_warnings_are_bounded_and_counted<S: Master>() {
    let h = H::<S>::init("flood");
    h.take_logged();
    let clamp = |x: f64| {
        format!("{}: u = {x} V is outside the drive range 0-10 V, clamped to 10 V", S::SET_REAL)
    };
    let statuses: Vec<i32> = (1..=150).map(|i| h.set_real(U, 10.0 + f64::from(i))).collect();
    let warned: Vec<usize> = (1..=150).filter(|&i| statuses[i - 1] == WARNING).collect();
    assert_eq!(warned, [1, 2, 3, 10, 100], "the calls that returned Warning");
    assert!(statuses.iter().all(|&s| s == OK || s == WARNING));
    assert_eq!(h.real(U), (OK, 10.0), "the last value, clamped like every other");
    let terminate = format!("{}Terminate", S::PREFIX);
    let w = |m: String| h.line(WARNING, "logStatusWarning", &m);
    assert_eq!(
        h.take_logged(),
        [
            w(clamp(11.0)),
            w(clamp(12.0)),
            w(format!("{}; u clamped 3 times now: further clamps are counted, logged at the 10th, 100th, 1000th, … and in all at {terminate}", clamp(13.0))),
            w(format!("{} (u clamped 10 times now, 4 of them logged)", clamp(20.0))),
            w(format!("{} (u clamped 100 times now, 5 of them logged)", clamp(110.0))),
        ]
    );
    // A value in range between them changes no count.
    assert_eq!(h.set_real(U, 5.0), OK);
    assert_eq!(h.terminate(), WARNING, "Terminate logs the total");
    let total = format!("{terminate}: u was clamped into the drive range 0-10 V 150 times in all (5 of them logged)");
    assert_eq!(h.take_logged(), [w(total)]);
    // Summed up once: Reset after Terminate repeats nothing, and counts anew.
    assert_eq!(h.reset(), OK);
    assert_eq!(h.take_logged(), Vec::<String>::new());
    assert_eq!((h.setup(), h.enter(), h.exit()), (OK, OK, OK));
    assert_eq!(h.set_real(U, 12.5), WARNING, "the first clamp of the new run, in full");
    assert_eq!(h.take_logged(), [w(clamp(12.5))]);
    // Three or fewer clamps were all warned of in full: nothing to sum up.
    assert_eq!(h.terminate(), OK);
    assert_eq!(h.take_logged(), Vec::<String>::new());
}

fn unknown_references_wrong_types_and_unsettable_variables_are_errors<S: Master>() {
    let h = H::<S>::init("vr");
    h.take_logged();
    assert_eq!(h.real(999).0, ERROR);
    let want = format!("{}: unknown value reference 999", S::GET_REAL);
    assert_eq!(h.take_logged(), [h.line(ERROR, "logStatusError", &want)]);
    assert_eq!(h.integer(X).0, ERROR);
    let (real, int) = (
        S::type_name(inchworm_fmi_export::Kind::Real),
        S::type_name(inchworm_fmi_export::Kind::Integer),
    );
    assert!(
        h.saw(ERROR, &[&format!("value reference {X} (x) is {real}, not {int}")]),
        "{:?}",
        h.logged()
    );
    assert_eq!(h.set_real(X, 1.0), ERROR, "outputs cannot be set");
    assert!(h.saw(ERROR, &["x (Output, Continuous) cannot be set"]));
    assert_eq!(h.set_real(K, 2.0), ERROR, "fixed parameters cannot be set after initialization");
    let mode = S::state_name(inchworm_fmi_export::State::StepComplete);
    assert!(h.saw(ERROR, &[&format!("k (Parameter, Fixed) cannot be set in state {mode}")]));
    assert_eq!((h.set_integer(GAIN, 2), h.integer(GAIN)), (OK, (OK, 2)));
    assert_eq!((h.set_boolean(HOLD, true), h.boolean(HOLD)), (OK, (OK, true)));
    assert_eq!(h.boolean(POSITIVE), (OK, false));
    assert_eq!(h.set_integer(STEPS, 3), ERROR);
}

fn bad_parameters_fail_initialization_and_reset_recovers<S: Master>() {
    let h = H::<S>::new("params");
    assert_eq!(h.set_real(K, -1.0), OK, "validated at initialization, as a whole");
    assert_eq!(h.set_integer(EVENT_EVERY, 0), OK);
    assert_eq!((h.setup(), h.enter()), (OK, OK));
    assert_eq!(h.set_real(K, -2.0), OK, "still settable in initialization mode");
    assert_eq!(h.exit(), ERROR);
    assert!(
        h.saw(ERROR, &["ExitInitializationMode: k = -2 and event_every = 0 must be > 0"]),
        "{:?}",
        h.logged()
    );
    assert_eq!(h.step(0.0, DT), ERROR, "no stepping after a failed initialization");
    assert_eq!(h.real(K), (OK, -2.0), "getters allowed in Error, for diagnosis");
    assert_eq!(h.reset(), OK, "reset recovers the instance");
    assert_eq!(h.real(K).0, ERROR, "back in Instantiated");
    assert_eq!((h.setup(), h.enter(), h.exit()), (OK, OK, OK));
    assert_eq!(h.real(K), (OK, 1.0), "at its start value again");
}

fn step_time_size_and_stop_time_are_checked<S: Master>() {
    let h = H::<S>::init("time");
    for bad in [0.0, -DT, f64::NAN, f64::INFINITY] {
        assert_eq!(h.step(0.0, bad), ERROR);
    }
    assert!(h.saw(ERROR, &["communicationStepSize"]));
    assert_eq!(h.step(0.0, 2.0), ERROR, "the model's own refusal");
    assert!(h.saw(ERROR, &[S::DO_STEP, "step 2 s is longer than 1 s"]), "{:?}", h.logged());
    let mut t = 0.0;
    for _ in 0..1000 {
        assert_eq!(h.step(t, DT), OK);
        t += DT;
    }
    // A master at t = k·h and one at t += h disagree by rounding: both are the same point.
    assert_eq!(h.step(1000.0 * DT, DT), OK, "k·h after 1000 steps of t += h");
    assert_eq!(h.step(10.01 + 1e-6, DT), ERROR);
    assert!(h.saw(ERROR, &["currentCommunicationPoint", "does not match the FMU time"]));
    assert_eq!(h.integer(STEPS), (OK, 1001), "refused steps took none");

    let s = H::<S>::new("stop");
    assert_eq!(s.experiment(1.0, Some(0.5)), if S::NAME_IN_MESSAGE { OK } else { ERROR });
    assert_eq!(s.experiment(f64::NAN, None), if S::NAME_IN_MESSAGE { OK } else { ERROR });
    assert_eq!(s.experiment(0.0, Some(0.015)), OK);
    assert_eq!((s.enter(), s.exit()), (OK, OK));
    assert_eq!(s.step(0.0, DT), OK);
    assert_eq!(s.step(DT, DT), ERROR);
    let want = format!("step to 0.02 passes the stop time 0.015 set in {}", S::EXPERIMENT_FN);
    assert!(s.saw(ERROR, &[&want]), "{:?}", s.logged());
    // FMI 3.0 checks the experiment where it receives it, at fmi3EnterInitializationMode.
    let e = H::<S>::new("experiment");
    assert_eq!(e.experiment(1.0, Some(0.5)), if S::NAME_IN_MESSAGE { OK } else { ERROR });
    if S::NAME_IN_MESSAGE {
        assert_eq!(e.enter(), ERROR);
    }
    assert!(
        e.saw(ERROR, &["stopTime 0.5 is not finite or before startTime 1"]),
        "{:?}",
        e.logged()
    );
}

/// Asserts that every line is a debug (status OK) message and returns the categories seen.
fn debug_categories(lines: &[String]) -> Vec<String> {
    assert!(lines.iter().all(|l| l.starts_with("0|")), "{lines:?}");
    categories_of(lines)
}

fn debug_logging_enables_exactly_the_named_categories<S: Master>() {
    let h = H::<S>::init("logging");
    run(&h, 0, 20, 1.0);
    assert_eq!(h.take_logged(), Vec::<String>::new(), "no debug messages without debug logging");

    // Only logEvents: the model's events and nothing of logAll's call trace.
    assert_eq!(h.set_debug_logging(true, &["logEvents"]), OK);
    run(&h, 20, 20, 1.0);
    assert_eq!(
        h.take_logged(),
        [h.line(OK, "logEvents", "step 30"), h.line(OK, "logEvents", "step 40")]
    );

    // None named: every category, so the trace of each call comes too.
    assert_eq!(h.set_debug_logging(true, &[]), OK);
    run(&h, 40, 10, 1.0);
    let all = h.take_logged();
    assert_eq!(debug_categories(&all), ["logAll", "logEvents"]);
    let trace = |f: &str| all.iter().filter(|l| **l == h.line(OK, "logAll", f)).count();
    assert_eq!((trace(S::DO_STEP), trace(S::SET_REAL), trace(S::GET_REAL)), (10, 1, 10));

    // Off with a category named disables that one only; the call itself is traced under
    // the setting it replaces.
    assert_eq!(h.set_debug_logging(false, &["logAll"]), OK);
    assert_eq!(h.take_logged(), [h.line(OK, "logAll", S::SET_DEBUG_LOGGING)]);
    run(&h, 50, 10, 1.0);
    assert_eq!(debug_categories(&h.take_logged()), ["logEvents"]);

    // logAll alone selects every message.
    assert_eq!(h.set_debug_logging(true, &["logAll"]), OK);
    run(&h, 60, 10, 1.0);
    assert_eq!(debug_categories(&h.take_logged()), ["logAll", "logEvents"]);

    // Off with none named disables all; warnings and errors still go out.
    assert_eq!(h.set_debug_logging(false, &[]), OK);
    h.take_logged();
    run(&h, 70, 10, 1.0);
    assert_eq!(h.take_logged(), Vec::<String>::new());
    assert_eq!(h.set_real(U, 11.0), WARNING);
    assert_eq!(h.take_logged().len(), 1);
}

fn unknown_or_null_log_categories_are_refused_and_change_nothing<S: Master>() {
    let h = H::<S>::init("bad categories");
    assert_eq!(h.set_debug_logging(true, &["logEvents"]), OK);
    assert_eq!(h.set_debug_logging(true, &["logAll", "logNonsense"]), ERROR);
    let want = format!("{}: unknown log category \"logNonsense\" (this FMU has logEvents, logStatusWarning, logStatusError, logAll); logging left unchanged", S::SET_DEBUG_LOGGING);
    assert_eq!(h.take_logged(), [h.line(ERROR, "logStatusError", &want)]);
    assert_eq!(h.set_debug_logging_raw(false, &[std::ptr::null()]), ERROR);
    assert!(h.saw(ERROR, &[S::SET_DEBUG_LOGGING, "a category name is NULL"]));
    let status = unsafe { S::set_debug_logging::<Toy>(h.c, true, 1, std::ptr::null()) };
    assert_eq!(status, ERROR);
    assert!(h.saw(ERROR, &[S::SET_DEBUG_LOGGING, "categories is NULL"]));
    h.take_logged();
    // Still logEvents only, as before the refused calls.
    run(&h, 0, 10, 1.0);
    assert_eq!(h.take_logged(), [h.line(OK, "logEvents", "step 10")]);
}

fn logging_on_at_instantiation_enables_every_category<S: Master>() {
    let h = H::<S>::with_logging("on", true);
    assert_eq!(h.set_debug_logging(false, &["logAll"]), OK);
    assert_eq!(h.take_logged(), [h.line(OK, "logAll", S::SET_DEBUG_LOGGING)]);
    assert_eq!((h.setup(), h.enter(), h.exit()), (OK, OK, OK));
    assert_eq!(h.take_logged(), Vec::<String>::new());
}

fn a_model_failure_moves_to_error_and_a_saved_state_recovers<S: Master>() {
    let h = H::<S>::init("error");
    run(&h, 0, 5, 1.0);
    let saved = h.get_state();
    assert_eq!(h.set_real(U, FAIL), OK);
    assert_eq!(h.step(5.0 * DT, DT), ERROR);
    assert!(h.saw(ERROR, &[S::DO_STEP, "the toy fails on u = 7"]));
    assert_eq!(h.step(5.0 * DT, DT), ERROR, "no stepping in Error");
    assert_eq!(h.real(X).0, OK, "getters stay allowed in Error");
    // The one rule the standards differ in: FMI 2.0 saves a state in Error, FMI 3.0 not.
    let (status, s) = h.try_get_state();
    assert_eq!(status, if S::GET_STATE_IN_ERROR { OK } else { ERROR });
    if status == OK {
        assert_eq!(h.free_state(s), OK);
    } else {
        assert!(h.saw(ERROR, &["an instance in Error state has no state worth saving"]));
    }
    // Both leave Error by restoring a state saved before it.
    assert_eq!(h.set_state(saved), OK);
    assert_eq!(h.real(U), (OK, 1.0));
    assert_eq!(run(&h, 5, 5, 1.0).len(), 5);
    assert_eq!(h.free_state(saved), OK);
}

fn a_panic_is_contained_and_ends_the_instance<S: Master>() {
    let h = H::<S>::init("panic");
    assert_eq!(h.set_real(U, PANIC), OK);
    assert_eq!(h.step(0.0, DT), FATAL);
    assert!(
        h.saw(FATAL, &[S::DO_STEP, "internal error, instance unusable: the toy panics on u = 6"]),
        "{:?}",
        h.logged()
    );
    assert_eq!(h.real(X).0, ERROR, "nothing but free after Fatal");
    assert_eq!(h.reset(), ERROR);
    assert!(h.saw(ERROR, &["not allowed in state Fatal"]));
}

fn state_round_trips_replay_bit_for_bit<S: Master>() {
    let a = H::<S>::init("a");
    run(&a, 0, 30, 3.0);
    let s = a.get_state();
    let first = run(&a, 30, 50, 8.0);
    assert_eq!(a.set_state(s), OK);
    assert_eq!(run(&a, 30, 50, 8.0), first);
    // A second get into the same handle updates it in place.
    let mut handle = s;
    assert_eq!(unsafe { S::get_state::<Toy>(a.c, &mut handle) }, OK);
    assert_eq!(handle, s);
    assert_eq!(a.free_state(s), OK);

    let blob = a.serialize();
    let s = a.get_state();
    let size = a.state_size(s);
    assert_eq!(size, blob.len());
    let mut short = vec![0u8; size - 1];
    assert_eq!(a.serialize_into(s, &mut short), ERROR);
    assert!(a.saw(
        ERROR,
        &[&format!("buffer of {} bytes is smaller than the state ({size} bytes)", size - 1)]
    ));
    assert_eq!(a.free_state(s), OK);
    let ahead = run(&a, 80, 50, 2.0);
    let b = H::<S>::new("b");
    assert_eq!(b.deserialize(&blob), OK, "{:?}", b.logged());
    assert_eq!(b.integer(STEPS), (OK, 80));
    assert_eq!(run(&b, 80, 50, 2.0), ahead);
    assert_eq!(b.serialize().len(), blob.len());
}

fn corrupt_truncated_and_foreign_blobs_are_refused<S: Master>() {
    let a = H::<S>::init("corrupt");
    run(&a, 0, 10, 1.0);
    let blob = a.serialize();
    let before = a.real(X);
    for at in 0..blob.len() {
        let mut bad = blob.clone();
        bad[at] ^= 0x21;
        assert_eq!(a.deserialize(&bad), ERROR, "flipped byte {at}");
    }
    assert!(a.saw(ERROR, &[S::DESERIALIZE, "CRC-32"]));
    for n in 0..blob.len() {
        assert_eq!(a.deserialize(&blob[..n]), ERROR, "truncated to {n}");
    }
    assert!(a.saw(ERROR, &["no IWFS header"]));
    assert_eq!(a.real(X), before, "refusals leave the instance as it was");
    assert_eq!(a.step(10.0 * DT, DT), OK);
}

/// A state carries the standard that wrote it: the FMI 2.0 and FMI 3.0 builds of one
/// model share its GUID and payload, yet neither takes the other's state (their states
/// and rules differ), and each says why.
#[test]
fn a_state_does_not_cross_standards() {
    let two = H::<Fmi2>::init("two");
    run(&two, 0, 10, 1.0);
    let three = H::<Fmi3>::init("three");
    run(&three, 0, 10, 1.0);
    let (from2, from3) = (two.serialize(), three.serialize());
    assert_eq!(payload_of::<Toy>(&from2), payload_of::<Toy>(&from3), "the same model state");
    assert_eq!(three.deserialize(&from2), ERROR);
    assert!(three.saw(ERROR, &["saved by the FMI 2.0 build of Toy, this is its FMI 3.0 build"]));
    assert_eq!(two.deserialize(&from3), ERROR);
    assert!(two.saw(ERROR, &["saved by the FMI 3.0 build of Toy, this is its FMI 2.0 build"]));
    assert_eq!((two.deserialize(&from2), three.deserialize(&from3)), (OK, OK));
}

/// The toy's payload: k, event_every, clamp_x (the parameters, as f64), then u, gain,
/// hold (a byte), x, steps.
const PAYLOAD_U: usize = 24;
const PAYLOAD_X: usize = 41;

fn forged_blobs_with_a_valid_checksum_are_validated<S: Master>() {
    let a = H::<S>::init("forged");
    run(&a, 0, 10, 1.0);
    let blob = a.serialize();
    let payload = payload_of::<Toy>(&blob);
    assert_eq!(payload.len(), 57);
    assert_eq!(&payload[PAYLOAD_X..PAYLOAD_X + 8], &a.real(X).1.to_le_bytes());
    let forge = |at: usize, x: f64| {
        let mut p = payload.clone();
        p[at..at + 8].copy_from_slice(&x.to_le_bytes());
        with_payload::<Toy>(&blob, &p)
    };
    let b = H::<S>::new("b");
    for (at, x, why) in [
        (PAYLOAD_X, f64::NAN, "x restored as NaN: must be finite"),
        (PAYLOAD_X, f64::INFINITY, "x restored as inf: must be finite"),
        (PAYLOAD_U, 50.0, "u restored as 50: must be finite and inside its declared range"),
        (PAYLOAD_U, f64::NAN, "u restored as NaN: must be finite and inside its declared range"),
        (0, f64::NAN, "parameter k has the invalid Real value NaN"),
        (8, 0.5, "parameter event_every has the invalid Integer value 0.5"),
        (16, 2.0, "parameter clamp_x has the invalid Boolean value 2"),
    ] {
        assert_eq!(b.deserialize(&forge(at, x)), ERROR, "{why}");
        let want = format!("{}: model state refused: {why}", S::DESERIALIZE);
        assert_eq!(b.take_logged(), [b.line(ERROR, "logStatusError", &want)]);
    }
    assert_eq!(b.deserialize(&blob), OK, "the unforged blob restores");
    let ahead = run(&a, 10, 10, 1.0);
    assert_eq!(run(&b, 10, 10, 1.0), ahead);
}

fn long_strings_from_outside_are_cut_in_messages<S: Master>() {
    let token = CString::new("x".repeat(5000)).unwrap();
    let log = H::<S>::try_with_token("long", &token, false).err().expect("refused");
    assert_eq!(log.len(), 1);
    let clipped = Clip(&"x".repeat(5000)).to_string();
    assert!(log[0].contains(&format!("\"{clipped}\" does not match")), "{log:?}");
    assert!(log[0].len() < 400, "{} bytes logged", log[0].len());

    let h = H::<S>::init("categories");
    let long = "log".repeat(1000);
    assert_eq!(h.set_debug_logging(true, &[&long]), ERROR);
    let logged = h.take_logged();
    assert!(logged[0].contains("… (3000 bytes)"), "{logged:?}");
    assert!(logged[0].len() < 400);
    // FMI 3.0 leads each message with the instance name: a long one is cut there too.
    let named = H::<S>::init(&"n".repeat(3000));
    assert_eq!(named.real(999).0, ERROR);
    assert!(named.logged()[0].len() < 400, "{:?}", named.logged());
}

fn instances_on_threads_match_serial_runs<S: Master>() {
    let drives = [1.0, 2.0, 3.0, 4.0, 5.0, 8.0, 9.0, 10.0];
    let go = |u: f64| {
        let h = H::<S>::init(&format!("u{u}"));
        let mut out = run(&h, 0, 200, u);
        out.extend(run(&h, 200, 200, u / 2.0));
        out
    };
    let serial: Vec<_> = drives.iter().map(|&u| go(u)).collect();
    let threads: Vec<_> = drives.iter().map(|&u| std::thread::spawn(move || go(u))).collect();
    let parallel: Vec<_> = threads.into_iter().map(|t| t.join().unwrap()).collect();
    assert_eq!(serial, parallel);
    assert_ne!(serial[0], serial[7]);
}

// What one standard has and the other has not.

#[test]
fn an_instance_of_one_standard_is_foreign_to_the_other() {
    let two = H::<Fmi2>::init("two");
    let three = H::<Fmi3>::init("three");
    unsafe {
        assert_eq!(refuses::<Fmi3, Toy>(two.c, "an FMI 2.0 instance"), 71);
        assert_eq!(refuses::<Fmi2, Toy>(three.c, "an FMI 3.0 instance"), 41);
    }
    assert_eq!((two.step(0.0, DT), three.step(0.0, DT)), (OK, OK));
}

#[test]
fn fmi2_instantiate_refuses_model_exchange_a_wrong_guid_and_no_name() {
    use inchworm_fmi_export::api::fmi2Instantiate;
    use inchworm_fmi_export::ffi::*;
    let log = inchworm_fmi_export::testing::Log(Default::default());
    let f = inchworm_fmi_export::testing::callbacks(&log);
    let guid = CString::new(model_description::guid::<Toy>()).unwrap();
    let cs_guid = CString::new(model_description::guid::<CsToy>()).unwrap();
    let null = std::ptr::null();
    unsafe {
        let x = c"x".as_ptr();
        assert!(fmi2Instantiate::<CsToy>(x, fmi2ModelExchange, cs_guid.as_ptr(), null, &f, 0, 0)
            .is_null());
        assert!(fmi2Instantiate::<Toy>(x, 2, guid.as_ptr(), null, &f, 0, 0).is_null());
        assert!(fmi2Instantiate::<Toy>(
            c"x".as_ptr(),
            fmi2CoSimulation,
            c"{wrong}".as_ptr(),
            null,
            &f,
            0,
            0
        )
        .is_null());
        assert!(
            fmi2Instantiate::<Toy>(null, fmi2CoSimulation, guid.as_ptr(), null, &f, 0, 0).is_null()
        );
        assert!(fmi2Instantiate::<Toy>(
            c"x".as_ptr(),
            fmi2CoSimulation,
            guid.as_ptr(),
            null,
            std::ptr::null(),
            0,
            0
        )
        .is_null());
    }
    let guid = model_description::guid::<Toy>();
    assert_eq!(
        *log.0.lock().unwrap(),
        [
            "3|logStatusError|fmi2Instantiate: not supported: this FMU implements Co-Simulation only".to_string(),
            "3|logStatusError|fmi2Instantiate: fmuType is neither fmi2ModelExchange (0) nor fmi2CoSimulation (1)".to_string(),
            format!("3|logStatusError|fmi2Instantiate: fmuGUID \"{{wrong}}\" does not match this FMU's \"{guid}\" (modelDescription.xml from another build?)"),
            "3|logStatusError|fmi2Instantiate: instanceName is NULL or empty".to_string(),
        ]
    );
}

#[test]
fn fmi2_status_queries() {
    use inchworm_fmi_export::api::*;
    use inchworm_fmi_export::ffi::*;
    let h = H::<Fmi2>::init("status");
    run(&h, 0, 3, 1.0);
    let (mut s, mut t, mut b) = (-1, 0.0, fmi2True);
    unsafe {
        assert_eq!(fmi2GetStatus::<Toy>(h.c, fmi2DoStepStatus, &mut s), OK);
        assert_eq!(fmi2GetRealStatus::<Toy>(h.c, fmi2LastSuccessfulTime, &mut t), OK);
        assert_eq!(fmi2GetBooleanStatus::<Toy>(h.c, fmi2Terminated, &mut b), OK);
        assert_eq!((s, t, b), (OK, 3.0 * DT, fmi2False));
        assert_eq!(fmi2GetStatus::<Toy>(h.c, fmi2PendingStatus, &mut s), ERROR);
        assert_eq!(fmi2GetRealStatus::<Toy>(h.c, fmi2DoStepStatus, std::ptr::null_mut()), ERROR);
        let mut i = 0;
        assert_eq!(fmi2GetIntegerStatus::<Toy>(h.c, fmi2DoStepStatus, &mut i), ERROR);
        let mut p: fmi2String = std::ptr::null();
        assert_eq!(fmi2GetStringStatus::<Toy>(h.c, fmi2PendingStatus, &mut p), ERROR);
        assert_eq!(fmi2CancelStep::<Toy>(h.c), ERROR);
        let mut str_out: fmi2String = std::ptr::null();
        assert_eq!(fmi2GetString::<Toy>(h.c, &X, 1, &mut str_out), ERROR);
        assert_eq!(fmi2GetString::<Toy>(h.c, &X, 0, &mut str_out), OK);
    }
    assert!(
        h.saw(ERROR, &["fmi2CancelStep: not supported: fmi2DoStep always completes synchronously"])
    );
    assert!(
        h.saw(ERROR, &["fmi2GetString: value reference 10 (x) is Real, not String"]),
        "{:?}",
        h.logged()
    );
    // The step status follows the last step's warning.
    assert_eq!(h.set_real(U, 10.0), OK);
    let mut k = 3;
    while h.step(k as f64 * DT, DT) == OK {
        k += 1;
    }
    unsafe { assert_eq!(fmi2GetStatus::<Toy>(h.c, fmi2DoStepStatus, &mut s), OK) };
    assert_eq!(s, WARNING);
    assert!(h.saw(WARNING, &["fmi2DoStep: x = ", "is close to its limit"]));
}

#[test]
fn fmi3_instantiate_checks_interface_token_and_event_mode() {
    use inchworm_fmi_export::fmi3::api::*;
    use inchworm_fmi_export::testing::Log;
    let log = Log(Default::default());
    let (env, logger) = inchworm_fmi_export::fmi3::testing::log_callback(&log);
    let token = CString::new(model_description::guid::<Toy>()).unwrap();
    let (n, t, null) = (c"me".as_ptr(), token.as_ptr(), std::ptr::null());
    let vr = [1u32];
    unsafe {
        let cs_token = CString::new(model_description::guid::<CsToy>()).unwrap();
        let cs_only = fmi3InstantiateModelExchange::<CsToy>(
            n,
            cs_token.as_ptr(),
            null,
            false,
            false,
            env,
            logger,
        );
        assert!(cs_only.is_null());
        assert!(fmi3InstantiateScheduledExecution::<Toy>(
            n, t, null, false, false, env, logger, None, None, None
        )
        .is_null());
        assert!(fmi3InstantiateCoSimulation::<Toy>(
            n,
            t,
            null,
            false,
            false,
            true,
            false,
            std::ptr::null(),
            0,
            env,
            logger,
            None
        )
        .is_null());
        assert!(fmi3InstantiateCoSimulation::<Toy>(
            n,
            t,
            null,
            false,
            false,
            false,
            false,
            vr.as_ptr(),
            1,
            env,
            logger,
            None
        )
        .is_null());
        assert!(fmi3InstantiateCoSimulation::<Toy>(
            n,
            null,
            null,
            false,
            false,
            false,
            false,
            std::ptr::null(),
            0,
            env,
            logger,
            None
        )
        .is_null());
    }
    assert_eq!(
        *log.0.lock().unwrap(),
        [
            "3|logStatusError|me: fmi3InstantiateModelExchange: not supported: this FMU implements Co-Simulation only",
            "3|logStatusError|me: fmi3InstantiateScheduledExecution: not supported: this FMU has no Scheduled Execution interface",
            "3|logStatusError|me: fmi3InstantiateCoSimulation: eventModeUsed requested, but this FMU has no event mode (hasEventMode=\"false\")",
            "3|logStatusError|me: fmi3InstantiateCoSimulation: requiredIntermediateVariables given, but this FMU provides no intermediate updates",
            "3|logStatusError|me: fmi3InstantiateCoSimulation: instantiationToken is NULL",
        ]
    );
}

#[test]
fn fmi3_time_do_step_results_counts_and_absent_types() {
    use inchworm_fmi_export::fmi3::api::*;
    let h = H::<Fmi3>::init("results");
    assert_eq!(h.real(0), (OK, 0.0), "time, value reference 0");
    assert_eq!(h.set_real(0, 1.0), ERROR, "time is not settable");
    assert!(h.saw(
        ERROR,
        &["value reference 0 is the independent variable time (Float64, not settable)"]
    ));
    let step = |t: f64, u: f64| {
        assert_eq!(h.set_real(U, u), OK);
        let (mut ev, mut term, mut early, mut last) = (true, true, true, f64::NAN);
        let s = unsafe {
            fmi3DoStep::<Toy>(h.c, t, DT, true, &mut ev, &mut term, &mut early, &mut last)
        };
        (s, [ev, term, early], last)
    };
    assert_eq!(step(0.0, 1.0), (OK, [false, false, false], DT));
    assert_eq!(h.real(0), (OK, DT));
    assert_eq!(
        step(1.0, 1.0),
        (ERROR, [false, false, false], DT),
        "refused: lastSuccessfulTime unchanged"
    );
    assert_eq!(step(DT, FAIL), (ERROR, [false, true, false], DT), "the model failed: terminate");
    let h = H::<Fmi3>::init("nulls");
    let mut last = 0.0;
    let null = std::ptr::null_mut();
    assert_eq!(
        unsafe { fmi3DoStep::<Toy>(h.c, 0.0, DT, true, null, null, null, &mut last) },
        ERROR
    );
    assert_eq!(last, 0.0);
    assert!(h.saw(
        ERROR,
        &["eventHandlingNeeded, terminateSimulation, earlyReturn or lastSuccessfulTime is NULL"]
    ));
    let (mut v, mut b) = (0i32, [0u8; 1]);
    unsafe {
        assert_eq!(fmi3GetInt32::<Toy>(h.c, &STEPS, 1, &mut v, 2), ERROR);
        assert_eq!(fmi3GetUInt8::<Toy>(h.c, &STEPS, 1, b.as_mut_ptr(), 1), ERROR);
        assert_eq!(fmi3GetUInt8::<Toy>(h.c, &STEPS, 0, b.as_mut_ptr(), 0), OK, "nothing asked");
        assert_eq!(fmi3GetInt8::<Toy>(h.c, &0u32, 1, null as *mut i8, 1), ERROR);
        let two = 2u8;
        assert_eq!(
            fmi3SetBoolean::<Toy>(h.c, &HOLD, 1, &two as *const u8 as *const bool, 1),
            OK,
            "any non-zero byte is true"
        );
        assert_eq!(fmi3GetBoolean::<Toy>(h.c, &HOLD, 1, b.as_mut_ptr() as *mut bool, 1), OK);
        assert_eq!(b[0], 1, "a C bool is written as 0 or 1");
        assert_eq!(fmi3EnterEventMode::<Toy>(h.c), ERROR);
        assert_eq!(fmi3SetTime::<Toy>(h.c, 0.0), ERROR);
    }
    for part in [
        "nValues 2 differs from the 1 values of the 1 value references",
        "value reference 11 (steps) is Int32, not UInt8",
        "value reference 0 (time) is Float64, not Int8",
        "fmi3EnterEventMode: not supported: a Co-Simulation instance has no event mode",
        "fmi3SetTime: not supported: a Co-Simulation instance has no event mode",
    ] {
        assert!(h.saw(ERROR, &[part]), "{part}: {:?}", h.logged());
    }
    assert_eq!(h.step(0.0, DT), OK, "refusals leave the instance usable");
}
