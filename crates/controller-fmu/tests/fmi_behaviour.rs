//! The FMI boundary of InchwormController: timing contract, bad inputs and parameters,
//! state round trips, threads, and the committed modelDescription.

use inchworm_fmi_export::ffi::*;
use inchworm_fmi_export::model_description;
use inchworm_fmi_export::testing::{categories_of, payload_of, with_payload, Harness};
use inchworm_fmi_export::{parameter_values, Model, Var};
use inchworm_fmu_models::{ControllerFmu, ControllerParams};

type H = Harness<ControllerFmu>;

/// Drives the controller against a synthetic encoder (each forward extension sample moves
/// it by 2 nm), returning the DAC codes sample by sample.
fn drive(h: &H, k0: usize, samples: usize) -> Vec<(i32, f64, i32)> {
    let mut out = Vec::new();
    let mut counts = 0;
    for k in k0..k0 + samples {
        assert_eq!(h.set_integer(ControllerFmu::ENCODER_COUNTS.vr(), counts), fmi2OK);
        assert_eq!(h.step(k as f64 * 0.002, 0.002), fmi2OK, "{:?}", h.logged());
        let (_, dac_n) = h.real(ControllerFmu::DAC_NONEARTH.vr());
        let (_, code) = h.integer(ControllerFmu::DAC_NONEARTH_CODE.vr());
        counts += (dac_n > 5.0) as i32 * 2;
        out.push((
            code,
            h.real(ControllerFmu::DAC_EARTH.vr()).1,
            h.integer(ControllerFmu::N_STEPS.vr()).1,
        ));
    }
    out
}

/// No time a master gives makes one call run unbounded work: a step or a Model Exchange
/// time more than 10^7 samples (20 000 s) past the last sample is refused before anything
/// runs, with the reason, and the instance goes on; a defined stop time is refused past.
#[test]
fn a_call_runs_a_bounded_number_of_samples_whatever_time_it_is_given() {
    let h = H::init("far");
    let started = std::time::Instant::now();
    for far in [2.1e4, 1e6, 1e300] {
        assert_eq!(h.step(0.0, far), fmi2Error, "a step of {far} s");
        let h_me = H::init_me("far_me");
        assert_eq!(h_me.enter_continuous_time_mode(), fmi2OK);
        assert_eq!(h_me.set_time(far), fmi2Error, "time {far} s");
        assert!(
            h_me.saw(
                fmi2Error,
                &[
                    "fmi2SetTime",
                    "sample instants past the last sample at 0 s; one call runs at most 1e7"
                ]
            ),
            "{:?}",
            h_me.logged()
        );
        // The instance goes on where it was.
        assert_eq!(h_me.set_time(0.01), fmi2OK);
        assert_eq!(h_me.enter_event_mode(), fmi2OK);
        let (status, update, _) = h_me.update();
        assert_eq!((status, update.next_event_time), (fmi2OK, Some(0.012)), "{:?}", h_me.logged());
    }
    assert!(h.saw(fmi2Error, &["fmi2DoStep", "one call runs at most 1e7"]), "{:?}", h.logged());
    assert!(started.elapsed().as_secs() < 10, "the refusals ran no samples");
    assert_eq!(h.step(0.0, 0.002), fmi2OK, "{:?}", h.logged());
    // A long but bounded step runs: 2 000 s, 10^6 samples.
    assert_eq!(h.step(0.002, 2000.0), fmi2OK, "{:?}", h.logged());
    // Past a defined stop time, the event update (which would run the samples) is refused
    // as a step past it is.
    let stop = H::new_me("stop");
    assert_eq!(
        (stop.experiment(0.0, Some(1.0)), stop.enter(), stop.exit()),
        (fmi2OK, fmi2OK, fmi2OK)
    );
    assert_eq!(stop.enter_continuous_time_mode(), fmi2OK);
    assert_eq!(stop.set_time(2.0), fmi2OK);
    assert_eq!(stop.enter_event_mode(), fmi2OK);
    assert_eq!(stop.update().0, fmi2Error);
    let want = "an event update at 2 s is past the stop time 1";
    assert!(stop.saw(fmi2Error, &["fmi2NewDiscreteStates", want]), "{:?}", stop.logged());
}

#[test]
fn timing_contract_one_sample_delay() {
    let h = H::init("timing");
    assert_eq!(h.set_real(ControllerFmu::REFERENCE.vr(), 100e-6), fmi2OK);
    // Before any step the outputs are the parked sample.
    assert_eq!(h.real(ControllerFmu::DAC_NONEARTH.vr()), (fmi2OK, 0.0));
    // doStep(0, 2 ms) chooses the move and outputs sample 2 (still parked).
    assert_eq!(h.step(0.0, 0.002), fmi2OK);
    assert_eq!(h.integer(ControllerFmu::N_STEPS.vr()), (fmi2OK, 3));
    assert_eq!(h.boolean(ControllerFmu::MOVING.vr()), (fmi2OK, true));
    assert_eq!(h.real(ControllerFmu::DAC_NONEARTH.vr()).1, 0.0);
    // After the step ending at 13 × 2 ms the output is sample 15: non-earth powered.
    assert_eq!(h.step(0.002, 0.024), fmi2OK, "12 samples in one call");
    assert_eq!(h.real(ControllerFmu::DAC_NONEARTH.vr()).1, 0.0, "sample 14");
    assert_eq!(h.step(0.026, 0.002), fmi2OK);
    assert_eq!(h.real(ControllerFmu::DAC_NONEARTH.vr()).1, 10.0, "sample 15");
    assert_eq!(h.integer(ControllerFmu::DAC_NONEARTH_CODE.vr()).1, 65535);
    // Any step size is accepted (tests/any_step.rs has the rule); a non-positive one is not.
    assert_eq!(h.step(0.028, 0.003), fmi2OK);
    assert_eq!(h.step(0.031, 0.0), fmi2Error);
    assert!(h.saw(fmi2Error, &["fmi2DoStep", "must be finite and > 0"]), "{:?}", h.logged());
    assert_eq!(h.step(0.031, 0.001), fmi2OK);
}

#[test]
fn bad_inputs_and_parameters_are_refused_with_a_message() {
    let h = H::init("inputs");
    assert_eq!(h.set_real(ControllerFmu::REFERENCE.vr(), 5e-6), fmi2OK);
    assert_eq!(h.set_real(ControllerFmu::REFERENCE.vr(), f64::NAN), fmi2Error);
    let reference = ControllerFmu::REFERENCE.name();
    assert!(h.saw(fmi2Error, &[reference, "NaN", "keeping 0.000005"]), "{:?}", h.logged());
    assert_eq!(h.real(ControllerFmu::REFERENCE.vr()), (fmi2OK, 5e-6));
    assert_eq!(h.step(0.0, 0.002), fmi2OK, "a refused input leaves the instance usable");
    assert_eq!(h.real(999).0, fmi2Error, "999 is no variable's value reference");
    assert_eq!(h.set_real(ControllerFmu::DAC_EARTH.vr(), 1.0), fmi2Error, "outputs cannot be set");
    assert_eq!(
        h.set_boolean(ControllerFmu::var(ControllerParams::FEEDFORWARD).vr(), false),
        fmi2Error,
        "fixed parameters cannot change after initialization"
    );

    for (what, set) in [
        (
            ControllerFmu::var(ControllerParams::SAMPLES_PER_STEP).name(),
            Box::new(|h: &H| {
                h.set_integer(ControllerFmu::var(ControllerParams::SAMPLES_PER_STEP).vr(), 3)
            }) as Box<dyn Fn(&H) -> fmi2Status>,
        ),
        (
            // The array's name (its elements are `basis_peak[k]`).
            ControllerFmu::var(ControllerParams::BASIS_PEAKS).name().strip_suffix("[1]").unwrap(),
            Box::new(|h: &H| {
                h.set_real(ControllerFmu::var(ControllerParams::BASIS_PEAKS).element(4).vr(), 2e-6)
            }),
        ),
    ] {
        let h = H::new("params");
        assert_eq!(h.setup(), fmi2OK);
        assert_eq!(set(&h), fmi2OK);
        assert_eq!(h.enter(), fmi2OK);
        assert_eq!(h.exit(), fmi2Error);
        assert!(
            h.saw(fmi2Error, &["fmi2ExitInitializationMode", what]),
            "{what}: {:?}",
            h.logged()
        );
        assert_eq!(h.reset(), fmi2OK);
    }
}

#[test]
fn state_round_trips_replay_bit_for_bit() {
    let a = H::init("a");
    assert_eq!(a.set_real(ControllerFmu::REFERENCE.vr(), 60e-6), fmi2OK);
    drive(&a, 0, 150);
    let s = a.get_state();
    let bytes = a.serialize();
    let first = drive(&a, 150, 400);
    assert_eq!(a.set_state(s), fmi2OK);
    assert_eq!(drive(&a, 150, 400), first);
    assert_eq!(a.free_state(s), fmi2OK);

    let b = H::new("b");
    assert_eq!(b.deserialize(&bytes), fmi2OK, "{:?}", b.logged());
    assert_eq!(drive(&b, 150, 400), first);
    let mut bad = bytes.clone();
    bad[10] ^= 0x20;
    assert_eq!(b.deserialize(&bad), fmi2Error);
    assert!(b.saw(fmi2Error, &["fmi2DeSerializeFMUstate"]));
}

#[test]
fn debug_logging_enables_exactly_the_named_categories() {
    let h = H::init("logging");
    assert_eq!(h.set_real(ControllerFmu::REFERENCE.vr(), 60e-6), fmi2OK);
    drive(&h, 0, 150);
    assert_eq!(h.take_logged(), Vec::<String>::new(), "no debug messages without debug logging");

    assert_eq!(h.set_debug_logging(true, &["logEvents"]), fmi2OK);
    assert_eq!(h.set_real(ControllerFmu::REFERENCE.vr(), -40e-6), fmi2OK);
    drive(&h, 150, 300);
    let events = h.take_logged();
    assert_eq!(
        events,
        ["0|logEvents|control iteration near t = 0.6 s: 3 full step(s) and fraction -0.9642, disturbance estimate 0.1009 um"]
    );

    assert_eq!(h.set_debug_logging(true, &[]), fmi2OK);
    assert_eq!(h.set_real(ControllerFmu::REFERENCE.vr(), 30e-6), fmi2OK);
    drive(&h, 450, 600);
    let all = h.take_logged();
    assert_eq!(categories_of(&all), ["logAll", "logEvents"]);
    assert!(all.iter().any(|l| l.starts_with("0|logEvents|control iteration")), "{all:?}");
    assert_eq!(all.iter().filter(|l| l.as_str() == "0|logAll|fmi2DoStep").count(), 600);
    assert_eq!(all.iter().filter(|l| l.as_str() == "0|logAll|fmi2SetInteger").count(), 600);

    assert_eq!(h.set_debug_logging(false, &["logEvents", "logAll"]), fmi2OK);
    assert_eq!(h.take_logged(), ["0|logAll|fmi2SetDebugLogging"]);
    assert_eq!(h.set_real(ControllerFmu::REFERENCE.vr(), 0.0), fmi2OK);
    drive(&h, 1050, 600);
    assert_eq!(h.take_logged(), Vec::<String>::new());

    assert_eq!(h.set_debug_logging(true, &["logEvent"]), fmi2Error);
    assert!(h.saw(fmi2Error, &["fmi2SetDebugLogging", "unknown log category \"logEvent\""]));
}

/// The payload of an uninitialized controller with prefilter on, samples_per_step = 50
/// and encoder_counts = -12, as the encoder before the table-driven parameter save wrote
/// it (state format 1): parameters in table order as f64, the inputs, no sample, no
/// controller. The parameters include the default estimates, so a recalibration
/// (docs/controller-design.md) changes those 88 bytes and nothing else; last changed
/// with the passive plant's calibration and the parameters of the options of
/// docs/controller-design.md (analog mode, disturbance map, single integrator), which
/// lengthen the parameter list (the GUID changes with it, so an older blob is refused).
const CONTROLLER_FORMAT_1: &str = concat!(
    "000000000000f03f000000000000f03f000000000000f03f000000000000f03f0000000000000000",
    "00000000000049400ad7a3703d0ad73f9a9999999999e93f9a9999999999e93f9a9999999999a93f",
    "f168e388b5f8d43efca9f1d24d62503f48afbc9af2d77a3e7b14ae47e17a743f48afbc9af2d76a3e",
    "4cce61e3a79d143ed6c62004e0b7d33e54e41071732af9be8dedb5a0f7c6f0be8dedb5a0f7c6e0be",
    "54e41071732ac9be8dedb5a0f7c6b0be8dedb5a0f7c6b03e54e41071732ac93e8dedb5a0f7c6e03e",
    "8dedb5a0f7c6f03e54e41071732af93e6825adf886c2f2bf018a912573aceabfe8d9acfa5c6ddcbf",
    "d04543c6a354c6bf177fdb1324b6abbf4f3fa88b14caaa3f8db800344a97c63f42e8a04b38f4db3f",
    "452fa3586ee9eb3f8c101e6d1cb1f13f0000000000000000f168e388b5f8c43e3d7a68c47185bc3e",
    "333333333333d33f000000000000f83f000000000000000000000000000000000000000000000000",
    "333333333333e33f00000000000028c000000000000000000000",
);

fn hex(s: &str) -> Vec<u8> {
    (0..s.len()).step_by(2).map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap()).collect()
}

#[test]
fn state_payload_keeps_format_1_byte_for_byte() {
    let a = H::new("format");
    // In initialization mode, where the restored copy may be read back.
    assert_eq!((a.setup(), a.enter()), (fmi2OK, fmi2OK));
    assert_eq!(a.set_boolean(ControllerFmu::var(ControllerParams::PREFILTER).vr(), true), fmi2OK);
    assert_eq!(
        a.set_integer(ControllerFmu::var(ControllerParams::SAMPLES_PER_STEP).vr(), 50),
        fmi2OK
    );
    assert_eq!(a.set_integer(ControllerFmu::ENCODER_COUNTS.vr(), -12), fmi2OK);
    let blob = a.serialize();
    assert_eq!(payload_of::<ControllerFmu>(&blob), hex(CONTROLLER_FORMAT_1));
    let b = H::new("restored");
    assert_eq!(b.deserialize(&blob), fmi2OK, "{:?}", b.logged());
    assert_eq!(b.boolean(ControllerFmu::var(ControllerParams::PREFILTER).vr()), (fmi2OK, true));
    assert_eq!(
        b.integer(ControllerFmu::var(ControllerParams::SAMPLES_PER_STEP).vr()),
        (fmi2OK, 50)
    );
    assert_eq!(b.integer(ControllerFmu::ENCODER_COUNTS.vr()), (fmi2OK, -12));
    assert_eq!(b.serialize(), blob);
}

#[test]
fn parameters_a_master_could_not_have_set_are_refused_in_a_state() {
    let a = H::new("source");
    let blob = a.serialize();
    let payload = payload_of::<ControllerFmu>(&blob);
    // The payload starts with the parameters in table order, 8 bytes each.
    let at = |var: Var<ControllerFmu>, x: f64| {
        let i = parameter_values(&ControllerFmu::new()).position(|(n, _)| n == var.name());
        let i = i.expect("a parameter");
        let mut p = payload.clone();
        p[8 * i..8 * i + 8].copy_from_slice(&x.to_le_bytes());
        with_payload::<ControllerFmu>(&blob, &p)
    };
    let b = H::new("target");
    for (bytes, why) in [
        (
            at(ControllerFmu::var(ControllerParams::PREFILTER), 0.5),
            "parameter prefilter has the invalid Boolean value 0.5",
        ),
        (
            at(ControllerFmu::var(ControllerParams::SAMPLES_PER_STEP), 1.5),
            "parameter samples_per_step has the invalid Integer value 1.5",
        ),
        (
            at(ControllerFmu::var(ControllerParams::SAMPLES_PER_STEP), -1.0),
            "parameter samples_per_step has the invalid Integer value -1",
        ),
        (
            at(ControllerFmu::var(ControllerParams::DEADBAND), f64::NAN),
            "parameter deadband has the invalid Real value NaN",
        ),
        (
            with_payload::<ControllerFmu>(&blob, &payload[..100]),
            "model state truncated in its 46 parameters",
        ),
        (
            with_payload::<ControllerFmu>(&blob, &[&payload[..], &[0]].concat()),
            "controller FMU state: trailing bytes after an uninitialized controller",
        ),
    ] {
        assert_eq!(b.deserialize(&bytes), fmi2Error, "{why}");
        let expected =
            format!("3|logStatusError|fmi2DeSerializeFMUstate: model state refused: {why}");
        assert_eq!(b.take_logged(), [expected]);
    }
    assert_eq!(b.deserialize(&blob), fmi2OK, "the refusals left the instance usable");
}

#[test]
fn committed_model_description_matches_the_variable_table() {
    let path =
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../modelDescription/InchwormController.xml");
    let committed = std::fs::read_to_string(path).unwrap_or_default();
    assert!(
        committed == model_description::model_description::<ControllerFmu>(),
        "{path} differs from the variable table: run `cargo run --release -p fmu-build` and commit modelDescription/"
    );
}
