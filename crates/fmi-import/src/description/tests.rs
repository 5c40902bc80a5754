//! The reader's tests, on FMI 2.0 descriptions and on FMI 3.0 ones.

use super::*;

mod fmi2 {
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

mod fmi3 {
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
