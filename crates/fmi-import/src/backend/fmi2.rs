//! FMI 2.0 Co-Simulation, natively: the `fmi2*` functions with their own signatures and
//! `fmi2Status`, the C-variadic logger of `logger.c`, the `fmi2CallbackFunctions` the
//! instance keeps pointers to.

use std::ffi::CString;
use std::os::raw::c_char;
use std::path::Path;

use super::clocks::StepEnd;
use super::state::{StateCalls, States};
use super::{Backend, Calls, Common, Done, Experiment, Instance, Setup};
use crate::binary::Binary;
use crate::ffi::*;
use crate::logger::{self, LogEnv};
use crate::FmuError;
use crate::{ImportError, Status};

/// The FMI 2.0 functions this layer calls; all of the CS API's required ones are resolved
/// (a binary missing one is refused up front).
struct Api {
    set_debug_logging: fmi2SetDebugLoggingTYPE,
    setup_experiment: fmi2SetupExperimentTYPE,
    enter_initialization_mode: fmi2EnterInitializationModeTYPE,
    get_real: fmi2GetRealTYPE,
    get_integer: fmi2GetIntegerTYPE,
    get_boolean: fmi2GetBooleanTYPE,
    get_string: fmi2GetStringTYPE,
    set_real: fmi2SetRealTYPE,
    set_integer: fmi2SetIntegerTYPE,
    set_boolean: fmi2SetBooleanTYPE,
    set_string: fmi2SetStringTYPE,
    /// `None` for a Model Exchange instance.
    do_step: Option<fmi2DoStepTYPE>,
}

/// The functions the FMI 2.0 Co-Simulation API requires (of a Co-Simulation instance) besides those in [`Api`] and [`super::FMI2_NAMES`]: resolved
/// so that an incomplete binary is refused at load, not at its first use.
const ALSO_REQUIRED: [&str; 6] = [
    "fmi2CancelStep",
    "fmi2GetStatus",
    "fmi2GetRealStatus",
    "fmi2GetIntegerStatus",
    "fmi2GetBooleanStatus",
    "fmi2GetStringStatus",
];

pub(crate) struct Fmi2Backend {
    // First: freed before what it may point to.
    instance: Instance,
    api: Api,
    states: States<fmi2Byte>,
    me: Option<super::me::Me>,
    /// The `fmi2Boolean`s (C ints) of a Boolean call, kept from call to call so that a
    /// master's steady loop allocates nothing.
    booleans: Vec<fmi2Boolean>,
    // What the FMU may hold pointers to until fmi2FreeInstance; dropped after it.
    _callbacks: Box<fmi2CallbackFunctions>,
    _env: Box<LogEnv>,
    _strings: [CString; 3],
}

fn status(raw: fmi2Status) -> Status {
    Status::from_raw(raw)
}

impl Fmi2Backend {
    /// Resolves the `fmi2*` functions of `binary`, checks its platform and version and
    /// instantiates it for Co-Simulation.
    pub fn instantiate(binary: Binary, setup: &Setup<'_>) -> Result<Fmi2Backend, ImportError> {
        let Setup { md, resources, instance_name, logging_on, .. } = *setup;
        let model_exchange = setup.model_exchange();
        // SAFETY: each type is the FMI 2.0 signature of the function named.
        let (api, instantiate, types_platform, get_version, common, mut me) = unsafe {
            let instantiate: fmi2InstantiateTYPE =
                binary.required(super::FMI2_NAMES.instantiate)?;
            let me = super::me::Me::for_setup(&binary, setup, status)?;
            if !model_exchange {
                for name in ALSO_REQUIRED {
                    binary.required::<fmi2CancelStepTYPE>(name)?;
                }
            }
            let common = Common::<fmi2Byte>::resolve(&binary, &super::FMI2_NAMES, status, setup)?;
            let api = Api {
                set_debug_logging: binary.required("fmi2SetDebugLogging")?,
                setup_experiment: binary.required("fmi2SetupExperiment")?,
                enter_initialization_mode: binary.required("fmi2EnterInitializationMode")?,
                get_real: binary.required("fmi2GetReal")?,
                get_integer: binary.required("fmi2GetInteger")?,
                get_boolean: binary.required("fmi2GetBoolean")?,
                get_string: binary.required("fmi2GetString")?,
                set_real: binary.required("fmi2SetReal")?,
                set_integer: binary.required("fmi2SetInteger")?,
                set_boolean: binary.required("fmi2SetBoolean")?,
                set_string: binary.required("fmi2SetString")?,
                do_step: if model_exchange { None } else { Some(binary.required("fmi2DoStep")?) },
            };
            let types_platform: fmi2GetTypesPlatformTYPE =
                binary.required("fmi2GetTypesPlatform")?;
            let get_version: fmi2GetVersionTYPE = binary.required("fmi2GetVersion")?;
            (api, instantiate, types_platform, get_version, common, me)
        };
        // SAFETY: both return a static NUL-terminated string.
        let platform = crate::binary::c_text(unsafe { types_platform() });
        if platform != "default" {
            return Err(ImportError::TypesPlatform(platform));
        }
        let version = Binary::check_version("fmi2GetVersion", unsafe { get_version() }, "2.")?;

        let nul = |what| ImportError::Nul { what };
        let c_name = CString::new(instance_name).map_err(|_| nul("the instance name"))?;
        let c_guid = CString::new(md.guid.as_str()).map_err(|_| nul("the guid"))?;
        let c_resources =
            CString::new(file_uri(resources)).map_err(|_| nul("the resource location"))?;
        let env = Box::new(LogEnv::new(instance_name));
        let callbacks = Box::new(fmi2CallbackFunctions {
            logger: Some(logger::inchworm_fmi_import_logger),
            allocateMemory: Some(libc::calloc),
            freeMemory: Some(libc::free),
            stepFinished: None,
            componentEnvironment: &*env as *const LogEnv as *mut std::os::raw::c_void,
        });
        // SAFETY: the FMI 2.0 signature; every pointer passed lives in the backend, which
        // frees the instance before dropping them.
        let component = unsafe {
            instantiate(
                c_name.as_ptr(),
                if model_exchange { fmi2ModelExchange } else { fmi2CoSimulation },
                c_guid.as_ptr(),
                c_resources.as_ptr(),
                &*callbacks,
                fmi2False,
                fmi2Boolean::from(logging_on),
            )
        };
        let (instance, states) = common.finish(component, (binary, version), status, setup)?;
        if let Some(me) = me.as_mut() {
            me.bind(instance.ptr());
        }
        Ok(Fmi2Backend {
            instance,
            states,
            me,
            api,
            booleans: Vec::new(),
            _callbacks: callbacks,
            _env: env,
            _strings: [c_name, c_guid, c_resources],
        })
    }
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

// SAFETY of every call below: FMI 2.0 signatures, a live component (freed only when the backend
// is dropped), and arrays of the lengths passed (CsFmu checks vrs and values
// have equal lengths).
impl Backend for Fmi2Backend {
    fn set_debug_logging(&mut self, cx: &mut Calls, on: bool, p: &[*const c_char]) -> Done {
        const F: &str = "fmi2SetDebugLogging";
        let (c, f) = (self.instance.ptr(), self.api.set_debug_logging);
        cx.call(F, || status(unsafe { f(c, fmi2Boolean::from(on), p.len(), p.as_ptr()) }))
    }

    fn enter_initialization(&mut self, cx: &mut Calls, e: Experiment) -> Done {
        let Experiment { tolerance, start, stop } = e;
        let (c, setup, enter) =
            (self.instance.ptr(), self.api.setup_experiment, self.api.enter_initialization_mode);
        cx.call("fmi2SetupExperiment", || {
            status(unsafe {
                setup(
                    c,
                    fmi2Boolean::from(tolerance.is_some()),
                    tolerance.unwrap_or(0.0),
                    start,
                    fmi2Boolean::from(stop.is_some()),
                    stop.unwrap_or(0.0),
                )
            })
        })?;
        cx.call("fmi2EnterInitializationMode", || status(unsafe { enter(c) }))
    }

    fn do_step(
        &mut self,
        cx: &mut Calls,
        t: f64,
        h: f64,
        no_prior: bool,
    ) -> Result<StepEnd, FmuError> {
        let c = self.instance.ptr();
        let f = self.api.do_step.ok_or_else(|| cx.other_interface("fmi2DoStep", true))?;
        cx.call("fmi2DoStep", || status(unsafe { f(c, t, h, fmi2Boolean::from(no_prior)) }))?;
        Ok(StepEnd { last_successful_time: t + h, ..StepEnd::default() })
    }

    fn get_f64(&mut self, cx: &mut Calls, vrs: &[u32], out: &mut [f64]) -> Done {
        let (c, f) = (self.instance.ptr(), self.api.get_real);
        cx.call("fmi2GetReal", || {
            status(unsafe { f(c, vrs.as_ptr(), vrs.len(), out.as_mut_ptr()) })
        })
    }

    fn set_f64(&mut self, cx: &mut Calls, vrs: &[u32], values: &[f64]) -> Done {
        let (c, f) = (self.instance.ptr(), self.api.set_real);
        cx.call("fmi2SetReal", || status(unsafe { f(c, vrs.as_ptr(), vrs.len(), values.as_ptr()) }))
    }

    fn get_i32(&mut self, cx: &mut Calls, vrs: &[u32], out: &mut [i32]) -> Done {
        let (c, f) = (self.instance.ptr(), self.api.get_integer);
        cx.call("fmi2GetInteger", || {
            status(unsafe { f(c, vrs.as_ptr(), vrs.len(), out.as_mut_ptr()) })
        })
    }

    fn set_i32(&mut self, cx: &mut Calls, vrs: &[u32], values: &[i32]) -> Done {
        let (c, f) = (self.instance.ptr(), self.api.set_integer);
        cx.call("fmi2SetInteger", || {
            status(unsafe { f(c, vrs.as_ptr(), vrs.len(), values.as_ptr()) })
        })
    }

    fn get_bool(&mut self, cx: &mut Calls, vrs: &[u32], out: &mut [bool]) -> Done {
        // fmi2Boolean is an int: read as such, any non-zero value is true.
        let (c, f) = (self.instance.ptr(), self.api.get_boolean);
        let raw = &mut self.booleans;
        raw.clear();
        raw.resize(vrs.len(), fmi2False);
        cx.call("fmi2GetBoolean", || {
            status(unsafe { f(c, vrs.as_ptr(), vrs.len(), raw.as_mut_ptr()) })
        })?;
        for (v, &r) in out.iter_mut().zip(raw.iter()) {
            *v = r != fmi2False;
        }
        Ok(())
    }

    fn set_bool(&mut self, cx: &mut Calls, vrs: &[u32], values: &[bool]) -> Done {
        let (c, f) = (self.instance.ptr(), self.api.set_boolean);
        let raw = &mut self.booleans;
        raw.clear();
        raw.extend(values.iter().map(|&b| fmi2Boolean::from(b)));
        cx.call("fmi2SetBoolean", || status(unsafe { f(c, vrs.as_ptr(), vrs.len(), raw.as_ptr()) }))
    }

    fn get_string(&mut self, cx: &mut Calls, vrs: &[u32], raw: &mut [*const c_char]) -> Done {
        let (c, f) = (self.instance.ptr(), self.api.get_string);
        cx.call("fmi2GetString", || {
            status(unsafe { f(c, vrs.as_ptr(), vrs.len(), raw.as_mut_ptr()) })
        })
    }

    fn set_string(&mut self, cx: &mut Calls, vrs: &[u32], p: &[*const c_char]) -> Done {
        const F: &str = "fmi2SetString";
        let (c, f) = (self.instance.ptr(), self.api.set_string);
        cx.call(F, || status(unsafe { f(c, vrs.as_ptr(), vrs.len(), p.as_ptr()) }))
    }

    fn states(&self) -> &dyn StateCalls {
        &self.states
    }

    fn me(&self) -> Option<&super::me::Me> {
        self.me.as_ref()
    }

    fn clocks(&self) -> Option<(&super::clocks::Clocks, &LogEnv)> {
        None
    }

    fn instance(&self) -> &Instance {
        &self.instance
    }
}
