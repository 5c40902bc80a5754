//! A tolerant FMI 2.0 and FMI 3.0 Co-Simulation import layer: loads any vendor's FMU,
//! finds variables by name, and says what went wrong and where when a file, name or
//! value is bad. Both standards go through the same code up to the C calls:
//!
//! * [`archive`] unpacks the FMU into a fresh temporary directory (zip-slip-safe, capped),
//!   removed when the [`CsFmu`] is dropped;
//! * [`description`] reads `modelDescription.xml` of either standard into one
//!   [`ModelDescription`] with one strict reader (line/column errors, a truncated file
//!   refused, duplicate names, numbers, `modelIdentifier` a plain file name, a size cap);
//! * `binary` finds `binaries/<platform>/<modelIdentifier>.<ext>` (FMI 2.0 folder or FMI
//!   3.0 tuple), checks an ELF file whole and loads it;
//! * `backend` calls it: `Fmi2Backend` the `fmi2*` functions, `Fmi3Backend` the `fmi3*`
//!   ones, each natively, behind one trait;
//! * the FMU's log messages arrive as `log` records whose target is the instance name
//!   (level by status: OK → info, Warning → warn, Discard/Error/Fatal → error), prefixed
//!   by the log category (FMI 2.0's C-variadic logger is formatted in `logger.c`).
//!
//! On top, [`CsFmu`] adds what a master needs: variables looked up by name with their
//! type checked, value-reference/value slices that always have matching lengths (the raw
//! calls trust the caller on that), the communication time kept as `start + k · h` so it
//! never drifts from the FMU's own clock, FMU state save/restore/serialize, and errors
//! that name the FMU, the real C function (`fmi2DoStep`, `fmi3GetFloat64`, …) and the
//! time. Warning lets the call succeed (with a warning logged); Discard, Error, Fatal and
//! (FMI 2.0) Pending are errors; after Fatal every further call is refused, as both
//! standards demand.

pub mod archive;
mod backend;
mod binary;
pub mod description;
mod error;
mod ffi;
mod logger;
mod model_exchange;

use std::collections::HashMap;
use std::mem::ManuallyDrop;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

pub use backend::me::EventUpdate;
pub use binary::{fmi2_platform, fmi3_platform};
pub use description::{
    ArrayElement, Causality, CoSimulation, ContinuousState, DefaultExperiment, Initial,
    ModelDescription, ModelExchange, VarType, Variability, Variable,
};
pub use error::{FmuError, ImportError, Status};
pub use model_exchange::{Loaded, MeFmu};

use archive::Unpacked;
use backend::fmi2::Fmi2Backend;
use backend::fmi3::Fmi3Backend;
use backend::{Backend, Calls, Experiment, Plain, RawState, Setup};
use binary::Binary;

/// A variable resolved against the model description.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Var {
    pub vr: u32,
    pub ty: VarType,
}

/// A saved FMU state, held by the [`CsFmu`] it was taken from and addressed by this handle.
/// The FMU's memory is freed by [`CsFmu::free_state`] or, at the latest, when the `CsFmu`
/// is dropped (before its instance is freed), so a state never outlives its instance; a
/// handle used with another `CsFmu`, or after it was freed, is refused.
#[derive(Debug, PartialEq, Eq, Hash)]
pub struct FmuState {
    owner: u64,
    id: u64,
}

/// What a state holds besides the FMU's own: the communication grid at the time it was
/// taken, so that the time after a restore is the time of the state.
#[derive(Clone, Copy)]
struct Saved {
    raw: RawState,
    start_time: f64,
    steps_done: u64,
    step_size: f64,
}

/// The first bytes of a serialized state, then version 1's grid: start time, steps done,
/// step size (little-endian), then the FMU's own bytes.
const STATE_MAGIC: &[u8; 8] = b"IWSTATE1";
const STATE_HEADER: usize = 8 + 3 * 8;

static NEXT_OWNER: AtomicU64 = AtomicU64::new(1);

/// One instantiated Co-Simulation FMU (FMI 2.0 or 3.0), stepped with a fixed
/// communication step.
pub struct CsFmu {
    cx: Calls,
    // Dropped by hand: after a Fatal it is leaked, as neither standard allows freeing.
    backend: ManuallyDrop<Box<dyn Backend>>,
    description: ModelDescription,
    owner: u64,
    states: HashMap<u64, Saved>,
    next_state: u64,
    /// The handles of FMI 3.0 array elements ([`ArrayElement`]), by handle.
    elements: HashMap<u32, ArrayElement>,
    /// The smallest element handle (`u32::MAX` with none): the handles count down from
    /// the top, so a reference below it is a scalar without a lookup.
    lowest_handle: u32,
    // Last: the unpacked directory goes after the library is unloaded. Shared by the
    // instances made with `instantiate_again`; removed with the last of them.
    unpacked: Arc<Unpacked>,
}

impl Drop for CsFmu {
    fn drop(&mut self) {
        if self.cx.fatal.is_some() {
            // After a Fatal no function may be called, the free functions included. The
            // instance, its states, the memory it may point to and the code it may still
            // run are left in place; only the unpacked files are removed.
            return;
        }
        for (_, saved) in std::mem::take(&mut self.states) {
            // A refusal here has nowhere to go; the instance is freed next either way.
            let _ = self.backend.states().free(&mut self.cx, saved.raw);
        }
        if self.cx.fatal.is_some() {
            // A free returned Fatal: the instance must not be freed either.
            return;
        }
        // SAFETY: dropped once, here; frees the instance, then what it pointed to, then
        // unloads the library.
        unsafe { ManuallyDrop::drop(&mut self.backend) };
    }
}

impl std::fmt::Debug for CsFmu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CsFmu")
            .field("model", &self.cx.model)
            .field("instance", &self.cx.instance)
            .field("fmi_version", &self.description.fmi_version)
            .field("library", &self.backend.instance().binary.full_path)
            .field("time", &self.time())
            .finish_non_exhaustive()
    }
}

/// Panics unless a value-reference slice and a value slice have the same length (the C
/// calls trust the lengths they are given).
fn same_length(call: &str, vrs: usize, values: usize) {
    assert_eq!(vrs, values, "{call}: value references and values differ in length");
}

impl CsFmu {
    /// Unpacks `path`, loads its library (`binaries/<platform>/` of FMI 2.0 or FMI 3.0, by
    /// the description's `fmiVersion`) and instantiates it for Co-Simulation under
    /// `instance_name`. `logging_on` is the FMI `loggingOn` flag (debug messages);
    /// warnings and errors reach the logger either way.
    pub fn load(path: &Path, instance_name: &str, logging_on: bool) -> Result<Self, FmuError> {
        if !path.is_file() {
            return Err(FmuError::Missing(path.to_path_buf()));
        }
        let import = |source: ImportError| FmuError::Import { path: path.to_path_buf(), source };
        let unpacked = archive::unpack(path).map_err(import)?;
        Self::from_unpacked(path, Arc::new(unpacked), instance_name, (logging_on, |_| false))
    }

    /// Whether [`CsFmu::instantiate_again`] may make more instances from this one's
    /// unpacked folder and library: not for an FMU that declares
    /// `canBeInstantiatedOnlyOncePerProcess`, whose every instance needs a library of its
    /// own (a copy unpacked apart, as [`CsFmu::load`] makes).
    pub fn can_instantiate_again(&self) -> bool {
        let md = &self.description;
        let once = if self.is_model_exchange() {
            md.model_exchange.as_ref().map(|me| me.can_be_instantiated_only_once_per_process)
        } else {
            md.co_simulation.as_ref().map(|cs| cs.can_be_instantiated_only_once_per_process)
        };
        once == Some(false)
    }

    /// Whether the instance was made for Model Exchange (by [`MeFmu::load`]).
    pub fn is_model_exchange(&self) -> bool {
        self.backend.me().is_some()
    }

    /// Another instance of the same FMU under `instance_name`, from the folder this one
    /// was unpacked in: a system that uses one FMU many times unpacks it once.
    pub fn instantiate_again(
        &self,
        instance_name: &str,
        logging_on: bool,
    ) -> Result<Self, FmuError> {
        if !self.can_instantiate_again() {
            return Err(FmuError::Import {
                path: self.unpacked.dir().to_path_buf(),
                source: ImportError::OncePerProcess { model: self.cx.model.clone() },
            });
        }
        let me = self.is_model_exchange();
        Self::from_unpacked(
            self.unpacked.dir(),
            Arc::clone(&self.unpacked),
            instance_name,
            (logging_on, |_| me),
        )
    }

    /// An instance for Model Exchange if `model_exchange` says so of the FMU's
    /// description, else for Co-Simulation; an interface the FMU lacks is refused.
    pub(crate) fn from_unpacked(
        path: &Path,
        unpacked: Arc<Unpacked>,
        instance_name: &str,
        (logging_on, model_exchange): (bool, impl FnOnce(&ModelDescription) -> bool),
    ) -> Result<Self, FmuError> {
        let import = |source: ImportError| FmuError::Import { path: path.to_path_buf(), source };
        let description = ModelDescription::parse(&unpacked.model_description).map_err(import)?;
        Self::from_description(
            path,
            unpacked,
            description,
            instance_name,
            (logging_on, model_exchange),
        )
    }

    /// [`CsFmu::from_unpacked`] with the description already read (from the archive,
    /// before it was unpacked).
    pub(crate) fn from_description(
        path: &Path,
        unpacked: Arc<Unpacked>,
        description: ModelDescription,
        instance_name: &str,
        (logging_on, model_exchange): (bool, impl FnOnce(&ModelDescription) -> bool),
    ) -> Result<Self, FmuError> {
        let import = |source: ImportError| FmuError::Import { path: path.to_path_buf(), source };
        let model = description.model_name.clone();
        let model_exchange = model_exchange(&description);
        let identifier = match (&description.co_simulation, &description.model_exchange) {
            (_, Some(me)) if model_exchange => &me.model_identifier,
            (Some(cs), _) if !model_exchange => &cs.model_identifier,
            _ if model_exchange => return Err(FmuError::NotModelExchange { model }),
            _ => return Err(FmuError::NotCoSimulation { model }),
        };
        let fmi3 = description.is_fmi3();
        let platform = if fmi3 { fmi3_platform() } else { fmi2_platform() };
        let library =
            binary::library_path_for(platform, unpacked.dir(), identifier).map_err(import)?;
        let binary = Binary::load(unpacked.dir(), &library).map_err(import)?;
        let resources = unpacked.dir().join("resources");
        let setup = Setup {
            md: &description,
            resources: &resources,
            instance_name,
            logging_on,
            model_exchange,
        };
        let backend: Box<dyn Backend> = if fmi3 {
            Box::new(Fmi3Backend::instantiate(binary, &setup).map_err(import)?)
        } else {
            Box::new(Fmi2Backend::instantiate(binary, &setup).map_err(import)?)
        };
        let elements: HashMap<u32, ArrayElement> =
            description.variables.iter().filter_map(|v| v.element.map(|e| (v.vr, e))).collect();
        Ok(CsFmu {
            cx: Calls::new(model, instance_name.to_owned(), fmi3),
            backend: ManuallyDrop::new(backend),
            description,
            lowest_handle: elements.keys().copied().min().unwrap_or(u32::MAX),
            elements,
            owner: NEXT_OWNER.fetch_add(1, Ordering::Relaxed),
            states: HashMap::new(),
            next_state: 0,
            unpacked,
        })
    }

    /// The model name from `modelDescription.xml`.
    pub fn model_name(&self) -> &str {
        &self.cx.model
    }

    /// The instance name given to [`CsFmu::load`] (the target of the FMU's log records).
    pub fn instance_name(&self) -> &str {
        &self.cx.instance
    }

    /// The `guid` attribute of `modelDescription.xml`.
    pub fn guid(&self) -> &str {
        &self.description.guid
    }

    /// The `fmiVersion` attribute of `modelDescription.xml` (2.x or 3.x).
    pub fn fmi_version(&self) -> &str {
        &self.description.fmi_version
    }

    /// What the binary's `fmi2GetVersion` / `fmi3GetVersion` returned.
    pub fn binary_version(&self) -> &str {
        &self.backend.instance().version
    }

    /// The path of the loaded library inside the unpacked FMU.
    pub fn library_path(&self) -> &Path {
        &self.backend.instance().binary.full_path
    }

    /// The directory the FMU is unpacked in (deleted on drop).
    pub fn unpacked_dir(&self) -> &Path {
        self.unpacked.dir()
    }

    /// The parsed `modelDescription.xml`.
    pub fn description(&self) -> &ModelDescription {
        &self.description
    }

    /// All scalar variables, in `modelDescription.xml` order.
    pub fn variables(&self) -> impl Iterator<Item = &Variable> + '_ {
        self.description.variables.iter()
    }

    /// The default experiment's step size, if the FMU declares one.
    pub fn default_step_size(&self) -> Option<f64> {
        self.description.default_experiment.and_then(|e| e.step_size)
    }

    /// Resolves a variable by name.
    pub fn var(&self, name: &str) -> Result<Var, FmuError> {
        let v = self.description.variable(name).ok_or_else(|| FmuError::UnknownVariable {
            model: self.cx.model.clone(),
            name: name.to_owned(),
        })?;
        Ok(Var { vr: v.vr, ty: v.ty })
    }

    /// Resolves a variable by name and checks its type (an Enumeration passes for an
    /// Integer: both go through `fmi2Get/SetInteger`; FMI 3.0 Enumerations are not addressed).
    pub fn var_of(&self, name: &str, expected: VarType) -> Result<Var, FmuError> {
        let v = self.var(name)?;
        if v.ty != expected && !(expected == VarType::Integer && v.ty == VarType::Enumeration) {
            return Err(FmuError::WrongType {
                model: self.cx.model.clone(),
                name: name.to_owned(),
                expected,
                found: v.ty,
            });
        }
        Ok(v)
    }

    /// Resolves several variables of one type, in order.
    pub fn vrs_of(&self, names: &[&str], expected: VarType) -> Result<Vec<u32>, FmuError> {
        names.iter().map(|n| self.var_of(n, expected).map(|v| v.vr)).collect()
    }

    /// Causality of a variable by name ("input", "output", "parameter", …).
    pub fn causality(&self, name: &str) -> Option<String> {
        self.description.variable(name).map(|v| v.causality.as_str().to_owned())
    }

    /// Names of the variables with the given causality ("input", "output", …; any case).
    pub fn names_with_causality(&self, causality: &str) -> Vec<String> {
        self.variables()
            .filter(|v| v.causality.as_str().eq_ignore_ascii_case(causality))
            .map(|v| v.name.clone())
            .collect()
    }

    /// `fmi*SetDebugLogging`: debug logging on or off, for the given categories (all if
    /// empty).
    pub fn set_debug_logging(&mut self, on: bool, categories: &[&str]) -> Result<(), FmuError> {
        let f = self.cx.named("fmi2SetDebugLogging", "fmi3SetDebugLogging");
        let cats = self.cx.c_strings(f, "a category name", categories)?;
        self.backend.set_debug_logging(&mut self.cx, on, &backend::pointers(&cats))
    }

    /// FMI 2.0 `fmi2SetupExperiment` + `fmi2EnterInitializationMode`, FMI 3.0
    /// `fmi3EnterInitializationMode`: parameters and start values may be set after this and
    /// before [`CsFmu::exit_initialization`].
    pub fn enter_initialization(
        &mut self,
        tolerance: Option<f64>,
        start_time: f64,
        stop_time: Option<f64>,
    ) -> Result<(), FmuError> {
        self.cx.alive(self.cx.named("fmi2SetupExperiment", "fmi3EnterInitializationMode"))?;
        self.cx.start_time = start_time;
        self.cx.steps_done = 0;
        let e = Experiment { tolerance, start: start_time, stop: stop_time };
        self.backend.enter_initialization(&mut self.cx, e)
    }

    /// `fmi*ExitInitializationMode`: the FMU is ready to step from the start time.
    pub fn exit_initialization(&mut self) -> Result<(), FmuError> {
        self.backend.instance().call(&mut self.cx, Plain::ExitInitialization)
    }

    /// The current communication point, `start + k · h` after k steps of size h.
    pub fn time(&self) -> f64 {
        self.cx.time()
    }

    /// One `fmi*DoStep` of `h` seconds from the current communication point. The step
    /// size is fixed by the first step: the time is kept as `start + k · h` (not summed) so
    /// that it stays exactly on the grid the FMU compares it with.
    pub fn do_step(&mut self, h: f64) -> Result<(), FmuError> {
        self.cx.alive(self.cx.named("fmi2DoStep", "fmi3DoStep"))?;
        if self.cx.steps_done == 0 {
            self.cx.step_size = h;
        } else {
            assert_eq!(
                h, self.cx.step_size,
                "CsFmu::do_step: the communication step is fixed at the first step"
            );
        }
        let t = self.time();
        // While a state is held, the master may go back to it: the FMU must know.
        let no_prior = self.states.is_empty();
        self.backend.do_step(&mut self.cx, t, h, no_prior)?;
        self.cx.steps_done += 1;
        Ok(())
    }

    /// `fmi2SetReal` / `fmi3SetFloat64`. The references may include FMI 3.0 array
    /// elements' handles ([`ArrayElement`]): see [`CsFmu::set_values`].
    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Result<(), FmuError> {
        same_length("set_real", vrs.len(), values.len());
        self.set_values(
            vrs,
            values,
            |b, cx, v, x| b.get_f64(cx, v, x),
            |b, cx, v, x| b.set_f64(cx, v, x),
        )
    }

    /// `fmi2GetReal` / `fmi3GetFloat64`, array elements included ([`CsFmu::get_values`]).
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

    /// `fmi*Terminate`. The instance is freed when `self` is dropped.
    pub fn terminate(&mut self) -> Result<(), FmuError> {
        self.backend.instance().call(&mut self.cx, Plain::Terminate)
    }

    /// `fmi*Reset`: back to the state right after instantiation (the time grid restarts
    /// at the next [`CsFmu::enter_initialization`]). Saved states stay valid.
    pub fn reset(&mut self) -> Result<(), FmuError> {
        self.backend.instance().call(&mut self.cx, Plain::Reset)?;
        self.cx.steps_done = 0;
        self.cx.step_size = 0.0;
        Ok(())
    }

    /// `fmi2GetFMUstate` / `fmi3GetFMUState`: saves the FMU's state and the communication
    /// time. Fails with [`FmuError::Unsupported`] unless the FMU declares
    /// `canGetAndSetFMUstate` (FMI 2.0) / `canGetAndSetFMUState` (FMI 3.0).
    pub fn get_state(&mut self) -> Result<FmuState, FmuError> {
        let raw = self.backend.states().get(&mut self.cx)?;
        Ok(self.hold(raw))
    }

    /// `fmi2SetFMUstate` / `fmi3SetFMUState`: back to `state`, time included.
    pub fn set_state(&mut self, state: &FmuState) -> Result<(), FmuError> {
        let saved = self.saved(state, self.backend.states().names().set)?;
        self.backend.states().set(&mut self.cx, saved.raw)?;
        self.cx.start_time = saved.start_time;
        self.cx.steps_done = saved.steps_done;
        self.cx.step_size = saved.step_size;
        Ok(())
    }

    /// `fmi2FreeFMUstate` / `fmi3FreeFMUState`. Dropping the `CsFmu` frees the states
    /// still held.
    pub fn free_state(&mut self, state: FmuState) -> Result<(), FmuError> {
        let saved = self.saved(&state, self.backend.states().names().free)?;
        self.states.remove(&state.id);
        self.backend.states().free(&mut self.cx, saved.raw)
    }

    /// `fmi2SerializeFMUstate` / `fmi3SerializeFMUState` (with the size call first): the
    /// state as bytes, to be read back by [`CsFmu::deserialize_state`] of an instance of
    /// the same FMU. The bytes are a short header (the communication grid) and the FMU's
    /// own serialization.
    pub fn serialize_state(&mut self, state: &FmuState) -> Result<Vec<u8>, FmuError> {
        let saved = self.saved(state, self.backend.states().names().serialize)?;
        let fmu = self.backend.states().serialize(&mut self.cx, saved.raw)?;
        let mut out = Vec::with_capacity(STATE_HEADER + fmu.len());
        out.extend_from_slice(STATE_MAGIC);
        out.extend_from_slice(&saved.start_time.to_le_bytes());
        out.extend_from_slice(&saved.steps_done.to_le_bytes());
        out.extend_from_slice(&saved.step_size.to_le_bytes());
        out.extend_from_slice(&fmu);
        Ok(out)
    }

    /// `fmi2DeSerializeFMUstate` / `fmi3DeserializeFMUState`: a new state from bytes of
    /// [`CsFmu::serialize_state`]; [`CsFmu::set_state`] restores it.
    pub fn deserialize_state(&mut self, bytes: &[u8]) -> Result<FmuState, FmuError> {
        let f = self.backend.states().names().deserialize;
        self.cx.alive(f)?;
        let header = bytes.get(..STATE_HEADER).filter(|h| h.starts_with(STATE_MAGIC));
        let Some(header) = header else {
            return Err(self.cx.invalid(
                f,
                format!(
                    "{} bytes that are not a state serialized by this importer (no {} header)",
                    bytes.len(),
                    String::from_utf8_lossy(STATE_MAGIC)
                ),
            ));
        };
        let word = |i: usize| {
            let mut w = [0u8; 8];
            w.copy_from_slice(&header[8 + 8 * i..16 + 8 * i]);
            w
        };
        let (start_time, steps_done, step_size) =
            (f64::from_le_bytes(word(0)), u64::from_le_bytes(word(1)), f64::from_le_bytes(word(2)));
        if !(start_time.is_finite() && step_size.is_finite() && step_size >= 0.0) {
            return Err(self.cx.invalid(f, "the serialized communication grid is damaged"));
        }
        let raw = self.backend.states().deserialize(&mut self.cx, &bytes[STATE_HEADER..])?;
        let state = self.hold(raw);
        if let Some(s) = self.states.get_mut(&state.id) {
            (s.start_time, s.steps_done, s.step_size) = (start_time, steps_done, step_size);
        }
        Ok(state)
    }

    /// How many saved states this instance holds.
    pub fn states_held(&self) -> usize {
        self.states.len()
    }

    fn hold(&mut self, raw: RawState) -> FmuState {
        let id = self.next_state;
        self.next_state += 1;
        let (start_time, steps_done, step_size) =
            (self.cx.start_time, self.cx.steps_done, self.cx.step_size);
        self.states.insert(id, Saved { raw, start_time, steps_done, step_size });
        FmuState { owner: self.owner, id }
    }

    fn saved(&self, state: &FmuState, function: &'static str) -> Result<Saved, FmuError> {
        self.cx.alive(function)?;
        match self.states.get(&state.id) {
            Some(s) if state.owner == self.owner => Ok(*s),
            _ => Err(self
                .cx
                .invalid(function, "the state was not taken from this instance, or was freed")),
        }
    }
}
