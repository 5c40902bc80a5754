//! FMI 3.0 clocks, event mode in Co-Simulation and Scheduled Execution: the calls an
//! instance made with `eventModeUsed` or by `fmi3InstantiateScheduledExecution` needs, and
//! the callbacks a Scheduled Execution FMU calls back. The callbacks only count (atomics
//! and thread-local cells, which cannot unwind), so nothing panics across the C boundary.

use std::cell::Cell;
use std::os::raw::c_void;
use std::sync::atomic::Ordering;

use inchworm_fmi_abi::fmi3::*;

use super::{Calls, Done};
use crate::binary::Binary;
use crate::logger::LogEnv;
use crate::{FmuError, ImportError, Status};

/// What `fmi3GetIntervalDecimal` says of a clock's interval (FMI 3.0 §2.2.9.3.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IntervalQualifier {
    /// `fmi3IntervalNotYetKnown`: the interval is not known yet.
    NotYetKnown,
    /// `fmi3IntervalUnchanged`: as at the last call.
    Unchanged,
    /// `fmi3IntervalChanged`: a new interval, the value is valid.
    Changed,
}

/// One clock's interval as the FMU reports it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    /// Seconds; meaningful when the qualifier is not `NotYetKnown`.
    pub value: f64,
    pub qualifier: IntervalQualifier,
}

/// How `fmi3DoStep` of an instance with event mode ended.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepEnd {
    /// `eventHandlingNeeded`: the master must enter event mode at the step's end.
    pub event_handling_needed: bool,
    /// `terminateSimulation`.
    pub terminate: bool,
    /// `earlyReturn` (never, as this layer instantiates without early return).
    pub early_return: bool,
    /// `lastSuccessfulTime`.
    pub last_successful_time: f64,
}

/// What one `fmi3ActivateModelPartition` signalled through the callbacks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Activation {
    /// `clockUpdate` calls: an output clock ticked (read it with `fmi3GetClock`).
    pub clock_updates: u64,
    /// `lockPreemption` calls (each matched by an `unlockPreemption`, or the activation is
    /// an error).
    pub preemption_locks: u64,
}

thread_local! {
    /// `lockPreemption` / `unlockPreemption` calls on this thread: (locks, unlocks). They
    /// carry no instance environment; a Scheduled Execution FMU calls them on the thread
    /// that activates its partition, around its critical sections.
    static PREEMPTION: Cell<(u64, u64)> = const { Cell::new((0, 0)) };
}

/// The callback `clockUpdate`: counts on the instance's environment.
pub(crate) unsafe extern "C" fn clock_update(env: fmi3InstanceEnvironment) {
    if !env.is_null() {
        // SAFETY: the environment is the `LogEnv` the backend passed at instantiation,
        // alive until after fmi3FreeInstance. An atomic add cannot unwind.
        unsafe { &*(env as *const LogEnv) }.clock_updates.fetch_add(1, Ordering::SeqCst);
    }
}

pub(crate) unsafe extern "C" fn lock_preemption() {
    // `try_with` cannot panic (it fails only while the thread is being torn down).
    let _ = PREEMPTION.try_with(|p| p.set((p.get().0 + 1, p.get().1)));
}

pub(crate) unsafe extern "C" fn unlock_preemption() {
    let _ = PREEMPTION.try_with(|p| p.set((p.get().0, p.get().1 + 1)));
}

fn preemption() -> (u64, u64) {
    PREEMPTION.try_with(Cell::get).unwrap_or((0, 0))
}

/// The clock calls of one FMI 3.0 instance made with event mode or for Scheduled Execution.
pub(crate) struct Clocks {
    instance: *mut c_void,
    set_clock: fmi3SetClockTYPE,
    get_clock: fmi3GetClockTYPE,
    get_interval: fmi3GetIntervalDecimalTYPE,
    get_shift: fmi3GetShiftDecimalTYPE,
    /// Event mode in Co-Simulation (`None` for Scheduled Execution).
    events: Option<Events>,
    /// Scheduled Execution (`None` for Co-Simulation).
    activate: Option<fmi3ActivateModelPartitionTYPE>,
}

#[derive(Clone, Copy)]
struct Events {
    enter_event: fmi3EnterEventModeTYPE,
    enter_step: fmi3EnterStepModeTYPE,
    update: fmi3UpdateDiscreteStatesTYPE,
}

fn status(raw: fmi3Status) -> Status {
    Status::from_fmi3(raw)
}

impl Clocks {
    /// Resolves the calls of event mode (`scheduled` false) or of Scheduled Execution.
    ///
    /// # Safety
    /// `binary` implements FMI 3.0.
    pub unsafe fn resolve(binary: &Binary, scheduled: bool) -> Result<Clocks, ImportError> {
        let events = if scheduled {
            None
        } else {
            Some(Events {
                enter_event: binary.required("fmi3EnterEventMode")?,
                enter_step: binary.required("fmi3EnterStepMode")?,
                update: binary.required("fmi3UpdateDiscreteStates")?,
            })
        };
        let activate =
            if scheduled { Some(binary.required("fmi3ActivateModelPartition")?) } else { None };
        Ok(Clocks {
            instance: std::ptr::null_mut(),
            set_clock: binary.required("fmi3SetClock")?,
            get_clock: binary.required("fmi3GetClock")?,
            get_interval: binary.required("fmi3GetIntervalDecimal")?,
            get_shift: binary.required("fmi3GetShiftDecimal")?,
            events,
            activate,
        })
    }

    /// The instance the calls go to, once it exists.
    pub fn bind(&mut self, instance: *mut c_void) {
        self.instance = instance;
    }

    fn events(&self, cx: &Calls, function: &'static str) -> Result<Events, FmuError> {
        self.events.ok_or_else(|| FmuError::Unsupported {
            model: cx.model.clone(),
            function,
            why: "the instance was made for Scheduled Execution, which has no event mode".into(),
        })
    }
}

// SAFETY of every call below: FMI 3.0 signatures resolved from the library, on the live
// instance `bind` gave, with buffers of the lengths passed (checked by the callers).
impl Clocks {
    pub fn set_clocks(&self, cx: &mut Calls, vrs: &[u32], values: &[bool]) -> Done {
        let (i, f, n) = (self.instance, self.set_clock, vrs.len());
        cx.call("fmi3SetClock", || status(unsafe { f(i, vrs.as_ptr(), n, values.as_ptr()) }))
    }

    pub fn get_clocks(&self, cx: &mut Calls, vrs: &[u32], out: &mut [bool]) -> Done {
        // Read as bytes: a value other than 0 or 1 must not make an invalid bool.
        let mut raw = vec![0u8; out.len()];
        let (i, f, n) = (self.instance, self.get_clock, vrs.len());
        cx.call("fmi3GetClock", || {
            status(unsafe { f(i, vrs.as_ptr(), n, raw.as_mut_ptr().cast::<fmi3Clock>()) })
        })?;
        for (o, r) in out.iter_mut().zip(raw) {
            *o = r != 0;
        }
        Ok(())
    }

    pub fn intervals(&self, cx: &mut Calls, vrs: &[u32]) -> Result<Vec<Interval>, FmuError> {
        const F: &str = "fmi3GetIntervalDecimal";
        let n = vrs.len();
        let (mut values, mut qualifiers) = (vec![0.0; n], vec![-1 as fmi3IntervalQualifier; n]);
        let (i, f) = (self.instance, self.get_interval);
        cx.call(F, || {
            status(unsafe { f(i, vrs.as_ptr(), n, values.as_mut_ptr(), qualifiers.as_mut_ptr()) })
        })?;
        values
            .into_iter()
            .zip(qualifiers)
            .map(|(value, q)| {
                let qualifier = match q {
                    q if q == fmi3IntervalNotYetKnown => IntervalQualifier::NotYetKnown,
                    q if q == fmi3IntervalUnchanged => IntervalQualifier::Unchanged,
                    q if q == fmi3IntervalChanged => IntervalQualifier::Changed,
                    other => {
                        let m = format!("the FMU returned the qualifier {other}, which is no fmi3IntervalQualifier");
                        return Err(cx.invalid(F, m));
                    }
                };
                Ok(Interval { value, qualifier })
            })
            .collect()
    }

    pub fn shifts(&self, cx: &mut Calls, vrs: &[u32]) -> Result<Vec<f64>, FmuError> {
        let n = vrs.len();
        let mut out = vec![0.0; n];
        let (i, f) = (self.instance, self.get_shift);
        cx.call("fmi3GetShiftDecimal", || {
            status(unsafe { f(i, vrs.as_ptr(), n, out.as_mut_ptr()) })
        })?;
        Ok(out)
    }

    pub fn enter_event_mode(&self, cx: &mut Calls) -> Done {
        let e = self.events(cx, "fmi3EnterEventMode")?;
        let i = self.instance;
        cx.call("fmi3EnterEventMode", || status(unsafe { (e.enter_event)(i) }))
    }

    pub fn enter_step_mode(&self, cx: &mut Calls) -> Done {
        let e = self.events(cx, "fmi3EnterStepMode")?;
        let i = self.instance;
        cx.call("fmi3EnterStepMode", || status(unsafe { (e.enter_step)(i) }))
    }

    pub fn update_discrete_states(
        &self,
        cx: &mut Calls,
    ) -> Result<super::me::EventUpdate, FmuError> {
        const F: &str = "fmi3UpdateDiscreteStates";
        let e = self.events(cx, F)?;
        let i = self.instance;
        let mut flags = [0u8; 5];
        let mut next = 0.0;
        cx.call(F, || {
            let p = flags.as_mut_ptr().cast::<bool>();
            // SAFETY: five distinct one-byte slots.
            status(unsafe { (e.update)(i, p, p.add(1), p.add(2), p.add(3), p.add(4), &mut next) })
        })?;
        let [needs, terminate, nominals, states, defined] = flags.map(|b| b != 0);
        Ok(super::me::EventUpdate {
            needs_update: needs,
            terminate,
            nominals_changed: nominals,
            states_changed: states,
            next_event_time: defined.then_some(next),
        })
    }

    /// `fmi3ActivateModelPartition(clock, t)`, with what the FMU signalled meanwhile
    /// through `clockUpdate` (counted on `env`) and the preemption callbacks.
    pub fn activate(
        &self,
        cx: &mut Calls,
        env: &LogEnv,
        clock: u32,
        t: f64,
    ) -> Result<Activation, FmuError> {
        const F: &str = "fmi3ActivateModelPartition";
        let f = self.activate.ok_or_else(|| FmuError::Unsupported {
            model: cx.model.clone(),
            function: F,
            why: "the instance was made for Co-Simulation; partitions are activated in Scheduled Execution".into(),
        })?;
        let updates = env.clock_updates.load(Ordering::SeqCst);
        let (locks, unlocks) = preemption();
        let i = self.instance;
        cx.call(F, || status(unsafe { f(i, clock, t) }))?;
        let (locks_after, unlocks_after) = preemption();
        let (locked, unlocked) = (locks_after - locks, unlocks_after - unlocks);
        if locked != unlocked {
            return Err(cx.invalid(
                F,
                format!("the FMU locked preemption {locked} times and unlocked it {unlocked} times during the activation at t = {t} s"),
            ));
        }
        Ok(Activation {
            clock_updates: env.clock_updates.load(Ordering::SeqCst) - updates,
            preemption_locks: locked,
        })
    }
}
