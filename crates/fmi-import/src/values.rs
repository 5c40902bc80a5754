//! The values of an [`Instance`]'s variables: get and set by value reference, each type
//! in its call, value-reference and value slices of one length, FMI 3.0 array elements
//! addressed one by one (the FMU gets and sets their arrays whole).

use crate::backend::{self, Backend, Calls};
use crate::{FmuError, Instance, VarType};

/// Panics unless a value-reference slice and a value slice have the same length (the C
/// calls trust the lengths they are given).
fn same_length(call: &str, vrs: usize, values: usize) {
    assert_eq!(vrs, values, "{call}: value references and values differ in length");
}

impl Instance {
    /// `fmi2SetReal` / `fmi3SetFloat64`. The references may include FMI 3.0 array
    /// elements' handles ([`ArrayElement`]): see [`Instance::set_values`].
    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Result<(), FmuError> {
        same_length("set_real", vrs.len(), values.len());
        self.set_values(
            vrs,
            values,
            |b, cx, v, x| b.get_f64(cx, v, x),
            |b, cx, v, x| b.set_f64(cx, v, x),
        )
    }

    /// `fmi2GetReal` / `fmi3GetFloat64`, array elements included ([`Instance::get_values`]).
    pub fn get_real(&mut self, vrs: &[u32], values: &mut [f64]) -> Result<(), FmuError> {
        same_length("get_real", vrs.len(), values.len());
        self.get_values(vrs, values, |b, cx, v, x| b.get_f64(cx, v, x))
    }

    /// `fmi2GetInteger` / `fmi3GetInt32`, array elements included.
    pub fn get_integer(&mut self, vrs: &[u32], values: &mut [i32]) -> Result<(), FmuError> {
        same_length("get_integer", vrs.len(), values.len());
        self.get_values(vrs, values, |b, cx, v, x| b.get_i32(cx, v, x))
    }

    /// `fmi2SetInteger` / `fmi3SetInt32`, array elements included.
    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Result<(), FmuError> {
        same_length("set_integer", vrs.len(), values.len());
        self.set_values(
            vrs,
            values,
            |b, cx, v, x| b.get_i32(cx, v, x),
            |b, cx, v, x| b.set_i32(cx, v, x),
        )
    }

    /// `fmi2SetBoolean` / `fmi3SetBoolean`, array elements included.
    pub fn set_boolean(&mut self, vrs: &[u32], values: &[bool]) -> Result<(), FmuError> {
        same_length("set_boolean", vrs.len(), values.len());
        self.set_values(
            vrs,
            values,
            |b, cx, v, x| b.get_bool(cx, v, x),
            |b, cx, v, x| b.set_bool(cx, v, x),
        )
    }

    /// `fmi2GetBoolean` / `fmi3GetBoolean`, array elements included.
    pub fn get_boolean(&mut self, vrs: &[u32], values: &mut [bool]) -> Result<(), FmuError> {
        same_length("get_boolean", vrs.len(), values.len());
        self.get_values(vrs, values, |b, cx, v, x| b.get_bool(cx, v, x))
    }

    /// Whether `vrs` name no FMI 3.0 array element: then they go to the FMU as they are.
    fn all_scalars(&self, vrs: &[u32]) -> bool {
        vrs.iter().all(|&r| r < self.lowest_handle || !self.elements.contains_key(&r))
    }

    /// Reads `vrs` with `get`: the scalars in one call, then each array with an element
    /// among them in one call of all its values (FMI 3.0 gets an array whole), from which
    /// the elements are taken. `get` (and `set` below) is a closure of its own type at
    /// each caller, not a function pointer: on the path of every value of every step, the
    /// backend is then called directly.
    fn get_values<T: Copy + Default>(
        &mut self,
        vrs: &[u32],
        values: &mut [T],
        get: impl Fn(&mut dyn Backend, &mut Calls, &[u32], &mut [T]) -> Result<(), FmuError>,
    ) -> Result<(), FmuError> {
        if self.all_scalars(vrs) {
            return get(&mut **self.backend, &mut self.cx, vrs, values);
        }
        let (scalar_vrs, at): (Vec<u32>, Vec<usize>) = vrs
            .iter()
            .enumerate()
            .filter(|(_, r)| !self.elements.contains_key(r))
            .map(|(i, r)| (*r, i))
            .unzip();
        if !scalar_vrs.is_empty() {
            let mut got = vec![T::default(); scalar_vrs.len()];
            get(&mut **self.backend, &mut self.cx, &scalar_vrs, &mut got)?;
            for (i, v) in at.into_iter().zip(got) {
                values[i] = v;
            }
        }
        for (array_vr, len) in self.arrays_among(vrs) {
            let mut whole = vec![T::default(); len as usize];
            get(&mut **self.backend, &mut self.cx, &[array_vr], &mut whole)?;
            for (i, r) in vrs.iter().enumerate() {
                match self.elements.get(r) {
                    Some(e) if e.array_vr == array_vr => values[i] = whole[e.index as usize],
                    _ => {}
                }
            }
        }
        Ok(())
    }

    /// Writes `vrs` with `set`: the scalars in one call, then each array with an element
    /// among them read whole with `get`, its elements replaced, and written whole (so an
    /// element is set where the FMU allows getting its array: FMI 3.0 Initialization Mode
    /// and after, where a master sets parameters).
    fn set_values<T: Copy + Default>(
        &mut self,
        vrs: &[u32],
        values: &[T],
        get: impl Fn(&mut dyn Backend, &mut Calls, &[u32], &mut [T]) -> Result<(), FmuError>,
        set: impl Fn(&mut dyn Backend, &mut Calls, &[u32], &[T]) -> Result<(), FmuError>,
    ) -> Result<(), FmuError> {
        if self.all_scalars(vrs) {
            return set(&mut **self.backend, &mut self.cx, vrs, values);
        }
        let (scalar_vrs, scalar_values): (Vec<u32>, Vec<T>) = vrs
            .iter()
            .zip(values)
            .filter(|(r, _)| !self.elements.contains_key(r))
            .map(|(r, v)| (*r, *v))
            .unzip();
        if !scalar_vrs.is_empty() {
            set(&mut **self.backend, &mut self.cx, &scalar_vrs, &scalar_values)?;
        }
        for (array_vr, len) in self.arrays_among(vrs) {
            let mut whole = vec![T::default(); len as usize];
            get(&mut **self.backend, &mut self.cx, &[array_vr], &mut whole)?;
            for (r, v) in vrs.iter().zip(values) {
                match self.elements.get(r) {
                    Some(e) if e.array_vr == array_vr => whole[e.index as usize] = *v,
                    _ => {}
                }
            }
            set(&mut **self.backend, &mut self.cx, &[array_vr], &whole)?;
        }
        Ok(())
    }

    /// The arrays (value reference, length) that elements among `vrs` belong to, each once.
    fn arrays_among(&self, vrs: &[u32]) -> Vec<(u32, u32)> {
        let mut arrays: Vec<(u32, u32)> = Vec::new();
        for e in vrs.iter().filter_map(|r| self.elements.get(r)) {
            if !arrays.iter().any(|a| a.0 == e.array_vr) {
                arrays.push((e.array_vr, e.len));
            }
        }
        arrays
    }

    /// `fmi2SetString` / `fmi3SetString`.
    pub fn set_string(&mut self, vrs: &[u32], values: &[&str]) -> Result<(), FmuError> {
        same_length("set_string", vrs.len(), values.len());
        let f = self.cx.named("fmi2SetString", "fmi3SetString");
        let owned = self.cx.c_strings(f, "a string value", values)?;
        self.backend.set_string(&mut self.cx, vrs, &backend::pointers(&owned))
    }

    /// `fmi2GetString` / `fmi3GetString`; the strings are copied.
    pub fn get_string(&mut self, vrs: &[u32], values: &mut [String]) -> Result<(), FmuError> {
        same_length("get_string", vrs.len(), values.len());
        let mut raw = vec![std::ptr::null(); vrs.len()];
        self.backend.get_string(&mut self.cx, vrs, &mut raw)?;
        backend::copy_strings(&raw, values);
        Ok(())
    }

    /// Reads one Real variable by name (parameters included).
    pub fn real(&mut self, name: &str) -> Result<f64, FmuError> {
        let vr = self.var_of(name, VarType::Real)?.vr;
        let mut v = [0.0];
        self.get_real(&[vr], &mut v)?;
        Ok(v[0])
    }
}
