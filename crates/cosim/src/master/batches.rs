//! The ports a step reads and sets, grouped into one FMI call per component and type.

use super::component::Component;
use super::Port;
use crate::fmu::VarType;
use crate::Error;

/// Ports grouped by component and type, each group one `fmi2Get*`/`fmi2Set*` call: per step
/// the master crosses the FMI boundary once per group instead of once per variable.
///
/// A group of inputs whose values are those its last `Set*` gave is not set again: FMI
/// 2.0 and 3.0 inputs keep their values until set (neither standard has an input that
/// forgets), so the call would change nothing, and a closed loop's slow inputs (a
/// reference that holds for seconds, an encoder count between moves) cost no call at all.
/// The values compare by their bits, so any change, a zero's sign included, is set.
pub(super) struct Batches {
    groups: Vec<Group>,
}

struct Group {
    component: usize,
    ty: VarType,
    vrs: Vec<u32>,
    /// Where each value goes in (or comes from) the caller's slice.
    slots: Vec<usize>,
    reals: Vec<f64>,
    integers: Vec<i32>,
    booleans: Vec<bool>,
    /// The FMU holds this group's values as last set: the last `Set*` of it succeeded and
    /// nothing has given the inputs other values since ([`Batches::forget`]).
    held: bool,
}

impl Batches {
    pub(super) fn new(ports: &[Port]) -> Result<Batches, Error> {
        let mut groups: Vec<Group> = Vec::new();
        for (slot, p) in ports.iter().enumerate() {
            let ty = match p.ty {
                VarType::String => {
                    return Err(Error::Config(
                        "String variables cannot be connected or recorded".into(),
                    ))
                }
                VarType::Enumeration => VarType::Integer,
                t => t,
            };
            let g = match groups.iter().position(|g| g.component == p.component && g.ty == ty) {
                Some(i) => &mut groups[i],
                None => {
                    groups.push(Group {
                        component: p.component,
                        ty,
                        vrs: vec![],
                        slots: vec![],
                        reals: vec![],
                        integers: vec![],
                        booleans: vec![],
                        held: false,
                    });
                    groups.last_mut().expect("just pushed")
                }
            };
            g.vrs.push(p.vr);
            g.slots.push(slot);
            g.reals.push(0.0);
            g.integers.push(0);
            g.booleans.push(false);
        }
        Ok(Batches { groups })
    }

    pub(super) fn read(
        &mut self,
        components: &mut [Component],
        out: &mut [f64],
        only: Option<usize>,
    ) -> Result<(), Error> {
        for g in self.groups.iter_mut().filter(|g| only.is_none_or(|c| c == g.component)) {
            let f = &mut components[g.component].fmu;
            match g.ty {
                VarType::Real => {
                    f.get_real(&g.vrs, &mut g.reals)?;
                    g.slots.iter().zip(&g.reals).for_each(|(&s, &v)| out[s] = v);
                }
                VarType::Boolean => {
                    f.get_boolean(&g.vrs, &mut g.booleans)?;
                    g.slots
                        .iter()
                        .zip(&g.booleans)
                        .for_each(|(&s, &v)| out[s] = f64::from(u8::from(v)));
                }
                _ => {
                    f.get_integer(&g.vrs, &mut g.integers)?;
                    g.slots.iter().zip(&g.integers).for_each(|(&s, &v)| out[s] = f64::from(v));
                }
            }
        }
        Ok(())
    }

    /// Sets `values` (by slot) on the groups of component `only` (every component if
    /// `None`); a group that holds these values already is skipped.
    pub(super) fn write(
        &mut self,
        components: &mut [Component],
        values: &[f64],
        only: Option<usize>,
    ) -> Result<(), Error> {
        for g in self.groups.iter_mut().filter(|g| only.is_none_or(|c| c == g.component)) {
            let mut changed = !g.held;
            match g.ty {
                VarType::Real => {
                    for (&s, v) in g.slots.iter().zip(&mut g.reals) {
                        changed |= v.to_bits() != values[s].to_bits();
                        *v = values[s];
                    }
                }
                VarType::Boolean => {
                    for (&s, v) in g.slots.iter().zip(&mut g.booleans) {
                        changed |= *v != (values[s] != 0.0);
                        *v = values[s] != 0.0;
                    }
                }
                _ => {
                    for (&s, v) in g.slots.iter().zip(&mut g.integers) {
                        let i = whole(values[s]);
                        changed |= *v != i;
                        *v = i;
                    }
                }
            }
            if !changed {
                continue;
            }
            // Held again only once the FMU has taken them: a refused call is made again.
            g.held = false;
            let f = &mut components[g.component].fmu;
            match g.ty {
                VarType::Real => f.set_real(&g.vrs, &g.reals)?,
                VarType::Boolean => f.set_boolean(&g.vrs, &g.booleans)?,
                _ => f.set_integer(&g.vrs, &g.integers)?,
            }
            g.held = true;
        }
        Ok(())
    }

    /// The FMUs' inputs may now hold other values than the last set (a restored FMU
    /// state): the next [`Batches::write`] sets every group.
    pub(super) fn forget(&mut self) {
        self.groups.iter_mut().for_each(|g| g.held = false);
    }
}

/// `x` rounded to an `i32` as `x.round() as i32` does, without a call into the C library
/// for the whole numbers an Integer output gives (the common case: they go through as
/// they are).
#[inline]
fn whole(x: f64) -> i32 {
    let t = x as i32;
    if f64::from(t) == x {
        t
    } else {
        x.round() as i32
    }
}

#[cfg(test)]
mod tests {
    use super::whole;

    #[test]
    fn whole_is_round_as_i32() {
        let cases = [
            0.0,
            -0.0,
            1.0,
            -7.0,
            0.5,
            -0.5,
            2.5,
            -2.5,
            0.49999999999999994,
            123_456.75,
            2_147_483_647.0,
            2_147_483_647.4,
            2_147_483_648.0,
            -2_147_483_648.0,
            -2_147_483_649.0,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for x in cases {
            assert_eq!(whole(x), x.round() as i32, "{x:e}");
        }
    }
}
