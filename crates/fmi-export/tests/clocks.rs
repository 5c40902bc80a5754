//! FMI 3.0 clocks in the layer, on the clocked toy (`toy/clocked.rs`): Co-Simulation with
//! event mode (steps end at ticks, `fmi3SetClock`, `fmi3UpdateDiscreteStates`, output
//! clocks), Scheduled Execution (`fmi3ActivateModelPartition`, `clockUpdate`, the
//! preemption lock), intervals, the call-order refusals with their logged reasons, calls
//! from two threads at once, and the descriptions: FMI 2.0 has no clocks.

#[path = "toy/clocked.rs"]
mod clocked;

use std::ffi::{c_void, CString};
use std::sync::atomic::{AtomicPtr, AtomicUsize, Ordering};

use clocked::*;
use inchworm_fmi_export::fmi3::api::*;
use inchworm_fmi_export::fmi3::ffi::*;
use inchworm_fmi_export::fmi3::model_description as description3;
use inchworm_fmi_export::fmi3::testing::{log_callback, Log};
use inchworm_fmi_export::model_description;

type M = ClockToy;

/// How an instance is made.
enum Kind {
    /// Co-Simulation: `eventModeUsed`, `earlyReturnAllowed`.
    Cs(bool, bool),
    /// Scheduled Execution with these callbacks.
    Se(
        fmi3ClockUpdateCallback,
        fmi3LockPreemptionCallback,
        fmi3UnlockPreemptionCallback,
        *mut c_void,
    ),
}

/// One instance of the clocked toy, initialized (start 0, stop 1).
struct Inst {
    c: fmi3Instance,
    log: Box<Log>,
}

impl Inst {
    fn new(kind: Kind) -> Inst {
        let log = Box::new(Log(Default::default()));
        let (env, logger) = log_callback(&log);
        let token = CString::new(model_description::guid::<M>()).unwrap();
        let (name, null) = (c"clocked".as_ptr(), std::ptr::null());
        let c = unsafe {
            match kind {
                Kind::Cs(events, early) => fmi3InstantiateCoSimulation::<M>(
                    name,
                    token.as_ptr(),
                    null,
                    false,
                    false,
                    events,
                    early,
                    std::ptr::null(),
                    0,
                    env,
                    logger,
                    None,
                ),
                Kind::Se(update, lock, unlock, se_env) => {
                    // The scheduler's callbacks get the instance environment: the test's own.
                    let env = if se_env.is_null() { env } else { se_env };
                    let logger = if se_env.is_null() { logger } else { None };
                    fmi3InstantiateScheduledExecution::<M>(
                        name,
                        token.as_ptr(),
                        null,
                        false,
                        false,
                        env,
                        logger,
                        update,
                        lock,
                        unlock,
                    )
                }
            }
        };
        assert!(!c.is_null(), "{:?}", log.0.lock().unwrap());
        let inst = Inst { c, log };
        unsafe {
            assert_eq!(fmi3EnterInitializationMode::<M>(c, false, 0.0, 0.0, true, 1.0), fmi3OK);
            assert_eq!(fmi3ExitInitializationMode::<M>(c), fmi3OK);
        }
        inst
    }
    fn step(&self, t: f64, h: f64) -> (fmi3Status, [bool; 3], f64) {
        let (mut ev, mut term, mut early, mut last) = (false, true, false, f64::NAN);
        let s = unsafe {
            fmi3DoStep::<M>(self.c, t, h, true, &mut ev, &mut term, &mut early, &mut last)
        };
        (s, [ev, early, term], last)
    }
    fn set_clock(&self, vr: u32, on: bool) -> fmi3Status {
        unsafe { fmi3SetClock::<M>(self.c, &vr, 1, &on) }
    }
    fn clock(&self, vr: u32) -> (fmi3Status, bool) {
        let mut v = false;
        (unsafe { fmi3GetClock::<M>(self.c, &vr, 1, &mut v) }, v)
    }
    fn update(&self) -> (fmi3Status, Option<f64>) {
        let (mut a, mut b, mut c, mut d, mut e, mut t) = (true, true, true, true, false, f64::NAN);
        let s = unsafe {
            fmi3UpdateDiscreteStates::<M>(self.c, &mut a, &mut b, &mut c, &mut d, &mut e, &mut t)
        };
        (s, e.then_some(t))
    }
    /// The tick at the instance's time: `tick` activated and the update that runs it.
    fn run_tick(&self) {
        assert_eq!(self.set_clock(TICK, true), fmi3OK, "{:?}", self.logged());
        assert_eq!(self.update().0, fmi3OK, "{:?}", self.logged());
    }
    fn enter_step_mode(&self) -> fmi3Status {
        unsafe { fmi3EnterStepMode::<M>(self.c) }
    }
    fn set_u(&self, u: f64) -> fmi3Status {
        unsafe { fmi3SetFloat64::<M>(self.c, &U, 1, &u, 1) }
    }
    fn real(&self, vr: u32) -> f64 {
        let mut v = f64::NAN;
        assert_eq!(unsafe { fmi3GetFloat64::<M>(self.c, &vr, 1, &mut v, 1) }, fmi3OK);
        v
    }
    fn activate(&self, clock: u32, t: f64) -> fmi3Status {
        unsafe { fmi3ActivateModelPartition::<M>(self.c, clock, t) }
    }
    fn logged(&self) -> Vec<String> {
        self.log.0.lock().unwrap().clone()
    }
    /// Whether an error naming all of `parts` was logged.
    fn saw(&self, parts: &[&str]) -> bool {
        self.logged().iter().any(|l| l.starts_with("3|") && parts.iter().all(|p| l.contains(p)))
    }
}

impl Drop for Inst {
    fn drop(&mut self) {
        unsafe { fmi3FreeInstance::<M>(self.c) };
    }
}

/// Event mode: `fmi3ExitInitializationMode` enters it (the start time is a tick), each
/// step ends at the next tick with `eventHandlingNeeded`, the tick's partition runs at
/// `fmi3UpdateDiscreteStates` once per activation, the output clock reads its tick in the
/// event and is off after it, and `x` integrates between ticks.
#[test]
fn event_mode_runs_each_tick_once_at_the_update() {
    let i = Inst::new(Kind::Cs(true, false));
    let mut sum = 0.0;
    for k in 0..9 {
        let t = k as f64 * PERIOD;
        let u = 0.5 + k as f64;
        assert_eq!((i.set_clock(TICK, true), i.set_u(u)), (fmi3OK, fmi3OK));
        assert_eq!(i.clock(TICK), (fmi3OK, true), "an activated input clock reads active");
        let (s, next) = i.update();
        assert_eq!(s, fmi3OK, "{:?}", i.logged());
        assert!((next.unwrap() - (t + PERIOD)).abs() < 1e-12, "next event: the next tick");
        sum += u;
        assert_eq!(i.real(SUM), sum, "tick {k}");
        assert_eq!(i.update().0, fmi3OK);
        assert_eq!(i.real(SUM), sum, "a second update runs no partition");
        assert_eq!(i.clock(THIRD), (fmi3OK, k % 3 == 2), "the output clock at tick {k}");
        assert_eq!(unsafe { fmi3EnterStepMode::<M>(i.c) }, fmi3OK);
        assert_eq!(i.step(t, PERIOD), (fmi3OK, [true, false, false], t + PERIOD));
        assert!((i.real(X) - sum * PERIOD).abs() < 1e-12, "x integrates u between ticks");
        assert_eq!(unsafe { fmi3EnterEventMode::<M>(i.c) }, fmi3OK);
        assert_eq!(i.clock(THIRD), (fmi3OK, false), "off once the event is left");
    }
    assert_eq!(i.real(SUM), 40.5);
}

/// A step that passes a tick is refused without `earlyReturnAllowed`, and returns early at
/// the tick with it; a step that ends before the tick ends where asked, with no event.
#[test]
fn a_step_ends_at_the_next_tick_at_the_latest() {
    let i = Inst::new(Kind::Cs(true, false));
    i.run_tick();
    assert_eq!(i.enter_step_mode(), fmi3OK);
    assert_eq!(i.step(0.0, 0.05), (fmi3OK, [false, false, false], 0.05));
    assert_eq!(i.step(0.05, 0.1).0, fmi3Error);
    assert!(
        i.saw(&["fmi3DoStep: the step to 0.15000000000000002 s passes the clock tick at 0.1 s"])
    );
    assert_eq!(i.step(0.05, 0.05), (fmi3OK, [true, false, false], 0.1));

    let e = Inst::new(Kind::Cs(true, true));
    e.run_tick();
    assert_eq!(e.enter_step_mode(), fmi3OK);
    assert_eq!(e.step(0.0, 0.25), (fmi3OK, [true, true, false], 0.1), "early at the tick");
    assert_eq!(e.step(0.1, 0.25), (fmi3OK, [true, true, false], 0.2), "from where it ended");
}

/// The call order of event mode, each refusal an fmi3Error with its reason logged and
/// nothing changed.
#[test]
fn event_mode_call_order_is_checked() {
    let i = Inst::new(Kind::Cs(true, false));
    assert_eq!(i.step(0.0, PERIOD).0, fmi3Error, "fmi3DoStep without leaving event mode");
    assert!(i.saw(&["fmi3DoStep: illegal call sequence: not allowed in state EventMode"]));
    assert_eq!(i.set_clock(99, true), fmi3Error);
    assert!(i.saw(&["fmi3SetClock: value reference 99 is not a clock of this FMU"]));
    assert_eq!(i.set_clock(THIRD, true), fmi3Error);
    assert!(i.saw(&["fmi3SetClock: third (value reference 21) is an output clock"]));
    // A byte other than 0 or 1, as a C master may pass; read as a byte, never as a bool.
    let two = 2u8;
    assert_eq!(
        unsafe { fmi3SetClock::<M>(i.c, &TICK, 1, &two as *const u8 as *const bool) },
        fmi3Error
    );
    assert!(i.saw(&["tick = 2 refused: a clock is 0 (inactive) or 1 (active)"]));
    assert_eq!(i.clock(TICK), (fmi3OK, false), "nothing activated by a refused call");
    i.run_tick();
    assert_eq!(i.enter_step_mode(), fmi3OK);
    assert_eq!(i.update().0, fmi3Error, "fmi3UpdateDiscreteStates outside event mode");
    assert!(
        i.saw(&["fmi3UpdateDiscreteStates: illegal call sequence: not allowed in state StepMode"])
    );
    assert_eq!(i.set_clock(TICK, true), fmi3Error);
    assert!(i.saw(&["fmi3SetClock: illegal call sequence: not allowed in state StepMode"]));
    assert_eq!(i.clock(THIRD).0, fmi3Error);
    assert_eq!(unsafe { fmi3EnterStepMode::<M>(i.c) }, fmi3Error);
    assert_eq!(i.step(0.0, 0.05).0, fmi3OK);
    assert_eq!(unsafe { fmi3EnterEventMode::<M>(i.c) }, fmi3OK);
    assert_eq!(i.set_clock(TICK, true), fmi3Error, "0.05 s is not a tick");
    assert!(i.saw(&["fmi3SetClock: tick ticks at 0 s + n × 0.1 s; 0.05 s is not one of its ticks"]));

    // Without eventModeUsed the instance has no event mode.
    let plain = Inst::new(Kind::Cs(false, false));
    assert_eq!(plain.step(0.0, 0.25).0, fmi3OK, "a plain step passes ticks");
    assert_eq!(plain.real(SUM), 0.0);
    assert_eq!(unsafe { fmi3EnterEventMode::<M>(plain.c) }, fmi3Error);
    assert!(plain.saw(&["fmi3EnterEventMode: not supported: this Co-Simulation instance was instantiated without eventModeUsed"]));
}

/// An importer that does not activate the input clock at its ticks: one that leaves the
/// event at a tick without `fmi3SetClock` (the loops of FMPy's
/// `simulate_fmu(use_event_mode=True)` and fmusim's `--event-mode-used`), or activates it
/// without the update that runs it. `fmi3EnterStepMode` runs the tick itself with the
/// inputs set, as a plain Co-Simulation step would, and returns OK; the first such tick of
/// the instance is logged as a warning with its time, the later ones are not. An event at
/// a time that is no tick (an input event) runs nothing.
#[test]
fn a_tick_the_importer_did_not_activate_runs_when_the_event_is_left_logged_once() {
    let why = "fmi3EnterStepMode: tick ticks at 0 s and the importer did not activate it (fmi3SetClock, then fmi3UpdateDiscreteStates, before leaving the event: FMI 3.0 section 2.2.8.2); the FMU runs the tick itself";
    let i = Inst::new(Kind::Cs(true, false));
    assert_eq!(i.set_u(2.0), fmi3OK);
    assert_eq!(i.update().0, fmi3OK, "an update without clocks");
    assert_eq!(i.real(SUM), 0.0, "the update ran no partition");
    assert_eq!(i.enter_step_mode(), fmi3OK);
    assert_eq!(i.real(SUM), 2.0, "the tick ran on leaving the event");
    let warned = |i: &Inst| -> Vec<String> {
        i.logged().into_iter().filter(|m| m.contains("did not activate")).collect()
    };
    assert!(
        warned(&i)[0].starts_with(&format!("1|logStatusWarning|clocked: {why}")),
        "{:?}",
        i.logged()
    );

    // The next tick: activated, but not run by an update. It runs once, not logged again.
    assert_eq!(i.step(0.0, PERIOD), (fmi3OK, [true, false, false], PERIOD));
    assert_eq!(unsafe { fmi3EnterEventMode::<M>(i.c) }, fmi3OK);
    assert_eq!((i.set_u(3.0), i.set_clock(TICK, true)), (fmi3OK, fmi3OK));
    assert_eq!((i.enter_step_mode(), i.real(SUM)), (fmi3OK, 5.0));
    // The third: run by the importer, so not again on leaving.
    assert_eq!(i.step(PERIOD, PERIOD).0, fmi3OK);
    assert_eq!(unsafe { fmi3EnterEventMode::<M>(i.c) }, fmi3OK);
    i.run_tick();
    assert_eq!((i.enter_step_mode(), i.real(SUM)), (fmi3OK, 8.0));
    assert_eq!(warned(&i).len(), 1, "logged once per instance: {:?}", i.logged());

    // An event between ticks runs nothing.
    assert_eq!(i.step(2.0 * PERIOD, 0.05), (fmi3OK, [false, false, false], 2.0 * PERIOD + 0.05));
    assert_eq!(unsafe { fmi3EnterEventMode::<M>(i.c) }, fmi3OK);
    assert_eq!(i.update().0, fmi3OK);
    assert_eq!((i.enter_step_mode(), i.real(SUM)), (fmi3OK, 8.0));
}

/// An importer that ignores `eventHandlingNeeded` and steps on from the tick without
/// entering event mode: the tick runs at the start of the next step, so every sample
/// runs, as without `eventModeUsed` (the toy sums its input at each tick); logged once.
#[test]
fn a_tick_stepped_past_without_an_event_runs_at_the_next_step_logged_once() {
    let i = Inst::new(Kind::Cs(true, false));
    assert_eq!(i.set_u(1.0), fmi3OK);
    i.run_tick();
    assert_eq!(i.enter_step_mode(), fmi3OK);
    let mut sum = 1.0;
    for k in 0..5 {
        let t = k as f64 * PERIOD;
        let u = 10.0 + k as f64;
        assert_eq!(i.set_u(u), fmi3OK);
        assert_eq!(i.step(t, PERIOD), (fmi3OK, [true, false, false], t + PERIOD));
        if k > 0 {
            sum += u;
        }
        assert_eq!(i.real(SUM), sum, "step {k}: the tick at {t} s ran at its start, with u = {u}");
    }
    let warned: Vec<_> =
        i.logged().into_iter().filter(|m| m.contains("did not activate")).collect();
    assert_eq!(warned.len(), 1, "{warned:?}");
    assert!(
        warned[0].starts_with("1|logStatusWarning|clocked: fmi3DoStep: tick ticks at 0.1 s"),
        "{warned:?}"
    );
}

/// A failing partition moves the instance to Error with `terminateSimulation`, as a
/// failed step does.
#[test]
fn a_failing_partition_ends_in_error() {
    let i = Inst::new(Kind::Cs(true, false));
    assert_eq!((i.set_clock(TICK, true), i.set_u(FAIL)), (fmi3OK, fmi3OK));
    let (mut a, mut term, mut c, mut d, mut e, mut t) = (true, false, true, true, true, 0.0);
    let s = unsafe {
        fmi3UpdateDiscreteStates::<M>(i.c, &mut a, &mut term, &mut c, &mut d, &mut e, &mut t)
    };
    assert_eq!((s, term), (fmi3Error, true));
    assert!(i.saw(&["fmi3UpdateDiscreteStates: the clocked toy fails on u = 7 at t = 0"]));
    assert_eq!(unsafe { fmi3EnterStepMode::<M>(i.c) }, fmi3Error, "in Error");
}

/// Intervals: the input clock's is the constant of the description, with the qualifier
/// `fmi3IntervalUnchanged`, the only one FMI 3.0 allows for a constant clock, at every
/// call; the output clock has none; setting them is refused.
#[test]
fn intervals_and_shifts_are_the_description_s() {
    let i = Inst::new(Kind::Cs(true, false));
    let (mut iv, mut q, mut shift) = ([f64::NAN], [-1], [f64::NAN]);
    unsafe {
        assert_eq!(
            fmi3GetIntervalDecimal::<M>(i.c, &TICK, 1, iv.as_mut_ptr(), q.as_mut_ptr()),
            fmi3OK
        );
        assert_eq!((iv[0], q[0]), (PERIOD, fmi3IntervalUnchanged));
        (iv[0], q[0]) = (f64::NAN, -1);
        assert_eq!(
            fmi3GetIntervalDecimal::<M>(i.c, &TICK, 1, iv.as_mut_ptr(), q.as_mut_ptr()),
            fmi3OK
        );
        assert_eq!((iv[0], q[0]), (PERIOD, fmi3IntervalUnchanged), "the second call alike");
        assert_eq!(fmi3GetShiftDecimal::<M>(i.c, &TICK, 1, shift.as_mut_ptr()), fmi3OK);
        assert_eq!(shift[0], 0.0);
        assert_eq!(
            fmi3GetIntervalDecimal::<M>(i.c, &THIRD, 1, iv.as_mut_ptr(), q.as_mut_ptr()),
            fmi3Error
        );
        assert_eq!(fmi3SetIntervalDecimal::<M>(i.c, &TICK, 1, iv.as_ptr()), fmi3Error);
    }
    assert!(i.saw(&["fmi3GetIntervalDecimal: third (value reference 21) is an output clock"]));
    assert!(i.saw(&[
        "fmi3SetIntervalDecimal: not supported: the clocks' intervals and shifts are constants"
    ]));
}

static UPDATES: AtomicUsize = AtomicUsize::new(0);
static LOCKS: AtomicUsize = AtomicUsize::new(0);
static UNLOCKS: AtomicUsize = AtomicUsize::new(0);

unsafe extern "C" fn count_update(env: *mut c_void) {
    (*(env as *const AtomicUsize)).fetch_add(1, Ordering::SeqCst);
}
unsafe extern "C" fn lock() {
    LOCKS.fetch_add(1, Ordering::SeqCst);
}
unsafe extern "C" fn unlock() {
    UNLOCKS.fetch_add(1, Ordering::SeqCst);
}

/// Scheduled Execution: each activation runs one tick under the preemption lock, the
/// output clock is signalled through `clockUpdate` and reads true once (reading it
/// deactivates it); activations are checked (clock, time, order) and refused with the
/// reason; a communication step or an event call is not for this interface.
#[test]
fn scheduled_execution_activates_one_tick_per_call() {
    // This instance logs nowhere (its environment is the update counter): refusals are
    // checked by status here, and their messages below.
    let env = &UPDATES as *const AtomicUsize as *mut c_void;
    let i = Inst::new(Kind::Se(Some(count_update), Some(lock), Some(unlock), env));
    let locks = LOCKS.load(Ordering::SeqCst);
    for k in 0..6 {
        assert_eq!(i.set_u(1.0), fmi3OK);
        assert_eq!(i.activate(TICK, k as f64 * PERIOD), fmi3OK);
        assert_eq!(i.real(SUM), (k + 1) as f64);
        let third = k % 3 == 2;
        assert_eq!(UPDATES.load(Ordering::SeqCst), (k + 1) / 3, "clockUpdate at tick {k}");
        assert_eq!(i.clock(THIRD), (fmi3OK, third));
        assert_eq!(i.clock(THIRD), (fmi3OK, false), "read once");
    }
    assert_eq!(LOCKS.load(Ordering::SeqCst) - locks, 6);
    assert_eq!(LOCKS.load(Ordering::SeqCst), UNLOCKS.load(Ordering::SeqCst));
    assert_eq!(i.activate(TICK, 0.3), fmi3Error, "activation times going backwards");
    assert_eq!(i.activate(THIRD, 0.6), fmi3Error, "an output clock");
    assert_eq!(i.activate(99, 0.6), fmi3Error, "an unknown clock");
    assert_eq!(i.activate(TICK, 0.65), fmi3Error, "not a tick");
    assert_eq!(i.activate(TICK, 1.1), fmi3Error, "past the stop time");
    assert_eq!(i.step(0.5, PERIOD).0, fmi3Error);
    assert_eq!(i.update().0, fmi3Error);
    assert_eq!(i.set_clock(TICK, true), fmi3Error);
    assert_eq!(i.real(SUM), 6.0, "refused activations ran nothing");
    assert_eq!(i.activate(TICK, 0.6), fmi3OK);
    assert_eq!(i.real(SUM), 7.0);
}

/// The same refusals logged: an SE instance with a logger.
#[test]
fn scheduled_execution_refusals_are_logged() {
    let i = Inst::new(Kind::Se(None, None, None, std::ptr::null_mut()));
    assert_eq!(i.activate(TICK, 0.2), fmi3OK);
    for (clock, t) in [(TICK, 0.1), (THIRD, 0.3), (99, 0.3), (TICK, 0.25)] {
        assert_eq!(i.activate(clock, t), fmi3Error);
    }
    assert_eq!(i.step(0.2, PERIOD).0, fmi3Error);
    for parts in [
        &["fmi3ActivateModelPartition: activationTime 0.1 s precedes the last activation at 0.2 s"][..],
        &["fmi3ActivateModelPartition: third (value reference 21) is an output clock"],
        &["fmi3ActivateModelPartition: value reference 99 is not a clock of this FMU"],
        &["fmi3ActivateModelPartition: tick ticks at 0 s + n × 0.1 s; 0.25 s is not one of its ticks"],
        &["fmi3DoStep: illegal call sequence: not allowed in state ClockActivationMode"],
    ] {
        assert!(i.saw(parts), "{parts:?} in {:?}", i.logged());
    }
    let cs = Inst::new(Kind::Cs(true, false));
    assert_eq!(cs.activate(TICK, 0.0), fmi3Error);
    assert!(cs.saw(&["fmi3ActivateModelPartition: not supported: fmi3ActivateModelPartition is for an instance of Scheduled Execution"]));
}

/// The instance a lock callback calls into from another thread.
static BUSY: AtomicPtr<c_void> = AtomicPtr::new(std::ptr::null_mut());
static OTHER: AtomicUsize = AtomicUsize::new(usize::MAX);

/// Inside a running partition (the preemption lock is taken there), another thread reads
/// the instance: its call is refused at once.
unsafe extern "C" fn lock_and_call_from_another_thread() {
    let c = BUSY.load(Ordering::SeqCst) as usize;
    let status = std::thread::spawn(move || {
        let mut v = 0.0;
        fmi3GetFloat64::<M>(c as fmi3Instance, &SUM, 1, &mut v, 1)
    })
    .join()
    .unwrap();
    OTHER.store(status as usize, Ordering::SeqCst);
}

/// Two threads at once on one SE instance: the second call is refused with fmi3Error (no
/// data race, nothing changed), and the running call logs that it was. Under load, every
/// call of two threads hammering the instance returns OK or Error, and the model counts
/// exactly the activations that returned OK.
#[test]
fn calls_from_two_threads_at_once_are_refused_not_raced() {
    let i = Inst::new(Kind::Se(
        None,
        Some(lock_and_call_from_another_thread),
        None,
        std::ptr::null_mut(),
    ));
    BUSY.store(i.c, Ordering::SeqCst);
    assert_eq!(i.set_u(1.0), fmi3OK);
    assert_eq!(i.activate(TICK, 0.0), fmi3OK);
    assert_eq!(OTHER.load(Ordering::SeqCst), fmi3Error as usize);
    assert!(i.saw(&["1 call(s) from another thread refused (fmi3Error) while this instance ran fmi3ActivateModelPartition: an instance takes one call at a time"]), "{:?}", i.logged());
    assert_eq!(i.real(SUM), 1.0);

    let h = Inst::new(Kind::Se(None, None, None, std::ptr::null_mut()));
    assert_eq!(h.set_u(1.0), fmi3OK);
    let c = h.c as usize;
    let reader = std::thread::spawn(move || {
        let (mut ok, mut refused) = (0, 0);
        for _ in 0..20_000 {
            let mut v = 0.0;
            match unsafe { fmi3GetFloat64::<M>(c as fmi3Instance, &SUM, 1, &mut v, 1) } {
                s if s == fmi3OK => ok += 1,
                s if s == fmi3Error => refused += 1,
                other => panic!("status {other}"),
            }
        }
        (ok, refused)
    });
    let mut activated = 0;
    for k in 0..10_000 {
        // Each tick activated a thousand times: the same time again is not backwards.
        match h.activate(TICK, (k / 1000) as f64 * PERIOD) {
            s if s == fmi3OK => activated += 1,
            s if s == fmi3Error => {}
            other => panic!("status {other}"),
        }
    }
    let (ok, refused) = reader.join().unwrap();
    assert_eq!(ok + refused, 20_000);
    assert_eq!(h.real(SUM), activated as f64, "each OK activation ran once, no other");
}

/// Instantiating a model without clocks for event mode or Scheduled Execution is refused
/// (`behaviour.rs`); this one has clocks, so the FMI 3.0 description declares them, with
/// `hasEventMode` and `<ScheduledExecution>`, and the FMI 2.0 one has none of it.
#[test]
fn descriptions_declare_clocks_in_fmi3_only() {
    let three = description3::model_description::<M>();
    for part in [
        r#"hasEventMode="true""#,
        r#"<ScheduledExecution modelIdentifier="ClockToy""#,
        r#"<Clock name="tick" valueReference="20" description="The sample clock" causality="input" variability="discrete" intervalVariability="constant" intervalDecimal="0.1" priority="0"/>"#,
        r#"<Clock name="third" valueReference="21" description="Every third tick" causality="output" variability="discrete" intervalVariability="triggered"/>"#,
        r#"<Float64 name="u" valueReference="1" description="Added to sum at each tick" causality="input" variability="discrete" clocks="20" start="0"/>"#,
        r#"<Output valueReference="21"/>"#,
    ] {
        assert!(three.contains(part), "{part} in\n{three}");
    }
    assert!(
        !three.contains(r#"<InitialUnknown valueReference="10"/>"#),
        "clocked: no initial unknown"
    );
    let two = model_description::model_description::<M>();
    assert!(!two.contains("<Clock") && !two.contains("clocks="), "{two}");
    assert!(two.contains(r#"name="u" valueReference="1""#));
}

/// A Scheduled Execution state restores at its time: activations resume from there (the
/// same tick again replays it, an earlier one is refused), bit for bit.
#[test]
fn a_restored_scheduled_state_resumes_at_its_time() {
    let i = Inst::new(Kind::Se(None, None, None, std::ptr::null_mut()));
    for (k, u) in [0.5, 1.25, 2.0].into_iter().enumerate() {
        assert_eq!((i.set_u(u), i.activate(TICK, k as f64 * PERIOD)), (fmi3OK, fmi3OK));
    }
    let mut state = std::ptr::null_mut();
    assert_eq!(unsafe { fmi3GetFMUState::<M>(i.c, &mut state) }, fmi3OK);
    assert_eq!(
        (i.set_u(3.0), i.activate(TICK, 0.3), i.activate(TICK, 0.4)),
        (fmi3OK, fmi3OK, fmi3OK)
    );
    let ahead = i.real(SUM);
    assert_eq!(unsafe { fmi3SetFMUState::<M>(i.c, state) }, fmi3OK);
    assert_eq!(i.real(SUM), 3.75);
    assert_eq!(i.activate(TICK, 0.1), fmi3Error, "before the restored time");
    assert_eq!(
        (i.set_u(3.0), i.activate(TICK, 0.3), i.activate(TICK, 0.4)),
        (fmi3OK, fmi3OK, fmi3OK)
    );
    assert_eq!(i.real(SUM).to_bits(), ahead.to_bits());
    assert_eq!(unsafe { fmi3FreeFMUState::<M>(i.c, &mut state) }, fmi3OK);
}
