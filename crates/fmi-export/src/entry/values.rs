//! `Get*` and `Set*` (FMI 2.0 section 2.1.7, FMI 3.0 section 2.2.6): value references
//! resolved through the instance's index, values converted between the C types and the
//! model's, inputs admitted into their declared ranges.

use std::ffi::c_void;

use super::call::{slice, slice_mut, with_instance};
use crate::access::Row;
pub use crate::access::Value;
use crate::instance::*;
use crate::state::*;
use crate::table::{Admission, Kind, Variable};
use crate::Model;

/// The clamps of one input warned of each in full, before only every tenfold count is.
pub const CLAMPS_IN_FULL: u64 = 3;

/// One `Get*`/`Set*` pair of a standard: the table type its variables have and the C
/// types it moves. A type parameter rather than a value (a type and a conversion
/// function) so that each entry point is compiled for its own type: the model's getter
/// or setter is called directly, the [`Value`] between them folds away, and nothing is
/// decided per value that the function's name already decided.
pub trait CTypes {
    /// The table type of the variables the pair reaches.
    const KIND: Kind;
    /// What `Get*` writes.
    type Out: Copy;
    /// What `Set*` reads.
    type In: Copy;
    /// A value of [`CTypes::KIND`] (or FMI 3.0's time, a Real) as `Get*` writes it.
    fn out(v: Value) -> Self::Out;
    /// What `Set*` was given, as the model's value.
    fn value(c: Self::In) -> Value;
}

/// `fmi2Get/SetReal`, `fmi3Get/SetFloat64`: a C double either way.
pub struct Reals;

impl CTypes for Reals {
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

impl CTypes for Integers {
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

impl<O: CBoolean, I: CBoolean> CTypes for Booleans<O, I> {
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

/// The value `row` holds on `model`, a non-finite Real refused: a model whose state has
/// left what it can represent says so instead of handing the master a NaN.
#[inline]
pub(crate) fn read_row<M>(row: &Row<M>, model: &M) -> Result<Value, String> {
    match row.get(model) {
        Value::Real(x) if !x.is_finite() => Err(not_finite(&row.var, x)),
        v => Ok(v),
    }
}

#[cold]
#[inline(never)]
fn not_finite(v: &Variable, x: f64) -> String {
    format!(
        "{} (value reference {}) is not finite ({x}): the model's state has left what it can represent",
        v.name, v.vr
    )
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
    pub(super) fn variable_of(&self, vr: u32, kind: Kind) -> Result<Indexed, String> {
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
    fn read<A: CTypes>(&self, what: Addressed, out: &mut [A::Out]) -> Result<(), String> {
        let rows = match what {
            Addressed::Variable(entry) => self.rows_of(entry),
            Addressed::Time => {
                out[0] = A::out(Value::Real(self.time));
                return Ok(());
            }
        };
        // An array's elements are the table's rows after its first, each with its own
        // value reference (crate::arrays): the model knows only those.
        for (slot, row) in out.iter_mut().zip(rows) {
            *slot = A::out(read_row(row, &self.model)?);
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
    fn write<A: CTypes>(
        &mut self,
        func: &str,
        (row, settable): (&'static Row<M>, u16),
        value: A::In,
    ) -> Status {
        let var = &row.var;
        if settable & self.state as u16 == 0 {
            let (c, v, s) = (var.causality, var.variability, S::state_name(self.state));
            let why = format_args!("{} ({c:?}, {v:?}) cannot be set in state {s}", var.name);
            return self.refuse(func, why);
        }
        let (stored, clamped_from) = match A::value(value) {
            Value::Real(x) => match var.admit(x) {
                Admission::Accept(y) | Admission::Limit(y) => {
                    (row.set(&mut self.model, Value::Real(y)), None)
                }
                Admission::Clamp(y) => (row.set(&mut self.model, Value::Real(y)), Some((x, y))),
                Admission::NonFinite => {
                    let current = row.real(&self.model).unwrap_or(f64::NAN);
                    return self.refuse(func, format_args!("{}", var.refusal(x, current)));
                }
            },
            other => (row.set(&mut self.model, other), None),
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
}

/// `Get*` of one type. One pass: each reference is resolved once and its values read
/// straight into the master's array; a count that turns out wrong on the way is refused
/// with the message a count check up front would have given.
pub unsafe fn get<S: Standard, M: Model, A: CTypes>(
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

/// How many references a `Set*` keeps resolved on the stack between its check of every
/// reference and its writes: a master's call sets a few inputs. A longer call finds the
/// references past these again as it writes.
const KEPT: usize = 8;

/// `Set*` of one type. The call reports the worst outcome of its values; a reference
/// refused (FMI 3.0's time among them: not settable) or a wrong count refuses it whole,
/// before any value is stored. One pass checks every reference and the count and keeps
/// the first [`KEPT`] references' entries, which the writes then use.
pub unsafe fn set<S: Standard, M: Model, A: CTypes>(
    c: *mut c_void,
    func: &str,
    (vr, nvr): (*const u32, usize),
    (values, nvalues): (*const A::In, usize),
) -> Status {
    with_instance::<S, M>(c, func, SETTABLE, |inst| {
        let Some(vrs) = slice(vr, nvr) else {
            return inst.refuse(func, format_args!("{} is NULL", S::VALUE_ARGS));
        };
        let unused = Indexed { first: 0, len: 0, kind: A::KIND, settable: 0 };
        let mut kept = [unused; KEPT];
        let (mut n, mut time) = (0, None);
        for (i, &r) in vrs.iter().enumerate() {
            let Some(what) = inst.address(r, A::KIND) else {
                return inst.refuse_counts(func, vrs, A::KIND, nvalues);
            };
            n += what.len();
            match what {
                Addressed::Variable(entry) => {
                    if let Some(k) = kept.get_mut(i) {
                        *k = entry;
                    }
                }
                Addressed::Time => time = time.or(Some(r)),
            }
        }
        if n != nvalues {
            return inst.refuse_counts(func, vrs, A::KIND, nvalues);
        }
        let Some(mut values) = slice(values, nvalues) else {
            return inst.refuse(func, format_args!("{} is NULL", S::VALUE_ARGS));
        };
        if let Some(r) = time {
            return inst.refuse(func, format_args!("{}", inst.time_refused(r)));
        }
        let mut status = OK;
        for (i, &r) in vrs.iter().enumerate() {
            let entry = match kept.get(i) {
                Some(&entry) => entry,
                // Checked above: found again.
                None => match inst.variable_of(r, A::KIND) {
                    Ok(entry) => entry,
                    Err(why) => return inst.refuse(func, format_args!("{why}")),
                },
            };
            // Counted above, so the values are there.
            let (these, rest) = values.split_at(entry.len as usize);
            for (row, &v) in inst.rows_of(entry).iter().zip(these) {
                status = status.max(inst.write::<A>(func, (row, entry.settable), v));
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
