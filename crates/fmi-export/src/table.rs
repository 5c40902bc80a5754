//! The variable table a model declares once; XML, documentation and the layer's checks
//! all read it.

/// FMI 2.0 scalar types used by the models.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Real,
    Integer,
    Boolean,
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
    pub min: Option<f64>,
    pub max: Option<f64>,
    pub description: &'static str,
}

impl Variable {
    /// A parameter fixed at initialization.
    pub const fn parameter(
        name: &'static str,
        vr: u32,
        start: f64,
        unit: Option<&'static str>,
        description: &'static str,
    ) -> Self {
        Variable {
            name,
            vr,
            kind: Kind::Real,
            causality: Causality::Parameter,
            variability: Variability::Fixed,
            initial: Some(Initial::Exact),
            start: Start::Real(start),
            unit,
            min: None,
            max: None,
            description,
        }
    }

    /// A continuous real input.
    pub const fn input(
        name: &'static str,
        vr: u32,
        start: f64,
        unit: Option<&'static str>,
        description: &'static str,
    ) -> Self {
        Variable {
            name,
            vr,
            kind: Kind::Real,
            causality: Causality::Input,
            variability: Variability::Continuous,
            initial: None,
            start: Start::Real(start),
            unit,
            min: None,
            max: None,
            description,
        }
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
        Variable {
            name,
            vr,
            kind,
            causality: Causality::Output,
            variability,
            initial: Some(Initial::Calculated),
            start: Start::None,
            unit,
            min: None,
            max: None,
            description,
        }
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

    pub const fn with_kind_start(mut self, kind: Kind, start: Start) -> Self {
        self.kind = kind;
        self.start = start;
        self
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

/// A unit and its SI base-unit exponents (kg, m, s, A, K, mol, cd, rad) and factor.
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
    /// An HTML fragment for `documentation/index.html`: the model, its modes, its limits.
    pub documentation_html: &'static str,
}
