//! The system of `SystemStructure.ssd`: its components, connectors with their types,
//! connections, default experiment and the project's communication-step annotation.

use std::collections::BTreeMap;

use quick_xml::events::Event;
use quick_xml::Reader;

use super::xml::{attr, line_of, required, Open};
use crate::archive::cut;
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
                sys.stop_time = attr(&e, "stopTime")?
                    .map(|v| duration("DefaultExperiment stopTime", &v))
                    .transpose()?;
            }
            // The project's own annotation carries the communication step.
            "CommunicationStep" => {
                sys.step_size = attr(&e, "stepSize")?
                    .map(|v| duration("CommunicationStep stepSize", &v))
                    .transpose()?;
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

/// A stop time or step of the SSD: a finite number of seconds above 0 (a NaN, an infinity,
/// 0 or a negative time would reach the master as a run of no or endless steps).
fn duration(what: &str, v: &str) -> Result<f64, Error> {
    match v.trim().parse::<f64>() {
        Ok(t) if t.is_finite() && t > 0.0 => Ok(t),
        Ok(_) => Err(Error::Ssp(format!(
            "{what}=\"{}\" refused: a time in seconds, finite and > 0",
            cut(v, 40)
        ))),
        Err(_) => Err(Error::Ssp(format!("{what}=\"{}\" is not a number", cut(v, 40)))),
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

    /// Found by the property tests (tests/properties.rs): a stop time or step of 0 parsed,
    /// and a NaN, an infinity or a negative one as well.
    #[test]
    fn a_stop_time_or_step_that_is_no_duration_is_refused() {
        let ssd = |experiment: &str| {
            format!("<ssd:SystemStructureDescription name='s'><ssd:System name='s'>{experiment}</ssd:System></ssd:SystemStructureDescription>")
        };
        for v in ["0", "-1", "NaN", "inf", "1e309"] {
            let e = parse_ssd(&ssd(&format!("<ssd:DefaultExperiment stopTime='{v}'/>")));
            assert_eq!(
                e.unwrap_err().to_string(),
                format!(
                    "DefaultExperiment stopTime=\"{v}\" refused: a time in seconds, finite and > 0"
                )
            );
            let step = format!("<ssd:Annotations><ssc:Annotation type='x'><iw:CommunicationStep stepSize='{v}'/></ssc:Annotation></ssd:Annotations>");
            let e = parse_ssd(&ssd(&step)).unwrap_err().to_string();
            assert!(e.contains("CommunicationStep stepSize"), "{e}");
        }
        let e = parse_ssd(&ssd("<ssd:DefaultExperiment stopTime='soon'/>")).unwrap_err();
        assert!(e.to_string().contains("stopTime=\"soon\" is not a number"), "{e}");
        assert_eq!(
            parse_ssd(&ssd("<ssd:DefaultExperiment stopTime='2e-3'/>")).unwrap().stop_time,
            Some(2e-3)
        );
    }
}
