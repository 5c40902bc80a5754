//! The strict reader both standards share: the walk over the XML events, the error
//! positions, attributes, numbers, enumerations, `start` values and duplicate names.

use std::collections::HashMap;

use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

use super::text::{attr, cut, line_column, Attrs};
use super::{Causality, Initial, ModelDescription, Variability, Variable};
use crate::ImportError;

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
    pub(super) text: &'a str,
    pub(super) reader: Reader<&'a [u8]>,
    /// Names of the open elements.
    pub(super) stack: Vec<String>,
    pub(super) md: ModelDescription,
    pub(super) seen_root: bool,
    /// Every variable's name, those the master cannot address (FMI 3.0 `Float32`, arrays,
    /// …) included: one namespace, so a duplicate is found whichever kinds the two are.
    pub(super) names: std::collections::HashSet<String>,
    /// The standard's names of the FMU-state capability flags of `<CoSimulation>`.
    pub(super) state_flags: (&'static str, &'static str),
    /// The `derivative` attributes read: keyed by the variable's 1-based index (FMI 2.0)
    /// or value reference (FMI 3.0), the state's index or value reference.
    pub(crate) derivative_of: HashMap<u32, u32>,
    /// `<ModelStructure>`'s derivatives (FMI 2.0 `<Derivatives><Unknown index>`, FMI 3.0
    /// `<ContinuousStateDerivative valueReference>`) and where each was read.
    pub(super) structure_derivatives: Vec<(u32, usize)>,
    /// FMI 3.0 `<EventIndicator>` elements; FMI 2.0's root attribute.
    pub(super) event_indicators: usize,
}

impl<'a> Doc<'a> {
    pub(super) fn new(text: &'a str) -> Self {
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

    pub(super) fn attrs(&self, e: &BytesStart<'_>, pos: usize) -> Result<Attrs, ImportError> {
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

    pub(super) fn boolean(
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

    pub(super) fn run(mut self) -> Result<ModelDescription, ImportError> {
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
}
