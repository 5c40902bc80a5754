//! FMI 3.0 variables: one element per variable, named by its type (`<Float64>`, `<Int32>`,
//! …), arrays marked by `<Dimension>` children. `<Float64>` is a Real, `<Int32>` an
//! Integer, `<Boolean>` and `<String>` as in FMI 2.0. Every variable is checked (name,
//! valueReference, causality, variability, initial, start). An array of those types with
//! one dimension of a fixed size (`<Dimension start="n"/>`) is added as its elements
//! `name[1]` … `name[n]` (the structured naming of FMI 2.0's scalars, so one name
//! addresses an element in either standard), each with an [`ArrayElement`]; the other
//! types (Float32, the other integer widths, Enumeration, Binary, Clock), other arrays and
//! the independent variable are not added to
//! [`ModelDescription::variables`](super::ModelDescription): the master's scalar calls
//! cannot address them, so asking for one is "unknown variable".

use super::text::{attr, cut, is_boolean, is_double, Attrs};
use super::{ArrayElement, Causality, Clock, Doc, Element, IntervalVariability, Standard, VarType};
use super::{Variability, Variable, MAX_ARRAY_ELEMENTS};
use crate::ImportError;

/// What a type element's `start` items must parse as.
fn start_item(element: &str) -> Option<fn(&str) -> bool> {
    Some(match element {
        "Float32" | "Float64" => is_double,
        "Int8" => |s| s.parse::<i8>().is_ok(),
        "UInt8" => |s| s.parse::<u8>().is_ok(),
        "Int16" => |s| s.parse::<i16>().is_ok(),
        "UInt16" => |s| s.parse::<u16>().is_ok(),
        "Int32" => |s| s.parse::<i32>().is_ok(),
        "UInt32" => |s| s.parse::<u32>().is_ok(),
        "Int64" | "Enumeration" => |s| s.parse::<i64>().is_ok(),
        "UInt64" => |s| s.parse::<u64>().is_ok(),
        "Boolean" => is_boolean,
        // Binary is hexadecimal text; a Clock has no start.
        "Binary" => |s| s.len() % 2 == 0 && s.bytes().all(|b| b.is_ascii_hexdigit()),
        "Clock" => |_| false,
        // String starts are <Start value="…"/> children: any text.
        "String" => |_| true,
        _ => return None,
    })
}

/// The variable element being read: kept at its end, as its elements if it is an array.
struct Pending {
    var: Option<Variable>,
    /// Each `<Dimension>`'s fixed size, `None` for one sized by a structural parameter.
    dims: Vec<Option<u32>>,
    pos: usize,
}

#[derive(Default)]
pub(super) struct Fmi3 {
    current: Option<Pending>,
    /// Array elements added so far, against [`MAX_ARRAY_ELEMENTS`].
    elements: usize,
}

impl Standard for Fmi3 {
    fn open(&mut self, doc: &mut Doc<'_>, e: &Element<'_>) -> Result<(), ImportError> {
        let (a, name, pos) = (e.attrs, e.name, e.pos);
        if e.depth == 3 && name == "Dimension" {
            if let Some(p) = self.current.as_mut() {
                p.dims.push(attr(a, "start").and_then(|n| n.parse().ok()));
            }
            return Ok(());
        }
        if e.depth != 2 {
            return Ok(());
        }
        // Not a variable type: a vendor's element, skipped as everywhere else.
        let Some(item) = start_item(name) else {
            return Ok(());
        };
        let var_name = doc.required(a, name, "name", pos)?.to_owned();
        let tag = format!("{name} name=\"{var_name}\"");
        let vr = doc.value_reference(a, &tag, pos)?;
        let default_variability =
            if name.starts_with("Float") { Variability::Continuous } else { Variability::Discrete };
        let (causality, variability, initial) = doc.kinds(
            a,
            &tag,
            pos,
            &[("structuralParameter", Causality::Parameter)],
            default_variability,
        )?;
        let start = doc.check_start(a, (&tag, name), true, item, pos)?;
        if let Some(of) = doc.number::<u32>(a, &tag, "derivative", "a value reference", pos)? {
            doc.derivative_of.insert(vr, of);
        }
        let clocks = match attr(a, "clocks") {
            None => Vec::new(),
            Some(list) => list
                .split_ascii_whitespace()
                .map(|c| c.parse::<u32>())
                .collect::<Result<Vec<u32>, _>>()
                .map_err(|_| {
                    doc.error(
                        pos,
                        format!(
                            "<{tag}> clocks=\"{}\" is not a list of value references",
                            cut(list, 100)
                        ),
                    )
                })?,
        };
        if name == "Clock" {
            doc.md.clocks.push(clock(doc, a, (&tag, var_name.clone(), vr, causality), pos)?);
        }
        let ty = match name {
            "Float64" => Some(VarType::Real),
            "Int32" => Some(VarType::Integer),
            "Boolean" => Some(VarType::Boolean),
            "String" => Some(VarType::String),
            _ => None,
        };
        let var = ty.filter(|_| causality != Causality::Independent).map(|ty| Variable {
            name: var_name.clone(),
            vr,
            ty,
            causality,
            variability,
            initial,
            start,
            description: attr(a, "description").map(str::to_owned),
            declared_type: attr(a, "declaredType").map(str::to_owned),
            element: None,
            clocks,
        });
        if var.is_none() {
            doc.claim_name(&var_name, pos)?;
        }
        self.current = Some(Pending { var, dims: Vec::new(), pos });
        Ok(())
    }

    fn close(&mut self, doc: &mut Doc<'_>, e: &Element<'_>) -> Result<(), ImportError> {
        if e.depth != 2 {
            return Ok(());
        }
        match self.current.take() {
            Some(Pending { var: Some(v), dims, pos }) if dims.is_empty() => {
                doc.add_variable(v, pos)
            }
            Some(Pending { var: Some(v), dims, pos }) => {
                doc.claim_name(&v.name, pos)?;
                let len = match dims[..] {
                    [Some(n)] if n > 0 && v.ty != VarType::String => n,
                    _ => return Ok(()),
                };
                if self.elements + len as usize > MAX_ARRAY_ELEMENTS {
                    return Ok(());
                }
                self.elements += len as usize;
                // One start item per element; a list of another length gives none.
                let starts: Vec<&str> = v
                    .start
                    .as_deref()
                    .map(|s| s.split_ascii_whitespace().collect())
                    .unwrap_or_default();
                for index in 0..len {
                    let start =
                        (starts.len() == len as usize).then(|| starts[index as usize].to_owned());
                    let element = ArrayElement { array_vr: v.vr, index, len };
                    let name = format!("{}[{}]", v.name, index + 1);
                    let e = Variable { name, start, element: Some(element), ..v.clone() };
                    doc.add_variable(e, pos)?;
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }
}

/// A `<Clock>` element: its interval's variability (required), `intervalDecimal`,
/// `shiftDecimal` and `priority`, each checked as a number.
fn clock(
    doc: &Doc<'_>,
    a: &Attrs,
    (tag, name, vr, causality): (&str, String, u32, Causality),
    pos: usize,
) -> Result<Clock, ImportError> {
    let iv = doc.required(a, tag, "intervalVariability", pos)?;
    let interval_variability = IntervalVariability::parse(iv.trim()).ok_or_else(|| {
        doc.error(
            pos,
            format!(
                "<{tag}> intervalVariability=\"{}\" is not one of {}",
                cut(iv, 100),
                IntervalVariability::ALL.trim_end()
            ),
        )
    })?;
    let interval_decimal = doc.number::<f64>(a, tag, "intervalDecimal", "a number", pos)?;
    if interval_decimal.is_some_and(|i| !(i.is_finite() && i > 0.0)) {
        return Err(doc.error(pos, format!("<{tag}> intervalDecimal must be a positive number")));
    }
    let shift_decimal = doc.number::<f64>(a, tag, "shiftDecimal", "a number", pos)?.unwrap_or(0.0);
    if !(shift_decimal.is_finite() && shift_decimal >= 0.0) {
        return Err(doc.error(pos, format!("<{tag}> shiftDecimal must be a number >= 0")));
    }
    let priority = doc.number::<u32>(a, tag, "priority", "an unsigned 32-bit integer", pos)?;
    Ok(Clock {
        name,
        vr,
        causality,
        interval_variability,
        interval_decimal,
        shift_decimal,
        priority,
    })
}
