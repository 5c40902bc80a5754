//! The entry points of every standard, written once. Each takes the C arguments already
//! reduced to what both standards share (an instance pointer, value references and
//! values as pointer and count, plain numbers); the per-standard files only name them.
//!
//! Every function follows one shape, as in the Reference-FMUs: check the instance pointer
//! and that the call is allowed in the current state (the masks below), check the
//! arguments, run the body inside `catch_unwind`, log every refusal with the function
//! name and the reason, and return a defined status.
//!
//! Status policy: a refused call (wrong state, bad argument, a NaN input) returns Error
//! and leaves the instance as it was, so the master can correct the call and go on; a
//! failure of the model itself (invalid parameters at exit from initialization, a failed
//! step) moves the instance to the Error state, from which only reset, free, getters and
//! state restore are allowed; a Rust panic (a bug) returns Fatal and moves it to Fatal,
//! from which only freeing the instance is allowed.
//!
//! Model Exchange is the same instance with its own states (EventMode and
//! ContinuousTimeMode, further bits of [`State`]) and its own calls, functions of the same
//! shape; an ME call on a Co-Simulation instance is refused by its mask, and a
//! Co-Simulation call on an ME instance likewise.
#![allow(clippy::missing_safety_doc, clippy::too_many_arguments)]

use std::ffi::{c_void, CStr};
use std::fmt;
use std::os::raw::c_char;
use std::panic::{catch_unwind, AssertUnwindSafe};

use crate::instance::*;
use crate::table::{Admission, Kind, Variable};
use crate::{model_description, registry, state_blob, EventUpdate, Message, Model, StepLog};

pub use crate::instance::{Standard, Status};

const I: u16 = State::Instantiated as u16;
const IM: u16 = State::InitializationMode as u16;
const SC: u16 = State::StepComplete as u16;
const SIP: u16 = State::StepInProgress as u16;
const SF: u16 = State::StepFailed as u16;
const SCA: u16 = State::StepCanceled as u16;
const T: u16 = State::Terminated as u16;
const E: u16 = State::Error as u16;
const EM: u16 = State::EventMode as u16;
const CTM: u16 = State::ContinuousTimeMode as u16;

/// The allowed-state masks, named for the calls that use them.
pub const INSTANTIATED: u16 = I;
pub const INITIALIZATION: u16 = IM;
pub const STEPPING: u16 = SC;
pub const STEP_ENDED: u16 = SC | SF | SCA;
pub const TERMINABLE: u16 = STEP_ENDED | EM | CTM;
pub const LIVE: u16 = I | IM | SC | SIP | SF | SCA | T | E | EM | CTM;
pub const GETTABLE: u16 = IM | SC | SF | SCA | T | E | EM | CTM;
pub const SETTABLE: u16 = I | IM | SC | EM | CTM;
pub const STATE_CALLS: u16 = I | IM | SC | SF | SCA | T | E | EM | CTM;
/// Model Exchange (FMI 2.0 section 3.2.3, FMI 3.0 section 3.2): time moves in both
/// modes; the integrator sets states only between events; states, derivatives and
/// indicators are readable once initialized (the model is built at exit from
/// initialization); nominals are constants of the table.
pub const TIMED: u16 = EM | CTM;
pub const EVENT_MODE: u16 = EM;
pub const CONTINUOUS_TIME: u16 = CTM;
pub const ME_READABLE: u16 = EM | CTM | T | E;
pub const NOMINALS: u16 = I | IM | EM | CTM | T | E;
pub const STATUS_CALLS: u16 = SC | SIP | SF | SCA | T;
pub const AFTER_STEP: u16 = SC | SF | SCA | T | E;
/// Every state the core has; a standard has those of [`Standard::STATES`].
pub const ALL_STATES: u16 = LIVE | State::Fatal as u16;

/// The clamps of one input warned of each in full, before only every tenfold count is.
pub const CLAMPS_IN_FULL: u64 = 3;

/// A value on its way between the master and the model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    Real(f64),
    Integer(i32),
    Boolean(bool),
}

impl Value {
    pub fn real(self) -> f64 {
        match self {
            Value::Real(x) => x,
            Value::Integer(i) => f64::from(i),
            Value::Boolean(b) => f64::from(u8::from(b)),
        }
    }
    pub fn integer(self) -> i32 {
        match self {
            Value::Integer(i) => i,
            Value::Boolean(b) => i32::from(b),
            Value::Real(x) => x as i32,
        }
    }
    pub fn boolean(self) -> bool {
        match self {
            Value::Boolean(b) => b,
            Value::Integer(i) => i != 0,
            Value::Real(x) => x != 0.0,
        }
    }
}

/// One `Get*`/`Set*` pair of a standard: the table type its variables have and the C
/// types it moves. A type parameter rather than a value (a type and a conversion
/// function) so that each entry point is compiled for its own type: the model's getter
/// or setter is called directly, the [`Value`] between them folds away, and nothing is
/// decided per value that the function's name already decided.
pub trait Access {
    /// The table type of the variables the pair reaches.
    const KIND: Kind;
    /// What `Get*` writes.
    type Out: Copy;
    /// What `Set*` reads.
    type In: Copy;
    /// A value of [`Access::KIND`] (or FMI 3.0's time, a Real) as `Get*` writes it.
    fn out(v: Value) -> Self::Out;
    /// What `Set*` was given, as the model's value.
    fn value(c: Self::In) -> Value;
}

/// `fmi2Get/SetReal`, `fmi3Get/SetFloat64`: a C double either way.
pub struct Reals;

impl Access for Reals {
    const KIND: Kind = Kind::Real;
    type Out = f64;
    type In = f64;
    fn out(v: Value) -> f64 {
        v.real()
    }
    fn value(c: f64) -> Value {
        Value::Real(c)
    }
}

/// `fmi2Get/SetInteger`, `fmi3Get/SetInt32`: a 32-bit C int either way.
pub struct Integers;

impl Access for Integers {
    const KIND: Kind = Kind::Integer;
    type Out = i32;
    type In = i32;
    fn out(v: Value) -> i32 {
        v.integer()
    }
    fn value(c: i32) -> Value {
        Value::Integer(c)
    }
}

/// A C type a standard passes Booleans as.
pub trait CBoolean: Copy {
    fn of(b: bool) -> Self;
    fn is_true(self) -> bool;
}

/// `fmi2Boolean`, a C int: any non-zero value is true.
impl CBoolean for std::os::raw::c_int {
    fn of(b: bool) -> Self {
        Self::from(b)
    }
    fn is_true(self) -> bool {
        self != 0
    }
}

/// `fmi3Boolean` as the layer writes it.
impl CBoolean for bool {
    fn of(b: bool) -> Self {
        b
    }
    fn is_true(self) -> bool {
        self
    }
}

/// `fmi3Boolean` as the layer reads it, a byte: a C bool the master filled with another
/// byte than 0 or 1 must not become an invalid Rust bool.
impl CBoolean for u8 {
    fn of(b: bool) -> Self {
        u8::from(b)
    }
    fn is_true(self) -> bool {
        self != 0
    }
}

/// `Get*Boolean` writing `O`, `Set*Boolean` reading `I`.
pub struct Booleans<O, I>(std::marker::PhantomData<(O, I)>);

impl<O: CBoolean, I: CBoolean> Access for Booleans<O, I> {
    const KIND: Kind = Kind::Boolean;
    type Out = O;
    type In = I;
    fn out(v: Value) -> O {
        O::of(v.boolean())
    }
    fn value(c: I) -> Value {
        Value::Boolean(c.is_true())
    }
}

/// What a value reference of a `Get*`/`Set*` names, classified once: a variable of the
/// call's type, or FMI 3.0's independent variable time, which only Reals reach and which
/// the layer holds. Anything else is refused by [`Instance::resolve`].
#[derive(Clone, Copy, Debug)]
enum Addressed {
    /// The variable's index entry: its rows, its type, where it may be set.
    Variable(Indexed),
    Time,
}

impl Addressed {
    /// How many values the reference stands for.
    fn len(self) -> usize {
        match self {
            Addressed::Variable(entry) => entry.len as usize,
            Addressed::Time => 1,
        }
    }
}

/// Runs `body` on the instance behind `c` if the call is allowed in its state. A pointer
/// that is not a live instance of this model and standard (NULL, freed, another FMU's,
/// junk) is refused without being read: there is no logger to tell but the instance's.
pub unsafe fn with_instance<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    allowed: u16,
    body: impl FnOnce(&mut Instance<S, M>) -> Status,
) -> Status {
    let c = c as *mut Instance<S, M>;
    if c.is_null() || !registry::is_live(c) {
        return ERROR;
    }
    let inst = &mut *c;
    if inst.state as u16 & allowed == 0 {
        let state = S::state_name(inst.state);
        let why = format_args!("illegal call sequence: not allowed in state {state}");
        return inst.refuse(func, why);
    }
    inst.log(OK, LogCategory::All, format_args!("{func}"));
    match catch_unwind(AssertUnwindSafe(|| body(&mut *inst))) {
        Ok(status) => status,
        Err(panic) => {
            inst.state = State::Fatal;
            let what = panic_text(panic.as_ref());
            let why = format_args!("{func}: internal error, instance unusable: {what}");
            inst.log(FATAL, LogCategory::StatusError, why);
            FATAL
        }
    }
}

unsafe fn slice<'a, T>(ptr: *const T, n: usize) -> Option<&'a [T]> {
    match (n, ptr.is_null()) {
        (0, _) => Some(&[]),
        (_, true) => None,
        _ => Some(std::slice::from_raw_parts(ptr, n)),
    }
}

unsafe fn slice_mut<'a, T>(ptr: *mut T, n: usize) -> Option<&'a mut [T]> {
    match (n, ptr.is_null()) {
        (0, _) => Some(&mut []),
        (_, true) => None,
        _ => Some(std::slice::from_raw_parts_mut(ptr, n)),
    }
}

fn text(p: *const c_char) -> String {
    // SAFETY: callers pass a non-NULL C string of the master's.
    unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
}

impl<S: Standard, M: Model> Instance<S, M> {
    /// What `vr` names for a `Get*`/`Set*` of type `kind`: the one place that tells a
    /// variable of that type from FMI 3.0's time (the reference no variable has) and
    /// from a reference that is refused (`None`). On the path of every value of every
    /// call, so the refusal's text is built elsewhere ([`Self::resolve`]).
    #[inline(always)]
    fn address(&self, vr: u32, kind: Kind) -> Option<Addressed> {
        match self.indexed(vr) {
            Some(entry) if entry.kind == kind => Some(Addressed::Variable(entry)),
            None if kind == Kind::Real && S::TIME_VR == Some(vr) => Some(Addressed::Time),
            _ => None,
        }
    }

    /// [`Self::address`], or why `vr` is refused.
    #[inline(always)]
    fn resolve(&self, vr: u32, kind: Kind) -> Result<Addressed, String> {
        self.address(vr, kind).ok_or_else(|| self.lookup_error(vr, kind))
    }

    /// The variable of type `kind` behind `vr`, for a call that cannot take time (a
    /// setter, a derivative's reference): time is refused as not settable.
    #[inline(always)]
    fn variable_of(&self, vr: u32, kind: Kind) -> Result<Indexed, String> {
        match self.resolve(vr, kind)? {
            Addressed::Variable(entry) => Ok(entry),
            Addressed::Time => Err(self.time_refused(vr)),
        }
    }

    /// Why [`Self::resolve`] refuses `vr`: out of the hot path of every `Get*` and `Set*`.
    #[cold]
    #[inline(never)]
    fn lookup_error(&self, vr: u32, kind: Kind) -> String {
        match self.variable(vr) {
            None if S::TIME_VR == Some(vr) => self.time_refused(vr),
            None => format!("unknown value reference {vr}"),
            // Known, so of another type.
            Some((v, _)) => format!(
                "value reference {vr} ({}) is {}, not {}",
                v.name,
                S::type_name(v.kind),
                S::type_name(kind)
            ),
        }
    }

    #[cold]
    #[inline(never)]
    fn time_refused(&self, vr: u32) -> String {
        let real = S::type_name(Kind::Real);
        format!("value reference {vr} is the independent variable time ({real}, not settable)")
    }

    /// The values of `what` into the start of `out`, which has room for them.
    #[inline]
    fn read<A: Access>(&self, what: Addressed, out: &mut [A::Out]) -> Result<(), String> {
        let rows = match what {
            Addressed::Variable(entry) => self.rows_of(entry),
            Addressed::Time => {
                out[0] = A::out(Value::Real(self.time));
                return Ok(());
            }
        };
        // An array's elements are the table's rows after its first, each with its own
        // value reference (crate::arrays): the model knows only those.
        for (slot, v) in out.iter_mut().zip(rows) {
            *slot = A::out(match A::KIND {
                Kind::Real => self.model.get_real(v.vr).map(Value::Real),
                Kind::Integer => self.model.get_integer(v.vr).map(Value::Integer),
                Kind::Boolean => self.model.get_boolean(v.vr).map(Value::Boolean),
            }?);
        }
        Ok(())
    }

    /// How many values the variables `vrs` of type `kind` have (time has one), or why
    /// one of them is refused.
    fn count_values(&self, vrs: &[u32], kind: Kind) -> Result<usize, String> {
        vrs.iter().try_fold(0, |n, &r| Ok(n + self.resolve(r, kind)?.len()))
    }

    /// Sets one value of a variable settable in the states `settable`
    /// ([`crate::instance::settable_states`]): each stands alone, so a refused one keeps
    /// its previous value and does not stop the others.
    #[inline]
    fn write<A: Access>(
        &mut self,
        func: &str,
        (var, settable): (&'static Variable, u16),
        value: A::In,
    ) -> Status {
        let vr = var.vr;
        if settable & self.state as u16 == 0 {
            let (c, v, s) = (var.causality, var.variability, S::state_name(self.state));
            let why = format_args!("{} ({c:?}, {v:?}) cannot be set in state {s}", var.name);
            return self.refuse(func, why);
        }
        let (stored, clamped_from) = match A::value(value) {
            Value::Real(x) => match var.admit(x) {
                Admission::Accept(y) | Admission::Limit(y) => (self.model.set_real(vr, y), None),
                Admission::Clamp(y) => (self.model.set_real(vr, y), Some((x, y))),
                Admission::NonFinite => {
                    let current = self.model.get_real(vr).unwrap_or(f64::NAN);
                    return self.refuse(func, format_args!("{}", var.refusal(x, current)));
                }
            },
            Value::Integer(i) => (self.model.set_integer(vr, i), None),
            Value::Boolean(b) => (self.model.set_boolean(vr, b), None),
        };
        match (stored, clamped_from) {
            (Err(why), _) => self.refuse(func, format_args!("{why}")),
            (Ok(()), None) => OK,
            (Ok(()), Some(clamp)) => self.clamped(func, var, clamp),
        }
    }

    /// Counts a clamp of `var` from `x` to `y` and warns of the first
    /// [`CLAMPS_IN_FULL`] and of the 10th, 100th, 1000th, …: a master that holds an input
    /// out of range, or a controller that saturates, at every step gets a few lines per
    /// input, not one per step, and nothing is lost, as the value stored is the clamped one
    /// either way and the total is logged at Terminate ([`Self::summarize_clamps`]).
    /// A clamp only counted returns OK: Warning tells the master that a warning was
    /// logged for the call, and a master that logs every Warning status (as the
    /// project's importer does) would make the flood again.
    #[cold]
    #[inline(never)]
    fn clamped(&mut self, func: &str, var: &'static Variable, (x, y): (f64, f64)) -> Status {
        let what = var.clamping(x, y);
        let Some(c) = self.clamps.iter_mut().find(|c| c.vr == var.vr) else {
            // Every input with a range has a counter; without one, warn every time.
            self.log(WARNING, LogCategory::StatusWarning, format_args!("{func}: {what}"));
            return WARNING;
        };
        c.count += 1;
        let (n, name) = (c.count, var.name);
        let decade = n > CLAMPS_IN_FULL && 10u64.checked_pow(n.ilog10()) == Some(n);
        if n > CLAMPS_IN_FULL && !decade {
            return OK;
        }
        c.logged += 1;
        let (logged, at) = (c.logged, LogCategory::StatusWarning);
        match n {
            CLAMPS_IN_FULL => self.log(WARNING, at, format_args!("{func}: {what}; {name} clamped {n} times now: further clamps are counted, logged at the 10th, 100th, 1000th, … and in all at {}Terminate", S::PREFIX)),
            _ if decade => self.log(WARNING, at, format_args!("{func}: {what} ({name} clamped {n} times now, {logged} of them logged)")),
            _ => self.log(WARNING, at, format_args!("{func}: {what}")),
        }
        WARNING
    }

    /// Logs, for every input clamped more often than warned of and not summed up since,
    /// how often in all; Warning if it logged any (Terminate, Reset, FreeInstance).
    pub(crate) fn summarize_clamps(&mut self, func: &str) -> Status {
        let mut status = OK;
        for i in 0..self.clamps.len() {
            let c = self.clamps[i];
            if c.count <= CLAMPS_IN_FULL || c.count == c.summarized {
                continue;
            }
            self.clamps[i].summarized = c.count;
            let Some((var, _)) = self.variable(c.vr) else { continue };
            let (name, range, (n, logged)) = (var.name, var.range_text(), (c.count, c.logged));
            let why = format_args!(
                "{func}: {name} was clamped into the {range} {n} times in all ({logged} of them logged)"
            );
            self.log(WARNING, LogCategory::StatusWarning, why);
            status = WARNING;
        }
        status
    }

    /// Refuses a call whose value count is not the number of values of its variables
    /// (one per scalar, an FMI 3.0 array's length for an array), or one of whose
    /// references is refused.
    fn check_counts(
        &self,
        func: &str,
        vrs: &[u32],
        kind: Kind,
        nvalues: usize,
    ) -> Result<(), Status> {
        let mut n = 0;
        for &r in vrs {
            match self.address(r, kind) {
                Some(what) => n += what.len(),
                None => return Err(self.refuse_counts(func, vrs, kind, nvalues)),
            }
        }
        match n == nvalues {
            true => Ok(()),
            false => Err(self.refuse_counts(func, vrs, kind, nvalues)),
        }
    }

    /// Why the references `vrs` and `nvalues` values do not go together: the first
    /// reference refused, else the counts.
    #[cold]
    #[inline(never)]
    fn refuse_counts(&self, func: &str, vrs: &[u32], kind: Kind, nvalues: usize) -> Status {
        let n = match self.count_values(vrs, kind) {
            Ok(n) => n,
            Err(why) => return self.refuse(func, format_args!("{why}")),
        };
        let nvr = vrs.len();
        match S::ARRAYS {
            false => self.refuse(func, format_args!("nValues {nvalues} differs from nValueReferences {nvr} (every variable of this FMU is a scalar)")),
            true => self.refuse(func, format_args!("nValues {nvalues} differs from the {n} values of the {nvr} value references (an array counts its elements)")),
        }
    }

    /// The snapshot behind `state` if this instance handed it out.
    unsafe fn own_snapshot<'a>(&self, state: *mut c_void) -> Option<&'a mut Snapshot<M>> {
        let p = state as *mut Snapshot<M>;
        self.snapshots.contains(&p).then(|| &mut *p)
    }

    /// Stores `snap` into `*slot`: in place if it already holds one of ours, else anew.
    unsafe fn store_snapshot(&mut self, slot: *mut *mut c_void, snap: Snapshot<M>) -> Status {
        if let Some(existing) = self.own_snapshot(*slot) {
            *existing = snap;
        } else {
            let p = Box::into_raw(Box::new(snap));
            self.snapshots.push(p);
            *slot = p as *mut c_void;
        }
        OK
    }

    fn not_ours(&self, func: &str) -> Status {
        let (p, s) = (S::PREFIX, S::FMU_STATE);
        self.refuse(
            func,
            format_args!("{s} was not created by {p}Get{s} of this instance (or was freed)"),
        )
    }
}

/// Logs through the master's callback before an instance exists.
fn log_early<S: Standard>(cb: &S::Callbacks, name: *const c_char, func: &str, why: fmt::Arguments) {
    // SAFETY: a non-NULL name is the master's C string.
    let name = (!name.is_null()).then(|| unsafe { CStr::from_ptr(name) });
    emit::<S>(cb, name, ERROR, LogCategory::StatusError, format_args!("{func}: {why}"));
}

/// Creates an instance of `interface` after checking its name, the interface-specific
/// `refusal` the standard's glue found, that the model has the interface, and the token,
/// which must be this build's GUID.
pub unsafe fn instantiate<S: Standard, M: Model>(
    func: &str,
    callbacks: Option<S::Callbacks>,
    name: *const c_char,
    token: *const c_char,
    (interface, refusal): (Interface, Option<&str>),
    logging_on: bool,
) -> *mut c_void {
    let result = catch_unwind(AssertUnwindSafe(|| {
        let Some(cb) = callbacks else { return std::ptr::null_mut() };
        let fail = |why: fmt::Arguments| {
            log_early::<S>(&cb, name, func, why);
            std::ptr::null_mut()
        };
        if name.is_null() || *name == 0 {
            return fail(format_args!("instanceName is NULL or empty"));
        }
        if let Some(why) = refusal {
            return fail(format_args!("{why}"));
        }
        if interface == Interface::ModelExchange && M::model_exchange().is_none() {
            return fail(format_args!("not supported: this FMU implements Co-Simulation only"));
        }
        let (arg, guid) = (S::TOKEN_ARG, model_description::guid::<M>());
        if token.is_null() {
            return fail(format_args!("{arg} is NULL"));
        }
        let given = text(token);
        if given != guid {
            let given = Clip(&given);
            return fail(format_args!("{arg} \"{given}\" does not match this FMU's \"{guid}\" (modelDescription.xml from another build?)"));
        }
        let name = CStr::from_ptr(name).to_owned();
        let inst = Box::into_raw(Box::new(Instance::<S, M>::new(name, cb, interface, logging_on)));
        registry::register(inst);
        inst as *mut c_void
    }));
    result.unwrap_or(std::ptr::null_mut())
}

/// An instantiation function of an interface this FMU does not implement.
pub unsafe fn refuse_instantiation<S: Standard>(
    func: &str,
    callbacks: S::Callbacks,
    name: *const c_char,
    why: &str,
) -> *mut c_void {
    let _ = catch_unwind(AssertUnwindSafe(|| {
        log_early::<S>(&callbacks, name, func, format_args!("not supported: {why}"))
    }));
    std::ptr::null_mut()
}

/// Frees the instance, after the totals of its inputs' clamps if no Terminate or Reset
/// logged them (the master's logger is valid until this call returns).
pub unsafe fn free_instance<S: Standard, M: Model>(c: *mut c_void, func: &str) {
    let c = c as *mut Instance<S, M>;
    // Out of the registry first: a second free, or a call racing this one's end, finds
    // nothing to read.
    if c.is_null() || !registry::unregister(c) {
        return;
    }
    // Dropping a model only frees memory; a panic there must still not unwind into C.
    let _ = catch_unwind(AssertUnwindSafe(|| {
        let mut inst = Box::from_raw(c);
        inst.summarize_clamps(func);
    }));
}

/// FMI 2.0 section 2.1.5, kept by FMI 3.0 section 2.3.1: on with no categories enables
/// all of them; on with categories enables exactly those; off with categories disables
/// those; off with none disables all. A NULL or unknown name refuses the whole call and
/// changes nothing, so a master's typo cannot leave half of its request applied.
pub unsafe fn set_debug_logging<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    on: bool,
    n: usize,
    categories: *const *const c_char,
) -> Status {
    with_instance::<S, M>(c, func, LIVE, |inst| {
        let Some(names) = slice(categories, n) else {
            return inst.refuse(func, format_args!("categories is NULL"));
        };
        let mut named = Categories::NONE;
        for &p in names {
            if p.is_null() {
                let why = format_args!("a category name is NULL; logging left unchanged");
                return inst.refuse(func, why);
            }
            match LogCategory::from_name(CStr::from_ptr(p).to_bytes()) {
                Some(cat) => named = named.with(cat),
                None => {
                    let (name, known) = (text(p), KnownCategories);
                    let name = Clip(&name);
                    return inst.refuse(func, format_args!("unknown log category \"{name}\" (this FMU has {known}); logging left unchanged"));
                }
            }
        }
        inst.categories = match (on, names.is_empty()) {
            (true, true) => Categories::ALL,
            (true, false) => named,
            (false, true) => Categories::NONE,
            (false, false) => inst.categories.without(named),
        };
        OK
    })
}

struct KnownCategories;

impl fmt::Display for KnownCategories {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, c) in LogCategory::ALL.iter().enumerate() {
            write!(f, "{}{}", if i == 0 { "" } else { ", " }, c.name())?;
        }
        Ok(())
    }
}

/// The experiment: a finite start, and a stop time, if any, not before it.
fn experiment<S: Standard, M: Model>(
    inst: &mut Instance<S, M>,
    func: &str,
    start: f64,
    stop: Option<f64>,
) -> Status {
    if !start.is_finite() {
        return inst.refuse(func, format_args!("startTime {start} is not finite"));
    }
    if let Some(stop) = stop.filter(|&s| !s.is_finite() || s < start) {
        let why = format_args!("stopTime {stop} is not finite or before startTime {start}");
        return inst.refuse(func, why);
    }
    (inst.start_time, inst.time, inst.stop_time) = (start, start, stop);
    OK
}

pub unsafe fn setup_experiment<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    start: f64,
    stop: Option<f64>,
) -> Status {
    with_instance::<S, M>(c, func, INSTANTIATED, |inst| experiment(inst, func, start, stop))
}

/// Enters initialization mode, with the experiment if the standard passes it here.
pub unsafe fn enter_initialization<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    exp: Option<(f64, Option<f64>)>,
) -> Status {
    with_instance::<S, M>(c, func, INSTANTIATED, |inst| {
        if let Some((start, stop)) = exp {
            if experiment(inst, func, start, stop) != OK {
                return ERROR;
            }
        }
        inst.state = State::InitializationMode;
        OK
    })
}

/// Without event mode, FMI 3.0 Co-Simulation goes straight to Step Mode, which is the
/// core's StepComplete; Model Exchange of both standards to EventMode.
pub unsafe fn exit_initialization<S: Standard, M: Model>(c: *mut c_void, func: &str) -> Status {
    with_instance::<S, M>(c, func, INITIALIZATION, |inst| {
        match inst.model.exit_initialization(inst.start_time) {
            Ok(()) => {
                inst.state = match inst.interface {
                    Interface::CoSimulation => State::StepComplete,
                    Interface::ModelExchange => State::EventMode,
                };
                OK
            }
            Err(why) => {
                inst.state = State::Error;
                inst.refuse(func, format_args!("{why}"))
            }
        }
    })
}

/// Terminates, with the totals of the inputs' clamps that were only counted.
pub unsafe fn terminate<S: Standard, M: Model>(c: *mut c_void, func: &str) -> Status {
    with_instance::<S, M>(c, func, TERMINABLE, |inst| {
        inst.state = State::Terminated;
        inst.summarize_clamps(func)
    })
}

/// Back to Instantiated; the clamps of the run that ends are summed up if Terminate did
/// not, and counted anew.
pub unsafe fn reset<S: Standard, M: Model>(c: *mut c_void, func: &str) -> Status {
    with_instance::<S, M>(c, func, LIVE, |inst| {
        let status = inst.summarize_clamps(func);
        inst.model = M::new();
        inst.state = State::Instantiated;
        (inst.time, inst.start_time, inst.stop_time) = (0.0, 0.0, None);
        inst.last_step_status = OK;
        for c in inst.clamps.iter_mut() {
            (c.count, c.logged, c.summarized) = (0, 0, 0);
        }
        status
    })
}

/// `Get*` of one type. One pass: each reference is resolved once and its values read
/// straight into the master's array; a count that turns out wrong on the way is refused
/// with the message a count check up front would have given.
pub unsafe fn get<S: Standard, M: Model, A: Access>(
    c: *mut c_void,
    func: &str,
    (vr, nvr): (*const u32, usize),
    (values, nvalues): (*mut A::Out, usize),
) -> Status {
    with_instance::<S, M>(c, func, GETTABLE, |inst| {
        let Some(vrs) = slice(vr, nvr) else {
            return inst.refuse(func, format_args!("{} is NULL", S::VALUE_ARGS));
        };
        let Some(mut out) = slice_mut(values, nvalues) else {
            // Refused as a call with a good array would be first: for its references
            // and counts.
            if let Err(s) = inst.check_counts(func, vrs, A::KIND, nvalues) {
                return s;
            }
            return inst.refuse(func, format_args!("{} is NULL", S::VALUE_ARGS));
        };
        for &r in vrs {
            let Some(what) = inst.address(r, A::KIND) else {
                return inst.refuse_counts(func, vrs, A::KIND, nvalues);
            };
            if what.len() > out.len() {
                return inst.refuse_counts(func, vrs, A::KIND, nvalues);
            }
            let (these, rest) = std::mem::take(&mut out).split_at_mut(what.len());
            if let Err(why) = inst.read::<A>(what, these) {
                return inst.refuse(func, format_args!("{why}"));
            }
            out = rest;
        }
        if !out.is_empty() {
            return inst.refuse_counts(func, vrs, A::KIND, nvalues);
        }
        OK
    })
}

/// `Set*` of one type. The call reports the worst outcome of its values; a reference
/// refused or a wrong count refuses it whole, before any value is stored.
pub unsafe fn set<S: Standard, M: Model, A: Access>(
    c: *mut c_void,
    func: &str,
    (vr, nvr): (*const u32, usize),
    (values, nvalues): (*const A::In, usize),
) -> Status {
    with_instance::<S, M>(c, func, SETTABLE, |inst| {
        let Some(vrs) = slice(vr, nvr) else {
            return inst.refuse(func, format_args!("{} is NULL", S::VALUE_ARGS));
        };
        if let Err(s) = inst.check_counts(func, vrs, A::KIND, nvalues) {
            return s;
        }
        let Some(mut values) = slice(values, nvalues) else {
            return inst.refuse(func, format_args!("{} is NULL", S::VALUE_ARGS));
        };
        let mut status = OK;
        for &r in vrs {
            let entry = match inst.variable_of(r, A::KIND) {
                Ok(entry) => entry,
                Err(why) => return inst.refuse(func, format_args!("{why}")),
            };
            // Counted above, so the values are there.
            let (these, rest) = values.split_at(entry.len as usize);
            for (var, &v) in inst.rows_of(entry).iter().zip(these) {
                status = status.max(inst.write::<A>(func, (var, entry.settable), v));
            }
            values = rest;
        }
        status
    })
}

/// `Get*`/`Set*` of a type the FMU has no variables of: nothing to do for no references,
/// else the first reference named (unknown, or of which type it is).
pub unsafe fn no_variables_of<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    allowed: u16,
    ty: &str,
    (vr, nvr): (*const u32, usize),
    values_null: bool,
) -> Status {
    with_instance::<S, M>(c, func, allowed, |inst| match slice(vr, nvr) {
        Some([]) => OK,
        Some([r, ..]) if !values_null => {
            let why = match inst.variable(*r) {
                Some((v, _)) => format!(
                    "value reference {r} ({}) is {}, not {ty}",
                    v.name,
                    S::type_name(v.kind)
                ),
                None if S::TIME_VR == Some(*r) => {
                    format!("value reference {r} (time) is {}, not {ty}", S::type_name(Kind::Real))
                }
                None => format!("unknown value reference {r}: this FMU has no {ty} variables"),
            };
            inst.refuse(func, format_args!("{why}"))
        }
        _ => inst.refuse(func, format_args!("{} is NULL", S::VALUE_ARGS)),
    })
}

/// An entry point this FMU does not support: logged with the reason, Error.
pub unsafe fn unsupported<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    allowed: u16,
    why: &str,
) -> Status {
    with_instance::<S, M>(c, func, allowed, |inst| {
        inst.refuse(func, format_args!("not supported: {why}"))
    })
}

/// A status query: `read` answers it from the instance or says why it cannot.
pub unsafe fn status_query<S: Standard, M: Model, T>(
    c: *mut c_void,
    func: &str,
    value: *mut T,
    read: impl FnOnce(&Instance<S, M>) -> Result<T, String>,
) -> Status {
    with_instance::<S, M>(c, func, STATUS_CALLS, |inst| {
        if value.is_null() {
            return inst.refuse(func, format_args!("value is NULL"));
        }
        match read(inst) {
            Ok(v) => {
                *value = v;
                OK
            }
            Err(why) => inst.refuse(func, format_args!("{why}")),
        }
    })
}

/// Where FMI 3.0's `fmi3DoStep` reports; FMI 2.0 has no such arguments.
pub struct StepOutputs {
    pub event_handling_needed: *mut bool,
    pub terminate_simulation: *mut bool,
    pub early_return: *mut bool,
    pub last_successful_time: *mut f64,
}

impl StepOutputs {
    /// The FMU has no event mode and never returns early, so those two are always false;
    /// `lastSuccessfulTime` is the FMU time; `terminateSimulation` is true only when the
    /// model failed (the instance is then in Error). A NULL one is skipped: the call has
    /// already been refused for it.
    unsafe fn report(&self, terminate: bool, time: f64) {
        for (p, v) in [
            (self.event_handling_needed, false),
            (self.early_return, false),
            (self.terminate_simulation, terminate),
        ] {
            if !p.is_null() {
                *p = v;
            }
        }
        if !self.last_successful_time.is_null() {
            *self.last_successful_time = time;
        }
    }

    fn any_null(&self) -> bool {
        self.event_handling_needed.is_null()
            || self.terminate_simulation.is_null()
            || self.early_return.is_null()
            || self.last_successful_time.is_null()
    }
}

/// One communication step from `t` of length `h`.
pub unsafe fn do_step<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    t: f64,
    h: f64,
    outputs: Option<StepOutputs>,
) -> Status {
    with_instance::<S, M>(c, func, STEPPING, |inst| {
        if let Some(o) = &outputs {
            o.report(false, inst.time);
            if o.any_null() {
                return inst.refuse(func, format_args!("eventHandlingNeeded, terminateSimulation, earlyReturn or lastSuccessfulTime is NULL"));
            }
        }
        if !(h.is_finite() && h > 0.0) {
            return inst
                .refuse(func, format_args!("communicationStepSize {h} must be finite and > 0"));
        }
        if !t.is_finite() || !same_time(t, inst.time) {
            let now = inst.time;
            return inst.refuse(func, format_args!("currentCommunicationPoint {t} does not match the FMU time {now} (a step must start where the last one ended)"));
        }
        if let Some(stop) = inst.stop_time.filter(|&s| t + h > s && !same_time(t + h, s)) {
            let (end, at) = (t + h, S::EXPERIMENT_FN);
            return inst.refuse(
                func,
                format_args!("step to {end} passes the stop time {stop} set in {at}"),
            );
        }
        if let Err(why) = inst.model.check_step(t, h) {
            return inst.refuse(func, format_args!("{why}"));
        }
        let result = inst.with_step_log(|model, log| model.do_step(t, h, log));
        match result {
            Ok(()) => {
                // The master's clock is the reference: following it keeps t and the FMU
                // time equal however the master accumulates it.
                inst.time = t + h;
                if let Some(o) = &outputs {
                    o.report(false, inst.time);
                }
                let status = inst.report_step_log(func);
                inst.last_step_status = status;
                status
            }
            Err(why) => {
                inst.state = State::Error;
                inst.last_step_status = ERROR;
                if let Some(o) = &outputs {
                    o.report(true, inst.time);
                }
                inst.refuse(func, format_args!("{why}"))
            }
        }
    })
}

impl<S: Standard, M: Model> Instance<S, M> {
    /// Runs `f` with the instance's reusable [`StepLog`], reset to what is wanted now.
    fn with_step_log<T>(&mut self, f: impl FnOnce(&mut M, &mut StepLog) -> T) -> T {
        let events = self.wants(LogCategory::Events);
        self.step_log.reset(events);
        f(&mut self.model, &mut self.step_log)
    }

    /// Logs what the model reported in its last step or update: OK, or Warning if it
    /// warned.
    fn report_step_log(&mut self, func: &str) -> Status {
        // Most steps report nothing: done without moving the log out and back.
        if self.step_log.messages().is_empty() {
            return OK;
        }
        let mut log = std::mem::take(&mut self.step_log);
        let mut status = OK;
        for m in log.drain() {
            match m {
                Message::Event(text) => self.log(OK, LogCategory::Events, format_args!("{text}")),
                Message::Warning(text) => {
                    let why = format_args!("{func}: {text}");
                    self.log(WARNING, LogCategory::StatusWarning, why);
                    status = WARNING;
                }
            }
        }
        self.step_log = log;
        status
    }
}

/// Communication points from `t += h` and from `k · h` differ by rounding; they are the
/// same point when within 1e-9 of the time (and within a few ulps at t = 0). The rule of
/// every `DoStep`'s time, and of a model whose own instants must meet it (the controller's
/// sample clock).
pub fn same_time(a: f64, b: f64) -> bool {
    let scale = a.abs().max(b.abs());
    (a - b).abs() <= (1e-9 * scale).max(4.0 * f64::EPSILON * scale).max(f64::MIN_POSITIVE)
}

pub unsafe fn get_fmu_state<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    slot: *mut *mut c_void,
) -> Status {
    with_instance::<S, M>(c, func, STATE_CALLS, |inst| {
        if slot.is_null() {
            return inst.refuse(func, format_args!("{} is NULL", S::FMU_STATE));
        }
        if inst.state == State::Error && !S::GET_STATE_IN_ERROR {
            return inst.refuse(
                func,
                format_args!("an instance in Error state has no state worth saving"),
            );
        }
        let snap = inst.snapshot();
        inst.store_snapshot(slot, snap)
    })
}

pub unsafe fn set_fmu_state<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    state: *mut c_void,
) -> Status {
    with_instance::<S, M>(c, func, STATE_CALLS, |inst| match inst.own_snapshot(state) {
        Some(s) => {
            let s = s.clone();
            inst.restore(&s);
            OK
        }
        None => inst.not_ours(func),
    })
}

pub unsafe fn free_fmu_state<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    slot: *mut *mut c_void,
) -> Status {
    with_instance::<S, M>(c, func, STATE_CALLS, |inst| {
        if slot.is_null() || (*slot).is_null() {
            return OK;
        }
        let p = *slot as *mut Snapshot<M>;
        match inst.snapshots.iter().position(|&s| s == p) {
            Some(i) => {
                inst.snapshots.swap_remove(i);
                drop(Box::from_raw(p));
                *slot = std::ptr::null_mut();
                OK
            }
            None => inst.not_ours(func),
        }
    })
}

fn encode<M: Model>(s: &Snapshot<M>) -> Result<Vec<u8>, String> {
    let payload = state_blob::save_model(&s.model)?;
    let h = state_blob::Header {
        state: s.state,
        time: s.time,
        start_time: s.start_time,
        stop_time: s.stop_time,
    };
    Ok(state_blob::encode(model_description::guid::<M>(), &h, &payload))
}

/// Serializes the snapshot behind `state` and hands the bytes to `out`.
unsafe fn with_blob<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    state: *mut c_void,
    out: impl FnOnce(&Instance<S, M>, Vec<u8>) -> Status,
) -> Status {
    with_instance::<S, M>(c, func, STATE_CALLS, |inst| {
        let Some(s) = inst.own_snapshot(state) else { return inst.not_ours(func) };
        match encode(s) {
            Ok(blob) => out(inst, blob),
            Err(why) => inst.refuse(func, format_args!("{why}")),
        }
    })
}

pub unsafe fn serialized_size<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    state: *mut c_void,
    size: *mut usize,
) -> Status {
    with_blob::<S, M>(c, func, state, |inst, blob| {
        if size.is_null() {
            return inst.refuse(func, format_args!("size is NULL"));
        }
        *size = blob.len();
        OK
    })
}

pub unsafe fn serialize<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    state: *mut c_void,
    (bytes, size): (*mut u8, usize),
) -> Status {
    with_blob::<S, M>(c, func, state, |inst, blob| {
        let Some(out) = slice_mut(bytes, size) else {
            return inst.refuse(func, format_args!("serializedState is NULL"));
        };
        if out.len() < blob.len() {
            let (have, need) = (out.len(), blob.len());
            return inst.refuse(
                func,
                format_args!("buffer of {have} bytes is smaller than the state ({need} bytes)"),
            );
        }
        out[..blob.len()].copy_from_slice(&blob);
        OK
    })
}

pub unsafe fn deserialize<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    (bytes, size): (*const u8, usize),
    slot: *mut *mut c_void,
) -> Status {
    with_instance::<S, M>(c, func, STATE_CALLS, |inst| {
        let (Some(blob), false) = (slice(bytes, size), slot.is_null()) else {
            return inst.refuse(func, format_args!("serializedState or {} is NULL", S::FMU_STATE));
        };
        let (header, payload) = match state_blob::decode(model_description::guid::<M>(), blob) {
            Ok(x) => x,
            Err(why) => return inst.refuse(func, format_args!("{why}")),
        };
        if header.state as u16 & S::STATES == 0 {
            let (s, v) = (header.state.name(), S::VERSION);
            return inst.refuse(
                func,
                format_args!("serialized state was saved in FMI 2.0 state {s}, which {v} has not"),
            );
        }
        if header.state as u16 & inst.interface.states() == 0 {
            let (s, i) = (S::state_name(header.state), inst.interface.name());
            return inst.refuse(
                func,
                format_args!("serialized state was saved in state {s}, which {i} has not"),
            );
        }
        let model = match state_blob::load_model::<M>(payload) {
            Ok(m) => m,
            Err(why) => return inst.refuse(func, format_args!("model state refused: {why}")),
        };
        let snap = Snapshot {
            model,
            state: header.state,
            time: header.time,
            start_time: header.start_time,
            stop_time: header.stop_time,
        };
        inst.store_snapshot(slot, snap)
    })
}

/// The model's Model Exchange declaration. Only reached through an instance of that
/// interface, which [`instantiate`] creates only for a model that has one.
fn me<M: Model>() -> &'static crate::ModelExchange {
    const NONE: crate::ModelExchange =
        crate::ModelExchange { states: &[], event_indicators: &[], directional_derivatives: false };
    M::model_exchange().unwrap_or(&NONE)
}

/// Runs `body` on a Model Exchange instance in one of the `allowed` states.
unsafe fn with_me<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    allowed: u16,
    body: impl FnOnce(&mut Instance<S, M>) -> Status,
) -> Status {
    with_instance::<S, M>(c, func, LIVE, |inst| {
        if inst.interface != Interface::ModelExchange {
            let why = "a Co-Simulation instance has no event mode (hasEventMode is false) and no continuous states";
            return inst.refuse(func, format_args!("not supported: {why}"));
        }
        if inst.state as u16 & allowed == 0 {
            let state = S::state_name(inst.state);
            let why = format_args!("illegal call sequence: not allowed in state {state}");
            return inst.refuse(func, why);
        }
        body(inst)
    })
}

/// The four arrays of Model Exchange, each in the order of its declaration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Array {
    States,
    Derivatives,
    EventIndicators,
    Nominals,
}

impl Array {
    fn len<M: Model>(self) -> usize {
        match self {
            Array::EventIndicators => me::<M>().event_indicators.len(),
            _ => me::<M>().states.len(),
        }
    }
    fn allowed(self) -> u16 {
        match self {
            Array::Nominals => NOMINALS,
            _ => ME_READABLE,
        }
    }
    fn what(self) -> &'static str {
        match self {
            Array::States => "continuous states",
            Array::Derivatives => "state derivatives",
            Array::EventIndicators => "event indicators",
            Array::Nominals => "nominals of continuous states",
        }
    }
}

/// Refuses an array whose length is not the model's count.
fn check_len<S: Standard, M: Model>(
    inst: &Instance<S, M>,
    func: &str,
    array: Array,
    n: usize,
) -> Result<(), Status> {
    let want = array.len::<M>();
    if n == want {
        return Ok(());
    }
    let what = array.what();
    Err(inst.refuse(func, format_args!("{n} {what} asked for, this FMU has {want}")))
}

/// `Get*` of one Model Exchange array.
pub unsafe fn get_array<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    array: Array,
    (out, n): (*mut f64, usize),
) -> Status {
    with_me::<S, M>(c, func, array.allowed(), |inst| {
        if let Err(s) = check_len(inst, func, array, n) {
            return s;
        }
        let Some(out) = slice_mut(out, n) else {
            return inst.refuse(func, format_args!("the array of {} is NULL", array.what()));
        };
        let decl = me::<M>();
        for (i, out) in out.iter_mut().enumerate() {
            let vr = match array {
                Array::States => decl.states[i].value,
                Array::Derivatives => decl.states[i].derivative,
                Array::EventIndicators => decl.event_indicators[i],
                Array::Nominals => {
                    *out = decl.states[i].nominal;
                    continue;
                }
            };
            match inst.model.get_real(vr) {
                Ok(v) => *out = v,
                Err(why) => return inst.refuse(func, format_args!("{why}")),
            }
        }
        OK
    })
}

/// FMI 3.0's `fmi3GetNumberOf*`.
pub unsafe fn get_count<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    array: Array,
    out: *mut usize,
) -> Status {
    with_me::<S, M>(c, func, LIVE, |inst| {
        if out.is_null() {
            return inst.refuse(func, format_args!("the count's pointer is NULL"));
        }
        *out = array.len::<M>();
        OK
    })
}

pub unsafe fn set_time<S: Standard, M: Model>(c: *mut c_void, func: &str, t: f64) -> Status {
    with_me::<S, M>(c, func, TIMED, |inst| {
        if !t.is_finite() {
            return inst.refuse(func, format_args!("time {t} is not finite"));
        }
        // A time past the stop time is taken: integrators evaluate their last step past the
        // end and interpolate back (FMPy's CVode does). The event update refuses it.
        if let Err(why) = inst.model.check_time(t) {
            return inst.refuse(func, format_args!("{why}"));
        }
        inst.time = t;
        OK
    })
}

/// The integrator's states: all finite or none taken, so a diverging integrator leaves
/// the model at its last consistent states (the rule of NaN inputs).
pub unsafe fn set_continuous_states<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    (x, n): (*const f64, usize),
) -> Status {
    with_me::<S, M>(c, func, CONTINUOUS_TIME, |inst| {
        if let Err(s) = check_len(inst, func, Array::States, n) {
            return s;
        }
        let Some(x) = slice(x, n) else {
            return inst.refuse(func, format_args!("the array of continuous states is NULL"));
        };
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            let name = inst.variable(me::<M>().states[i].value).map_or("?", |v| v.0.name);
            let why = format_args!(
                "state {i} ({name}) = {} refused: continuous states must be finite; keeping all",
                x[i]
            );
            return inst.refuse(func, why);
        }
        match inst.model.set_continuous_states(x) {
            Ok(()) => OK,
            Err(why) => inst.refuse(func, format_args!("{why}")),
        }
    })
}

pub unsafe fn enter_event_mode<S: Standard, M: Model>(c: *mut c_void, func: &str) -> Status {
    with_me::<S, M>(c, func, TIMED, |inst| {
        inst.state = State::EventMode;
        OK
    })
}

pub unsafe fn enter_continuous_time_mode<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
) -> Status {
    with_me::<S, M>(c, func, EVENT_MODE, |inst| {
        inst.state = State::ContinuousTimeMode;
        OK
    })
}

/// The model has no step events and never ends the simulation: both flags false.
pub unsafe fn completed_integrator_step<S: Standard, M: Model, B: Copy>(
    c: *mut c_void,
    func: &str,
    (enter_event_mode, terminate): (*mut B, *mut B),
    no: B,
) -> Status {
    with_me::<S, M>(c, func, CONTINUOUS_TIME, |inst| {
        if enter_event_mode.is_null() || terminate.is_null() {
            let why = "enterEventMode or terminateSimulation is NULL";
            return inst.refuse(func, format_args!("{why}"));
        }
        (*enter_event_mode, *terminate) = (no, no);
        OK
    })
}

/// Where a standard wants the outcome of one event-mode update: FMI 2.0's
/// `fmi2EventInfo`, FMI 3.0's six pointers.
pub trait EventSink {
    fn any_null(&self) -> bool;
    /// Writes the update; `terminate` is true only when the model failed.
    ///
    /// # Safety
    /// [`EventSink::any_null`] is false.
    unsafe fn write(&self, u: &EventUpdate, terminate: bool);
}

/// One pass of the event iteration at the instance's time. The model reaches its fixed
/// point in one update, so the master is never asked for another.
pub unsafe fn update_discrete_states<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    out: impl EventSink,
) -> Status {
    with_me::<S, M>(c, func, EVENT_MODE, |inst| {
        if out.any_null() {
            return inst.refuse(func, format_args!("an argument for the event's outcome is NULL"));
        }
        let t = inst.time;
        // The stop time holds in Model Exchange as in a step (FMI 2.0 section 2.1.6, FMI
        // 3.0 section 2.3.2 allow an error for computing past a defined stop time): the
        // update is the computation whose results a master keeps.
        if let Some(stop) = inst.stop_time.filter(|&s| t > s && !same_time(t, s)) {
            let at = S::EXPERIMENT_FN;
            return inst.refuse(
                func,
                format_args!("an event update at {t} s is past the stop time {stop} set in {at}"),
            );
        }
        match inst.with_step_log(|model, log| model.update_discrete_states(t, log)) {
            Ok(update) => {
                out.write(&update, false);
                inst.report_step_log(func)
            }
            Err(why) => {
                inst.state = State::Error;
                out.write(&EventUpdate::default(), true);
                inst.refuse(func, format_args!("{why}"))
            }
        }
    })
}

/// `GetDirectionalDerivative(s)`: `sensitivity = J seed` over the given unknowns and
/// knowns, from the model's exact partial derivatives.
pub unsafe fn directional_derivative<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    (unknowns, nu): (*const u32, usize),
    (knowns, nk): (*const u32, usize),
    (seed, ns): (*const f64, usize),
    (out, no): (*mut f64, usize),
) -> Status {
    with_instance::<S, M>(c, func, GETTABLE, |inst| {
        if !M::model_exchange().is_some_and(|me| me.directional_derivatives) {
            let why = format_args!("not supported: {}", S::NO_DIRECTIONAL_DERIVATIVES);
            return inst.refuse(func, why);
        }
        if ns != nk || no != nu {
            let why = format_args!("{ns} seeds for {nk} knowns, {no} sensitivities for {nu} unknowns (every variable of this FMU is a scalar)");
            return inst.refuse(func, why);
        }
        let (Some(u), Some(k), Some(seed), Some(out)) =
            (slice(unknowns, nu), slice(knowns, nk), slice(seed, ns), slice_mut(out, no))
        else {
            return inst.refuse(func, format_args!("an array argument is NULL"));
        };
        for &vr in u.iter().chain(k) {
            if let Err(why) = inst.variable_of(vr, Kind::Real) {
                return inst.refuse(func, format_args!("{why}"));
            }
        }
        if let Some(s) = seed.iter().find(|s| !s.is_finite()) {
            return inst.refuse(func, format_args!("seed {s} is not finite"));
        }
        match inst.model.directional_derivative(u, k, seed, out) {
            Ok(()) => OK,
            Err(why) => inst.refuse(func, format_args!("{why}")),
        }
    })
}
