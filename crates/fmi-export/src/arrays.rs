//! FMI 3.0 arrays over the scalar table.
//!
//! A model declares each array once, as the scalars `name[1]` … `name[n]` with consecutive
//! value references, the first marked with [`Variable::array`]. FMI 2.0 has no arrays and
//! keeps the scalars (`variableNamingConvention="structured"` reads `name[k]` as element
//! k). FMI 3.0 declares one variable `name` with `<Dimension start="n"/>`, whose value
//! reference is the first element's; its values travel in the standard's serialization
//! order (row-major; these arrays have one dimension, so element 1 first), and the value
//! references of elements 2 … n are not the FMI 3.0 FMU's. The model itself only ever sees
//! the scalars' value references.

use crate::table::Variable;

/// One variable as a standard declares it: the table rows `first .. first + len`, one
/// row for a scalar.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Entry {
    pub first: usize,
    pub len: usize,
}

impl Entry {
    /// Whether it is an FMI 3.0 array (even of one element).
    pub fn is_array<V: AsRef<Variable>>(&self, vars: &[V]) -> bool {
        vars[self.first].as_ref().array.is_some()
    }
}

/// The name of an array whose first element is `head` (`name[1]` → `name`).
pub fn array_name(head: &Variable) -> &'static str {
    head.name.strip_suffix("[1]").unwrap_or(head.name)
}

/// `name[k]` → (`name`, k).
fn element(name: &str) -> Option<(&str, usize)> {
    let (base, rest) = name.strip_suffix(']')?.rsplit_once('[')?;
    let k = rest.parse().ok().filter(|&k| k >= 1 && rest.bytes().all(|b| b.is_ascii_digit()))?;
    Some((base, k))
}

/// Whether `e` may follow `head` as element `k` of one array: the same declaration but
/// for its name, value reference, start and description.
fn same_declaration(head: &Variable, e: &Variable) -> bool {
    (e.kind, e.causality, e.variability, e.initial, e.unit, e.min, e.max, e.wording)
        == (
            head.kind,
            head.causality,
            head.variability,
            head.initial,
            head.unit,
            head.min,
            head.max,
            head.wording,
        )
        && std::mem::discriminant(&e.start) == std::mem::discriminant(&head.start)
        && e.array.is_none()
}

/// The table as FMI 3.0 declares it: each marked run of elements one entry, every other
/// row one. `Err` names the first row that breaks the rules: a marked head not named
/// `name[1]`, an element out of order, of another declaration or off the consecutive
/// value references, or an element `name[k]` outside any marked array (the FMI 3.0 FMU
/// would declare a scalar with an element's name).
pub fn fmi3_entries<V: AsRef<Variable>>(vars: &[V]) -> Result<Vec<Entry>, String> {
    let mut entries = Vec::with_capacity(vars.len());
    let mut i = 0;
    while i < vars.len() {
        let head = vars[i].as_ref();
        if head.array.is_none() {
            if element(head.name).is_some() {
                let why = "an element outside any array (mark its first element with .array())";
                return Err(format!("{}: {why}", head.name));
            }
            entries.push(Entry { first: i, len: 1 });
            i += 1;
            continue;
        }
        if element(head.name).map(|(_, k)| k) != Some(1) {
            return Err(format!("{}: the first element of an array is named name[1]", head.name));
        }
        let base = array_name(head);
        let mut len = 1;
        while let Some(e) = vars.get(i + len).map(AsRef::as_ref) {
            match element(e.name) {
                Some((b, k)) if b == base => {
                    let vr_ok = u32::try_from(len).ok().and_then(|l| head.vr.checked_add(l));
                    if k != len + 1 || vr_ok != Some(e.vr) || !same_declaration(head, e) {
                        let why = format!(
                            "element {} of {base}[] must be named {base}[{}], have value reference {} and {}'s declaration",
                            len + 1,
                            len + 1,
                            head.vr as usize + len,
                            head.name
                        );
                        return Err(format!("{}: {why}", e.name));
                    }
                    len += 1;
                }
                _ => break,
            }
        }
        entries.push(Entry { first: i, len });
        i += len;
    }
    Ok(entries)
}

/// Every row its own entry: FMI 2.0, and FMI 3.0 of a table [`fmi3_entries`] refuses
/// (whose FMU `fmu-build` never writes, as it generates the XML from the same rules).
pub fn scalar_entries<V>(vars: &[V]) -> Vec<Entry> {
    (0..vars.len()).map(|first| Entry { first, len: 1 }).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const fn p(name: &'static str, vr: u32) -> Variable {
        Variable::parameter(name, vr, 1.0, Some("V"), "")
    }

    #[test]
    fn marked_runs_are_arrays_and_the_rest_scalars() {
        let t = [p("a", 1), p("r[1]", 2).array("radii"), p("r[2]", 3), p("r[3]", 4), p("b", 5)];
        let e = fmi3_entries(&t).unwrap();
        assert_eq!(
            e,
            [Entry { first: 0, len: 1 }, Entry { first: 1, len: 3 }, Entry { first: 4, len: 1 }]
        );
        assert!(e[1].is_array(&t) && !e[0].is_array(&t));
        assert_eq!(array_name(&t[1]), "r");
        assert_eq!(scalar_entries(&t).len(), 5);
    }

    #[test]
    fn broken_arrays_are_refused_by_name() {
        let stray = [p("a", 1), p("r[1]", 2)];
        assert!(fmi3_entries(&stray).unwrap_err().starts_with("r[1]: an element outside"));
        let gap = [p("r[1]", 2).array(""), p("r[2]", 4)];
        assert!(fmi3_entries(&gap).unwrap_err().contains("value reference 3"));
        let order = [p("r[1]", 2).array(""), p("r[3]", 3)];
        assert!(fmi3_entries(&order).unwrap_err().contains("named r[2]"));
        let unit = [p("r[1]", 2).array(""), Variable::parameter("r[2]", 3, 1.0, None, "")];
        assert!(fmi3_entries(&unit).unwrap_err().contains("declaration"));
        let head = [p("r[2]", 2).array("")];
        assert!(fmi3_entries(&head).unwrap_err().contains("named name[1]"));
        // A run ends at a row of another name; a stray element after it is refused.
        let two = [p("r[1]", 2).array(""), p("r[2]", 3), p("s[2]", 4)];
        assert!(fmi3_entries(&two).unwrap_err().starts_with("s[2]"));
    }

    #[test]
    fn element_names() {
        assert_eq!(element("play_radius[12]"), Some(("play_radius", 12)));
        assert_eq!(element("x[0]"), None);
        assert_eq!(element("x[+1]"), None);
        assert_eq!(element("x"), None);
    }
}
