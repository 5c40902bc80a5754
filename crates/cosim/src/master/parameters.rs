//! Values given as text (`--param`, an SSD's bindings, a parameter set) checked against
//! their variables' types and set in initialization mode.

use std::collections::BTreeSet;

use super::component::{resolve, Component};
use super::{Options, Port, System};
use crate::archive::cut;
use crate::fmu::{Instance, Var, VarType};
use crate::ssp::{Archive, TypedValue};
use crate::Error;

fn set(components: &mut [Component], p: Port, value: f64) -> Result<(), Error> {
    set_var(&mut components[p.component].fmu, Var { vr: p.vr, ty: p.ty }, value)
}

fn set_var(f: &mut Instance, v: Var, value: f64) -> Result<(), Error> {
    match v.ty {
        VarType::Real => f.set_real(&[v.vr], &[value]),
        VarType::Integer | VarType::Enumeration => f.set_integer(&[v.vr], &[value.round() as i32]),
        VarType::Boolean => f.set_boolean(&[v.vr], &[value != 0.0]),
        VarType::String => {
            return Err(Error::Config("String variables cannot be connected".into()))
        }
    }
    .map_err(Error::from)
}

/// A start value or parameter given as text (`--param`, an `.ssv`), checked against the
/// variable's type.
fn parse_value(ty: VarType, name: &str, text: &str) -> Result<f64, Error> {
    let value = match ty {
        VarType::Boolean => match text.trim() {
            "true" | "1" => 1.0,
            "false" | "0" => 0.0,
            t => return Err(Error::Config(format!("{name} = {t}: not a Boolean (true/false)"))),
        },
        _ => text
            .trim()
            .parse::<f64>()
            .map_err(|_| Error::Config(format!("{name} = {text}: not a number")))?,
    };
    if !value.is_finite() {
        return Err(Error::Config(format!("{name} = {text}: not a finite number")));
    }
    if matches!(ty, VarType::Integer | VarType::Enumeration) {
        if value.fract() != 0.0 {
            return Err(Error::Config(format!("{name} = {text}: not an integer")));
        }
        // fmi2Integer is 32 bits: a cast would saturate silently.
        if !(f64::from(i32::MIN)..=f64::from(i32::MAX)).contains(&value) {
            return Err(Error::Config(format!(
                "{name} = {text}: out of the Integer range {}..={}",
                i32::MIN,
                i32::MAX
            )));
        }
    }
    Ok(value)
}

/// Whether an SSP type (`Real`, `Integer`, … of `ssc:`/`ssv:`) is that of an FMI variable of
/// type `ty`: the same name, or `Integer` for an enumeration (its values are integers).
pub(super) fn ssp_type_fits(kind: &str, ty: VarType) -> bool {
    match ty {
        VarType::Real => kind == "Real",
        VarType::Integer => kind == "Integer",
        VarType::Boolean => kind == "Boolean",
        VarType::String => kind == "String",
        VarType::Enumeration => matches!(kind, "Enumeration" | "Integer"),
    }
}

/// A parameter set's value of SSP type `kind` for a variable of type `ty`: SSP 1.0 gives
/// each value the type of the variable it sets (an `ssv:Enumeration` or `ssv:Integer` for
/// an FMI enumeration), and a value of another type (a Real `3` for an Integer, an Integer
/// `1` for a Boolean) is a mistake in the set, not a conversion to make silently.
fn check_binding_type(name: &str, kind: &str, ty: VarType) -> Result<(), Error> {
    if ssp_type_fits(kind, ty) {
        return Ok(());
    }
    Err(Error::Config(format!(
        "parameter `{}`: the parameter set gives it an ssv:{kind} value, but the variable is of type {ty}: refused (SSP 1.0: a value has its variable's type)",
        cut(name, 200)
    )))
}

fn set_text(components: &mut [Component], p: Port, name: &str, text: &str) -> Result<(), Error> {
    set(components, p, parse_value(p.ty, name, text)?)
}

/// Sets one variable of a single FMU by name from text, as `--param NAME=VALUE` does.
pub fn set_param(fmu: &mut Instance, name: &str, text: &str) -> Result<(), Error> {
    let v = fmu.var(name)?;
    set_var(fmu, v, parse_value(v.ty, name, text)?)
}

impl System {
    /// Initialization mode: each component's first binding, the parameter set's values,
    /// then `--param` values (so a `--param` overrides the set). A value from the SSP
    /// carries its SSP type, checked against the variable's.
    pub(super) fn set_parameters(&mut self, opts: &Options, stop: f64) -> Result<(), Error> {
        let first = crate::ssp::first_bindings_typed(self.archive.as_ref())?;
        let (components, archive) = (&mut self.components, self.archive.as_ref());
        set_parameters(components, archive, &self.elsewhere, first, opts, stop)
    }
}

/// Initialization mode on every component, from entering it to leaving it: `first`, then
/// the parameter set of `opts`, then its `params`, each value over the ones before. A
/// value from the SSP (a first binding or the set) comes with the SSP type it is given,
/// which must be its variable's ([`check_binding_type`]); a `--param` has no type of its
/// own and is read as the variable's. The values of the components of `elsewhere` (run
/// by other parts of the system) are left to those parts.
fn set_parameters(
    components: &mut [Component],
    archive: Option<&Archive>,
    elsewhere: &BTreeSet<String>,
    first: Vec<(String, TypedValue)>,
    opts: &Options,
    stop: f64,
) -> Result<(), Error> {
    for c in components.iter_mut() {
        c.fmu.enter_initialization(None, 0.0, Some(stop))?;
    }
    // (name, the SSP type the SSP gives it, value text).
    let typed = |(n, (k, v)): (String, TypedValue)| (n, Some(k), v);
    let mut values: Vec<(String, Option<String>, String)> = first.into_iter().map(typed).collect();
    if let Some(set_name) = &opts.parameter_set {
        let a = archive.ok_or(Error::Config("--parameter-set needs an .ssp file".into()))?;
        values.extend(a.parameter_set_typed(set_name)?.into_iter().map(typed));
    }
    values.extend(opts.params.iter().map(|(n, v)| (n.clone(), None, v.clone())));
    values.retain(|(n, _, _)| !super::partition::is_elsewhere(elsewhere, n));
    for (name, kind, text) in &values {
        let p = resolve(components, archive.is_some(), name)
            .map_err(|e| e.context(format!("parameter `{name}`")))?;
        if let Some(kind) = kind {
            check_binding_type(name, kind, p.ty)?;
        }
        set_text(components, p, name, text)?;
    }
    for c in components.iter_mut() {
        c.fmu.exit_initialization()?;
    }
    Ok(())
}

/// Property tests of the values `--param` and parameter sets give as text
/// (crates/properties: 10 000 cases each, a fixed seed).
#[cfg(test)]
mod properties {
    use super::*;
    use inchworm_properties::{apply_text, check, mutations};
    use proptest::prelude::*;

    /// A finite Real written any way a user or tool writes it reads back to its bits.
    #[test]
    fn a_real_reads_back_to_its_bits() {
        let real = any::<f64>().prop_filter("finite", |x| x.is_finite());
        check("--param: a Real written and read", (real, 0u8..4), |(x, style)| {
            let text = match style {
                0 => format!("{x:?}"),
                1 => format!("{x}"),
                2 => format!("{x:e}"),
                _ => format!("  {x:E}\t"),
            };
            let v = parse_value(VarType::Real, "p", &text)
                .map_err(|e| TestCaseError::fail(e.to_string()))?;
            prop_assert_eq!(v.to_bits(), x.to_bits(), "{}", text);
            Ok(())
        });
    }

    /// Any text for any type: a value the variable can hold, or refused naming it.
    #[test]
    fn any_text_is_a_value_of_the_type_or_refused() {
        let bases = ["1.5e7", "-2147483648", "true", "0", "2147483647", " 3e-5 "];
        let types = prop_oneof![
            Just(VarType::Real),
            Just(VarType::Integer),
            Just(VarType::Enumeration),
            Just(VarType::Boolean)
        ];
        check("--param: any text", (types, mutations(bases.len())), |(ty, (i, edits))| {
            let text = apply_text(bases[i], &edits);
            match parse_value(ty, "p", &text) {
                Ok(v) => {
                    prop_assert!(v.is_finite());
                    match ty {
                        VarType::Integer | VarType::Enumeration => {
                            prop_assert!(v.fract() == 0.0 && v.abs() <= 2_147_483_648.0);
                            prop_assert!((f64::from(i32::MIN)..=f64::from(i32::MAX)).contains(&v));
                        }
                        VarType::Boolean => prop_assert!(v == 0.0 || v == 1.0),
                        _ => {}
                    }
                }
                Err(e) => prop_assert!(e.to_string().starts_with("p = "), "{}", e),
            }
            Ok(())
        });
    }
}
