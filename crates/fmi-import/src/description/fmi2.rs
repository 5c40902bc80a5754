//! FMI 2.0 variables: `<ScalarVariable>` with one type element (`<Real>`, `<Integer>`,
//! `<Boolean>`, `<String>` or `<Enumeration>`) as its child.

use super::text::{attr, is_boolean, is_double};
use super::{Doc, Element, Standard, VarType, Variability, Variable};
use crate::ImportError;

/// The `<ScalarVariable>` being read (its type element comes later) and where it started.
#[derive(Default)]
pub(super) struct Fmi2 {
    current: Option<(Variable, bool, usize)>,
}

impl Standard for Fmi2 {
    fn open(&mut self, doc: &mut Doc<'_>, e: &Element<'_>) -> Result<(), ImportError> {
        let (a, name, pos) = (e.attrs, e.name, e.pos);
        match (e.depth, name, &mut self.current) {
            (2, "ScalarVariable", _) => {
                let var_name = doc.required(a, name, "name", pos)?.to_owned();
                let tag = format!("ScalarVariable name=\"{var_name}\"");
                let vr = doc.value_reference(a, &tag, pos)?;
                let (causality, variability, initial) =
                    doc.kinds(a, &tag, pos, &[], Variability::Continuous)?;
                let var = Variable {
                    name: var_name,
                    vr,
                    ty: VarType::Real,
                    causality,
                    variability,
                    initial,
                    start: None,
                    description: attr(a, "description").map(str::to_owned),
                    declared_type: None,
                    element: None,
                    clocks: Vec::new(),
                };
                self.current = Some((var, false, pos));
            }
            (3, "Real" | "Integer" | "Boolean" | "String" | "Enumeration", Some((v, typed, _))) => {
                let (ty, item): (VarType, fn(&str) -> bool) = match name {
                    "Real" => (VarType::Real, is_double),
                    "Integer" => (VarType::Integer, |s| s.parse::<i32>().is_ok()),
                    "Boolean" => (VarType::Boolean, is_boolean),
                    "String" => (VarType::String, |_| true),
                    _ => (VarType::Enumeration, |s| s.parse::<i32>().is_ok()),
                };
                if *typed {
                    return Err(doc.error(
                        pos,
                        format!(
                            "<ScalarVariable name=\"{}\"> has a second type element <{name}>",
                            v.name
                        ),
                    ));
                }
                let tag = format!("{name}> of <ScalarVariable name=\"{}\"", v.name);
                // A String's start is any text, the empty one included.
                v.start = match ty {
                    VarType::String => attr(a, "start").map(str::to_owned),
                    _ => doc.check_start(a, (&tag, &ty.to_string()), false, item, pos)?,
                };
                if let Some(of) = doc.number::<u32>(a, &tag, "derivative", "an index", pos)? {
                    // This variable's index: the variables before it, plus one.
                    let index = doc.md_variables() as u32 + 1;
                    doc.derivative_of.insert(index, of);
                }
                v.ty = ty;
                v.declared_type = attr(a, "declaredType").map(str::to_owned);
                *typed = true;
            }
            _ => {}
        }
        Ok(())
    }

    fn close(&mut self, doc: &mut Doc<'_>, e: &Element<'_>) -> Result<(), ImportError> {
        if e.depth != 2 || e.name != "ScalarVariable" {
            return Ok(());
        }
        let Some((v, typed, start)) = self.current.take() else {
            return Ok(());
        };
        if !typed {
            return Err(doc.error(start, format!("<ScalarVariable name=\"{}\"> has no type element (<Real>, <Integer>, <Boolean>, <String> or <Enumeration>)", v.name)));
        }
        doc.add_variable(v, start)
    }
}
