//! `modelDescription.xml` of FMI 2.0 or FMI 3.0, read as a stream of XML events into one
//! [`ModelDescription`]. Only what a Co-Simulation master needs is kept; every other
//! element (`<Annotations>`, `<VendorAnnotations>`, `<UnitDefinitions>`,
//! `<TypeDefinitions>`, `<LogCategories>`, `<ModelStructure>`, and whatever a vendor
//! invents) and every unknown attribute is skipped, as real FMUs carry them.
//!
//! The walk over the events, the root element, `<CoSimulation>` (its `modelIdentifier`
//! must be a plain file name: it names the library to load), `<DefaultExperiment>`, the
//! size cap, the end-of-file check (a truncated file is refused), attribute, number and
//! enumeration parsing, `start` values and duplicate names are this module's, for both
//! standards; [`fmi2`] and [`fmi3`] only say how each standard spells a variable.
//! The text helpers the reader uses (positions, attribute lookup, value checks, clipping
//! untrusted text) are in `text`; the size cap is defined with the archive's other caps.
//! Every error carries the line and column it was found at.

mod fmi2;
mod fmi3;
pub(crate) mod text;

use std::collections::HashMap;
use std::fmt;

use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

pub use crate::archive::{ENV_DESCRIPTION, MAX_DESCRIPTION_BYTES};
use crate::ImportError;
use text::{attr, cut, line_column, plain_file_name, Attrs};

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
            const ALL: &'static str = concat!($("`", $text, "` "),+);
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
    pub default_experiment: Option<DefaultExperiment>,
    pub variables: Vec<Variable>,
    by_name: HashMap<String, usize>,
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

    /// Whether this is an FMI 3.0 description (else FMI 2.0).
    pub fn is_fmi3(&self) -> bool {
        self.fmi_version.starts_with("3.")
    }
}

/// One element under `<ModelVariables>`: `depth` 2 is a child of it.
pub(crate) struct Element<'e> {
    pub depth: usize,
    pub name: &'e str,
    pub attrs: &'e Attrs,
    pub pos: usize,
}

/// How a standard spells its variables; the rest of the description is read by [`Doc`]
/// for both (the other spellings are in [`Doc::root`]).
pub(crate) trait Standard {
    /// An element opened (`e.attrs` set) or closed (after its children).
    fn open(&mut self, doc: &mut Doc<'_>, e: &Element<'_>) -> Result<(), ImportError>;
    fn close(&mut self, doc: &mut Doc<'_>, e: &Element<'_>) -> Result<(), ImportError>;
}

/// The strict reader both standards share: the event walk, the error positions and the
/// checks every value gets.
pub(crate) struct Doc<'a> {
    text: &'a str,
    reader: Reader<&'a [u8]>,
    /// Names of the open elements.
    stack: Vec<String>,
    md: ModelDescription,
    seen_root: bool,
    /// Every variable's name, those the master cannot address (FMI 3.0 `Float32`, arrays,
    /// …) included: one namespace, so a duplicate is found whichever kinds the two are.
    names: std::collections::HashSet<String>,
    /// The standard's names of the FMU-state capability flags of `<CoSimulation>`.
    state_flags: (&'static str, &'static str),
    /// The `derivative` attributes read: keyed by the variable's 1-based index (FMI 2.0)
    /// or value reference (FMI 3.0), the state's index or value reference.
    pub(crate) derivative_of: HashMap<u32, u32>,
    /// `<ModelStructure>`'s derivatives (FMI 2.0 `<Derivatives><Unknown index>`, FMI 3.0
    /// `<ContinuousStateDerivative valueReference>`) and where each was read.
    structure_derivatives: Vec<(u32, usize)>,
    /// FMI 3.0 `<EventIndicator>` elements; FMI 2.0's root attribute.
    event_indicators: usize,
}

impl<'a> Doc<'a> {
    fn new(text: &'a str) -> Self {
        let mut reader = Reader::from_str(text);
        let config = reader.config_mut();
        config.check_end_names = true;
        config.expand_empty_elements = false;
        Doc {
            text,
            reader,
            stack: Vec::new(),
            md: ModelDescription::default(),
            seen_root: false,
            names: Default::default(),
            state_flags: ("", ""),
            derivative_of: HashMap::new(),
            structure_derivatives: Vec::new(),
            event_indicators: 0,
        }
    }

    pub(crate) fn error(&self, pos: usize, message: impl Into<String>) -> ImportError {
        let (line, column) = line_column(self.text, pos);
        ImportError::Description { line, column, message: message.into() }
    }

    fn attrs(&self, e: &BytesStart<'_>, pos: usize) -> Result<Attrs, ImportError> {
        let tag = e.name().as_ref().to_owned();
        let mut out = Vec::new();
        for a in e.attributes() {
            let a =
                a.map_err(|err| self.error(pos, format!("<{tag}>: malformed attribute: {err}")))?;
            let key = a.key.as_ref().to_owned();
            let value = a
                .normalized_value(quick_xml::XmlVersion::Implicit1_0)
                .map_err(|err| self.error(pos, format!("<{tag}> attribute {key}: {err}")))?
                .into_owned();
            out.push((key, value));
        }
        Ok(out)
    }

    pub(crate) fn required<'s>(
        &self,
        attrs: &'s Attrs,
        tag: &str,
        key: &str,
        pos: usize,
    ) -> Result<&'s str, ImportError> {
        attr(attrs, key)
            .ok_or_else(|| self.error(pos, format!("<{tag}> lacks the required attribute {key}")))
    }

    pub(crate) fn number<T: std::str::FromStr>(
        &self,
        attrs: &Attrs,
        tag: &str,
        key: &str,
        what: &str,
        pos: usize,
    ) -> Result<Option<T>, ImportError> {
        match attr(attrs, key) {
            None => Ok(None),
            Some(v) => v.trim().parse::<T>().map(Some).map_err(|_| {
                self.error(pos, format!("<{tag}> {key}=\"{}\" is not {what}", cut(v, 100)))
            }),
        }
    }

    fn boolean(
        &self,
        attrs: &Attrs,
        tag: &str,
        key: &str,
        pos: usize,
    ) -> Result<bool, ImportError> {
        match attr(attrs, key).map(str::trim) {
            None | Some("false") | Some("0") => Ok(false),
            Some("true") | Some("1") => Ok(true),
            Some(v) => Err(self.error(
                pos,
                format!("<{tag}> {key}=\"{}\" is not a boolean (true/false)", cut(v, 100)),
            )),
        }
    }

    /// The `valueReference` every variable of either standard has.
    pub(crate) fn value_reference(
        &self,
        a: &Attrs,
        tag: &str,
        pos: usize,
    ) -> Result<u32, ImportError> {
        self.number::<u32>(a, tag, "valueReference", "an unsigned 32-bit integer", pos)?.ok_or_else(
            || self.error(pos, format!("<{tag}> lacks the required attribute valueReference")),
        )
    }

    /// `causality`, `variability` and `initial` of a variable; `renamed` maps a
    /// standard's own causality (FMI 3.0 `structuralParameter`) onto the shared ones.
    pub(crate) fn kinds(
        &self,
        a: &Attrs,
        tag: &str,
        pos: usize,
        renamed: &[(&str, Causality)],
        default_variability: Variability,
    ) -> Result<(Causality, Variability, Option<Initial>), ImportError> {
        let bad = |key: &str, v: &str, all: &str| {
            self.error(
                pos,
                format!("<{tag}> {key}=\"{}\" is not one of {}", cut(v, 100), all.trim_end()),
            )
        };
        let causality = match attr(a, "causality") {
            None => Causality::Local,
            Some(c) => match renamed.iter().find(|(k, _)| *k == c.trim()) {
                Some(&(_, mapped)) => mapped,
                None => {
                    Causality::parse(c.trim()).ok_or_else(|| bad("causality", c, Causality::ALL))?
                }
            },
        };
        let variability = match attr(a, "variability") {
            None => default_variability,
            Some(v) => Variability::parse(v.trim())
                .ok_or_else(|| bad("variability", v, Variability::ALL))?,
        };
        let initial = match attr(a, "initial") {
            None => None,
            Some(i) => {
                Some(Initial::parse(i.trim()).ok_or_else(|| bad("initial", i, Initial::ALL))?)
            }
        };
        Ok((causality, variability, initial))
    }

    /// Checks a `start` value: one item (`many` false) or space-separated items (an FMI 3.0
    /// array), each of which must parse with `item`, named `what` in the error.
    pub(crate) fn check_start(
        &self,
        a: &Attrs,
        (tag, what): (&str, &str),
        many: bool,
        item: fn(&str) -> bool,
        pos: usize,
    ) -> Result<Option<String>, ImportError> {
        let Some(s) = attr(a, "start") else { return Ok(None) };
        let mut items = s.split_ascii_whitespace();
        let count = items.clone().count();
        if count > 0 && (many || count == 1) && items.all(item) {
            return Ok(Some(s.to_owned()));
        }
        Err(self.error(pos, format!("<{tag}> start=\"{}\" is not a valid {what}", cut(s, 100))))
    }

    /// Adds a variable the master can address; a name used before (by any variable) is an
    /// error at `pos`.
    pub(crate) fn add_variable(&mut self, v: Variable, pos: usize) -> Result<(), ImportError> {
        self.claim_name(&v.name, pos)?;
        self.md.by_name.insert(v.name.clone(), self.md.variables.len());
        self.md.variables.push(v);
        Ok(())
    }

    /// How many variables were added so far.
    pub(crate) fn md_variables(&self) -> usize {
        self.md.variables.len()
    }

    /// Takes a name for a variable the master cannot address (it is still checked unique).
    pub(crate) fn claim_name(&mut self, name: &str, pos: usize) -> Result<(), ImportError> {
        if !self.names.insert(name.to_owned()) {
            return Err(self.error(pos, format!("a second variable named `{}`", cut(name, 200))));
        }
        Ok(())
    }

    fn run(mut self) -> Result<ModelDescription, ImportError> {
        let mut standard: Option<Box<dyn Standard>> = None;
        loop {
            let pos = self.reader.buffer_position() as usize;
            let event = match self.reader.read_event() {
                Ok(e) => e,
                Err(err) => {
                    let at = self.reader.error_position() as usize;
                    return Err(self.error(at, format!("malformed XML: {err}")));
                }
            };
            let (e, empty) = match event {
                Event::Start(e) => (e, false),
                Event::Empty(e) => (e, true),
                Event::End(e) => {
                    self.stack.pop();
                    let name = e.name().as_ref().to_owned();
                    self.close(standard.as_deref_mut(), &name, pos)?;
                    continue;
                }
                Event::Eof => break,
                _ => continue,
            };
            let name = e.name().as_ref().to_owned();
            let a = self.attrs(&e, pos)?;
            if self.stack.is_empty() {
                standard = Some(self.root(&name, &a, pos)?);
            } else {
                self.open(standard.as_deref_mut(), &name, &a, pos)?;
            }
            if empty {
                self.close(standard.as_deref_mut(), &name, pos)?;
            } else {
                self.stack.push(name);
            }
        }
        if !self.seen_root {
            return Err(self.error(0, "no <fmiModelDescription> element"));
        }
        if !self.stack.is_empty() {
            return Err(self.error(
                self.text.len(),
                format!(
                    "the file ends inside <{}>: expected </{}> (a truncated file?)",
                    self.stack.join("> <"),
                    self.stack.last().map_or("", String::as_str)
                ),
            ));
        }
        self.resolve_states()?;
        Ok(self.md)
    }

    /// The continuous states of `<ModelExchange>`, from `<ModelStructure>`'s derivatives
    /// and each derivative's `derivative` attribute.
    fn resolve_states(&mut self) -> Result<(), ImportError> {
        let Some(me) = self.md.model_exchange.as_mut() else { return Ok(()) };
        me.number_of_event_indicators = self.event_indicators;
        let fmi3 = self.md.fmi_version.starts_with("3.");
        let variables = &self.md.variables;
        // FMI 2.0 refers to variables by 1-based index, FMI 3.0 by value reference.
        let vr_of = |key: u32| -> Option<u32> {
            if fmi3 {
                Some(key)
            } else {
                variables.get((key as usize).checked_sub(1)?).map(|v| v.vr)
            }
        };
        let (what, key) = if fmi3 {
            ("<ContinuousStateDerivative valueReference", "value reference")
        } else {
            ("<Derivatives><Unknown index", "index")
        };
        let mut states = Vec::with_capacity(self.structure_derivatives.len());
        for &(d, pos) in &self.structure_derivatives {
            let bad = |why: String| {
                let (line, column) = line_column(self.text, pos);
                ImportError::Description {
                    line,
                    column,
                    message: format!("{what}=\"{d}\">: {why}"),
                }
            };
            let derivative = vr_of(d).ok_or_else(|| bad(format!("no variable has {key} {d}")))?;
            let of = self
                .derivative_of
                .get(&d)
                .copied()
                .ok_or_else(|| bad("the variable has no `derivative` attribute".into()))?;
            let state =
                vr_of(of).ok_or_else(|| bad(format!("its state ({key} {of}) is no variable")))?;
            states.push(ContinuousState { state, derivative });
        }
        me.states = states;
        Ok(())
    }

    /// `<fmiModelDescription>`: picks the standard by `fmiVersion`.
    fn root(
        &mut self,
        name: &str,
        a: &Attrs,
        pos: usize,
    ) -> Result<Box<dyn Standard>, ImportError> {
        if self.seen_root {
            return Err(self.error(pos, format!("a second root element <{name}>")));
        }
        if name != "fmiModelDescription" {
            return Err(self.error(
                pos,
                format!("the root element is <{name}>, expected <fmiModelDescription>"),
            ));
        }
        self.seen_root = true;
        let version = self.required(a, name, "fmiVersion", pos)?.trim().to_owned();
        // What the two standards spell differently outside the variables: the token
        // attribute and the state capability flags.
        let (standard, token, flags): (Box<dyn Standard>, _, _) = if version.starts_with("2.") {
            (
                Box::new(fmi2::Fmi2::default()),
                "guid",
                ("canGetAndSetFMUstate", "canSerializeFMUstate"),
            )
        } else if version.starts_with("3.") {
            (
                Box::new(fmi3::Fmi3::default()),
                "instantiationToken",
                ("canGetAndSetFMUState", "canSerializeFMUState"),
            )
        } else {
            return Err(ImportError::UnsupportedVersion(cut(&version, 40)));
        };
        self.state_flags = flags;
        if version.starts_with("2.") {
            self.event_indicators = self
                .number::<usize>(a, name, "numberOfEventIndicators", "a count", pos)?
                .unwrap_or(0);
        }
        self.md.fmi_version = version;
        self.md.model_name = self.required(a, name, "modelName", pos)?.to_owned();
        self.md.guid = self.required(a, name, token, pos)?.to_owned();
        self.md.description = attr(a, "description").map(str::to_owned);
        self.md.generation_tool = attr(a, "generationTool").map(str::to_owned);
        Ok(standard)
    }

    fn open(
        &mut self,
        standard: Option<&mut (dyn Standard + 'static)>,
        name: &str,
        a: &Attrs,
        pos: usize,
    ) -> Result<(), ImportError> {
        let depth = self.stack.len();
        match (depth, name) {
            (1, "CoSimulation") => self.co_simulation(a, pos),
            (1, "ModelExchange") => self.model_exchange(a, pos),
            (3, "Unknown")
                if self.stack[1] == "ModelStructure" && self.stack[2] == "Derivatives" =>
            {
                let index = self.number::<u32>(a, "Unknown", "index", "an index", pos)?;
                let index = index.ok_or_else(|| {
                    self.error(pos, "<Derivatives><Unknown> lacks the required attribute index")
                })?;
                self.structure_derivatives.push((index, pos));
                Ok(())
            }
            (2, "ContinuousStateDerivative") if self.stack[1] == "ModelStructure" => {
                let vr = self.value_reference(a, name, pos)?;
                self.structure_derivatives.push((vr, pos));
                Ok(())
            }
            (2, "EventIndicator") if self.stack[1] == "ModelStructure" => {
                self.event_indicators += 1;
                Ok(())
            }
            (1, "DefaultExperiment") => {
                let n = |k| self.number::<f64>(a, name, k, "a number", pos);
                self.md.default_experiment = Some(DefaultExperiment {
                    start_time: n("startTime")?,
                    stop_time: n("stopTime")?,
                    tolerance: n("tolerance")?,
                    step_size: n("stepSize")?,
                });
                Ok(())
            }
            (2.., _) if self.stack[1] == "ModelVariables" => match standard {
                Some(s) => s.open(self, &Element { depth, name, attrs: a, pos }),
                None => Ok(()),
            },
            // Everything else: annotations, units, type definitions, log categories, model
            // structure, vendor extensions.
            _ => Ok(()),
        }
    }

    fn close(
        &mut self,
        standard: Option<&mut (dyn Standard + 'static)>,
        name: &str,
        pos: usize,
    ) -> Result<(), ImportError> {
        // `self.stack` no longer holds `name`: a child of <ModelVariables> closes at depth 2.
        let depth = self.stack.len();
        match standard {
            Some(s) if depth >= 2 && self.stack[1] == "ModelVariables" => {
                s.close(self, &Element { depth, name, attrs: &Vec::new(), pos })
            }
            _ => Ok(()),
        }
    }

    /// The `modelIdentifier` of `<CoSimulation>` or `<ModelExchange>` (`tag`).
    fn model_identifier(&self, a: &Attrs, tag: &str, pos: usize) -> Result<String, ImportError> {
        let model_identifier = self.required(a, tag, "modelIdentifier", pos)?.trim().to_owned();
        if model_identifier.is_empty() {
            return Err(self.error(pos, format!("<{tag}> has an empty modelIdentifier")));
        }
        // It names the binary to dlopen: a path in it would load a library from outside
        // the FMU.
        if !plain_file_name(&model_identifier) {
            return Err(self.error(
                pos,
                format!("<{tag}> modelIdentifier=\"{}\" is not a plain file name (no `/`, `\\`, `:` or NUL; not `.` or `..`): refused", cut(&model_identifier, 200)),
            ));
        }
        Ok(model_identifier)
    }

    fn model_exchange(&mut self, a: &Attrs, pos: usize) -> Result<(), ImportError> {
        const TAG: &str = "ModelExchange";
        if self.md.model_exchange.is_some() {
            return Err(self.error(pos, "a second <ModelExchange>"));
        }
        let model_identifier = self.model_identifier(a, TAG, pos)?;
        let (get_set, serialize) = self.state_flags;
        let flag = |k| self.boolean(a, TAG, k, pos);
        // FMI 2.0 spells it in the singular, FMI 3.0 in the plural.
        let directional =
            flag("providesDirectionalDerivative")? || flag("providesDirectionalDerivatives")?;
        let me = ModelExchange {
            model_identifier,
            needs_execution_tool: flag("needsExecutionTool")?,
            completed_integrator_step_not_needed: flag("completedIntegratorStepNotNeeded")?,
            can_be_instantiated_only_once_per_process: flag("canBeInstantiatedOnlyOncePerProcess")?,
            can_get_and_set_fmu_state: flag(get_set)?,
            can_serialize_fmu_state: flag(serialize)?,
            provides_directional_derivative: directional,
            number_of_event_indicators: 0,
            states: Vec::new(),
        };
        self.md.has_model_exchange = true;
        self.md.model_exchange = Some(me);
        Ok(())
    }

    fn co_simulation(&mut self, a: &Attrs, pos: usize) -> Result<(), ImportError> {
        const TAG: &str = "CoSimulation";
        if self.md.co_simulation.is_some() {
            return Err(self.error(pos, "a second <CoSimulation>"));
        }
        let model_identifier = self.model_identifier(a, TAG, pos)?;
        let (get_set, serialize) = self.state_flags;
        let flag = |k| self.boolean(a, TAG, k, pos);
        self.md.co_simulation = Some(CoSimulation {
            model_identifier,
            needs_execution_tool: flag("needsExecutionTool")?,
            can_handle_variable_communication_step_size: flag(
                "canHandleVariableCommunicationStepSize",
            )?,
            can_be_instantiated_only_once_per_process: flag("canBeInstantiatedOnlyOncePerProcess")?,
            can_get_and_set_fmu_state: flag(get_set)?,
            can_serialize_fmu_state: flag(serialize)?,
        });
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MD: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="M" guid="{g}" fooBar="1">
  <CoSimulation modelIdentifier="m" canHandleMultipleSetPerTimeInstant="true" canGetAndSetFMUstate="true">
    <SourceFiles><File name="a.c"/></SourceFiles>
    <Annotations/>
  </CoSimulation>
  <VendorAnnotations><Tool name="X"><Anything deep="1"><ScalarVariable name="not_a_var"/></Anything></Tool></VendorAnnotations>
  <TypeDefinitions><SimpleType name="T"><Real unit="m"/></SimpleType></TypeDefinitions>
  <DefaultExperiment startTime="0" stopTime="2" stepSize="1e-3"/>
  <ModelVariables>
    <ScalarVariable name="x" valueReference="1" causality="output" fooBar="2">
      <Real declaredType="T" start="1.5" unknown="3"/>
      <Annotations><Tool name="Vendor"><x a="1"/></Tool></Annotations>
    </ScalarVariable>
    <ScalarVariable name="n" valueReference="2" causality="parameter" variability="fixed" initial="exact"><Integer start="-3"/></ScalarVariable>
    <ScalarVariable name="b" valueReference="3"><Boolean start="true"/></ScalarVariable>
    <ScalarVariable name="s" valueReference="4"><String start="a &amp; b"/></ScalarVariable>
    <ScalarVariable name="e" valueReference="5"><Enumeration declaredType="E" start="2"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="1"/></Outputs></ModelStructure>
</fmiModelDescription>"#;

    #[test]
    fn tolerates_annotations_and_unknown_attributes() {
        let md = ModelDescription::parse(MD).unwrap();
        assert_eq!(md.model_name, "M");
        assert_eq!(md.guid, "{g}");
        let cs = md.co_simulation.as_ref().unwrap();
        assert_eq!(cs.model_identifier, "m");
        assert!(cs.can_get_and_set_fmu_state && !cs.can_serialize_fmu_state);
        assert_eq!(md.default_experiment.unwrap().step_size, Some(1e-3));
        assert_eq!(md.variables.len(), 5);
        let x = md.variable("x").unwrap();
        assert_eq!(
            (x.vr, x.ty, x.causality, x.variability),
            (1, VarType::Real, Causality::Output, Variability::Continuous)
        );
        assert_eq!(x.start.as_deref(), Some("1.5"));
        assert_eq!(md.variable("n").unwrap().initial, Some(Initial::Exact));
        assert_eq!(md.variable("s").unwrap().start.as_deref(), Some("a & b"));
        assert_eq!(md.variable("e").unwrap().ty, VarType::Enumeration);
        assert!(md.variable("not_a_var").is_none());
    }

    fn err(xml: &str) -> String {
        ModelDescription::parse(xml).unwrap_err().to_string()
    }

    #[test]
    fn errors_say_what_and_where() {
        let e = err(&MD.replace(r#"valueReference="2""#, r#"valueReference="two""#));
        assert!(
            e.contains("line 15,")
                && e.contains("name=\"n\"> valueReference=\"two\" is not an unsigned"),
            "{e}"
        );
        let e = err(&MD.replace(r#"name="b""#, r#"name="x""#));
        assert!(e.contains("line 16,") && e.contains("second variable named `x`"), "{e}");
        let e = err(&MD.replace(r#"start="-3""#, r#"start="1.5""#));
        assert!(e.contains("start=\"1.5\" is not a valid Integer"), "{e}");
        let e = err(&MD.replace(r#" guid="{g}""#, ""));
        assert!(e.contains("line 2,") && e.contains("lacks the required attribute guid"), "{e}");
        let e = err(&MD.replace(r#"causality="output""#, r#"causality="outptu""#));
        assert!(e.contains("causality=\"outptu\""), "{e}");
        let e = err(&MD.replace(r#"fmiVersion="2.0""#, r#"fmiVersion="4.0""#));
        assert!(e.contains("fmiVersion=\"4.0\""), "{e}");
        let e = err(&MD.replace("</ModelVariables>", "</ModelVariable>"));
        assert!(e.contains("malformed XML"), "{e}");
        let e = err(&MD.replace("<Boolean start=\"true\"/>", ""));
        assert!(e.contains("name=\"b\"> has no type element"), "{e}");
        let e = err(&MD.replace("stepSize=\"1e-3\"", "stepSize=\"fast\""));
        assert!(e.contains("stepSize=\"fast\" is not a number"), "{e}");
    }

    #[test]
    fn a_truncated_file_is_refused_with_what_was_expected() {
        let cut_at = MD.find("</ModelVariables>").unwrap();
        let e = err(&MD[..cut_at]);
        assert!(
            e.contains("the file ends inside <fmiModelDescription> <ModelVariables>: expected </ModelVariables> (a truncated file?)"),
            "{e}"
        );
        let e = err(MD.trim_end().strip_suffix("</fmiModelDescription>").unwrap());
        assert!(e.contains("expected </fmiModelDescription>"), "{e}");
        // Cut inside a tag.
        let e = err(&MD[..MD.find("<ModelStructure>").unwrap() + 4]);
        assert!(e.contains("malformed XML") || e.contains("the file ends inside"), "{e}");
    }

    #[test]
    fn a_model_identifier_with_a_path_is_refused() {
        for evil in ["../../../../tmp/x/evil", "/tmp/evil", "a\\b", "..", "sub/m"] {
            let e =
                err(&MD.replace(r#"modelIdentifier="m""#, &format!(r#"modelIdentifier="{evil}""#)));
            assert!(e.contains("is not a plain file name"), "{evil}: {e}");
        }
    }
}

#[cfg(test)]
mod fmi3_tests {
    use super::*;

    const XML: &str = r#"<?xml version="1.0"?>
<fmiModelDescription fmiVersion="3.0" modelName="M" instantiationToken="{t}">
  <CoSimulation modelIdentifier="m" canGetAndSetFMUState="true"/>
  <DefaultExperiment stepSize="0.01"/>
  <ModelVariables>
    <Float64 name="time" valueReference="0" causality="independent" variability="continuous"/>
    <Float64 name="x" valueReference="1" causality="output" initial="calculated"/>
    <Int32 name="n" valueReference="2" causality="parameter" variability="fixed" start="3"/>
    <Boolean name="b" valueReference="3" causality="input" start="false"/>
    <Float64 name="a" valueReference="4" causality="parameter" variability="tunable" start="1 2">
      <Dimension start="2"/>
    </Float64>
    <UInt8 name="u" valueReference="5" causality="input" start="0"/>
    <Float64 name="y" valueReference="6" causality="input" start="0"><Annotations/></Float64>
  </ModelVariables>
  <ModelStructure><Output valueReference="1"/></ModelStructure>
</fmiModelDescription>"#;

    fn err(xml: &str) -> String {
        ModelDescription::parse(xml).unwrap_err().to_string()
    }

    #[test]
    fn fmi3_description_reads_scalars_and_leaves_out_what_csfmu_cannot_address() {
        let md = ModelDescription::parse(XML).unwrap();
        assert!(md.is_fmi3());
        assert_eq!((md.fmi_version.as_str(), md.guid.as_str()), ("3.0", "{t}"));
        let cs = md.co_simulation.as_ref().unwrap();
        assert!(cs.can_get_and_set_fmu_state && !cs.can_serialize_fmu_state);
        assert_eq!(md.default_experiment.unwrap().step_size, Some(0.01));
        let vars: Vec<_> =
            md.variables.iter().map(|v| (v.name.as_str(), v.ty, v.variability)).collect();
        assert_eq!(
            vars,
            [
                ("x", VarType::Real, Variability::Continuous),
                ("n", VarType::Integer, Variability::Fixed),
                ("b", VarType::Boolean, Variability::Discrete),
                ("a[1]", VarType::Real, Variability::Tunable),
                ("a[2]", VarType::Real, Variability::Tunable),
                ("y", VarType::Real, Variability::Continuous),
            ]
        );
        // The array's elements: handles from the top of the value references, each with
        // its place in the array and its own start item.
        let (a1, a2) = (md.variable("a[1]").unwrap(), md.variable("a[2]").unwrap());
        assert_eq!((a1.vr, a2.vr), (u32::MAX, u32::MAX - 1));
        assert_eq!(md.element(a2.vr), Some(ArrayElement { array_vr: 4, index: 1, len: 2 }));
        assert_eq!((a1.start.as_deref(), a2.start.as_deref()), (Some("1"), Some("2")));
        assert!(md.variable("a").is_none() && md.element(4).is_none());
        assert_eq!(md.variable("n").unwrap().start.as_deref(), Some("3"));
    }

    #[test]
    fn fmi3_descriptions_get_every_check_of_fmi2_ones() {
        let e = err(&XML.replace(r#"name="y""#, r#"name="x""#));
        assert!(e.contains("line 14,") && e.contains("a second variable named `x`"), "{e}");
        // A duplicate of a variable the master cannot address is still one.
        let e = err(&XML.replace(r#"name="u""#, r#"name="a""#));
        assert!(e.contains("a second variable named `a`"), "{e}");
        let e = err(&XML.replace(r#"name="u""#, r#"name="time""#));
        assert!(e.contains("a second variable named `time`"), "{e}");
        let e = err(&XML.replace(r#"valueReference="2""#, r#"valueReference="-2""#));
        assert!(e.contains(r#"<Int32 name="n"> valueReference="-2" is not an unsigned"#), "{e}");
        let e = err(&XML.replace(r#"valueReference="5""#, ""));
        assert!(
            e.contains(r#"<UInt8 name="u"> lacks the required attribute valueReference"#),
            "{e}"
        );
        let e = err(&XML.replace(r#"start="3""#, r#"start="three""#));
        assert!(e.contains(r#"start="three" is not a valid Int32"#), "{e}");
        let e = err(&XML.replace(r#"start="0"/>"#, r#"start="300"/>"#));
        assert!(e.contains(r#"<UInt8 name="u"> start="300" is not a valid UInt8"#), "{e}");
        let e = err(&XML.replace(r#"start="1 2""#, r#"start="1 x""#));
        assert!(e.contains(r#"start="1 x" is not a valid Float64"#), "{e}");
        let e =
            err(&XML
                .replace(r#"causality="input" start="0"/>"#, r#"causality="inptu" start="0"/>"#));
        assert!(e.contains(r#"causality="inptu" is not one of"#), "{e}");
        let e = err(&XML.replace(r#" instantiationToken="{t}""#, ""));
        assert!(
            e.contains("line 2,") && e.contains("lacks the required attribute instantiationToken"),
            "{e}"
        );
        let e = err(&XML.replace(r#"stepSize="0.01""#, r#"stepSize="fast""#));
        assert!(e.contains(r#"stepSize="fast" is not a number"#), "{e}");
        let e =
            err(&XML.replace(r#"canGetAndSetFMUState="true""#, r#"canGetAndSetFMUState="yes""#));
        assert!(e.contains(r#"canGetAndSetFMUState="yes" is not a boolean"#), "{e}");
    }

    #[test]
    fn a_truncated_fmi3_file_is_refused() {
        let e = err(&XML[..XML.find("</ModelVariables>").unwrap()]);
        assert!(e.contains("the file ends inside <fmiModelDescription> <ModelVariables>: expected </ModelVariables> (a truncated file?)"), "{e}");
        let e = err(XML.strip_suffix("</fmiModelDescription>").unwrap());
        assert!(e.contains("expected </fmiModelDescription>"), "{e}");
    }

    #[test]
    fn an_fmi3_model_identifier_with_a_path_is_refused() {
        for evil in ["../../../../tmp/x/evil", "/tmp/evil", "a\\b", "..", "sub/m", "C:evil"] {
            let e = err(
                &XML.replace(r#"modelIdentifier="m""#, &format!(r#"modelIdentifier="{evil}""#))
            );
            assert!(e.contains("is not a plain file name"), "{evil}: {e}");
        }
    }

    #[test]
    fn an_oversize_description_is_refused_before_it_is_read() {
        let e = ModelDescription::parse_within(XML, 100).unwrap_err().to_string();
        assert!(
            e.contains(&format!("modelDescription.xml has {} bytes (limit 100 bytes", XML.len())),
            "{e}"
        );
        assert!(ModelDescription::parse_within(XML, XML.len() as u64).is_ok());
    }
}
