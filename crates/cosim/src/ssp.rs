//! Reading an SSP 1.0 file: the system structure (components, connectors, connections)
//! and parameter sets, enough to run a flat system of FMI 2.0 and FMI 3.0 Co-Simulation FMUs.
//! Elements and attributes this master does not use (geometry, annotations of other
//! tools, units) are skipped, not refused.

use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};

use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

use crate::Error;

#[derive(Clone, Debug, PartialEq)]
pub struct Component {
    pub name: String,
    /// Path of the FMU inside the SSP archive, e.g. `resources/Plant.fmu`.
    pub source: String,
}

/// One end of a connection: an element's connector, or the system's (`element` None).
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct End {
    pub element: Option<String>,
    pub connector: String,
}

#[derive(Clone, Debug, Default)]
pub struct System {
    pub name: String,
    pub components: Vec<Component>,
    /// System connectors: (name, kind).
    pub connectors: Vec<(String, String)>,
    pub connections: Vec<(End, End)>,
    pub stop_time: Option<f64>,
    pub step_size: Option<f64>,
    /// The type each connector declares (`Real`, `Integer`, `Boolean`, `String`,
    /// `Enumeration`, `Binary`: its `ssc:` child), by its end: the system's connectors
    /// (`element` None) and the components'. A connector without one is absent.
    pub connector_types: BTreeMap<End, String>,
}

fn attr(e: &BytesStart, name: &str) -> Result<Option<String>, Error> {
    for a in e.attributes() {
        let a = a.map_err(|err| Error::Ssp(format!("malformed attribute: {err}")))?;
        if a.key.local_name().into_inner() == name {
            return a
                .normalized_value(quick_xml::XmlVersion::Implicit1_0)
                .map(|v| Some(v.into_owned()))
                .map_err(|err| Error::Ssp(format!("attribute {name}: {err}")));
        }
    }
    Ok(None)
}

fn required(e: &BytesStart, name: &str) -> Result<String, Error> {
    attr(e, name)?.ok_or_else(|| {
        Error::Ssp(format!("<{}> lacks the attribute {name}", e.local_name().into_inner()))
    })
}

/// Parses `SystemStructure.ssd`. Nested systems are refused with a message: this master
/// runs flat systems.
pub fn parse_ssd(xml: &str) -> Result<System, Error> {
    let xml = xml.strip_prefix('\u{feff}').unwrap_or(xml);
    let mut reader = Reader::from_str(xml);
    let mut sys = System::default();
    // Element path of local names, to know whose <Connector> this is.
    let mut path: Vec<String> = Vec::new();
    let mut open = Open::default();
    let mut systems = 0;
    // The component being read, and the connector whose type a child may give.
    let mut component: Option<String> = None;
    let mut connector: Option<End> = None;
    loop {
        let ev = reader.read_event().map_err(|e| {
            let at = line_of(xml, reader.error_position());
            Error::Ssp(format!("SystemStructure.ssd line {at}: malformed XML: {e}"))
        })?;
        open.track(&ev);
        let (e, empty) = match &ev {
            Event::Start(e) => (e.clone(), false),
            Event::Empty(e) => (e.clone(), true),
            Event::End(_) => {
                match path.pop().as_deref() {
                    Some("Component") => component = None,
                    Some("Connector") => connector = None,
                    _ => {}
                }
                continue;
            }
            Event::Eof => {
                open.complete("SystemStructure.ssd ", xml)?;
                break;
            }
            _ => continue,
        };
        let name = e.local_name().into_inner().to_owned();
        let parent = path.last().map(String::as_str);
        let grandparent = path.len().checked_sub(2).and_then(|i| path.get(i)).map(String::as_str);
        match name.as_str() {
            "System" => {
                systems += 1;
                if systems > 1 {
                    return Err(Error::Ssp("SystemStructure.ssd: nested systems are not supported by this master; flatten the system".into()));
                }
                sys.name = required(&e, "name")?;
            }
            "Component" => {
                let kind =
                    attr(&e, "type")?.unwrap_or_else(|| "application/x-fmu-sharedlibrary".into());
                if kind != "application/x-fmu-sharedlibrary" {
                    return Err(Error::Ssp(format!(
                        "component type {kind} is not supported (FMUs only)"
                    )));
                }
                let name = required(&e, "name")?;
                sys.components
                    .push(Component { name: name.clone(), source: required(&e, "source")? });
                component = Some(name);
            }
            "Connector" if parent == Some("Connectors") && grandparent == Some("System") => {
                let name = required(&e, "name")?;
                sys.connectors.push((name.clone(), attr(&e, "kind")?.unwrap_or_default()));
                connector = Some(End { element: None, connector: name });
            }
            "Connector" if parent == Some("Connectors") && grandparent == Some("Component") => {
                connector =
                    Some(End { element: component.clone(), connector: required(&e, "name")? });
            }
            kind @ ("Real" | "Integer" | "Boolean" | "String" | "Enumeration" | "Binary")
                if parent == Some("Connector") =>
            {
                if let Some(end) = &connector {
                    sys.connector_types.insert(end.clone(), kind.to_string());
                }
            }
            "Connection" => {
                let end = |el: &str, c: &str| -> Result<End, Error> {
                    Ok(End { element: attr(&e, el)?, connector: required(&e, c)? })
                };
                sys.connections.push((
                    end("startElement", "startConnector")?,
                    end("endElement", "endConnector")?,
                ));
            }
            "DefaultExperiment" => {
                let num = |n: &str| -> Result<Option<f64>, Error> {
                    attr(&e, n)?
                        .map(|v| {
                            v.trim().parse::<f64>().map_err(|_| {
                                Error::Ssp(format!("DefaultExperiment {n}=\"{v}\" is not a number"))
                            })
                        })
                        .transpose()
                };
                sys.stop_time = num("stopTime")?;
            }
            // The project's own annotation carries the communication step.
            "CommunicationStep" => {
                if let Some(v) = attr(&e, "stepSize")? {
                    sys.step_size =
                        Some(v.trim().parse().map_err(|_| {
                            Error::Ssp(format!("stepSize \"{v}\" is not a number"))
                        })?);
                }
            }
            _ => {}
        }
        if !empty {
            path.push(name);
        }
    }
    if systems == 0 {
        return Err(Error::Ssp("SystemStructure.ssd has no <System>".into()));
    }
    Ok(sys)
}

/// Parses an `.ssv` parameter set into `component.variable` → value text.
pub fn parse_ssv(xml: &str) -> Result<BTreeMap<String, String>, Error> {
    Ok(parse_ssv_typed(xml)?.into_iter().map(|(n, (_, v))| (n, v)).collect())
}

/// A parameter value of an `.ssv`: its SSP type (the element: `Real`, `Integer`,
/// `Boolean`, `String`, `Enumeration`) and its value text.
pub type TypedValue = (String, String);

/// [`parse_ssv`] with each value's SSP type, which the master checks against the
/// variable's declared type.
pub fn parse_ssv_typed(xml: &str) -> Result<BTreeMap<String, TypedValue>, Error> {
    let xml = xml.strip_prefix('\u{feff}').unwrap_or(xml);
    let mut reader = Reader::from_str(xml);
    let mut out = BTreeMap::new();
    let mut current: Option<String> = None;
    let mut open = Open::default();
    loop {
        let ev = reader.read_event().map_err(|e| {
            Error::Ssp(format!(
                "line {}: malformed XML: {e}",
                line_of(xml, reader.error_position())
            ))
        })?;
        open.track(&ev);
        match ev {
            Event::Start(e) | Event::Empty(e) => match e.local_name().into_inner() {
                "Parameter" => current = Some(required(&e, "name")?),
                kind @ ("Real" | "Integer" | "Boolean" | "String" | "Enumeration") => {
                    if let Some(name) = current.take() {
                        out.insert(name, (kind.to_string(), required(&e, "value")?));
                    }
                }
                _ => {}
            },
            Event::Eof => {
                open.complete("", xml)?;
                break;
            }
            _ => {}
        }
    }
    Ok(out)
}

/// 1-based line of byte offset `pos` in `xml`.
fn line_of(xml: &str, pos: u64) -> usize {
    let end = (pos as usize).min(xml.len());
    xml.as_bytes()[..end].iter().filter(|&&b| b == b'\n').count() + 1
}

/// The elements open so far. quick-xml reports the end of the text as a plain end of
/// file even inside an element, so a file cut short would parse as a complete, smaller
/// one: the file is complete only when every element it opened is closed.
#[derive(Default)]
struct Open {
    names: Vec<String>,
    root_seen: bool,
}

impl Open {
    fn track(&mut self, ev: &Event) {
        match ev {
            Event::Start(e) => {
                self.root_seen = true;
                self.names.push(e.name().as_ref().to_owned());
            }
            Event::Empty(_) => self.root_seen = true,
            Event::End(_) => {
                self.names.pop();
            }
            _ => {}
        }
    }

    fn complete(&self, file: &str, xml: &str) -> Result<(), Error> {
        match self.names.last() {
            Some(inner) => Err(Error::Ssp(format!(
                "{file}line {}: the file ends inside <{}>: expected </{inner}> (a truncated file?)",
                line_of(xml, xml.len() as u64),
                self.names.join("> <"),
            ))),
            None if !self.root_seen => {
                Err(Error::Ssp(format!("{file}has no root element (an empty file?)")))
            }
            None => Ok(()),
        }
    }
}

/// An SSP archive unpacked into a temporary directory (removed on drop).
pub struct Archive {
    pub dir: PathBuf,
    pub system: System,
    /// Owns `dir`: removes it when the archive is dropped.
    _unpacked: crate::archive::Unpacked,
}

impl Archive {
    pub fn open(path: &Path) -> Result<Archive, Error> {
        let unpacked = crate::archive::unpack_ssp(path)?;
        let dir = unpacked.dir().to_path_buf();
        let mut ssd = String::new();
        std::fs::File::open(dir.join("SystemStructure.ssd"))
            .and_then(|mut f| f.read_to_string(&mut ssd))
            .map_err(|source| Error::NoSsd { path: path.to_path_buf(), source })?;
        let system = parse_ssd(&ssd).map_err(|e| e.context(path.display().to_string()))?;
        Ok(Archive { dir, system, _unpacked: unpacked })
    }

    /// The parameter set `name` as `component.variable` → value text: the SSD's
    /// ParameterBindings whose set has that name ([`Archive::bound_parameter_set`]), else
    /// (an SSP without bindings) the file `resources/<name>.ssv` with qualified names.
    pub fn parameter_set(&self, name: &str) -> Result<BTreeMap<String, String>, Error> {
        Ok(self.parameter_set_typed(name)?.into_iter().map(|(n, (_, v))| (n, v)).collect())
    }

    /// [`Archive::parameter_set`] with each value's SSP type.
    pub fn parameter_set_typed(&self, name: &str) -> Result<BTreeMap<String, TypedValue>, Error> {
        if let Some(values) = self.bound_parameter_set_typed(Some(name))? {
            return Ok(values);
        }
        let p = self.dir.join("resources").join(format!("{name}.ssv"));
        let text = std::fs::read_to_string(&p)
            .map_err(|e| Error::Ssp(format!("parameter set {name}: {}: {e}", p.display())))?;
        parse_ssv_typed(&text)
            .map_err(|e| e.context(format!("parameter set {name} (resources/{name}.ssv)")))
    }
}

/// One `ssd:ParameterBinding` of the SSD: on a component (`component` Some; its
/// parameter names relative to the component) or on the system (names qualified).
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterBinding {
    pub component: Option<String>,
    /// The `.ssv` file, relative to the SSP root.
    pub source: String,
    /// Prepended to every parameter name of the set (SSP 1.0 `prefix`).
    pub prefix: String,
}

/// The `ssd:ParameterBinding`s of `SystemStructure.ssd` that reference a file, in document
/// order. Inline `ssd:ParameterValues` are not read.
pub fn parse_parameter_bindings(xml: &str) -> Result<Vec<ParameterBinding>, Error> {
    let mut reader = Reader::from_str(xml);
    let mut out = Vec::new();
    // The innermost open Component or System: the element a binding belongs to.
    let mut owners: Vec<Option<String>> = Vec::new();
    loop {
        let ev = reader
            .read_event()
            .map_err(|e| Error::Ssp(format!("SystemStructure.ssd: XML error: {e}")))?;
        match &ev {
            Event::Start(e) | Event::Empty(e) => {
                let empty = matches!(ev, Event::Empty(_));
                match e.local_name().into_inner() {
                    "Component" if !empty => owners.push(Some(required(e, "name")?)),
                    "System" if !empty => owners.push(None),
                    "ParameterBinding" => {
                        if let Some(source) = attr(e, "source")? {
                            out.push(ParameterBinding {
                                component: owners.last().cloned().flatten(),
                                source,
                                prefix: attr(e, "prefix")?.unwrap_or_default(),
                            });
                        }
                    }
                    _ => {}
                }
            }
            Event::End(e) if matches!(e.local_name().into_inner(), "Component" | "System") => {
                owners.pop();
            }
            Event::Eof => break,
            _ => {}
        }
    }
    Ok(out)
}

/// The `name` attribute of an `.ssv` file's `ssv:ParameterSet`.
pub fn parameter_set_name(xml: &str) -> Result<String, Error> {
    let mut reader = Reader::from_str(xml);
    loop {
        match reader
            .read_event()
            .map_err(|e| Error::Ssp(format!("parameter set: XML error: {e}")))?
        {
            Event::Start(e) | Event::Empty(e) if e.local_name().into_inner() == "ParameterSet" => {
                return required(&e, "name");
            }
            Event::Eof => return Err(Error::Ssp("no <ssv:ParameterSet>".into())),
            _ => {}
        }
    }
}

/// The output connectors of the SSD's components, as `component.connector` in document
/// order: what a closed system (no system connectors) records by default.
pub fn parse_component_outputs(xml: &str) -> Result<Vec<String>, Error> {
    let mut reader = Reader::from_str(xml);
    let mut out = Vec::new();
    let mut component: Option<String> = None;
    loop {
        let ev = reader
            .read_event()
            .map_err(|e| Error::Ssp(format!("SystemStructure.ssd: XML error: {e}")))?;
        match &ev {
            Event::Start(e) | Event::Empty(e) => match e.local_name().into_inner() {
                "Component" if matches!(ev, Event::Start(_)) => {
                    component = Some(required(e, "name")?)
                }
                "Connector" => {
                    if let (Some(c), Some("output")) = (&component, attr(e, "kind")?.as_deref()) {
                        out.push(format!("{c}.{}", required(e, "name")?));
                    }
                }
                _ => {}
            },
            Event::End(e) if e.local_name().into_inner() == "Component" => component = None,
            Event::Eof => break,
            _ => {}
        }
    }
    Ok(out)
}

impl Archive {
    fn read_ssd(&self) -> Result<String, Error> {
        let p = self.dir.join("SystemStructure.ssd");
        std::fs::read_to_string(&p).map_err(|source| Error::Io { path: p, source })
    }

    /// An `.ssv` of a binding, by its `source` relative to the SSP root; a source that
    /// would leave the archive is refused.
    fn read_bound_ssv(&self, source: &str) -> Result<String, Error> {
        let rel = Path::new(source);
        if rel.is_absolute()
            || rel.components().any(|c| !matches!(c, std::path::Component::Normal(_)))
        {
            return Err(Error::Ssp(format!(
                "parameter binding source `{source}` must be a relative path inside the SSP"
            )));
        }
        let p = self.dir.join(rel);
        std::fs::read_to_string(&p).map_err(|e| {
            Error::Ssp(format!("parameter binding source `{source}`: {}: {e}", p.display()))
        })
    }

    /// The SSD's parameter sets by name, in the order of their first binding.
    pub fn bound_parameter_set_names(&self) -> Result<Vec<String>, Error> {
        let mut names = Vec::new();
        for b in parse_parameter_bindings(&self.read_ssd()?)? {
            let n = parameter_set_name(&self.read_bound_ssv(&b.source)?)
                .map_err(|e| e.context(&b.source))?;
            if !names.contains(&n) {
                names.push(n);
            }
        }
        Ok(names)
    }

    /// The parameter values the SSD's ParameterBindings give, as `component.variable` →
    /// value text (names qualified by the binding's component and prefix): each
    /// component's first binding (its default), then, if `selected` names a set, that
    /// set's bindings over it. `None` if the SSD binds no parameter sets; an error naming
    /// the known sets if `selected` is none of them.
    pub fn bound_parameter_set(
        &self,
        selected: Option<&str>,
    ) -> Result<Option<BTreeMap<String, String>>, Error> {
        Ok(self
            .bound_parameter_set_typed(selected)?
            .map(|m| m.into_iter().map(|(n, (_, v))| (n, v)).collect()))
    }

    /// [`Archive::bound_parameter_set`] with each value's SSP type.
    pub fn bound_parameter_set_typed(
        &self,
        selected: Option<&str>,
    ) -> Result<Option<BTreeMap<String, TypedValue>>, Error> {
        let bindings = parse_parameter_bindings(&self.read_ssd()?)?;
        if bindings.is_empty() {
            return Ok(None);
        }
        let mut out = BTreeMap::new();
        let mut found = false;
        let mut seen: Vec<&Option<String>> = Vec::new();
        for b in &bindings {
            let first = !seen.contains(&&b.component);
            if first {
                seen.push(&b.component);
            }
            let text = self.read_bound_ssv(&b.source)?;
            let name = parameter_set_name(&text).map_err(|e| e.context(&b.source))?;
            let chosen = selected == Some(name.as_str());
            found |= chosen;
            if !first && !chosen {
                continue;
            }
            let qualify = |p: &str| match &b.component {
                Some(c) => format!("{c}.{}{p}", b.prefix),
                None => format!("{}{p}", b.prefix),
            };
            let values = parse_ssv_typed(&text).map_err(|e| e.context(&b.source))?;
            out.extend(values.into_iter().map(|(p, v)| (qualify(&p), v)));
        }
        if let Some(name) = selected {
            if !found {
                return Err(Error::Ssp(format!(
                    "parameter set {name} is not bound in the SSD (its sets: {})",
                    self.bound_parameter_set_names()?.join(", ")
                )));
            }
        }
        Ok(Some(out))
    }

    /// What a run records by default: the system's output connectors, or for a closed
    /// system (none) every component's output connector (`component.connector`).
    pub fn default_outputs(&self, system_outputs: Vec<String>) -> Result<Vec<String>, Error> {
        if !system_outputs.is_empty() {
            return Ok(system_outputs);
        }
        parse_component_outputs(&self.read_ssd()?)
    }
}

/// What a run sets before any `--parameter-set` or `--param`: the first binding of each
/// component of an SSP (nothing for a single FMU or an SSP without bindings), as libcosim
/// and Ecos apply them.
pub fn first_bindings(a: Option<&Archive>) -> Result<Vec<(String, String)>, Error> {
    Ok(first_bindings_typed(a)?.into_iter().map(|(n, (_, v))| (n, v)).collect())
}

/// [`first_bindings`] with each value's SSP type.
pub fn first_bindings_typed(a: Option<&Archive>) -> Result<Vec<(String, TypedValue)>, Error> {
    match a {
        Some(a) => Ok(a.bound_parameter_set_typed(None)?.unwrap_or_default().into_iter().collect()),
        None => Ok(Vec::new()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_system_with_foreign_annotations_parses() {
        let xml = r#"<?xml version="1.0"?>
<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" version="1.0" name="S">
  <ssd:System name="S">
    <ssd:Connectors><ssd:Connector name="u" kind="input"><ssc:Real/></ssd:Connector></ssd:Connectors>
    <ssd:Elements>
      <ssd:Component name="a" source="resources/A.fmu"><ssd:Connectors><ssd:Connector name="x" kind="output"/></ssd:Connectors>
        <ssd:ElementGeometry x1="0" y1="0" x2="1" y2="1"/></ssd:Component>
      <ssd:Component name="b" source="resources/B.fmu" type="application/x-fmu-sharedlibrary"/>
    </ssd:Elements>
    <ssd:Connections>
      <ssd:Connection startElement="a" startConnector="x" endElement="b" endConnector="y"/>
      <ssd:Connection startConnector="u" endElement="a" endConnector="v"/>
    </ssd:Connections>
    <ssd:Annotations><ssc:Annotation type="com.vendor.gui"><gui:Layout xmlns:gui="urn:x" zoom="2"/></ssc:Annotation></ssd:Annotations>
  </ssd:System>
  <ssd:DefaultExperiment startTime="0" stopTime="3.5"/>
</ssd:SystemStructureDescription>"#;
        let s = parse_ssd(xml).unwrap();
        assert_eq!(s.name, "S");
        assert_eq!(s.components.len(), 2);
        assert_eq!(s.connectors, vec![("u".to_string(), "input".to_string())]);
        assert_eq!(s.connections[1].0, End { element: None, connector: "u".into() });
        assert_eq!(s.stop_time, Some(3.5));
        assert!(parse_ssd("<x/>").unwrap_err().to_string().contains("no <System>"));
        assert!(parse_ssd(
            "<ssd:System name='a'><ssd:Elements><ssd:System name='b'/></ssd:Elements></ssd:System>"
        )
        .unwrap_err()
        .to_string()
        .contains("nested"));
        assert!(parse_ssd("<a><b></a>").is_err());
        let cut = &xml[..xml.find("  <ssd:DefaultExperiment").unwrap()];
        assert_eq!(
            parse_ssd(cut).unwrap_err().to_string(),
            "SystemStructure.ssd line 16: the file ends inside <ssd:SystemStructureDescription>: \
             expected </ssd:SystemStructureDescription> (a truncated file?)"
        );
        assert!(parse_ssd(&format!("\u{feff}{xml}")).is_ok(), "a BOM is skipped");
    }

    #[test]
    fn component_and_system_parameter_bindings_in_order() {
        let xml = r#"<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" version="1.0" name="S">
  <ssd:System name="S">
    <ssd:Elements>
      <ssd:Component name="a" source="resources/A.fmu">
        <ssd:Connectors><ssd:Connector name="y" kind="output"/><ssd:Connector name="u" kind="input"/></ssd:Connectors>
        <ssd:ParameterBindings>
          <ssd:ParameterBinding source="resources/a.default.ssv"/>
          <ssd:ParameterBinding source="resources/a.fast.ssv" prefix="inner."/>
        </ssd:ParameterBindings>
      </ssd:Component>
      <ssd:Component name="b" source="resources/B.fmu"><ssd:Connectors><ssd:Connector name="z" kind="output"/></ssd:Connectors></ssd:Component>
    </ssd:Elements>
    <ssd:ParameterBindings><ssd:ParameterBinding source="resources/sys.ssv"/></ssd:ParameterBindings>
  </ssd:System>
</ssd:SystemStructureDescription>"#;
        let b = parse_parameter_bindings(xml).unwrap();
        let on = |c: Option<&str>, s: &str, p: &str| ParameterBinding {
            component: c.map(str::to_string),
            source: s.into(),
            prefix: p.into(),
        };
        assert_eq!(
            b,
            [
                on(Some("a"), "resources/a.default.ssv", ""),
                on(Some("a"), "resources/a.fast.ssv", "inner."),
                on(None, "resources/sys.ssv", ""),
            ]
        );
        assert_eq!(parse_component_outputs(xml).unwrap(), ["a.y", "b.z"]);
        assert_eq!(
            parameter_set_name(r#"<ssv:ParameterSet xmlns:ssv="x" version="1.0" name="fast"/>"#)
                .unwrap(),
            "fast"
        );
    }

    #[test]
    fn first_bindings_by_default_and_a_selected_set_over_them() {
        let unpacked = crate::archive::Unpacked::new(tempfile::tempdir().unwrap());
        let dir = unpacked.dir().to_path_buf();
        std::fs::create_dir_all(dir.join("resources")).unwrap();
        let ssv = |set: &str, body: &str| {
            format!(
                r#"<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="{set}"><ssv:Parameters>{body}</ssv:Parameters></ssv:ParameterSet>"#
            )
        };
        let real = |n: &str, v: &str| {
            format!(r#"<ssv:Parameter name="{n}"><ssv:Real value="{v}"/></ssv:Parameter>"#)
        };
        for (file, set, body) in [
            ("a.default", "default", real("k", "1") + &real("m", "2")),
            ("a.fast", "fast", real("k", "10")),
            ("b.default", "default", real("k", "3")),
        ] {
            std::fs::write(dir.join(format!("resources/{file}.ssv")), ssv(set, &body)).unwrap();
        }
        std::fs::write(
            dir.join("SystemStructure.ssd"),
            r#"<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" version="1.0" name="S"><ssd:System name="S"><ssd:Elements>
  <ssd:Component name="a" source="resources/A.fmu"><ssd:ParameterBindings><ssd:ParameterBinding source="resources/a.default.ssv"/><ssd:ParameterBinding source="resources/a.fast.ssv"/></ssd:ParameterBindings></ssd:Component>
  <ssd:Component name="b" source="resources/B.fmu"><ssd:ParameterBindings><ssd:ParameterBinding source="resources/b.default.ssv"/></ssd:ParameterBindings></ssd:Component>
</ssd:Elements></ssd:System></ssd:SystemStructureDescription>"#,
        )
        .unwrap();
        let a = Archive { dir, system: System::default(), _unpacked: unpacked };
        let pairs =
            |m: BTreeMap<String, String>| -> Vec<(String, String)> { m.into_iter().collect() };
        let kv = |v: &[(&str, &str)]| -> Vec<(String, String)> {
            v.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect()
        };
        assert_eq!(
            first_bindings(Some(&a)).unwrap(),
            kv(&[("a.k", "1"), ("a.m", "2"), ("b.k", "3")])
        );
        assert_eq!(
            pairs(a.parameter_set("fast").unwrap()),
            kv(&[("a.k", "10"), ("a.m", "2"), ("b.k", "3")])
        );
        assert_eq!(a.bound_parameter_set_names().unwrap(), ["default", "fast"]);
        let e = a.parameter_set("slow").unwrap_err().to_string();
        assert!(e.contains("parameter set slow") && e.contains("default, fast"), "{e}");
        assert!(a
            .read_bound_ssv("../etc/passwd")
            .unwrap_err()
            .to_string()
            .contains("inside the SSP"));
        assert!(first_bindings(None).unwrap().is_empty());
    }

    #[test]
    fn parameter_set_values() {
        let xml = r#"<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="p">
  <ssv:Parameters><ssv:Parameter name="plant.T_em"><ssv:Real value="2.5"/></ssv:Parameter>
  <ssv:Parameter name="controller.prefilter"><ssv:Boolean value="true"/></ssv:Parameter></ssv:Parameters></ssv:ParameterSet>"#;
        let p = parse_ssv(xml).unwrap();
        assert_eq!(p["plant.T_em"], "2.5");
        assert_eq!(p["controller.prefilter"], "true");
        let cut = &xml[..xml.find("<ssv:Parameter name=\"controller").unwrap()];
        assert_eq!(
            parse_ssv(cut).unwrap_err().to_string(),
            "line 3: the file ends inside <ssv:ParameterSet> <ssv:Parameters>: \
             expected </ssv:Parameters> (a truncated file?)"
        );
    }
}
