//! A model's variable table with the accessors in its rows.
//!
//! Each row is one variable: its declaration ([`Variable`]: what the XML, the docs and
//! the layer's checks read) and how the layer reads and writes it on the model
//! ([`Access`]). The layer serves every `Get*`/`Set*`, the FMU state's parameters and the
//! Model Exchange arrays through the rows, so a model has no value-reference constants
//! and no `match` over them, and a parameter is added by adding its row. [`table!`] also
//! names each row ([`Var`]), so that masters, the SSP generator and the tests refer to a
//! variable by a checked name instead of a string or a number.

use std::marker::PhantomData;

use inchworm_declare::{Access as FieldAccess, Field, FieldId, Role, Start as DeclaredStart};

use crate::table::{Causality, Kind, Start, Variable};
use crate::Model;

/// How the layer reads and, for a variable a master may set, writes one variable of a
/// model `M`. Getters cannot fail: a model's values exist in every state (before
/// initialization they are the start values or the model at rest); a non-finite Real is
/// refused by the layer when read.
pub enum Access<M: 'static> {
    Real {
        get: fn(&M) -> f64,
        set: Option<fn(&mut M, f64)>,
    },
    Integer {
        get: fn(&M) -> i32,
        set: Option<fn(&mut M, i32)>,
    },
    Boolean {
        get: fn(&M) -> bool,
        set: Option<fn(&mut M, bool)>,
    },
    /// A clock: the layer activates an input clock (`ticked` is `None`); the model ticks
    /// an output clock, read with `ticked`.
    Clock {
        ticked: Option<fn(&M) -> bool>,
    },
}

impl<M> Clone for Access<M> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<M> Copy for Access<M> {}

/// One value of any of the table's types.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    Real(f64),
    Integer(i32),
    Boolean(bool),
}

impl Value {
    /// As a C double: a Boolean as 0 or 1.
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

impl std::fmt::Display for Value {
    /// As a master writes it in a parameter file: a Real in Rust's shortest round-trip
    /// form, an Integer in decimal, a Boolean as `true`/`false`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Value::Real(x) => write!(f, "{x}"),
            Value::Integer(i) => write!(f, "{i}"),
            Value::Boolean(b) => write!(f, "{b}"),
        }
    }
}

/// One row of a model's table: the variable and its accessor.
pub struct Row<M: 'static> {
    pub var: Variable,
    pub access: Access<M>,
}

impl<M> Clone for Row<M> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<M> Copy for Row<M> {}

impl<M> Row<M> {
    /// The row of a declared field (`inchworm_declare`) at value reference `vr`: a
    /// parameter fixed at initialization or a continuous input, with the field's start,
    /// unit, range, description, array and wording.
    pub const fn declared(f: Field<M>, vr: u32) -> Row<M> {
        let (name, unit, desc) = (f.name, f.unit, f.description);
        let mut var = match (f.role, f.start) {
            (Role::Parameter, DeclaredStart::Real(x)) => {
                Variable::parameter(name, vr, x, unit, desc)
            }
            (Role::Parameter, DeclaredStart::Integer(i)) => {
                Variable::integer_parameter(name, vr, i, unit, desc)
            }
            (Role::Parameter, DeclaredStart::Boolean(b)) => {
                Variable::boolean_parameter(name, vr, b, desc)
            }
            (Role::Input, DeclaredStart::Real(x)) => Variable::input(name, vr, x, unit, desc),
            (Role::Input, DeclaredStart::Integer(i)) => {
                Variable::integer_input(name, vr, i, unit, desc)
            }
            (Role::Input, DeclaredStart::Boolean(b)) => Variable::boolean_input(name, vr, b, desc),
        };
        var.min = f.min;
        var.max = f.max;
        var.array = f.array;
        if let Some((quantity, range)) = f.wording {
            var = var.worded(quantity, range);
        }
        let access = match f.access {
            FieldAccess::Real { get, set } => Access::Real { get, set: Some(set) },
            FieldAccess::Integer { get, set } => Access::Integer { get, set: Some(set) },
            FieldAccess::Boolean { get, set } => Access::Boolean { get, set: Some(set) },
        };
        var.with_access(access)
    }
}

/// The rows a [`table!`] filled in, unwrapped (every slot is filled: the macro counts).
#[doc(hidden)]
pub const fn filled<M, const N: usize>(slots: [Option<Row<M>>; N]) -> [Row<M>; N] {
    const fn take<M>(slot: Option<Row<M>>) -> Row<M> {
        match slot {
            Some(row) => row,
            None => panic!("a table slot left empty"),
        }
    }
    let mut rows = [take(slots[0]); N];
    let mut i = 1;
    while i < N {
        rows[i] = take(slots[i]);
        i += 1;
    }
    rows
}

/// A model whose table takes the declared fields of its part `P` (`fields(P, vr)` in
/// [`table!`]): where they start in the table.
pub trait Declares<P>: Model {
    #[doc(hidden)]
    const OFFSET: usize;
}

impl<M> AsRef<Variable> for Row<M> {
    fn as_ref(&self) -> &Variable {
        &self.var
    }
}

impl AsRef<Variable> for Variable {
    fn as_ref(&self) -> &Variable {
        self
    }
}

impl<M> Row<M> {
    /// The value the model holds.
    pub fn get(&self, model: &M) -> Value {
        match self.access {
            Access::Real { get, .. } => Value::Real(get(model)),
            Access::Integer { get, .. } => Value::Integer(get(model)),
            Access::Boolean { get, .. } => Value::Boolean(get(model)),
            Access::Clock { ticked } => Value::Boolean(ticked.is_some_and(|f| f(model))),
        }
    }

    /// Stores `value` without the layer's checks (ranges, states): for the layer, which
    /// has made them, and for tests and tools that build a model in Rust. `Err` when the
    /// variable is read-only or of another type.
    pub fn set(&self, model: &mut M, value: Value) -> Result<(), String> {
        match (self.access, value) {
            (Access::Real { set: Some(set), .. }, Value::Real(x)) => set(model, x),
            (Access::Integer { set: Some(set), .. }, Value::Integer(i)) => set(model, i),
            (Access::Boolean { set: Some(set), .. }, Value::Boolean(b)) => set(model, b),
            (_, value) => {
                return Err(format!("{} cannot be set to {value:?}", self.var.name));
            }
        }
        Ok(())
    }

    /// A Real's value (`None` for another type).
    #[inline]
    pub fn real(&self, model: &M) -> Option<f64> {
        match self.access {
            Access::Real { get, .. } => Some(get(model)),
            _ => None,
        }
    }
}

/// Declaring a row's accessor is the last step of declaring its variable.
impl Variable {
    /// A Real read with `get` and written with `set`.
    pub const fn real<M>(self, get: fn(&M) -> f64, set: fn(&mut M, f64)) -> Row<M> {
        self.with_access(Access::Real { get, set: Some(set) })
    }
    /// A Real the model computes (an output, a Model Exchange state derivative or event
    /// indicator): read only.
    pub const fn real_out<M>(self, get: fn(&M) -> f64) -> Row<M> {
        self.with_access(Access::Real { get, set: None })
    }
    pub const fn integer<M>(self, get: fn(&M) -> i32, set: fn(&mut M, i32)) -> Row<M> {
        self.with_access(Access::Integer { get, set: Some(set) })
    }
    pub const fn integer_out<M>(self, get: fn(&M) -> i32) -> Row<M> {
        self.with_access(Access::Integer { get, set: None })
    }
    pub const fn boolean<M>(self, get: fn(&M) -> bool, set: fn(&mut M, bool)) -> Row<M> {
        self.with_access(Access::Boolean { get, set: Some(set) })
    }
    pub const fn boolean_out<M>(self, get: fn(&M) -> bool) -> Row<M> {
        self.with_access(Access::Boolean { get, set: None })
    }
    /// An input clock: the layer keeps its activations and hands its ticks to
    /// [`Model::activate_clock`].
    pub const fn clock_in<M>(self) -> Row<M> {
        assert!(matches!(self.causality, Causality::Input), "clock_in is for an input clock");
        self.with_access(Access::Clock { ticked: None })
    }
    /// An output clock, ticked by the model: `ticked` reads whether it ticked since it was
    /// last cleared ([`Model::clear_output_clocks`]).
    pub const fn clock_out<M>(self, ticked: fn(&M) -> bool) -> Row<M> {
        assert!(matches!(self.causality, Causality::Output), "clock_out is for an output clock");
        self.with_access(Access::Clock { ticked: Some(ticked) })
    }

    /// The row; the table is a `static`, so a row whose accessor's type is not the
    /// variable's, or an input or parameter without a setter, fails the build.
    const fn with_access<M>(self, access: Access<M>) -> Row<M> {
        let kind_matches = matches!(
            (self.kind, &access),
            (Kind::Real, Access::Real { .. })
                | (Kind::Integer, Access::Integer { .. })
                | (Kind::Boolean, Access::Boolean { .. })
                | (Kind::Clock, Access::Clock { .. })
        );
        assert!(kind_matches, "a row's accessor must be of its variable's type");
        let settable = matches!(
            &access,
            Access::Real { set: Some(_), .. }
                | Access::Integer { set: Some(_), .. }
                | Access::Boolean { set: Some(_), .. }
        );
        let needs_setter = matches!(self.causality, Causality::Input | Causality::Parameter)
            && !matches!(self.kind, Kind::Clock);
        assert!(settable == needs_setter, "inputs and parameters have a setter, nothing else");
        Row { var: self, access }
    }
}

/// The name of one row of the table of `M`, made by [`table!`]: what masters, the SSP
/// generator and tests use to refer to a variable, checked by the compiler.
pub struct Var<M> {
    index: usize,
    model: PhantomData<fn() -> M>,
}

impl<M> Clone for Var<M> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<M> Copy for Var<M> {}

impl<M> std::fmt::Debug for Var<M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Var({})", self.index)
    }
}

impl<M: Model> Var<M> {
    /// Row `index` of the table; [`table!`] makes these.
    #[doc(hidden)]
    pub const fn at(index: usize) -> Self {
        Var { index, model: PhantomData }
    }
    /// The row's position in the table.
    #[doc(hidden)]
    pub const fn index(self) -> usize {
        self.index
    }
    /// The row of the declared field `f` of the model's part `P`.
    pub const fn of<P>(f: FieldId<P>) -> Self
    where
        M: Declares<P>,
    {
        Var::at(<M as Declares<P>>::OFFSET + f.index())
    }
    pub fn row(self) -> &'static Row<M> {
        &M::table()[self.index]
    }
    pub fn name(self) -> &'static str {
        self.row().var.name
    }
    pub fn vr(self) -> u32 {
        self.row().var.vr
    }
    /// Element `1 + k` of the array whose first element `name[1]` this is.
    ///
    /// # Panics
    /// If the table has no such element: a bug of the caller, like an index out of bounds.
    pub fn element(self, k: usize) -> Self {
        let e = Var::at(self.index + k);
        let base = self.name().strip_suffix("[1]");
        let name = e.row().var.name;
        let ok = base.is_some_and(|b| name.strip_prefix(b) == Some(&format!("[{}]", k + 1)));
        assert!(ok, "{name} is not element {} of the array {}", k + 1, self.name());
        e
    }
}

/// Declares a model's table and names its rows. `table!(Model, TABLE; NAME: row, …)` (or
/// `table!(Model, pub(super) TABLE; …)`) defines `static TABLE: [Row<Model>; n]` and one
/// associated constant `Model::NAME` of type [`Var<Model>`] per row. The table may also be
/// a sequence of segments, each a run of named rows in braces or `fields(Part, vr)`: the
/// declared fields of a part the model holds (`inchworm_declare`, the model
/// `Has<Part>`), at value references `vr`, `vr + 1`, … in declaration order (with the gaps
/// the declaration leaves, `at = n`), named by
/// `Var::of(Part::FIELD)` (or `Model::var(Part::FIELD)`):
///
/// ```ignore
/// table!(PlantFmu, TABLE;
///     fields(Dac, 1),
///     { ENCODER_COUNTS: Variable::output("encoder_counts", 10, …).integer_out(…) },
///     fields(PlantParams, 100),
/// );
/// ```
#[macro_export]
macro_rules! table {
    // One named row: its constant, and its slot.
    (@rows ($model:ty) ($vis:vis) ($table:ident) [$t:ident $k:ident] ($off:expr) [$($fill:tt)*]
        { $id:ident: $row:expr $(, $($more:tt)*)? } $($rest:tt)*) => {
        #[allow(dead_code)]
        impl $model {
            pub const $id: $crate::Var<$model> = $crate::Var::at($off);
        }
        $crate::table!(@rows ($model) ($vis) ($table) [$t $k] ($off + 1)
            [$($fill)* $t[$k] = ::core::option::Option::Some($row); $k += 1;]
            { $($($more)*)? } $($rest)*);
    };
    // The end of a run of rows.
    (@rows ($model:ty) ($vis:vis) ($table:ident) [$t:ident $k:ident] ($off:expr) [$($fill:tt)*]
        { } $(, $($rest:tt)*)?) => {
        $crate::table!(@rows ($model) ($vis) ($table) [$t $k] ($off) [$($fill)*] $($($rest)*)?);
    };
    // A part's declared fields.
    (@rows ($model:ty) ($vis:vis) ($table:ident) [$t:ident $k:ident] ($off:expr) [$($fill:tt)*]
        fields($part:ty, $vr:expr) $(, $($rest:tt)*)?) => {
        impl $crate::access::Declares<$part> for $model {
            const OFFSET: usize = $off;
        }
        $crate::table!(@rows ($model) ($vis) ($table) [$t $k] ($off + <$part>::N_FIELDS)
            [$($fill)* {
                let fields = <$part>::fields_in::<$model>();
                let mut i = 0;
                while i < fields.len() {
                    $t[$k] = ::core::option::Option::Some(
                        $crate::Row::declared(fields[i], $vr + fields[i].offset),
                    );
                    $k += 1;
                    i += 1;
                }
            }]
            $($($rest)*)?);
    };
    // Every segment read: the table.
    (@rows ($model:ty) ($vis:vis) ($table:ident) [$t:ident $k:ident] ($off:expr) [$($fill:tt)*]) => {
        $vis static $table: [$crate::Row<$model>; $off] = {
            let mut $t: [::core::option::Option<$crate::Row<$model>>; $off] = [None; $off];
            let mut $k = 0usize;
            $($fill)*
            assert!($k == $off, "every row has its slot");
            $crate::access::filled($t)
        };
        #[allow(dead_code)]
        impl $model {
            /// The row of the declared field `f` of a part this model holds.
            pub const fn var<P>(f: $crate::inchworm_declare::FieldId<P>) -> $crate::Var<$model>
            where
                $model: $crate::access::Declares<P>,
            {
                $crate::Var::of(f)
            }
            /// The value reference of row `v`, in a constant (the Model Exchange states
            /// and event indicators name their rows with it).
            pub const fn vr_of(v: $crate::Var<$model>) -> u32 {
                $table[v.index()].var.vr
            }
            /// The name of row `v`, in a constant (for a client's signal names).
            pub const fn name_of(v: $crate::Var<$model>) -> &'static str {
                $table[v.index()].var.name
            }
        }
    };
    ($model:ty, $vis:vis $table:ident; $($id:ident: $row:expr),+ $(,)?) => {
        $crate::table!($model, $vis $table; { $($id: $row),+ });
    };
    ($model:ty, $vis:vis $table:ident; $($segments:tt)+) => {
        $crate::table!(@rows ($model) ($vis) ($table) [__slots __at] (0usize) [] $($segments)+);
    };
}

/// The row of the variable with value reference `vr`.
pub fn row_of<M: Model>(vr: u32) -> Option<&'static Row<M>> {
    M::table().iter().find(|r| r.var.vr == vr)
}

/// The row of the variable named `name` (an array's element as `name[k]`).
pub fn row_named<M: Model>(name: &str) -> Option<&'static Row<M>> {
    M::table().iter().find(|r| r.var.name == name)
}

/// Every parameter of the table with the value `model` holds, in table order: what a
/// master sets so that an FMU runs exactly `model`'s parameters, whatever its start
/// values are.
pub fn parameter_values<M: Model>(model: &M) -> impl Iterator<Item = (&'static str, Value)> + '_ {
    M::table()
        .iter()
        .filter(|r| r.var.causality == Causality::Parameter)
        .map(move |r| (r.var.name, r.get(model)))
}

/// A variable's start value as a [`Value`] (`None` for a calculated one).
pub fn start_value(v: &Variable) -> Option<Value> {
    match v.start {
        Start::Real(x) => Some(Value::Real(x)),
        Start::Integer(i) => Some(Value::Integer(i)),
        Start::Boolean(b) => Some(Value::Boolean(b)),
        Start::None => None,
    }
}
