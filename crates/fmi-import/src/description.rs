//! `modelDescription.xml`, read as a stream of XML events. Only what a Co-Simulation master
//! needs is kept; every other element (`<Annotations>`, `<VendorAnnotations>`,
//! `<UnitDefinitions>`, `<TypeDefinitions>`, `<LogCategories>`, `<ModelStructure>`, and
//! whatever a vendor invents) and every unknown attribute is skipped, as real FMUs carry
//! them. What is kept is checked: a missing required attribute, a number that does not
//! parse, an unknown causality or a duplicate variable name is an error that says where.

use std::collections::HashMap;
use std::fmt;

use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

use crate::ImportError;

/// The FMI 2.0 base type of a scalar variable.
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
}

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
    pub default_experiment: Option<DefaultExperiment>,
    pub variables: Vec<Variable>,
    by_name: HashMap<String, usize>,
}

impl ModelDescription {
    /// Parses the text of `modelDescription.xml`.
    pub fn parse(xml: &str) -> Result<Self, ImportError> {
        Parser::new(xml).run()
    }

    /// The variable called `name`.
    pub fn variable(&self, name: &str) -> Option<&Variable> {
        self.by_name.get(name).map(|&i| &self.variables[i])
    }

    /// Appends a variable read by another parser (FMI 3.0, `crate::fmi3`); false, and
    /// nothing added, if its name is taken.
    pub(crate) fn add_variable(&mut self, v: Variable) -> bool {
        if self.by_name.contains_key(&v.name) {
            return false;
        }
        self.by_name.insert(v.name.clone(), self.variables.len());
        self.variables.push(v);
        true
    }
}

/// 1-based line and column (in characters) of byte offset `pos` in `text`.
pub(crate) fn line_column(text: &str, pos: usize) -> (usize, usize) {
    let mut pos = pos.min(text.len());
    while !text.is_char_boundary(pos) {
        pos -= 1;
    }
    let before = &text[..pos];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    (line, before[line_start..].chars().count() + 1)
}

/// A name usable as one file name in one folder: not empty, no separator, not `.`/`..`.
fn plain_file_name(s: &str) -> bool {
    !s.is_empty() && s != "." && s != ".." && !s.contains(['/', '\\', '\0', ':'])
}

/// `s` cut to its first `n` characters, marked if cut, for echoing untrusted text.
pub(crate) fn cut(s: &str, n: usize) -> String {
    match s.char_indices().nth(n) {
        Some((i, _)) => format!("{}…", &s[..i]),
        None => s.to_string(),
    }
}

struct Parser<'a> {
    text: &'a str,
    reader: Reader<&'a [u8]>,
    /// Names of the open elements.
    stack: Vec<String>,
    md: ModelDescription,
    seen_root: bool,
    /// The `<ScalarVariable>` being read and where it started.
    current: Option<(Pending, usize)>,
}

struct Pending {
    name: String,
    vr: u32,
    causality: Causality,
    variability: Variability,
    initial: Option<Initial>,
    description: Option<String>,
    ty: Option<(VarType, Option<String>, Option<String>)>,
}

type Attrs = Vec<(String, String)>;

fn attr<'s>(attrs: &'s Attrs, key: &str) -> Option<&'s str> {
    attrs.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
}

impl<'a> Parser<'a> {
    fn new(text: &'a str) -> Self {
        let mut reader = Reader::from_str(text);
        let config = reader.config_mut();
        config.check_end_names = true;
        config.expand_empty_elements = false;
        Parser {
            text,
            reader,
            stack: Vec::new(),
            md: ModelDescription::default(),
            seen_root: false,
            current: None,
        }
    }

    fn error(&self, pos: usize, message: impl Into<String>) -> ImportError {
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

    fn required<'s>(
        &self,
        attrs: &'s Attrs,
        tag: &str,
        key: &str,
        pos: usize,
    ) -> Result<&'s str, ImportError> {
        attr(attrs, key)
            .ok_or_else(|| self.error(pos, format!("<{tag}> lacks the required attribute {key}")))
    }

    fn number<T: std::str::FromStr>(
        &self,
        attrs: &Attrs,
        tag: &str,
        key: &str,
        what: &str,
        pos: usize,
    ) -> Result<Option<T>, ImportError> {
        match attr(attrs, key) {
            None => Ok(None),
            Some(v) => v
                .trim()
                .parse::<T>()
                .map(Some)
                .map_err(|_| self.error(pos, format!("<{tag}> {key}=\"{v}\" is not {what}"))),
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
            Some(v) => {
                Err(self.error(pos, format!("<{tag}> {key}=\"{v}\" is not a boolean (true/false)")))
            }
        }
    }

    fn run(mut self) -> Result<ModelDescription, ImportError> {
        loop {
            let pos = self.reader.buffer_position() as usize;
            let event = match self.reader.read_event() {
                Ok(e) => e,
                Err(err) => {
                    let at = self.reader.error_position() as usize;
                    return Err(self.error(at, format!("malformed XML: {err}")));
                }
            };
            match event {
                Event::Start(e) => {
                    self.open(&e, pos)?;
                    self.stack.push(e.name().as_ref().to_owned());
                }
                Event::Empty(e) => {
                    self.open(&e, pos)?;
                    self.close(e.name().as_ref(), pos)?;
                }
                Event::End(e) => {
                    self.stack.pop();
                    self.close(e.name().as_ref(), pos)?;
                }
                Event::Eof => break,
                _ => {}
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
        Ok(self.md)
    }

    fn open(&mut self, e: &BytesStart<'_>, pos: usize) -> Result<(), ImportError> {
        let name = e.name().as_ref().to_owned();
        let depth = self.stack.len();
        if depth == 0 {
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
            let a = self.attrs(e, pos)?;
            let version = self.required(&a, &name, "fmiVersion", pos)?.trim().to_owned();
            if !version.starts_with("2.") {
                return Err(ImportError::UnsupportedVersion(version));
            }
            self.md.fmi_version = version;
            self.md.model_name = self.required(&a, &name, "modelName", pos)?.to_owned();
            self.md.guid = self.required(&a, &name, "guid", pos)?.to_owned();
            self.md.description = attr(&a, "description").map(str::to_owned);
            self.md.generation_tool = attr(&a, "generationTool").map(str::to_owned);
            return Ok(());
        }
        let in_variables = depth == 2 && self.stack[1] == "ModelVariables";
        let in_variable =
            depth == 3 && self.stack[1] == "ModelVariables" && self.stack[2] == "ScalarVariable";
        match (depth, name.as_str()) {
            (1, "CoSimulation") => {
                let a = self.attrs(e, pos)?;
                if self.md.co_simulation.is_some() {
                    return Err(self.error(pos, "a second <CoSimulation>"));
                }
                let model_identifier =
                    self.required(&a, &name, "modelIdentifier", pos)?.trim().to_owned();
                if model_identifier.is_empty() {
                    return Err(self.error(pos, "<CoSimulation> has an empty modelIdentifier"));
                }
                // It names the binary to dlopen: a path in it would load a library from
                // outside the FMU.
                if !plain_file_name(&model_identifier) {
                    return Err(self.error(
                        pos,
                        format!("<CoSimulation> modelIdentifier=\"{}\" is not a plain file name (no `/`, `\\`, `:` or NUL; not `.` or `..`): refused", cut(&model_identifier, 200)),
                    ));
                }
                self.md.co_simulation = Some(CoSimulation {
                    model_identifier,
                    needs_execution_tool: self.boolean(&a, &name, "needsExecutionTool", pos)?,
                    can_handle_variable_communication_step_size: self.boolean(
                        &a,
                        &name,
                        "canHandleVariableCommunicationStepSize",
                        pos,
                    )?,
                    can_be_instantiated_only_once_per_process: self.boolean(
                        &a,
                        &name,
                        "canBeInstantiatedOnlyOncePerProcess",
                        pos,
                    )?,
                    can_get_and_set_fmu_state: self.boolean(
                        &a,
                        &name,
                        "canGetAndSetFMUstate",
                        pos,
                    )?,
                    can_serialize_fmu_state: self.boolean(
                        &a,
                        &name,
                        "canSerializeFMUstate",
                        pos,
                    )?,
                });
            }
            (1, "ModelExchange") => self.md.has_model_exchange = true,
            (1, "DefaultExperiment") => {
                let a = self.attrs(e, pos)?;
                let n = |k| self.number::<f64>(&a, &name, k, "a number", pos);
                self.md.default_experiment = Some(DefaultExperiment {
                    start_time: n("startTime")?,
                    stop_time: n("stopTime")?,
                    tolerance: n("tolerance")?,
                    step_size: n("stepSize")?,
                });
            }
            (2, "ScalarVariable") if in_variables => {
                let a = self.attrs(e, pos)?;
                let var_name = self.required(&a, &name, "name", pos)?.to_owned();
                let tag = format!("ScalarVariable name=\"{var_name}\"");
                let vr = self
                    .number::<u32>(&a, &tag, "valueReference", "an unsigned 32-bit integer", pos)?
                    .ok_or_else(|| {
                        self.error(
                            pos,
                            format!("<{tag}> lacks the required attribute valueReference"),
                        )
                    })?;
                let causality = match attr(&a, "causality") {
                    None => Causality::Local,
                    Some(c) => Causality::parse(c.trim()).ok_or_else(|| {
                        self.error(
                            pos,
                            format!(
                                "<{tag}> causality=\"{c}\" is not one of {}",
                                Causality::ALL.trim_end()
                            ),
                        )
                    })?,
                };
                let variability = match attr(&a, "variability") {
                    None => Variability::Continuous,
                    Some(c) => Variability::parse(c.trim()).ok_or_else(|| {
                        self.error(
                            pos,
                            format!(
                                "<{tag}> variability=\"{c}\" is not one of {}",
                                Variability::ALL.trim_end()
                            ),
                        )
                    })?,
                };
                let initial = match attr(&a, "initial") {
                    None => None,
                    Some(c) => Some(Initial::parse(c.trim()).ok_or_else(|| {
                        self.error(
                            pos,
                            format!(
                                "<{tag}> initial=\"{c}\" is not one of {}",
                                Initial::ALL.trim_end()
                            ),
                        )
                    })?),
                };
                let description = attr(&a, "description").map(str::to_owned);
                self.current = Some((
                    Pending {
                        name: var_name,
                        vr,
                        causality,
                        variability,
                        initial,
                        description,
                        ty: None,
                    },
                    pos,
                ));
            }
            (3, "Real" | "Integer" | "Boolean" | "String" | "Enumeration") if in_variable => {
                let a = self.attrs(e, pos)?;
                let ty = match name.as_str() {
                    "Real" => VarType::Real,
                    "Integer" => VarType::Integer,
                    "Boolean" => VarType::Boolean,
                    "String" => VarType::String,
                    _ => VarType::Enumeration,
                };
                let var_name =
                    self.current.as_ref().map(|(p, _)| p.name.clone()).unwrap_or_default();
                let tag = format!("{name}> of <ScalarVariable name=\"{var_name}\"");
                let start = attr(&a, "start").map(str::to_owned);
                if let Some(s) = &start {
                    let t = s.trim();
                    let ok = match ty {
                        VarType::Real => {
                            t.parse::<f64>().is_ok() || matches!(t, "INF" | "-INF" | "NaN")
                        }
                        VarType::Integer | VarType::Enumeration => t.parse::<i32>().is_ok(),
                        VarType::Boolean => matches!(t, "true" | "false" | "1" | "0"),
                        VarType::String => true,
                    };
                    if !ok {
                        return Err(
                            self.error(pos, format!("<{tag}> start=\"{s}\" is not a valid {ty}"))
                        );
                    }
                }
                let declared = attr(&a, "declaredType").map(str::to_owned);
                if let Some((p, _)) = &mut self.current {
                    if p.ty.is_some() {
                        return Err(self.error(
                            pos,
                            format!("<ScalarVariable name=\"{var_name}\"> has a second type element <{name}>"),
                        ));
                    }
                    p.ty = Some((ty, start, declared));
                }
            }
            // Everything else: annotations, units, type definitions, log categories, model
            // structure, vendor extensions.
            _ => {}
        }
        Ok(())
    }

    fn close(&mut self, name: &str, pos: usize) -> Result<(), ImportError> {
        // `self.stack` no longer holds `name`: a ScalarVariable closes at depth 2.
        if name != "ScalarVariable" || self.stack.len() != 2 || self.stack[1] != "ModelVariables" {
            return Ok(());
        }
        let Some((p, start)) = self.current.take() else {
            return Ok(());
        };
        let _ = pos;
        let (ty, start_value, declared_type) = p.ty.ok_or_else(|| {
            self.error(start, format!("<ScalarVariable name=\"{}\"> has no type element (<Real>, <Integer>, <Boolean>, <String> or <Enumeration>)", p.name))
        })?;
        if self.md.by_name.contains_key(&p.name) {
            return Err(self.error(start, format!("a second variable named `{}`", p.name)));
        }
        self.md.by_name.insert(p.name.clone(), self.md.variables.len());
        self.md.variables.push(Variable {
            name: p.name,
            vr: p.vr,
            ty,
            causality: p.causality,
            variability: p.variability,
            initial: p.initial,
            start: start_value,
            description: p.description,
            declared_type,
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
        let e = err(&MD.replace(r#"fmiVersion="2.0""#, r#"fmiVersion="3.0""#));
        assert!(e.contains("fmiVersion=\"3.0\""), "{e}");
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

    #[test]
    fn line_and_column() {
        assert_eq!(line_column("ab\ncd", 4), (2, 2));
        assert_eq!(line_column("ab", 0), (1, 1));
    }
}
