//! Parameter sets: the `.ssv` files, the SSD's `ssd:ParameterBinding`s that bind them to
//! components or the system, and the values an [`Archive`]'s bindings give.

use std::collections::BTreeMap;

use quick_xml::events::Event;
use quick_xml::Reader;

use super::xml::{attr, line_of, required, Open};
use super::Archive;
use crate::archive::cut;
use crate::Error;

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
                        let value = (kind.to_string(), required(&e, "value")?);
                        if out.contains_key(&name) {
                            return Err(Error::Ssp(format!(
                                "line {}: parameter `{}` is set twice in this parameter set: which value holds is not said",
                                line_of(xml, reader.buffer_position()),
                                cut(&name, 80)
                            )));
                        }
                        out.insert(name, value);
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

impl Archive {
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
    use crate::ssp::{parse_component_outputs, System};

    /// A set naming a parameter twice is refused: the property tests' generated sets have
    /// distinct names, and an edit that repeats one took the later value silently.
    #[test]
    fn a_parameter_set_twice_in_one_set_is_refused() {
        let xml = "<ssv:ParameterSet name='s'><ssv:Parameters>\n<ssv:Parameter name='k'><ssv:Real value='1'/></ssv:Parameter>\n<ssv:Parameter name='k'><ssv:Real value='2'/></ssv:Parameter>\n</ssv:Parameters></ssv:ParameterSet>";
        let e = parse_ssv_typed(xml).unwrap_err().to_string();
        assert_eq!(e, "line 3: parameter `k` is set twice in this parameter set: which value holds is not said");
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
        let a = Archive { dir, system: System::default(), _unpacked: unpacked.into() };
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
