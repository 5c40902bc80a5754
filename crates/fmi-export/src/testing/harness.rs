//! One instance of a model under either standard, called as a master would.

use std::cell::Cell;
use std::ffi::{c_char, CStr, CString};
use std::marker::PhantomData;
use std::sync::Mutex;

use super::{Log, Master, C};
use crate::api::Fmi2;
use crate::entry::Array;
use crate::instance::{Interface, Status};
use crate::model_description::guid;
use crate::{EventUpdate, Model};

/// One instance of `M` under standard `S` (FMI 2.0 unless named).
pub struct Harness<M: Model, S: Master = Fmi2> {
    pub c: C,
    pub name: String,
    log: Box<Log>,
    _keep: S::Keep,
    /// The experiment FMI 3.0 passes at `enter`.
    experiment: Cell<(f64, Option<f64>)>,
    _model: PhantomData<M>,
}

// The layer promises independent instances usable from any thread.
unsafe impl<M: Model, S: Master> Send for Harness<M, S> {}

impl<M: Model, S: Master> Harness<M, S> {
    /// An instance in state Instantiated.
    pub fn new(name: &str) -> Self {
        Self::with_logging(name, false)
    }

    /// An instance in state Instantiated, with `loggingOn` as given.
    pub fn with_logging(name: &str, logging_on: bool) -> Self {
        let token = CString::new(guid::<M>()).unwrap();
        Self::try_with_token(name, &token, logging_on)
            .unwrap_or_else(|log| panic!("instantiation failed: {log:?}"))
    }

    /// Instantiates with `token`: the harness, or what was logged instead.
    pub fn try_with_token(name: &str, token: &CStr, logging_on: bool) -> Result<Self, Vec<String>> {
        Self::try_interface(Interface::CoSimulation, name, token, logging_on)
    }

    /// A Model Exchange instance in state Instantiated.
    pub fn new_me(name: &str) -> Self {
        let token = CString::new(guid::<M>()).unwrap();
        Self::try_interface(Interface::ModelExchange, name, &token, false)
            .unwrap_or_else(|log| panic!("instantiation failed: {log:?}"))
    }

    /// A Model Exchange instance in Event Mode at t = 0, right after initialization.
    pub fn init_me(name: &str) -> Self {
        let h = Self::new_me(name);
        assert_eq!((h.setup(), h.enter()), (0, 0));
        assert_eq!(h.exit(), 0, "{:?}", h.logged());
        h
    }

    /// Instantiates `interface` with `token`: the harness, or what was logged instead.
    pub fn try_interface(
        interface: Interface,
        name: &str,
        token: &CStr,
        logging_on: bool,
    ) -> Result<Self, Vec<String>> {
        let log = Box::new(Log(Mutex::new(Vec::new())));
        let cname = CString::new(name).unwrap();
        let (c, keep) = unsafe { S::instantiate::<M>(interface, &cname, token, &log, logging_on) };
        if c.is_null() {
            return Err(log.0.lock().unwrap().clone());
        }
        let experiment = Cell::new((0.0, None));
        Ok(Harness { c, name: name.into(), log, _keep: keep, experiment, _model: PhantomData })
    }

    /// An instance in state StepComplete (Step Mode) at t = 0.
    pub fn init(name: &str) -> Self {
        let h = Self::new(name);
        assert_eq!(h.setup(), 0);
        assert_eq!(h.enter(), 0);
        assert_eq!(h.exit(), 0, "{:?}", h.logged());
        h
    }

    pub fn setup(&self) -> Status {
        self.experiment(0.0, None)
    }
    /// The experiment: FMI 2.0's `fmi2SetupExperiment`; for FMI 3.0, kept for `enter`.
    pub fn experiment(&self, start: f64, stop: Option<f64>) -> Status {
        self.experiment.set((start, stop));
        unsafe { S::setup::<M>(self.c, start, stop) }
    }
    pub fn enter(&self) -> Status {
        let (start, stop) = self.experiment.get();
        unsafe { S::enter::<M>(self.c, start, stop) }
    }
    pub fn exit(&self) -> Status {
        unsafe { S::exit::<M>(self.c) }
    }
    pub fn terminate(&self) -> Status {
        unsafe { S::terminate::<M>(self.c) }
    }
    pub fn reset(&self) -> Status {
        unsafe { S::reset::<M>(self.c) }
    }
    pub fn set_real(&self, vr: u32, v: f64) -> Status {
        self.set_reals(&[vr], &[v])
    }
    pub fn set_reals(&self, vrs: &[u32], vs: &[f64]) -> Status {
        assert_eq!(vrs.len(), vs.len());
        unsafe { S::set_reals::<M>(self.c, vrs.as_ptr(), vrs.len(), vs.as_ptr()) }
    }
    pub fn set_integer(&self, vr: u32, v: i32) -> Status {
        unsafe { S::set_integer::<M>(self.c, vr, v) }
    }
    pub fn set_boolean(&self, vr: u32, v: bool) -> Status {
        unsafe { S::set_boolean::<M>(self.c, vr, v) }
    }
    pub fn real(&self, vr: u32) -> (Status, f64) {
        let mut v = f64::NAN;
        let s = unsafe { S::get_reals::<M>(self.c, &vr, 1, &mut v) };
        (s, v)
    }
    /// The `n` values of the array whose first element is `vr`, in either standard.
    pub fn reals(&self, vr: u32, n: usize) -> (Status, Vec<f64>) {
        let mut v = vec![f64::NAN; n];
        let s = unsafe { S::get_array::<M>(self.c, vr, &mut v) };
        (s, v)
    }
    pub fn integer(&self, vr: u32) -> (Status, i32) {
        unsafe { S::get_integer::<M>(self.c, vr) }
    }
    pub fn boolean(&self, vr: u32) -> (Status, bool) {
        unsafe { S::get_boolean::<M>(self.c, vr) }
    }
    pub fn step(&self, t: f64, h: f64) -> Status {
        unsafe { S::step::<M>(self.c, t, h) }
    }

    /// One Model Exchange array: the status and the values (NaN where none was written).
    pub fn array(&self, array: Array, n: usize) -> (Status, Vec<f64>) {
        let mut v = vec![f64::NAN; n];
        (unsafe { S::continuous_array::<M>(self.c, array, v.as_mut_ptr(), n) }, v)
    }
    /// `J seed` over `unknowns` and `knowns`: the status and the sensitivities.
    pub fn directional(
        &self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
    ) -> (Status, Vec<f64>) {
        let mut out = vec![f64::NAN; unknowns.len()];
        (unsafe { S::directional::<M>(self.c, unknowns, knowns, seed, &mut out) }, out)
    }
    pub fn set_time(&self, t: f64) -> Status {
        unsafe { S::set_time::<M>(self.c, t) }
    }
    pub fn set_states(&self, x: &[f64]) -> Status {
        unsafe { S::set_states::<M>(self.c, x.as_ptr(), x.len()) }
    }
    pub fn enter_event_mode(&self) -> Status {
        unsafe { S::enter_event_mode::<M>(self.c) }
    }
    pub fn enter_continuous_time_mode(&self) -> Status {
        unsafe { S::enter_continuous_time_mode::<M>(self.c) }
    }
    /// One event-mode update: status, what it says, `terminateSimulation`.
    pub fn update(&self) -> (Status, EventUpdate, bool) {
        unsafe { S::update::<M>(self.c) }
    }
    /// `CompletedIntegratorStep`: status, `[enterEventMode, terminateSimulation]`.
    pub fn completed_step(&self) -> (Status, [bool; 2]) {
        unsafe { S::completed_step::<M>(self.c) }
    }

    pub fn logged(&self) -> Vec<String> {
        self.log.0.lock().unwrap().clone()
    }

    /// The messages logged so far, removed from the log.
    pub fn take_logged(&self) -> Vec<String> {
        std::mem::take(&mut *self.log.0.lock().unwrap())
    }

    /// A logged line as this standard writes it: FMI 3.0 leads with the instance name.
    pub fn line(&self, status: Status, category: &str, message: &str) -> String {
        match S::NAME_IN_MESSAGE {
            true => format!("{status}|{category}|{}: {message}", self.name),
            false => format!("{status}|{category}|{message}"),
        }
    }

    /// `Set*DebugLogging` with these category names.
    pub fn set_debug_logging(&self, on: bool, categories: &[&str]) -> Status {
        let names: Vec<CString> = categories.iter().map(|c| CString::new(*c).unwrap()).collect();
        let ptrs: Vec<*const c_char> = names.iter().map(|c| c.as_ptr()).collect();
        self.set_debug_logging_raw(on, &ptrs)
    }

    pub fn set_debug_logging_raw(&self, on: bool, ptrs: &[*const c_char]) -> Status {
        unsafe { S::set_debug_logging::<M>(self.c, on, ptrs.len(), ptrs.as_ptr()) }
    }

    /// Whether a message with this status containing every part was logged.
    pub fn saw(&self, status: Status, parts: &[&str]) -> bool {
        self.logged()
            .iter()
            .any(|m| m.starts_with(&format!("{status}|")) && parts.iter().all(|p| m.contains(p)))
    }

    /// `Get*FMUState`; the caller frees it with [`Harness::free_state`].
    pub fn get_state(&self) -> C {
        let (status, s) = self.try_get_state();
        assert_eq!(status, 0, "{:?}", self.logged());
        s
    }
    pub fn try_get_state(&self) -> (Status, C) {
        let mut s: C = std::ptr::null_mut();
        (unsafe { S::get_state::<M>(self.c, &mut s) }, s)
    }
    pub fn set_state(&self, s: C) -> Status {
        unsafe { S::set_state::<M>(self.c, s) }
    }
    pub fn free_state(&self, mut s: C) -> Status {
        unsafe { S::free_state::<M>(self.c, &mut s) }
    }

    /// The current state, serialized.
    pub fn serialize(&self) -> Vec<u8> {
        let s = self.get_state();
        let size = self.state_size(s);
        let mut bytes = vec![0u8; size];
        assert_eq!(self.serialize_into(s, &mut bytes), 0);
        assert_eq!(self.free_state(s), 0);
        bytes
    }

    pub fn state_size(&self, s: C) -> usize {
        let mut size = 0usize;
        assert_eq!(unsafe { S::state_size::<M>(self.c, s, &mut size) }, 0);
        size
    }

    pub fn serialize_into(&self, s: C, out: &mut [u8]) -> Status {
        unsafe { S::serialize::<M>(self.c, s, out.as_mut_ptr(), out.len()) }
    }

    /// Deserializes `bytes` and sets the instance to it.
    pub fn deserialize(&self, bytes: &[u8]) -> Status {
        let mut s: C = std::ptr::null_mut();
        let st = unsafe { S::deserialize::<M>(self.c, bytes.as_ptr(), bytes.len(), &mut s) };
        if st != 0 {
            return st;
        }
        let st = self.set_state(s);
        self.free_state(s);
        st
    }
}

impl<M: Model, S: Master> Drop for Harness<M, S> {
    fn drop(&mut self) {
        unsafe { S::free::<M>(self.c) };
    }
}
