//! A tolerant FMI 2.0 Co-Simulation import layer: loads any vendor's FMU, finds variables
//! by name, and says what went wrong and where when a file, name or value is bad.
//!
//! * [`archive`] unpacks the FMU into a fresh temporary directory (zip-slip-safe), removed
//!   when the [`CsFmu`] is dropped;
//! * [`description`] reads `modelDescription.xml` as XML events with `quick-xml`, skipping
//!   vendor annotations, unknown elements and unknown attributes as real FMUs carry them,
//!   and reporting a missing attribute, a bad number or a duplicate name with its line;
//! * `binary` loads `binaries/<platform>/<modelIdentifier>.<ext>` with `libloading` and
//!   resolves the `fmi2*` functions against the hand-written C types in `ffi`;
//! * the FMU's C-variadic logger callback is formatted in C (`logger.c`) and arrives as a
//!   `log` record whose target is the instance name (level by status: OK → info,
//!   Warning → warn, Discard/Error/Fatal → error), its text prefixed by the log category.
//!
//! On top, [`CsFmu`] adds what a master needs: variables looked up by name with their
//! type checked, value-reference/value slices that always have matching lengths (the raw
//! calls trust the caller on that), the communication time kept as `start + k · h` so it
//! never drifts from the FMU's own clock, and errors that name the FMU, the call and the
//! time. `fmi2Warning` lets the call succeed (with a warning logged); `fmi2Discard`,
//! `fmi2Error`, `fmi2Fatal` and `fmi2Pending` are errors; after `fmi2Fatal` every further
//! call is refused, as FMI 2.0 demands.

pub mod archive;
mod binary;
pub mod description;
mod error;
mod ffi;
mod fmi3;
mod logger;

use std::ffi::{CStr, CString};
use std::mem::ManuallyDrop;
use std::path::Path;

pub use binary::{fmi2_platform, fmi3_platform};
pub use description::{
    Causality, CoSimulation, DefaultExperiment, Initial, ModelDescription, VarType, Variability,
    Variable,
};
pub use error::{FmuError, ImportError, Status};

use archive::Unpacked;
use binary::{Api, Binary};
use ffi::*;
use logger::LogEnv;

/// A variable resolved against the model description.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Var {
    pub vr: u32,
    pub ty: VarType,
}

/// `file:///…` URI of a directory (FMI 2.0 `fmuResourceLocation`).
fn file_uri(dir: &Path) -> String {
    let path = dir.to_string_lossy().replace('\\', "/");
    let mut uri = String::from(if path.starts_with('/') { "file://" } else { "file:///" });
    for b in path.bytes() {
        if b.is_ascii_alphanumeric() || b"-._~/:".contains(&b) {
            uri.push(b as char);
        } else {
            uri.push_str(&format!("%{b:02X}"));
        }
    }
    uri
}

/// One instantiated Co-Simulation FMU, stepped with a fixed communication step.
pub struct CsFmu {
    component: fmi2Component,
    api: Api,
    model: String,
    instance_name: String,
    description: ModelDescription,
    start_time: f64,
    steps_done: u64,
    step_size: f64,
    /// The function that returned `fmi2Fatal`, if one did.
    fatal: Option<&'static str>,
    // What the FMU may hold pointers to until fmi2FreeInstance: freed in `Drop` after it.
    callbacks: ManuallyDrop<Box<fmi2CallbackFunctions>>,
    env: ManuallyDrop<Box<LogEnv>>,
    c_strings: ManuallyDrop<[CString; 3]>,
    binary: ManuallyDrop<Binary>,
    // Last: the unpacked directory goes after the library is unloaded.
    unpacked: Unpacked,
}

impl Drop for CsFmu {
    fn drop(&mut self) {
        if self.fatal.is_some() {
            // FMI 2.0: after fmi2Fatal no function may be called, fmi2FreeInstance
            // included. The instance, the memory it may point to and the code it may
            // still run are left in place; only the unpacked files are removed.
            return;
        }
        // SAFETY: `component` came from fmi2Instantiate of this library, is freed only
        // here, once; the callbacks, environment and strings it may use are still alive.
        unsafe { (self.api.free_instance)(self.component) };
        self.component = std::ptr::null_mut();
        // SAFETY: each is dropped once, here, after the instance is gone; the library is
        // unloaded last, once nothing points into it.
        unsafe {
            ManuallyDrop::drop(&mut self.callbacks);
            ManuallyDrop::drop(&mut self.env);
            ManuallyDrop::drop(&mut self.c_strings);
            ManuallyDrop::drop(&mut self.binary);
        }
    }
}

impl std::fmt::Debug for CsFmu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CsFmu")
            .field("model", &self.model)
            .field("instance", &self.instance_name)
            .field("library", &self.binary.path)
            .field("time", &self.time())
            .finish_non_exhaustive()
    }
}

impl CsFmu {
    /// Unpacks `path`, loads its `binaries/<platform>/` library and instantiates it for
    /// Co-Simulation under `instance_name`. `logging_on` is the FMI `loggingOn` flag
    /// (debug messages); warnings and errors reach the logger either way.
    pub fn load(path: &Path, instance_name: &str, logging_on: bool) -> Result<Self, FmuError> {
        if !path.is_file() {
            return Err(FmuError::Missing(path.to_path_buf()));
        }
        let import = |source: ImportError| FmuError::Import { path: path.to_path_buf(), source };
        let unpacked = archive::unpack(path).map_err(import)?;
        if fmi3::declares_fmi3(&unpacked.model_description) {
            return fmi3::load(path, unpacked, instance_name, logging_on);
        }
        let description = ModelDescription::parse(&unpacked.model_description).map_err(import)?;
        let model = description.model_name.clone();
        let Some(cs) = &description.co_simulation else {
            return Err(FmuError::NotCoSimulation { model });
        };
        let library = binary::library_path(unpacked.dir(), &cs.model_identifier).map_err(import)?;
        let binary = Binary::load(unpacked.dir(), &library).map_err(import)?;

        let nul = |what| import(ImportError::Nul { what });
        let c_name = CString::new(instance_name).map_err(|_| nul("the instance name"))?;
        let c_guid = CString::new(description.guid.as_str()).map_err(|_| nul("the guid"))?;
        let c_resources = CString::new(file_uri(&unpacked.dir().join("resources")))
            .map_err(|_| nul("the resource location"))?;
        let env = Box::new(LogEnv { instance: instance_name.to_owned() });
        let callbacks = Box::new(fmi2CallbackFunctions {
            logger: Some(logger::inchworm_fmi_import_logger),
            allocateMemory: Some(libc::calloc),
            freeMemory: Some(libc::free),
            stepFinished: None,
            componentEnvironment: &*env as *const LogEnv as *mut std::os::raw::c_void,
        });
        let api = binary.api;
        // SAFETY: the FMI 2.0 signature; every pointer passed lives until after
        // fmi2FreeInstance (owned by the returned CsFmu, dropped after the free).
        let component = unsafe {
            (api.instantiate)(
                c_name.as_ptr(),
                fmi2CoSimulation,
                c_guid.as_ptr(),
                c_resources.as_ptr(),
                &*callbacks,
                fmi2False,
                if logging_on { fmi2True } else { fmi2False },
            )
        };
        if component.is_null() {
            // Nothing to free; `binary`, `callbacks`, `env` drop here, the library last.
            drop(callbacks);
            drop(env);
            drop(binary);
            return Err(import(ImportError::Instantiate { instance: instance_name.to_owned() }));
        }
        Ok(CsFmu {
            component,
            api,
            model,
            instance_name: instance_name.to_owned(),
            description,
            start_time: 0.0,
            steps_done: 0,
            step_size: 0.0,
            fatal: None,
            callbacks: ManuallyDrop::new(callbacks),
            env: ManuallyDrop::new(env),
            c_strings: ManuallyDrop::new([c_name, c_guid, c_resources]),
            binary: ManuallyDrop::new(binary),
            unpacked,
        })
    }

    /// The model name from `modelDescription.xml`.
    pub fn model_name(&self) -> &str {
        &self.model
    }

    /// The instance name given to [`CsFmu::load`] (the target of the FMU's log records).
    pub fn instance_name(&self) -> &str {
        &self.instance_name
    }

    /// The `guid` attribute of `modelDescription.xml`.
    pub fn guid(&self) -> &str {
        &self.description.guid
    }

    /// The `fmiVersion` attribute of `modelDescription.xml` (2.x).
    pub fn fmi_version(&self) -> &str {
        &self.description.fmi_version
    }

    /// What the binary's `fmi2GetVersion` returned.
    pub fn binary_version(&self) -> &str {
        &self.binary.version
    }

    /// The path of the loaded library inside the unpacked FMU.
    pub fn library_path(&self) -> &Path {
        &self.binary.path
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
            model: self.model.clone(),
            name: name.to_owned(),
        })?;
        Ok(Var { vr: v.vr, ty: v.ty })
    }

    /// Resolves a variable by name and checks its type (an Enumeration passes for an
    /// Integer: both go through `fmi2Get/SetInteger`).
    pub fn var_of(&self, name: &str, expected: VarType) -> Result<Var, FmuError> {
        let v = self.var(name)?;
        if v.ty != expected && !(expected == VarType::Integer && v.ty == VarType::Enumeration) {
            return Err(FmuError::WrongType {
                model: self.model.clone(),
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

    fn alive(&self, function: &'static str) -> Result<(), FmuError> {
        match self.fatal {
            Some(fatal_in) => {
                Err(FmuError::AfterFatal { model: self.model.clone(), function, fatal_in })
            }
            None => Ok(()),
        }
    }

    fn check(&mut self, function: &'static str, raw: fmi2Status) -> Result<(), FmuError> {
        match Status::from_raw(raw) {
            Status::Ok => Ok(()),
            Status::Warning => {
                logger::emit(
                    log::Level::Warn,
                    &self.instance_name,
                    format_args!("{function} returned fmi2Warning at t = {} s", self.time()),
                );
                Ok(())
            }
            status => {
                if status == Status::Fatal {
                    self.fatal = Some(function);
                }
                Err(FmuError::Call {
                    model: self.model.clone(),
                    function,
                    time: self.time(),
                    status,
                })
            }
        }
    }

    /// `fmi2SetDebugLogging`: debug logging on or off, for the given categories (all if empty).
    pub fn set_debug_logging(&mut self, on: bool, categories: &[&str]) -> Result<(), FmuError> {
        const F: &str = "fmi2SetDebugLogging";
        self.alive(F)?;
        let cats =
            categories.iter().map(|c| CString::new(*c)).collect::<Result<Vec<_>, _>>().map_err(
                |_| FmuError::InvalidArgument {
                    model: self.model.clone(),
                    function: F,
                    message: "a category name contains a NUL byte".into(),
                },
            )?;
        let ptrs: Vec<fmi2String> = cats.iter().map(|c| c.as_ptr()).collect();
        // SAFETY: FMI 2.0 signature; the arrays live for the call.
        let s = unsafe {
            (self.api.set_debug_logging)(self.component, i32::from(on), ptrs.len(), ptrs.as_ptr())
        };
        self.check(F, s)
    }

    /// `fmi2SetupExperiment` + `fmi2EnterInitializationMode`: parameters and start values
    /// may be set after this and before [`CsFmu::exit_initialization`].
    pub fn enter_initialization(
        &mut self,
        tolerance: Option<f64>,
        start_time: f64,
        stop_time: Option<f64>,
    ) -> Result<(), FmuError> {
        self.alive("fmi2SetupExperiment")?;
        self.start_time = start_time;
        self.steps_done = 0;
        // SAFETY: FMI 2.0 signature, live component.
        let s = unsafe {
            (self.api.setup_experiment)(
                self.component,
                i32::from(tolerance.is_some()),
                tolerance.unwrap_or(0.0),
                start_time,
                i32::from(stop_time.is_some()),
                stop_time.unwrap_or(0.0),
            )
        };
        self.check("fmi2SetupExperiment", s)?;
        // SAFETY: as above.
        let s = unsafe { (self.api.enter_initialization_mode)(self.component) };
        self.check("fmi2EnterInitializationMode", s)
    }

    /// `fmi2ExitInitializationMode`: the FMU is ready to step from the start time.
    pub fn exit_initialization(&mut self) -> Result<(), FmuError> {
        self.alive("fmi2ExitInitializationMode")?;
        // SAFETY: FMI 2.0 signature, live component.
        let s = unsafe { (self.api.exit_initialization_mode)(self.component) };
        self.check("fmi2ExitInitializationMode", s)
    }

    /// The current communication point, `start + k · h` after k steps of size h.
    pub fn time(&self) -> f64 {
        self.start_time + self.steps_done as f64 * self.step_size
    }

    /// One `fmi2DoStep` of `h` seconds from the current communication point. The step
    /// size is fixed by the first step: the time is kept as `start + k · h` (not summed) so
    /// that it stays exactly on the grid the FMU compares it with.
    pub fn do_step(&mut self, h: f64) -> Result<(), FmuError> {
        self.alive("fmi2DoStep")?;
        if self.steps_done == 0 {
            self.step_size = h;
        } else {
            assert_eq!(
                h, self.step_size,
                "CsFmu::do_step: the communication step is fixed at the first step"
            );
        }
        let t = self.time();
        // SAFETY: FMI 2.0 signature, live component.
        let s = unsafe { (self.api.do_step)(self.component, t, h, fmi2True) };
        self.check("fmi2DoStep", s)?;
        self.steps_done += 1;
        Ok(())
    }

    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Result<(), FmuError> {
        assert_eq!(
            vrs.len(),
            values.len(),
            "set_real: value references and values differ in length"
        );
        self.alive("fmi2SetReal")?;
        // SAFETY: FMI 2.0 signature; both arrays hold vrs.len() elements.
        let s = unsafe {
            (self.api.set_real)(self.component, vrs.as_ptr(), vrs.len(), values.as_ptr())
        };
        self.check("fmi2SetReal", s)
    }

    pub fn get_real(&mut self, vrs: &[u32], values: &mut [f64]) -> Result<(), FmuError> {
        assert_eq!(
            vrs.len(),
            values.len(),
            "get_real: value references and values differ in length"
        );
        self.alive("fmi2GetReal")?;
        // SAFETY: as above.
        let s = unsafe {
            (self.api.get_real)(self.component, vrs.as_ptr(), vrs.len(), values.as_mut_ptr())
        };
        self.check("fmi2GetReal", s)
    }

    pub fn get_integer(&mut self, vrs: &[u32], values: &mut [i32]) -> Result<(), FmuError> {
        assert_eq!(
            vrs.len(),
            values.len(),
            "get_integer: value references and values differ in length"
        );
        self.alive("fmi2GetInteger")?;
        // SAFETY: as above.
        let s = unsafe {
            (self.api.get_integer)(self.component, vrs.as_ptr(), vrs.len(), values.as_mut_ptr())
        };
        self.check("fmi2GetInteger", s)
    }

    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Result<(), FmuError> {
        assert_eq!(
            vrs.len(),
            values.len(),
            "set_integer: value references and values differ in length"
        );
        self.alive("fmi2SetInteger")?;
        // SAFETY: as above.
        let s = unsafe {
            (self.api.set_integer)(self.component, vrs.as_ptr(), vrs.len(), values.as_ptr())
        };
        self.check("fmi2SetInteger", s)
    }

    pub fn set_boolean(&mut self, vrs: &[u32], values: &[bool]) -> Result<(), FmuError> {
        assert_eq!(
            vrs.len(),
            values.len(),
            "set_boolean: value references and values differ in length"
        );
        self.alive("fmi2SetBoolean")?;
        let raw: Vec<fmi2Boolean> = values.iter().map(|&b| i32::from(b)).collect();
        // SAFETY: as above.
        let s = unsafe {
            (self.api.set_boolean)(self.component, vrs.as_ptr(), vrs.len(), raw.as_ptr())
        };
        self.check("fmi2SetBoolean", s)
    }

    pub fn get_boolean(&mut self, vrs: &[u32], values: &mut [bool]) -> Result<(), FmuError> {
        assert_eq!(
            vrs.len(),
            values.len(),
            "get_boolean: value references and values differ in length"
        );
        self.alive("fmi2GetBoolean")?;
        let mut raw = vec![0 as fmi2Boolean; vrs.len()];
        // SAFETY: as above.
        let s = unsafe {
            (self.api.get_boolean)(self.component, vrs.as_ptr(), vrs.len(), raw.as_mut_ptr())
        };
        self.check("fmi2GetBoolean", s)?;
        for (v, r) in values.iter_mut().zip(raw) {
            *v = r != 0;
        }
        Ok(())
    }

    pub fn set_string(&mut self, vrs: &[u32], values: &[&str]) -> Result<(), FmuError> {
        const F: &str = "fmi2SetString";
        assert_eq!(
            vrs.len(),
            values.len(),
            "set_string: value references and values differ in length"
        );
        self.alive(F)?;
        let owned =
            values.iter().map(|v| CString::new(*v)).collect::<Result<Vec<_>, _>>().map_err(
                |_| FmuError::InvalidArgument {
                    model: self.model.clone(),
                    function: F,
                    message: "a string value contains a NUL byte".into(),
                },
            )?;
        let ptrs: Vec<fmi2String> = owned.iter().map(|c| c.as_ptr()).collect();
        // SAFETY: as above; the strings live for the call (the FMU copies them).
        let s = unsafe {
            (self.api.set_string)(self.component, vrs.as_ptr(), vrs.len(), ptrs.as_ptr())
        };
        self.check(F, s)
    }

    pub fn get_string(&mut self, vrs: &[u32], values: &mut [String]) -> Result<(), FmuError> {
        assert_eq!(
            vrs.len(),
            values.len(),
            "get_string: value references and values differ in length"
        );
        self.alive("fmi2GetString")?;
        let mut raw: Vec<fmi2String> = vec![std::ptr::null(); vrs.len()];
        // SAFETY: as above.
        let s = unsafe {
            (self.api.get_string)(self.component, vrs.as_ptr(), vrs.len(), raw.as_mut_ptr())
        };
        self.check("fmi2GetString", s)?;
        for (v, p) in values.iter_mut().zip(raw) {
            // SAFETY: the FMU's strings are valid until its next call; copied right away.
            *v = if p.is_null() {
                String::new()
            } else {
                unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
            };
        }
        Ok(())
    }

    /// Reads one Real variable by name (parameters included).
    pub fn real(&mut self, name: &str) -> Result<f64, FmuError> {
        let vr = self.var_of(name, VarType::Real)?.vr;
        let mut v = [0.0];
        self.get_real(&[vr], &mut v)?;
        Ok(v[0])
    }

    /// `fmi2Terminate`. The instance is freed when `self` is dropped.
    pub fn terminate(&mut self) -> Result<(), FmuError> {
        self.alive("fmi2Terminate")?;
        // SAFETY: FMI 2.0 signature, live component.
        let s = unsafe { (self.api.terminate)(self.component) };
        self.check("fmi2Terminate", s)
    }

    /// `fmi2Reset`: back to the state right after instantiation (the time grid restarts
    /// at the next [`CsFmu::enter_initialization`]).
    pub fn reset(&mut self) -> Result<(), FmuError> {
        self.alive("fmi2Reset")?;
        // SAFETY: FMI 2.0 signature, live component.
        let s = unsafe { (self.api.reset)(self.component) };
        self.check("fmi2Reset", s)?;
        self.steps_done = 0;
        self.step_size = 0.0;
        Ok(())
    }
}
