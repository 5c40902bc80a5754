//! FMI 3.0, natively: the `fmi3*` functions with their own signatures (`nValues` passed,
//! `fmi3Boolean` a C `bool`), `fmi3Status`, the instantiation of each interface with a
//! plain-function logger, and `fmi3DoStep`'s event and early-return outputs. Instantiated
//! without early return, so `earlyReturn` should stay false, and `eventHandlingNeeded`
//! too unless the instance was made with event mode (its master then handles the event);
//! otherwise, and on `terminateSimulation`, the step is an error that says which.

use std::ffi::CString;
use std::os::raw::c_char;
use std::os::raw::c_void;

use inchworm_fmi_abi::fmi3::*;

use super::clocks::{self, Clocks, StepEnd};
use super::state::{StateCalls, States};
use super::{Backend, Calls, Common, Done, Experiment, Instance, Setup};
use crate::binary::Binary;
use crate::logger::LogEnv;
use crate::{FmuError, ImportError, Interface, Status};

/// The FMI 3.0 functions this layer calls.
struct Api {
    set_debug_logging: fmi3SetDebugLoggingTYPE,
    enter_initialization_mode: fmi3EnterInitializationModeTYPE,
    get_float64: fmi3GetFloat64TYPE,
    get_int32: fmi3GetInt32TYPE,
    get_boolean: fmi3GetBooleanTYPE,
    get_string: fmi3GetStringTYPE,
    set_float64: fmi3SetFloat64TYPE,
    set_int32: fmi3SetInt32TYPE,
    set_boolean: fmi3SetBooleanTYPE,
    set_string: fmi3SetStringTYPE,
    /// `None` for a Model Exchange instance.
    do_step: Option<fmi3DoStepTYPE>,
}

pub(crate) struct Fmi3Backend {
    // First: freed before what it may point to.
    instance: Instance,
    api: Api,
    states: States<fmi3Byte>,
    me: Option<super::me::Me>,
    /// With event mode or for Scheduled Execution.
    clocks: Option<Clocks>,
    /// The bytes `fmi3GetBoolean` writes, kept from call to call so that a master's steady
    /// loop allocates nothing.
    booleans: Vec<u8>,
    // What the FMU may hold pointers to until fmi3FreeInstance; dropped after it.
    env: Box<LogEnv>,
    _strings: [CString; 3],
}

/// The instantiate function of the interface asked for.
enum Instantiate {
    Cs(fmi3InstantiateCoSimulationTYPE),
    Me(fmi3InstantiateModelExchangeTYPE),
    Se(fmi3InstantiateScheduledExecutionTYPE),
}

fn status(raw: fmi3Status) -> Status {
    Status::from_fmi3(raw)
}

/// The FMI 3.0 logger: a plain C function (not variadic), fed into the same `log` records
/// as the FMI 2.0 one.
unsafe extern "C" fn log_message(
    env: fmi3InstanceEnvironment,
    status: fmi3Status,
    category: fmi3String,
    message: fmi3String,
) {
    crate::logger::inchworm_fmi_import_log(env, std::ptr::null(), status, category, message);
}

impl Fmi3Backend {
    /// Resolves the `fmi3*` functions of `binary`, checks its version and instantiates it
    /// for Co-Simulation.
    pub fn instantiate(binary: Binary, setup: &Setup<'_>) -> Result<Fmi3Backend, ImportError> {
        let Setup { md, resources, instance_name, logging_on, interface } = *setup;
        let model_exchange = setup.model_exchange();
        let event_mode = interface == Interface::CoSimulationEventMode;
        let scheduled = interface == Interface::ScheduledExecution;
        // SAFETY: each type is the FMI 3.0 signature of the function named.
        let (api, instantiate, get_version, common, mut me, mut clocks) = unsafe {
            let instantiate = match interface {
                Interface::ModelExchange => {
                    Instantiate::Me(binary.required(super::FMI3_NAMES.instantiate_me)?)
                }
                Interface::ScheduledExecution => {
                    Instantiate::Se(binary.required("fmi3InstantiateScheduledExecution")?)
                }
                _ => Instantiate::Cs(binary.required(super::FMI3_NAMES.instantiate)?),
            };
            let clocks = match event_mode || scheduled {
                true => Some(Clocks::resolve(&binary, scheduled)?),
                false => None,
            };
            let me = super::me::Me::for_setup(&binary, setup, status)?;
            let common = Common::<fmi3Byte>::resolve(&binary, &super::FMI3_NAMES, status, setup)?;
            let api = Api {
                set_debug_logging: binary.required("fmi3SetDebugLogging")?,
                enter_initialization_mode: binary.required("fmi3EnterInitializationMode")?,
                get_float64: binary.required("fmi3GetFloat64")?,
                get_int32: binary.required("fmi3GetInt32")?,
                get_boolean: binary.required("fmi3GetBoolean")?,
                get_string: binary.required("fmi3GetString")?,
                set_float64: binary.required("fmi3SetFloat64")?,
                set_int32: binary.required("fmi3SetInt32")?,
                set_boolean: binary.required("fmi3SetBoolean")?,
                set_string: binary.required("fmi3SetString")?,
                do_step: match model_exchange || scheduled {
                    true => None,
                    false => Some(binary.required("fmi3DoStep")?),
                },
            };
            let get_version: fmi3GetVersionTYPE = binary.required("fmi3GetVersion")?;
            (api, instantiate, get_version, common, me, clocks)
        };
        // SAFETY: returns a static NUL-terminated string.
        let version = Binary::check_version("fmi3GetVersion", unsafe { get_version() }, "3.")?;

        let nul = |what| ImportError::Nul { what };
        let c_name = CString::new(instance_name).map_err(|_| nul("the instance name"))?;
        let c_token = CString::new(md.guid.as_str()).map_err(|_| nul("the instantiation token"))?;
        // FMI 3.0 resourcePath: a native path ending in a separator (not a URI).
        let resources = format!("{}{}", resources.display(), std::path::MAIN_SEPARATOR);
        let c_resources = CString::new(resources).map_err(|_| nul("the resource path"))?;
        let env = Box::new(LogEnv::new(instance_name));
        // SAFETY: the FMI 3.0 signature; every pointer passed lives in the backend, which
        // frees the instance before dropping them.
        let environment = &*env as *const LogEnv as *mut c_void;
        let (name, token, resource) = (c_name.as_ptr(), c_token.as_ptr(), c_resources.as_ptr());
        let instance = match instantiate {
            Instantiate::Cs(instantiate) => unsafe {
                instantiate(
                    name,
                    token,
                    resource,
                    fmi3False, // visible
                    logging_on,
                    event_mode, // eventModeUsed
                    fmi3False,  // earlyReturnAllowed
                    std::ptr::null(),
                    0,
                    environment,
                    Some(log_message),
                    None,
                )
            },
            Instantiate::Me(instantiate) => unsafe {
                instantiate(
                    name,
                    token,
                    resource,
                    fmi3False,
                    logging_on,
                    environment,
                    Some(log_message),
                )
            },
            Instantiate::Se(instantiate) => unsafe {
                instantiate(
                    name,
                    token,
                    resource,
                    fmi3False,
                    logging_on,
                    environment,
                    Some(log_message),
                    Some(clocks::clock_update),
                    Some(clocks::lock_preemption),
                    Some(clocks::unlock_preemption),
                )
            },
        };
        let (instance, states) = common.finish(instance, (binary, version), status, setup)?;
        if let Some(me) = me.as_mut() {
            me.bind(instance.ptr());
        }
        if let Some(c) = clocks.as_mut() {
            c.bind(instance.ptr());
        }
        Ok(Fmi3Backend {
            instance,
            states,
            me,
            clocks,
            api,
            booleans: Vec::new(),
            env,
            _strings: [c_name, c_token, c_resources],
        })
    }
}

// SAFETY of every call below: FMI 3.0 signatures, a live instance (freed only when the backend
// is dropped), and arrays of the lengths passed as both nValueReferences and
// nValues (every variable this layer addresses is a scalar; CsFmu checks the lengths).
impl Backend for Fmi3Backend {
    fn set_debug_logging(&mut self, cx: &mut Calls, on: bool, p: &[*const c_char]) -> Done {
        const F: &str = "fmi3SetDebugLogging";
        let (i, f) = (self.instance.ptr(), self.api.set_debug_logging);
        cx.call(F, || status(unsafe { f(i, on, p.len(), p.as_ptr()) }))
    }

    fn enter_initialization(&mut self, cx: &mut Calls, e: Experiment) -> Done {
        let Experiment { tolerance, start, stop } = e;
        let (i, f) = (self.instance.ptr(), self.api.enter_initialization_mode);
        cx.call("fmi3EnterInitializationMode", || {
            let (tol, end) = (tolerance.unwrap_or(0.0), stop.unwrap_or(0.0));
            status(unsafe { f(i, tolerance.is_some(), tol, start, stop.is_some(), end) })
        })
    }

    fn do_step(
        &mut self,
        cx: &mut Calls,
        t: f64,
        h: f64,
        no_prior: bool,
    ) -> Result<StepEnd, FmuError> {
        const F: &str = "fmi3DoStep";
        let i = self.instance.ptr();
        let f = self.api.do_step.ok_or_else(|| match self.clocks.is_some() {
            true => FmuError::Unsupported {
                model: cx.model.clone(),
                function: F,
                why: "the instance was made for Scheduled Execution: its partitions are activated (fmi3ActivateModelPartition)".into(),
            },
            false => cx.other_interface(F, true),
        })?;
        // Read as bytes: a value other than 0 or 1 must not make an invalid bool.
        let mut flags = [0u8; 3];
        let mut last = t;
        cx.call(F, || {
            let p = flags.as_mut_ptr().cast::<bool>();
            // SAFETY: three distinct one-byte slots.
            status(unsafe { f(i, t, h, no_prior, p, p.add(1), p.add(2), &mut last) })
        })?;
        let [event, end, early] = flags.map(|b| b != 0);
        let event_mode = self.clocks.is_some();
        let why = if end {
            "the FMU asked to terminate the simulation (terminateSimulation)"
        } else if early {
            "the FMU returned early (earlyReturn), though instantiated without early return"
        } else if event && !event_mode {
            "the FMU needs event handling (eventHandlingNeeded), though instantiated without event mode"
        } else {
            return Ok(StepEnd {
                event_handling_needed: event,
                terminate: false,
                early_return: false,
                last_successful_time: last,
            });
        };
        Err(FmuError::StepEnded {
            model: cx.model.clone(),
            function: F,
            time: t,
            why,
            last_time: last,
        })
    }

    fn get_f64(&mut self, cx: &mut Calls, vrs: &[u32], out: &mut [f64]) -> Done {
        let (i, f) = (self.instance.ptr(), self.api.get_float64);
        let (n, m) = (vrs.len(), out.len());
        cx.call("fmi3GetFloat64", || status(unsafe { f(i, vrs.as_ptr(), n, out.as_mut_ptr(), m) }))
    }

    fn set_f64(&mut self, cx: &mut Calls, vrs: &[u32], values: &[f64]) -> Done {
        let (i, f) = (self.instance.ptr(), self.api.set_float64);
        let (n, m) = (vrs.len(), values.len());
        cx.call("fmi3SetFloat64", || status(unsafe { f(i, vrs.as_ptr(), n, values.as_ptr(), m) }))
    }

    fn get_i32(&mut self, cx: &mut Calls, vrs: &[u32], out: &mut [i32]) -> Done {
        let (i, f) = (self.instance.ptr(), self.api.get_int32);
        let (n, m) = (vrs.len(), out.len());
        cx.call("fmi3GetInt32", || status(unsafe { f(i, vrs.as_ptr(), n, out.as_mut_ptr(), m) }))
    }

    fn set_i32(&mut self, cx: &mut Calls, vrs: &[u32], values: &[i32]) -> Done {
        let (i, f) = (self.instance.ptr(), self.api.set_int32);
        let (n, m) = (vrs.len(), values.len());
        cx.call("fmi3SetInt32", || status(unsafe { f(i, vrs.as_ptr(), n, values.as_ptr(), m) }))
    }

    fn get_bool(&mut self, cx: &mut Calls, vrs: &[u32], out: &mut [bool]) -> Done {
        // Read as bytes: an FMU writing another byte than 0 or 1 must not make an invalid
        // Rust bool.
        let (i, f, n, m) = (self.instance.ptr(), self.api.get_boolean, vrs.len(), out.len());
        let raw = &mut self.booleans;
        raw.clear();
        raw.resize(m, 0);
        cx.call("fmi3GetBoolean", || {
            status(unsafe { f(i, vrs.as_ptr(), n, raw.as_mut_ptr().cast::<fmi3Boolean>(), m) })
        })?;
        for (v, &r) in out.iter_mut().zip(raw.iter()) {
            *v = r != 0;
        }
        Ok(())
    }

    fn set_bool(&mut self, cx: &mut Calls, vrs: &[u32], values: &[bool]) -> Done {
        let (i, f, n, m) = (self.instance.ptr(), self.api.set_boolean, vrs.len(), values.len());
        cx.call("fmi3SetBoolean", || status(unsafe { f(i, vrs.as_ptr(), n, values.as_ptr(), m) }))
    }

    fn get_string(&mut self, cx: &mut Calls, vrs: &[u32], raw: &mut [*const c_char]) -> Done {
        let (i, f, n) = (self.instance.ptr(), self.api.get_string, vrs.len());
        cx.call("fmi3GetString", || status(unsafe { f(i, vrs.as_ptr(), n, raw.as_mut_ptr(), n) }))
    }

    fn set_string(&mut self, cx: &mut Calls, vrs: &[u32], p: &[*const c_char]) -> Done {
        const F: &str = "fmi3SetString";
        let (i, f, n) = (self.instance.ptr(), self.api.set_string, vrs.len());
        cx.call(F, || status(unsafe { f(i, vrs.as_ptr(), n, p.as_ptr(), n) }))
    }

    fn states(&self) -> &dyn StateCalls {
        &self.states
    }

    fn me(&self) -> Option<&super::me::Me> {
        self.me.as_ref()
    }

    fn clocks(&self) -> Option<(&Clocks, &LogEnv)> {
        self.clocks.as_ref().map(|c| (c, &*self.env))
    }

    fn instance(&self) -> &Instance {
        &self.instance
    }
}
