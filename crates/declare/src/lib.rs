//! A model's variables declared once, on the fields of the plain Rust struct that holds
//! them: `#[derive(Declare)]` with a `#[var(...)]` attribute on each field gives the
//! struct its [`Field`]s (name, role, unit, start, range, description, accessors) in
//! declaration order, a typed handle per field ([`FieldId`]) and its start values
//! ([`Declared::declared`]). Everything that names or describes a variable reads these:
//! the FMI layer's variable table (and so the model descriptions, the accessors, the SSP
//! parameter sets, the CLI's `--param` and the docs' tables), the model's own range checks
//! and the tests. Nothing here knows FMI: the plant and controller crates stay plain Rust.
//!
//! ```
//! use inchworm_declare::{Declare, Declared};
//!
//! #[derive(Declare, Clone, Debug, PartialEq)]
//! pub struct Spring {
//!     /// Spring stiffness
//!     #[var(unit = "N/m", start = 2.0e4, min = 0.0, max = 1e9)]
//!     pub k: f64,
//!     /// Seed of the noise
//!     #[var(start = 1)]
//!     pub seed: u64,
//! }
//!
//! assert_eq!(Spring::declared(), Spring { k: 2.0e4, seed: 1 });
//! let k = &Spring::FIELDS[Spring::K.index()];
//! assert_eq!((k.name, k.unit, k.min, k.max), ("k", Some("N/m"), Some(0.0), Some(1e9)));
//! assert_eq!(inchworm_declare::out_of_range(&Spring { k: -1.0, seed: 1 }).unwrap().0, "k");
//! ```

use std::marker::PhantomData;

/// `#[derive(Declare)]`: the attribute `#[var(...)]` on every field (keys: `name`, `unit`,
/// `start`, `min`, `max`, `input`, `quantity` and `range_name` for an input's messages,
/// `elements` (one each) or `element` (a template, `{k}` the element's number) for the
/// descriptions of an array's elements, `at = n` to start the field at value reference
/// base + n, `flatten` for a field that is itself a declared struct, whose variables are
/// spliced in (one level: a model holding the outer struct holds the inner one too),
/// `skip` for a field that is not a variable), the first paragraph of the doc comment its
/// description.
pub use inchworm_declare_derive::Declare;

/// A model that holds a declared part `P` (its parameters, its inputs): what lets the
/// part's accessors reach it inside the model.
pub trait Has<P> {
    fn part(&self) -> &P;
    fn part_mut(&mut self) -> &mut P;
}

/// Every declared struct is a part of itself.
impl<P> Has<P> for P {
    fn part(&self) -> &P {
        self
    }
    fn part_mut(&mut self) -> &mut P {
        self
    }
}

/// What a master does with the variable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// Set before initialization and fixed after it.
    Parameter,
    /// Set at every communication point (a continuous Real input).
    Input,
}

/// A field's start value, of the variable's type.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Start {
    Real(f64),
    Integer(i32),
    Boolean(bool),
}

/// How a model `M` that holds the part reads and writes the field.
pub enum Access<M: 'static> {
    Real { get: fn(&M) -> f64, set: fn(&mut M, f64) },
    Integer { get: fn(&M) -> i32, set: fn(&mut M, i32) },
    Boolean { get: fn(&M) -> bool, set: fn(&mut M, bool) },
}

impl<M> Clone for Access<M> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<M> Copy for Access<M> {}

/// One declared variable (an array field is one per element, `name[1]` … `name[n]`), as
/// a model `M` that holds its part reaches it.
pub struct Field<M: 'static> {
    /// The variable's name (an array's element as `name[k]`, from 1).
    pub name: &'static str,
    pub role: Role,
    /// The field's doc comment (an array element's: its entry of `elements`).
    pub description: &'static str,
    pub unit: Option<&'static str>,
    pub start: Start,
    /// The valid range (a parameter outside it is refused, an input clamped into it).
    pub min: Option<f64>,
    pub max: Option<f64>,
    /// On an array's first element: the description of the whole array.
    pub array: Option<&'static str>,
    /// How messages name an input's values and its range ("DAC volts", "DAC range").
    pub wording: Option<(&'static str, &'static str)>,
    /// The value reference relative to the part's base: the declaration order, an array
    /// one per element, with the gaps `at = n` leaves.
    pub offset: u32,
    pub access: Access<M>,
}

impl<M> Clone for Field<M> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<M> Copy for Field<M> {}

impl<M> Field<M> {
    /// The Real the model holds (`None` for another type).
    pub fn real(&self, model: &M) -> Option<f64> {
        match self.access {
            Access::Real { get, .. } => Some(get(model)),
            _ => None,
        }
    }
}

/// The typed name of field `index` of the declared struct `P` (an array's: its first
/// element), generated as an associated constant per field (`PlantParams::K_E`).
pub struct FieldId<P> {
    index: usize,
    part: PhantomData<fn() -> P>,
}

impl<P> Clone for FieldId<P> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<P> Copy for FieldId<P> {}

impl<P> std::fmt::Debug for FieldId<P> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "FieldId({})", self.index)
    }
}

impl<P> FieldId<P> {
    #[doc(hidden)]
    pub const fn at(index: usize) -> Self {
        FieldId { index, part: PhantomData }
    }
    /// The position of the field's (first) variable in [`Declared::FIELDS`].
    pub const fn index(self) -> usize {
        self.index
    }
}

impl<P: Declared> FieldId<P> {
    pub fn field(self) -> &'static Field<P> {
        &P::FIELDS[self.index]
    }
    /// The variable's name; an array field's first element's (`basis_peak[1]`).
    pub fn name(self) -> &'static str {
        self.field().name
    }
    /// The field's name without an element's index: an array's own name (`basis_peak`),
    /// a scalar's name.
    pub fn base_name(self) -> &'static str {
        let name = self.name();
        match name.strip_suffix(']').and_then(|n| n.rsplit_once('[')) {
            Some((base, _)) => base,
            None => name,
        }
    }
}

/// A struct whose fields are declared variables (`#[derive(Declare)]`).
pub trait Declared: Sized + 'static {
    /// Every variable, in declaration order.
    const FIELDS: &'static [Field<Self>];
    /// Every field at its declared start value.
    fn declared() -> Self;
}

/// An integer field's conversion to and from the FMI Integer (`i32`) that carries it.
pub trait IntegerField: Copy {
    fn to_fmi(self) -> i32;
    fn from_fmi(x: i32) -> Self;
}

impl IntegerField for i32 {
    fn to_fmi(self) -> i32 {
        self
    }
    fn from_fmi(x: i32) -> Self {
        x
    }
}

/// Counts: a negative Integer is 0.
impl IntegerField for u32 {
    fn to_fmi(self) -> i32 {
        self.min(i32::MAX as u32) as i32
    }
    fn from_fmi(x: i32) -> Self {
        x.max(0) as u32
    }
}

/// Seeds: the Integer's 32 bits, read back as they were written.
impl IntegerField for u64 {
    fn to_fmi(self) -> i32 {
        self as i32
    }
    fn from_fmi(x: i32) -> Self {
        x as u32 as u64
    }
}

/// The first Real field of `p` outside its declared range or not finite: its name and
/// why (`must be within [lo, hi] unit, got v`).
pub fn out_of_range<P: Declared>(p: &P) -> Option<(&'static str, String)> {
    P::FIELDS.iter().find_map(|f| {
        let v = f.real(p)?;
        let (lo, hi) = (f.min.unwrap_or(f64::NEG_INFINITY), f.max.unwrap_or(f64::INFINITY));
        if v.is_finite() && (lo..=hi).contains(&v) {
            return None;
        }
        let unit = f.unit.unwrap_or("(dimensionless)");
        Some((f.name, format!("must be within [{lo:e}, {hi:e}] {unit}, got {v:e}")))
    })
}

/// Sets the field of `p` named `name` from `text` (a number for a Real or an Integer,
/// `true`/`false` or `1`/`0` for a Boolean): what a command line's `--param NAME=VALUE`
/// does to a declared struct. Refuses an unknown name (listing the known ones), a value
/// that does not parse as the field's type, and a value outside the declared range.
pub fn set_named<P: Declared>(p: &mut P, name: &str, text: &str) -> Result<(), String> {
    let f = field_named::<P>(name).ok_or_else(|| {
        let known: Vec<&str> = P::FIELDS.iter().map(|f| f.name).collect();
        format!("unknown parameter `{name}`; known: {}", known.join(", "))
    })?;
    let text = text.trim();
    let range = |v: f64| {
        let (lo, hi) = (f.min.unwrap_or(f64::NEG_INFINITY), f.max.unwrap_or(f64::INFINITY));
        if v.is_finite() && (lo..=hi).contains(&v) {
            Ok(())
        } else {
            Err(format!("{name} = {text}: must be finite, within [{lo:e}, {hi:e}]"))
        }
    };
    match f.access {
        Access::Real { set, .. } => {
            let v: f64 = text.parse().map_err(|_| format!("{name} = {text}: not a number"))?;
            range(v)?;
            set(p, v);
        }
        Access::Integer { set, .. } => {
            let v: i32 =
                text.parse().map_err(|_| format!("{name} = {text}: not a 32-bit integer"))?;
            range(f64::from(v))?;
            set(p, v);
        }
        Access::Boolean { set, .. } => {
            let v = match text {
                "true" | "1" => true,
                "false" | "0" => false,
                _ => return Err(format!("{name} = {text}: not true, false, 1 or 0")),
            };
            set(p, v);
        }
    }
    Ok(())
}

/// The field of `P` named `name` (an array's element as `name[k]`).
pub fn field_named<P: Declared>(name: &str) -> Option<&'static Field<P>> {
    P::FIELDS.iter().find(|f| f.name == name)
}

/// `has!(Model { Part => field.path, … })`: the model holds each part at that path, so the
/// part's declared fields reach it ([`Has`]).
#[macro_export]
macro_rules! has {
    ($model:ty { $($part:ty => $($path:ident).+),+ $(,)? }) => {
        $(
            impl $crate::Has<$part> for $model {
                fn part(&self) -> &$part {
                    &self.$($path).+
                }
                fn part_mut(&mut self) -> &mut $part {
                    &mut self.$($path).+
                }
            }
        )+
    };
}
