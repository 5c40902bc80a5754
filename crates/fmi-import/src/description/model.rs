//! What the reader keeps of `modelDescription.xml`: the [`ModelDescription`], its
//! variables and interfaces, and its lookups by name and by FMI 3.0 element handle.

use std::collections::HashMap;
use std::fmt;

use super::{Doc, ENV_DESCRIPTION, MAX_DESCRIPTION_BYTES};
use crate::ImportError;

/// The type of a scalar variable, as the master addresses it: FMI 2.0's types; an FMI 3.0
/// `Float64` is a Real, an `Int32` an Integer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum VarType {
    Real,
    Integer,
    Boolean,
    String,
    Enumeration,
}

impl fmt::Display for VarType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            VarType::Real => "Real",
            VarType::Integer => "Integer",
            VarType::Boolean => "Boolean",
            VarType::String => "String",
            VarType::Enumeration => "Enumeration",
        })
    }
}

macro_rules! fmi_enum {
    ($(#[$m:meta])* $name:ident { $($variant:ident = $text:literal),+ $(,)? } default $default:ident) => {
        $(#[$m])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum $name { $($variant),+ }
        impl $name {
            /// The spelling in `modelDescription.xml`.
            pub fn as_str(self) -> &'static str {
                match self { $($name::$variant => $text),+ }
            }
            pub(crate) fn parse(s: &str) -> Option<Self> {
                match s { $($text => Some($name::$variant),)+ _ => None }
            }
            pub(super) const ALL: &'static str = concat!($("`", $text, "` "),+);
        }
        impl Default for $name {
            fn default() -> Self { $name::$default }
        }
        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result { f.write_str(self.as_str()) }
        }
    };
}

fmi_enum!(
    /// `causality` of a scalar variable (default `local`).
    Causality {
        Parameter = "parameter",
        CalculatedParameter = "calculatedParameter",
        Input = "input",
        Output = "output",
        Local = "local",
        Independent = "independent",
    } default Local
);

fmi_enum!(
    /// `variability` of a scalar variable (default `continuous`).
    Variability {
        Constant = "constant",
        Fixed = "fixed",
        Tunable = "tunable",
        Discrete = "discrete",
        Continuous = "continuous",
    } default Continuous
);

fmi_enum!(
    /// `initial` of a scalar variable.
    Initial {
        Exact = "exact",
        Approx = "approx",
        Calculated = "calculated",
    } default Exact
);

/// One `<ScalarVariable>`.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    pub name: String,
    pub vr: u32,
    pub ty: VarType,
    pub causality: Causality,
    pub variability: Variability,
    pub initial: Option<Initial>,
    /// The type element's `start` attribute as written (checked to parse as the type).
    pub start: Option<String>,
    pub description: Option<String>,
    /// The type element's `declaredType` (a `<SimpleType>` name), if any.
    pub declared_type: Option<String>,
    /// For element `name[k]` of an FMI 3.0 array (one dimension of a fixed size): which.
    /// Its `vr` is then not the FMU's but a handle of the importer's, unique among the
    /// FMU's value references, which [`crate::CsFmu`] turns into the array's value
    /// reference and the element's position in it.
    pub element: Option<ArrayElement>,
    /// FMI 3.0 `clocks`: the value references of the clocks the variable is clocked by
    /// (empty for a variable of continuous time or without clocks).
    pub clocks: Vec<u32>,
}

/// Where an element of an FMI 3.0 array is: the array's value reference, the element's
/// 0-based position in the standard's serialization order, the array's length.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ArrayElement {
    pub array_vr: u32,
    pub index: u32,
    pub len: u32,
}

/// The most elements of FMI 3.0 arrays a description may expand into addressable
/// scalars, over all its arrays: the work and memory of reading an untrusted file stay
/// bounded. Larger arrays are read and checked, but not addressed.
pub const MAX_ARRAY_ELEMENTS: usize = 65_536;

/// `<CoSimulation>`: the identifier of the binary and the capability flags a master uses.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CoSimulation {
    pub model_identifier: String,
    pub needs_execution_tool: bool,
    pub can_handle_variable_communication_step_size: bool,
    pub can_be_instantiated_only_once_per_process: bool,
    pub can_get_and_set_fmu_state: bool,
    pub can_serialize_fmu_state: bool,
    /// FMI 3.0 `hasEventMode`: the FMU can be instantiated with `eventModeUsed` (its steps
    /// then end at clock ticks and events are handled in event mode).
    pub has_event_mode: bool,
}

/// FMI 3.0 `<ScheduledExecution>`: the identifier of the binary and the flags a master
/// uses.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ScheduledExecution {
    pub model_identifier: String,
    pub needs_execution_tool: bool,
    pub can_be_instantiated_only_once_per_process: bool,
    pub can_get_and_set_fmu_state: bool,
    pub can_serialize_fmu_state: bool,
}

fmi_enum!(
    /// FMI 3.0 `intervalVariability` of a `<Clock>`.
    IntervalVariability {
        Constant = "constant",
        Fixed = "fixed",
        Tunable = "tunable",
        Changing = "changing",
        Countdown = "countdown",
        Triggered = "triggered",
    } default Triggered
);

/// One FMI 3.0 `<Clock>` variable.
#[derive(Debug, Clone, PartialEq)]
pub struct Clock {
    pub name: String,
    pub vr: u32,
    /// `input` (the importer ticks it) or `output` (the FMU does); `local` for an FMU's own.
    pub causality: Causality,
    pub interval_variability: IntervalVariability,
    /// `intervalDecimal`: the interval in seconds, for a time-based clock that declares it.
    pub interval_decimal: Option<f64>,
    /// `shiftDecimal`: the first tick's offset from the start time (default 0).
    pub shift_decimal: f64,
    /// `priority`: of input clocks for Scheduled Execution, 0 the highest.
    pub priority: Option<u32>,
}

impl Clock {
    /// Whether the clock ticks by time on its own (periodic: `constant`, `fixed` or
    /// `tunable`), so that a master schedules its ticks from its interval.
    pub fn is_periodic(&self) -> bool {
        matches!(
            self.interval_variability,
            IntervalVariability::Constant
                | IntervalVariability::Fixed
                | IntervalVariability::Tunable
        )
    }
}

/// `<ModelExchange>`: the identifier of the binary, the capability flags a master uses,
/// and the sizes of the problem (from `<ModelStructure>` and, in FMI 2.0, the root's
/// `numberOfEventIndicators`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ModelExchange {
    pub model_identifier: String,
    pub needs_execution_tool: bool,
    pub completed_integrator_step_not_needed: bool,
    pub can_be_instantiated_only_once_per_process: bool,
    pub can_get_and_set_fmu_state: bool,
    pub can_serialize_fmu_state: bool,
    pub provides_directional_derivative: bool,
    pub number_of_event_indicators: usize,
    /// The continuous states in `<ModelStructure>` order: the order of the state vector
    /// of `fmi*GetContinuousStates` and of the derivatives.
    pub states: Vec<ContinuousState>,
}

/// One continuous state: its value reference and that of its derivative.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ContinuousState {
    pub state: u32,
    pub derivative: u32,
}

/// `<DefaultExperiment>`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DefaultExperiment {
    pub start_time: Option<f64>,
    pub stop_time: Option<f64>,
    pub tolerance: Option<f64>,
    pub step_size: Option<f64>,
}

/// The parts of `modelDescription.xml` a Co-Simulation master needs.
#[derive(Debug, Clone, Default)]
pub struct ModelDescription {
    pub fmi_version: String,
    pub model_name: String,
    pub guid: String,
    pub description: Option<String>,
    pub generation_tool: Option<String>,
    /// `None` if the FMU has no `<CoSimulation>` (a Model Exchange-only FMU).
    pub co_simulation: Option<CoSimulation>,
    pub has_model_exchange: bool,
    /// `None` if the FMU has no `<ModelExchange>`.
    pub model_exchange: Option<ModelExchange>,
    /// FMI 3.0: `None` if the FMU has no `<ScheduledExecution>`.
    pub scheduled_execution: Option<ScheduledExecution>,
    /// FMI 3.0 `<Clock>` variables, in document order (FMI 2.0: none).
    pub clocks: Vec<Clock>,
    pub default_experiment: Option<DefaultExperiment>,
    pub variables: Vec<Variable>,
    pub(super) by_name: HashMap<String, usize>,
}

impl ModelDescription {
    /// Parses the text of `modelDescription.xml`, FMI 2.0 or FMI 3.0 by its `fmiVersion`,
    /// within [`MAX_DESCRIPTION_BYTES`] (or [`ENV_DESCRIPTION`]).
    pub fn parse(xml: &str) -> Result<Self, ImportError> {
        let cap = crate::archive::env_cap(ENV_DESCRIPTION, MAX_DESCRIPTION_BYTES)?;
        Self::parse_within(xml, cap)
    }

    /// [`ModelDescription::parse`] with a cap of `max_bytes`.
    pub fn parse_within(xml: &str, max_bytes: u64) -> Result<Self, ImportError> {
        if xml.len() as u64 > max_bytes {
            return Err(ImportError::Limit(format!(
                "modelDescription.xml has {} bytes (limit {max_bytes} bytes; raise it with {ENV_DESCRIPTION})",
                xml.len()
            )));
        }
        let mut md = Doc::new(xml).run()?;
        md.assign_element_handles();
        Ok(md)
    }

    /// Gives each array element a handle for its `vr`: the largest numbers no variable of
    /// the FMU uses, counted down from `u32::MAX`, in document order.
    fn assign_element_handles(&mut self) {
        let used: std::collections::HashSet<u32> =
            self.variables.iter().filter(|v| v.element.is_none()).map(|v| v.vr).collect();
        let mut next = u32::MAX;
        for v in self.variables.iter_mut().filter(|v| v.element.is_some()) {
            while used.contains(&next) {
                next -= 1;
            }
            v.vr = next;
            next -= 1;
        }
    }

    /// Where the element behind handle `vr` is, if `vr` is an element's handle.
    pub fn element(&self, vr: u32) -> Option<ArrayElement> {
        self.variables.iter().find(|v| v.vr == vr).and_then(|v| v.element)
    }

    /// The variable called `name`.
    pub fn variable(&self, name: &str) -> Option<&Variable> {
        self.by_name.get(name).map(|&i| &self.variables[i])
    }

    /// The clock with value reference `vr`.
    pub fn clock(&self, vr: u32) -> Option<&Clock> {
        self.clocks.iter().find(|c| c.vr == vr)
    }

    /// Whether this is an FMI 3.0 description (else FMI 2.0).
    pub fn is_fmi3(&self) -> bool {
        self.fmi_version.starts_with("3.")
    }
}
