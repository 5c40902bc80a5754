//! The variable table a model declares once; XML, documentation and the layer's checks
//! all read it.

use std::fmt;

/// FMI 2.0 scalar types used by the models.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Real,
    Integer,
    Boolean,
    /// An FMI 3.0 clock (section 2.2.8): its [`Variable::clock`] says which; FMI 2.0 has
    /// no clocks and leaves these rows out ([`crate::Facts::CLOCKS`]).
    Clock,
}

/// What kind of clock a [`Kind::Clock`] row is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ClockKind {
    /// An input clock that ticks at `t0 + n × interval` (start time t0, n = 0, 1, …):
    /// time-based, `intervalVariability="constant"`, the importer activates it at each
    /// tick.
    Periodic { interval: f64 },
    /// An output clock the model ticks (`intervalVariability="triggered"`).
    Triggered,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Causality {
    Parameter,
    CalculatedParameter,
    Input,
    Output,
    Local,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variability {
    Constant,
    Fixed,
    Tunable,
    Discrete,
    Continuous,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Initial {
    Exact,
    Approx,
    Calculated,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Start {
    None,
    Real(f64),
    Integer(i32),
    Boolean(bool),
}

/// One scalar variable of the FMU.
#[derive(Clone, Copy, Debug)]
pub struct Variable {
    pub name: &'static str,
    pub vr: u32,
    pub kind: Kind,
    pub causality: Causality,
    pub variability: Variability,
    /// `None` leaves the attribute out (the standard's default for the combination).
    pub initial: Option<Initial>,
    pub start: Start,
    /// Unit name, declared in [`ModelInfo::units`].
    pub unit: Option<&'static str>,
    /// The declared range. An input with a range is clamped into it on set, with a
    /// warning; a parameter's range is the model's to check at initialization.
    pub min: Option<f64>,
    pub max: Option<f64>,
    pub description: &'static str,
    /// How the layer's messages name this variable's values and range.
    pub wording: Wording,
    /// On the first element `name[1]` of a run of scalars `name[1]` … `name[n]`: the
    /// description of the whole, which FMI 3.0 declares as one array variable `name`
    /// (see [`crate::arrays`]); FMI 2.0 keeps the scalars.
    pub array: Option<&'static str>,
    /// On a [`Kind::Clock`] row: which clock.
    pub clock: Option<ClockKind>,
    /// The value reference of the clock this variable is clocked by (FMI 3.0's `clocks`
    /// attribute); FMI 2.0 leaves it out.
    pub clocks: Option<u32>,
}

/// Words the layer puts into the messages about a variable, so that they speak the
/// model's language ("valve openings must be finite") without the layer knowing the model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Wording {
    /// What the values are, as in "<quantity> must be finite"; `None`: "must be finite".
    pub quantity: Option<&'static str>,
    /// What the declared range is called, as in "outside the <range> 0-10 V".
    pub range: &'static str,
}

impl Wording {
    pub const PLAIN: Wording = Wording { quantity: None, range: "declared range" };
}

impl Variable {
    const fn new(
        name: &'static str,
        vr: u32,
        kind: Kind,
        (causality, variability, initial): (Causality, Variability, Option<Initial>),
        start: Start,
        unit: Option<&'static str>,
        description: &'static str,
    ) -> Self {
        Variable {
            name,
            vr,
            kind,
            causality,
            variability,
            initial,
            start,
            unit,
            min: None,
            max: None,
            description,
            wording: Wording::PLAIN,
            array: None,
            clock: None,
            clocks: None,
        }
    }

    const fn fixed_parameter(
        name: &'static str,
        vr: u32,
        kind: Kind,
        start: Start,
        unit: Option<&'static str>,
        description: &'static str,
    ) -> Self {
        let role = (Causality::Parameter, Variability::Fixed, Some(Initial::Exact));
        Variable::new(name, vr, kind, role, start, unit, description)
    }

    /// A Real parameter fixed at initialization.
    pub const fn parameter(
        name: &'static str,
        vr: u32,
        start: f64,
        unit: Option<&'static str>,
        description: &'static str,
    ) -> Self {
        Variable::fixed_parameter(name, vr, Kind::Real, Start::Real(start), unit, description)
    }

    /// An Integer parameter fixed at initialization.
    pub const fn integer_parameter(
        name: &'static str,
        vr: u32,
        start: i32,
        unit: Option<&'static str>,
        description: &'static str,
    ) -> Self {
        Variable::fixed_parameter(name, vr, Kind::Integer, Start::Integer(start), unit, description)
    }

    /// A Boolean parameter fixed at initialization.
    pub const fn boolean_parameter(
        name: &'static str,
        vr: u32,
        start: bool,
        description: &'static str,
    ) -> Self {
        Variable::fixed_parameter(name, vr, Kind::Boolean, Start::Boolean(start), None, description)
    }

    /// A continuous Real input.
    pub const fn input(
        name: &'static str,
        vr: u32,
        start: f64,
        unit: Option<&'static str>,
        description: &'static str,
    ) -> Self {
        let role = (Causality::Input, Variability::Continuous, None);
        Variable::new(name, vr, Kind::Real, role, Start::Real(start), unit, description)
    }

    /// An Integer input: discrete, as FMI 2.0 requires of every Integer.
    pub const fn integer_input(
        name: &'static str,
        vr: u32,
        start: i32,
        unit: Option<&'static str>,
        description: &'static str,
    ) -> Self {
        let role = (Causality::Input, Variability::Discrete, None);
        Variable::new(name, vr, Kind::Integer, role, Start::Integer(start), unit, description)
    }

    /// A Boolean input: discrete, as FMI 2.0 requires of every Boolean.
    pub const fn boolean_input(
        name: &'static str,
        vr: u32,
        start: bool,
        description: &'static str,
    ) -> Self {
        let role = (Causality::Input, Variability::Discrete, None);
        Variable::new(name, vr, Kind::Boolean, role, Start::Boolean(start), None, description)
    }

    /// An output computed by the model (`initial="calculated"`, no start value).
    pub const fn output(
        name: &'static str,
        vr: u32,
        kind: Kind,
        unit: Option<&'static str>,
        description: &'static str,
    ) -> Self {
        let variability = match kind {
            Kind::Real => Variability::Continuous,
            _ => Variability::Discrete,
        };
        let role = (Causality::Output, variability, Some(Initial::Calculated));
        Variable::new(name, vr, kind, role, Start::None, unit, description)
    }

    /// A Real the model computes for Model Exchange (a state derivative, an event
    /// indicator): local, continuous, calculated.
    pub const fn local(
        name: &'static str,
        vr: u32,
        unit: Option<&'static str>,
        description: &'static str,
    ) -> Self {
        let role = (Causality::Local, Variability::Continuous, Some(Initial::Calculated));
        Variable::new(name, vr, Kind::Real, role, Start::None, unit, description)
    }

    /// An input clock ticking every `interval` seconds from the start time.
    pub const fn periodic_clock(
        name: &'static str,
        vr: u32,
        interval: f64,
        description: &'static str,
    ) -> Self {
        let role = (Causality::Input, Variability::Discrete, None);
        let mut v = Variable::new(name, vr, Kind::Clock, role, Start::None, None, description);
        v.clock = Some(ClockKind::Periodic { interval });
        v
    }

    /// An output clock the model ticks.
    pub const fn output_clock(name: &'static str, vr: u32, description: &'static str) -> Self {
        let role = (Causality::Output, Variability::Discrete, None);
        let mut v = Variable::new(name, vr, Kind::Clock, role, Start::None, None, description);
        v.clock = Some(ClockKind::Triggered);
        v
    }

    /// Clocked by the clock with value reference `clock` (FMI 3.0; FMI 2.0 has no clocks,
    /// and the variable is as it was).
    pub const fn clocked_by(mut self, clock: u32) -> Self {
        self.clocks = Some(clock);
        self
    }

    /// Piecewise constant: changes only at communication points.
    pub const fn discrete(mut self) -> Self {
        self.variability = Variability::Discrete;
        self
    }

    pub const fn with_range(mut self, min: f64, max: f64) -> Self {
        self.min = Some(min);
        self.max = Some(max);
        self
    }

    /// Marks the first element `name[1]` of an array (FMI 3.0: one `name` with a
    /// `<Dimension>`), described as a whole by `description`.
    pub const fn array(mut self, description: &'static str) -> Self {
        self.array = Some(description);
        self
    }

    /// The words of [`Wording`] for this variable's messages.
    pub const fn worded(mut self, quantity: &'static str, range: &'static str) -> Self {
        self.wording = Wording { quantity: Some(quantity), range };
        self
    }

    /// What a model gets when a master sets this Real to `value`, decided without
    /// formatting anything: the hot path of every `Set*` call.
    pub fn admit(&self, value: f64) -> Admission {
        if !value.is_finite() {
            return Admission::NonFinite;
        }
        if self.causality != Causality::Input {
            return Admission::Accept(value);
        }
        // Not f64::clamp: it panics on a table whose min exceeds its max.
        let limit = match (self.min, self.max) {
            (Some(min), _) if value < min => min,
            (_, Some(max)) if value > max => max,
            _ => return Admission::Accept(value),
        };
        match (value - limit).abs() <= LIMIT_TOLERANCE * self.range_scale(limit) {
            true => Admission::Limit(limit),
            false => Admission::Clamp(limit),
        }
    }

    /// What [`LIMIT_TOLERANCE`] is relative to: the width of a two-sided range, the
    /// limit itself for a one-sided one.
    fn range_scale(&self, limit: f64) -> f64 {
        match (self.min, self.max) {
            (Some(min), Some(max)) if max > min => max - min,
            _ => limit.abs(),
        }
    }

    /// The declared range as messages name it: "DAC range 0-10 V".
    pub fn range_text(&self) -> impl fmt::Display + '_ {
        RangeText(self)
    }

    /// Why `value` was refused while the model holds `current`, built when logged.
    pub fn refusal(&self, value: f64, current: f64) -> impl fmt::Display + '_ {
        Refusal { v: self, value, current }
    }

    /// The warning for `value` clamped to `clamped`, built when logged.
    pub fn clamping(&self, value: f64, clamped: f64) -> impl fmt::Display + '_ {
        Clamping { v: self, value, clamped }
    }

    /// [`Variable::admit`] with its messages, for callers that want them as strings: a
    /// non-finite value is refused (the model keeps `current`); an input outside its
    /// declared range is clamped into it, with the warning to log.
    pub fn admit_real(&self, value: f64, current: f64) -> Result<(f64, Option<String>), String> {
        match self.admit(value) {
            Admission::Accept(x) | Admission::Limit(x) => Ok((x, None)),
            Admission::Clamp(x) => Ok((x, Some(self.clamping(value, x).to_string()))),
            Admission::NonFinite => Err(self.refusal(value, current).to_string()),
        }
    }

    /// Whether a master may set it in a state (FMI 2.0 CS, section 4.2.4).
    pub(crate) fn settable_before_init(&self) -> bool {
        self.variability != Variability::Constant
            && (matches!(self.initial, Some(Initial::Exact) | Some(Initial::Approx))
                || self.causality == Causality::Input)
    }

    pub(crate) fn settable_after_init(&self) -> bool {
        self.causality == Causality::Input
            || (self.causality == Causality::Parameter && self.variability == Variability::Tunable)
    }
}

/// How far past a limit of its declared range an input may lie and still be that limit,
/// relative to the range's width (to the limit itself for a one-sided range): a master's
/// rounding, not a value out of range. FMPy interpolates inputs linearly between
/// communication points and hands the plant 10.000000000000002 V for a DAC at 10 V, a
/// few ulps past the limit; 1e-12 of a 10 V range is 1e-11 V, some 5 000 ulps at 10 V and
/// far below anything a DAC (150 µV a count) or a model could mean.
pub const LIMIT_TOLERANCE: f64 = 1e-12;

/// What [`Variable::admit`] decided.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Admission {
    /// Stored as given.
    Accept(f64),
    /// An input past a limit by no more than rounding ([`LIMIT_TOLERANCE`]): stored as
    /// the limit, which is what the master meant, without a warning.
    Limit(f64),
    /// An input outside its declared range, stored clamped with a warning.
    Clamp(f64),
    /// Refused: the model keeps its value.
    NonFinite,
}

struct Unit_<'a>(Option<&'a str>);

impl fmt::Display for Unit_<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(u) => write!(f, " {u}"),
            None => Ok(()),
        }
    }
}

struct Refusal<'a> {
    v: &'a Variable,
    value: f64,
    current: f64,
}

impl fmt::Display for Refusal<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (name, value, current, unit) =
            (self.v.name, self.value, self.current, Unit_(self.v.unit));
        write!(f, "{name} = {value} refused: ")?;
        if let Some(q) = self.v.wording.quantity {
            write!(f, "{q} ")?;
        }
        write!(f, "must be finite; keeping {current}{unit}")
    }
}

struct Clamping<'a> {
    v: &'a Variable,
    value: f64,
    clamped: f64,
}

impl fmt::Display for Clamping<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (v, clamped, unit) = (self.v, self.clamped, Unit_(self.v.unit));
        write!(f, "{} = {}{unit} is outside the {}", v.name, self.value, v.range_text())?;
        write!(f, ", clamped to {clamped}{unit}")
    }
}

struct RangeText<'a>(&'a Variable);

impl fmt::Display for RangeText<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (v, unit) = (self.0, Unit_(self.0.unit));
        write!(f, "{} ", v.wording.range)?;
        match (v.min, v.max) {
            (Some(min), Some(max)) => write!(f, "{min}-{max}")?,
            (Some(min), None) => write!(f, "from {min}")?,
            (None, Some(max)) => write!(f, "up to {max}")?,
            (None, None) => write!(f, "(none)")?,
        }
        write!(f, "{unit}")
    }
}

/// A unit as its exponents of the SI base units kg, m, s and A, the only ones the models
/// need (factor 1, offset 0: every unit here is coherent SI).
#[derive(Clone, Copy, Debug)]
pub struct Unit {
    pub name: &'static str,
    pub kg: i8,
    pub m: i8,
    pub s: i8,
    pub a: i8,
}

/// Identity and defaults of an FMU.
#[derive(Clone, Copy, Debug)]
pub struct ModelInfo {
    pub model_name: &'static str,
    pub model_identifier: &'static str,
    pub description: &'static str,
    pub version: &'static str,
    pub default_start_time: f64,
    pub default_stop_time: f64,
    pub default_step_size: f64,
    pub default_tolerance: f64,
    pub units: &'static [Unit],
    /// What this model reports under `logEvents`, for the category's description.
    pub log_events: &'static str,
    /// An HTML fragment for `documentation/index.html`: the model, its modes, its limits.
    pub documentation_html: &'static str,
}

#[cfg(test)]
mod tests {
    use super::*;

    const VALVE: Variable = Variable::input("valve", 1, 0.0, Some("%"), "")
        .with_range(0.0, 10.0)
        .worded("valve openings", "valve range");

    #[test]
    fn inputs_are_clamped_into_their_range_and_non_finite_values_refused() {
        assert_eq!(VALVE.admit_real(4.5, 1.0), Ok((4.5, None)));
        assert_eq!(
            VALVE.admit_real(12.5, 1.0),
            Ok((
                10.0,
                Some("valve = 12.5 % is outside the valve range 0-10 %, clamped to 10 %".into())
            ))
        );
        assert_eq!(VALVE.admit_real(-0.5, 1.0).unwrap().0.to_bits(), 0.0f64.to_bits());
        // -0 is inside [0, 10]: kept as it came, sign and all.
        assert_eq!(VALVE.admit_real(-0.0, 1.0).unwrap(), (-0.0, None));
        assert_eq!(VALVE.admit_real(-0.0, 1.0).unwrap().0.to_bits(), (-0.0f64).to_bits());
        assert_eq!(
            VALVE.admit_real(f64::NAN, 4.0),
            Err("valve = NaN refused: valve openings must be finite; keeping 4 %".into())
        );
        assert_eq!(
            VALVE.admit_real(f64::NEG_INFINITY, 4.0),
            Err("valve = -inf refused: valve openings must be finite; keeping 4 %".into())
        );
    }

    #[test]
    fn plain_wording_one_sided_ranges_and_parameters() {
        let v = Variable::input("u", 2, 0.0, None, "").with_range(1.0, 2.0);
        assert_eq!(
            v.admit_real(3.0, 0.0),
            Ok((2.0, Some("u = 3 is outside the declared range 1-2, clamped to 2".into())))
        );
        let mut up = Variable::input("u", 2, 0.0, Some("m"), "");
        up.max = Some(2.0);
        assert_eq!(
            up.admit_real(3.0, 0.0),
            Ok((
                2.0,
                Some("u = 3 m is outside the declared range up to 2 m, clamped to 2 m".into())
            ))
        );
        let mut from = Variable::input("u", 2, 0.0, None, "");
        from.min = Some(2.0);
        assert_eq!(
            from.admit_real(1.0, 0.0).unwrap().1.unwrap(),
            "u = 1 is outside the declared range from 2, clamped to 2"
        );
        // Within rounding of a limit: the limit, without a warning; past that, clamped.
        assert_eq!(VALVE.admit(10.000000000000002), Admission::Limit(10.0));
        assert_eq!(VALVE.admit(10.0 + 1e-11), Admission::Limit(10.0));
        assert_eq!(VALVE.admit(10.0 + 2e-11), Admission::Clamp(10.0));
        assert_eq!(VALVE.admit(-1e-12), Admission::Limit(0.0));
        assert_eq!(VALVE.admit_real(10.000000000000002, 1.0), Ok((10.0, None)));
        assert_eq!(v.admit(2.0 + 1e-13), Admission::Limit(2.0));
        // One-sided: relative to the limit itself (to nothing at a limit of 0).
        assert_eq!(up.admit(2.0 * (1.0 + 1e-13)), Admission::Limit(2.0));
        assert_eq!(up.admit(2.0 * (1.0 + 1e-11)), Admission::Clamp(2.0));
        let mut at_zero = Variable::input("u", 2, 0.0, None, "");
        at_zero.min = Some(0.0);
        assert_eq!(at_zero.admit(-1e-300), Admission::Clamp(0.0));
        // A table whose min exceeds its max clamps without panicking.
        let crossed = Variable::input("x", 3, 0.0, None, "").with_range(5.0, 1.0);
        assert_eq!(crossed.admit_real(3.0, 0.0).unwrap().0, 5.0);
        // Only inputs are clamped; a parameter's range is the model's to check.
        let p = Variable::parameter("p", 4, 1.0, None, "").with_range(0.0, 1.0);
        assert_eq!(p.admit_real(7.0, 1.0), Ok((7.0, None)));
        assert_eq!(
            p.admit_real(f64::INFINITY, 1.0),
            Err("p = inf refused: must be finite; keeping 1".into())
        );
    }

    #[test]
    fn typed_constructors_declare_what_fmi_requires() {
        let role = |v: Variable| (v.kind, v.causality, v.variability, v.initial, v.start);
        let fixed = (Causality::Parameter, Variability::Fixed, Some(Initial::Exact));
        assert_eq!(
            role(Variable::integer_parameter("n", 1, 7, None, "")),
            (Kind::Integer, fixed.0, fixed.1, fixed.2, Start::Integer(7))
        );
        assert_eq!(
            role(Variable::boolean_parameter("b", 2, true, "")),
            (Kind::Boolean, fixed.0, fixed.1, fixed.2, Start::Boolean(true))
        );
        assert_eq!(
            role(Variable::integer_input("i", 3, -2, None, "")),
            (Kind::Integer, Causality::Input, Variability::Discrete, None, Start::Integer(-2))
        );
        assert_eq!(
            role(Variable::boolean_input("j", 4, false, "")),
            (Kind::Boolean, Causality::Input, Variability::Discrete, None, Start::Boolean(false))
        );
        assert_eq!(
            role(Variable::output("o", 5, Kind::Integer, None, "")),
            (
                Kind::Integer,
                Causality::Output,
                Variability::Discrete,
                Some(Initial::Calculated),
                Start::None
            )
        );
    }
}
