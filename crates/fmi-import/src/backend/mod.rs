//! The FMU behind [`CsFmu`](crate::CsFmu): one [`Backend`] trait, implemented natively by
//! [`fmi2::Fmi2Backend`] and [`fmi3::Fmi3Backend`]. Each holds its own standard's resolved
//! function table and instance, calls its own functions with their own signatures and
//! reads their own status values; neither goes through the other.
//!
//! What both share is [`Calls`]: the refusal after a Fatal, the status check (Warning
//! logged and passed, Discard/Error/Fatal/Pending an error naming the real function and
//! the time), the communication grid `start + k · h`, and the argument conversions.

pub(crate) mod clocks;
pub(crate) mod fmi2;
pub(crate) mod fmi3;
pub(crate) mod me;
pub(crate) mod state;

use std::ffi::{CStr, CString};
use std::os::raw::{c_char, c_void};

use crate::binary::Binary;
use crate::{logger, FmuError, Status};

/// What a backend is instantiated with.
pub(crate) struct Setup<'a> {
    pub md: &'a crate::ModelDescription,
    /// The unpacked FMU's `resources` folder.
    pub resources: &'a std::path::Path,
    pub instance_name: &'a str,
    pub logging_on: bool,
    pub interface: crate::Interface,
}

impl Setup<'_> {
    pub fn model_exchange(&self) -> bool {
        self.interface == crate::Interface::ModelExchange
    }
}

/// The experiment a backend enters initialization with.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Experiment {
    pub tolerance: Option<f64>,
    pub start: f64,
    pub stop: Option<f64>,
}

/// What a call that returns nothing but its status gives.
pub(crate) type Done = Result<(), FmuError>;

/// An FMU state as the FMU handed it out (`fmi2FMUstate`, `fmi3FMUState`).
pub(crate) type RawState = *mut c_void;

/// The calls of one FMU instance, in the FMU's own standard. Every method that calls the
/// FMU goes through [`Calls::call`] with the real function name.
pub(crate) trait Backend {
    /// `cats`: NUL-terminated category names, alive for the call.
    fn set_debug_logging(&mut self, cx: &mut Calls, on: bool, cats: &[*const c_char]) -> Done;
    /// Everything up to and including entering Initialization Mode.
    fn enter_initialization(&mut self, cx: &mut Calls, e: Experiment) -> Done;
    /// One step from `t`; `no_prior`: no state of an earlier time will be restored.
    fn do_step(
        &mut self,
        cx: &mut Calls,
        t: f64,
        h: f64,
        no_prior: bool,
    ) -> Result<clocks::StepEnd, FmuError>;
    fn get_f64(&mut self, cx: &mut Calls, vrs: &[u32], out: &mut [f64]) -> Done;
    fn set_f64(&mut self, cx: &mut Calls, vrs: &[u32], values: &[f64]) -> Done;
    fn get_i32(&mut self, cx: &mut Calls, vrs: &[u32], out: &mut [i32]) -> Done;
    fn set_i32(&mut self, cx: &mut Calls, vrs: &[u32], values: &[i32]) -> Done;
    fn get_bool(&mut self, cx: &mut Calls, vrs: &[u32], out: &mut [bool]) -> Done;
    fn set_bool(&mut self, cx: &mut Calls, vrs: &[u32], values: &[bool]) -> Done;
    /// `out`: the FMU's own strings, valid until its next call.
    fn get_string(&mut self, cx: &mut Calls, vrs: &[u32], out: &mut [*const c_char]) -> Done;
    fn set_string(&mut self, cx: &mut Calls, vrs: &[u32], values: &[*const c_char]) -> Done;
    /// The FMU-state calls of this instance.
    fn states(&self) -> &dyn state::StateCalls;
    /// The Model Exchange calls, if instantiated for Model Exchange.
    fn me(&self) -> Option<&me::Me>;
    /// The FMI 3.0 clock calls and the environment their callbacks count on, if
    /// instantiated with event mode or for Scheduled Execution.
    fn clocks(&self) -> Option<(&clocks::Clocks, &crate::logger::LogEnv)>;
    /// The instance: its instance-only calls; freed when the backend is dropped.
    fn instance(&self) -> &Instance;
}

/// The state of one instance's calls that is the same in both standards.
pub(crate) struct Calls {
    pub model: String,
    pub instance: String,
    pub start_time: f64,
    pub steps_done: u64,
    pub step_size: f64,
    /// The function that returned Fatal, if one did.
    pub fatal: Option<&'static str>,
    /// Whether the FMU is FMI 3.0 (for the names of the calls [`crate::CsFmu`] checks
    /// before reaching the backend).
    fmi3: bool,
}

impl Calls {
    pub fn new(model: String, instance: String, fmi3: bool) -> Calls {
        Calls { model, instance, start_time: 0.0, steps_done: 0, step_size: 0.0, fatal: None, fmi3 }
    }

    /// The name of a call in the FMU's standard.
    pub fn named(&self, fmi2: &'static str, fmi3: &'static str) -> &'static str {
        if self.fmi3 {
            fmi3
        } else {
            fmi2
        }
    }

    /// The current communication point, `start + k · h` after k steps of size h.
    pub fn time(&self) -> f64 {
        self.start_time + self.steps_done as f64 * self.step_size
    }

    /// Refuses any call after a Fatal, as both standards demand.
    pub fn alive(&self, function: &'static str) -> Done {
        match self.fatal {
            Some(fatal_in) => {
                Err(FmuError::AfterFatal { model: self.model.clone(), function, fatal_in })
            }
            None => Ok(()),
        }
    }

    /// Makes the call `function` (unless a Fatal came before) and checks its status.
    pub fn call(&mut self, function: &'static str, run: impl FnOnce() -> Status) -> Done {
        self.alive(function)?;
        let status = run();
        self.check(function, status)
    }

    #[inline]
    fn check(&mut self, function: &'static str, status: Status) -> Done {
        if status == Status::Ok {
            return Ok(());
        }
        self.check_not_ok(function, status)
    }

    /// [`Self::check`] of a status other than OK, out of the path of every call.
    #[cold]
    #[inline(never)]
    fn check_not_ok(&mut self, function: &'static str, status: Status) -> Done {
        match status {
            Status::Ok => Ok(()),
            Status::Warning => {
                logger::emit(
                    log::Level::Warn,
                    &self.instance,
                    format_args!(
                        "{function} returned {} at t = {} s",
                        status.spelled(function),
                        self.time()
                    ),
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

    pub fn invalid(&self, function: &'static str, message: impl Into<String>) -> FmuError {
        FmuError::InvalidArgument { model: self.model.clone(), function, message: message.into() }
    }

    /// `function` is absent because the FMU does not declare `flag`.
    /// `function` belongs to the other interface than the instance was made for.
    pub fn other_interface(&self, function: &'static str, model_exchange: bool) -> FmuError {
        let (made, other) = if model_exchange {
            ("Model Exchange", "Co-Simulation")
        } else {
            ("Co-Simulation", "Model Exchange")
        };
        FmuError::Unsupported {
            model: self.model.clone(),
            function,
            why: format!("the instance was made for {made}, and {function} is a {other} call"),
        }
    }

    pub fn unsupported(&self, function: &'static str, flag: &'static str) -> FmuError {
        FmuError::Unsupported {
            model: self.model.clone(),
            function,
            why: format!("the FMU's modelDescription.xml does not declare {flag}=\"true\""),
        }
    }

    /// `values` as C strings for `function` (`what`: the values, for the error).
    pub fn c_strings(
        &self,
        function: &'static str,
        what: &str,
        values: &[&str],
    ) -> Result<Vec<CString>, FmuError> {
        self.alive(function)?;
        values
            .iter()
            .map(|v| CString::new(*v))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|_| self.invalid(function, format!("{what} contains a NUL byte")))
    }
}

/// Pointers to `strings`, valid while they live.
pub(crate) fn pointers(strings: &[CString]) -> Vec<*const c_char> {
    strings.iter().map(|c| c.as_ptr()).collect()
}

/// Copies the FMU's strings into `out` right away: they are valid only until its next call.
pub(crate) fn copy_strings(raw: &[*const c_char], out: &mut [String]) {
    for (v, &p) in out.iter_mut().zip(raw) {
        *v = if p.is_null() {
            String::new()
        } else {
            // SAFETY: a non-NULL string from the FMU is NUL-terminated and alive until its
            // next call; copied here before that.
            unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
        };
    }
}

/// The calls both standards make on the instance alone.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Plain {
    ExitInitialization,
    Terminate,
    Reset,
}

// The C shapes of those calls and of the free, the same in both standards (checked below).
type InstanceOnly = unsafe extern "C" fn(*mut c_void) -> std::os::raw::c_int;
type Free = unsafe extern "C" fn(*mut c_void);

// This compiles only if both standards' signatures are exactly these shapes.
#[allow(clippy::type_complexity)]
const _SAME_SHAPES: [fn(
    (crate::ffi::fmi2TerminateTYPE, crate::ffi::fmi2FreeInstanceTYPE),
    (inchworm_fmi_abi::fmi3::fmi3TerminateTYPE, inchworm_fmi_abi::fmi3::fmi3FreeInstanceTYPE),
) -> [(InstanceOnly, Free); 2]; 1] = [|a, b| [a, b]];

/// One standard's instance: its pointer, its free function (called once, on drop) and its
/// instance-only calls with their names.
pub(crate) struct Instance {
    ptr: *mut c_void,
    /// What the binary's `fmi*GetVersion` returned.
    pub version: String,
    // After `ptr` is freed (in `drop`), the library is unloaded with this field.
    pub binary: Binary,
    free: Free,
    status: fn(std::os::raw::c_int) -> Status,
    /// Exit initialization, terminate, reset: the standard's name and function of each.
    plain: [(&'static str, InstanceOnly); 3],
}

impl Instance {
    /// Takes ownership of `ptr` (non-NULL, from the standard's instantiate function).
    pub fn new(
        (ptr, free): (*mut c_void, Free),
        (binary, version): (Binary, String),
        status: fn(std::os::raw::c_int) -> Status,
        plain: [(&'static str, InstanceOnly); 3],
    ) -> Instance {
        Instance { ptr, version, binary, free, status, plain }
    }

    pub fn ptr(&self) -> *mut c_void {
        self.ptr
    }

    /// One of the instance-only calls.
    pub fn call(&self, cx: &mut Calls, which: Plain) -> Done {
        let (name, f) = self.plain[which as usize];
        let i = self.ptr;
        // SAFETY: the standard's own function for this shape, on the live instance.
        cx.call(name, || (self.status)(unsafe { f(i) }))
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        // SAFETY: from this library's instantiate function, freed only here, once. CsFmu
        // leaks the backend (and so this) instead after a Fatal.
        unsafe { (self.free)(self.ptr) };
    }
}

/// The calls and flags both backends resolve the same way, as FMI 2.0 (0) and FMI 3.0 (1)
/// spell them: one concordance, so that neither standard's names are written twice.
struct Spellings {
    instantiate: [&'static str; 2],
    instantiate_me: [&'static str; 2],
    free: [&'static str; 2],
    exit: [&'static str; 2],
    terminate: [&'static str; 2],
    reset: [&'static str; 2],
    get: [&'static str; 2],
    set: [&'static str; 2],
    free_state: [&'static str; 2],
    size: [&'static str; 2],
    serialize: [&'static str; 2],
    deserialize: [&'static str; 2],
    get_set_flag: [&'static str; 2],
    serialize_flag: [&'static str; 2],
}

const SPELLINGS: Spellings = Spellings {
    instantiate: ["fmi2Instantiate", "fmi3InstantiateCoSimulation"],
    instantiate_me: ["fmi2Instantiate", "fmi3InstantiateModelExchange"],
    free: ["fmi2FreeInstance", "fmi3FreeInstance"],
    exit: ["fmi2ExitInitializationMode", "fmi3ExitInitializationMode"],
    terminate: ["fmi2Terminate", "fmi3Terminate"],
    reset: ["fmi2Reset", "fmi3Reset"],
    get: ["fmi2GetFMUstate", "fmi3GetFMUState"],
    set: ["fmi2SetFMUstate", "fmi3SetFMUState"],
    free_state: ["fmi2FreeFMUstate", "fmi3FreeFMUState"],
    size: ["fmi2SerializedFMUstateSize", "fmi3SerializedFMUStateSize"],
    serialize: ["fmi2SerializeFMUstate", "fmi3SerializeFMUState"],
    deserialize: ["fmi2DeSerializeFMUstate", "fmi3DeserializeFMUState"],
    get_set_flag: ["canGetAndSetFMUstate", "canGetAndSetFMUState"],
    serialize_flag: ["canSerializeFMUstate", "canSerializeFMUState"],
};

const fn spelled(i: usize) -> Names {
    let s = &SPELLINGS;
    Names {
        instantiate: s.instantiate[i],
        instantiate_me: s.instantiate_me[i],
        free: s.free[i],
        plain: [s.exit[i], s.terminate[i], s.reset[i]],
        state: state::Names {
            get: s.get[i],
            set: s.set[i],
            free: s.free_state[i],
            size: s.size[i],
            serialize: s.serialize[i],
            deserialize: s.deserialize[i],
            get_set_flag: s.get_set_flag[i],
            serialize_flag: s.serialize_flag[i],
        },
    }
}

pub(crate) static FMI2_NAMES: Names = spelled(0);
pub(crate) static FMI3_NAMES: Names = spelled(1);

/// One standard's names of what [`Common`] resolves.
pub(crate) struct Names {
    pub instantiate: &'static str,
    pub instantiate_me: &'static str,
    pub free: &'static str,
    /// Exit initialization, terminate, reset (the order of [`Plain`]).
    pub plain: [&'static str; 3],
    pub state: state::Names,
}

/// What both backends resolve from their library the same way: the free, the
/// instance-only calls and the FMU-state functions, each under its standard's name.
pub(crate) struct Common<B: 'static> {
    names: &'static Names,
    free: Free,
    plain: [InstanceOnly; 3],
    states: state::States<B>,
}

impl<B: Copy + 'static> Common<B> {
    /// # Safety
    /// The standard's signatures of these functions must have the shapes checked above
    /// and in `state` (they do in FMI 2.0 and FMI 3.0).
    pub unsafe fn resolve(
        binary: &Binary,
        names: &'static Names,
        status: fn(std::os::raw::c_int) -> Status,
        setup: &Setup<'_>,
    ) -> Result<Self, crate::ImportError> {
        let capabilities = if setup.model_exchange() {
            let me = setup.md.model_exchange.as_ref().expect("checked by MeFmu::load");
            (me.can_get_and_set_fmu_state, me.can_serialize_fmu_state)
        } else if setup.interface == crate::Interface::ScheduledExecution {
            let se = setup.md.scheduled_execution.as_ref().expect("checked by SeFmu::load");
            (se.can_get_and_set_fmu_state, se.can_serialize_fmu_state)
        } else {
            let cs = setup.md.co_simulation.as_ref().expect("checked by CsFmu::load");
            (cs.can_get_and_set_fmu_state, cs.can_serialize_fmu_state)
        };
        let [exit, terminate, reset] = names.plain;
        Ok(Common {
            names,
            free: binary.required(names.free)?,
            plain: [binary.required(exit)?, binary.required(terminate)?, binary.required(reset)?],
            states: state::States::resolve(binary, &names.state, status, capabilities)?,
        })
    }

    /// The instance `ptr` (from the standard's instantiate function for `setup`) and its
    /// state calls; NULL is the instantiation's refusal.
    pub fn finish(
        self,
        ptr: *mut c_void,
        loaded: (Binary, String),
        status: fn(std::os::raw::c_int) -> Status,
        setup: &Setup<'_>,
    ) -> Result<(Instance, state::States<B>), crate::ImportError> {
        if ptr.is_null() {
            let names = self.names;
            return Err(crate::ImportError::Instantiate {
                function: match setup.interface {
                    crate::Interface::ModelExchange => names.instantiate_me,
                    crate::Interface::ScheduledExecution => "fmi3InstantiateScheduledExecution",
                    _ => names.instantiate,
                },
                instance: setup.instance_name.to_owned(),
            });
        }
        let mut states = self.states;
        states.bind(ptr);
        let [n0, n1, n2] = self.names.plain;
        let [f0, f1, f2] = self.plain;
        let plain = [(n0, f0), (n1, f1), (n2, f2)];
        Ok((Instance::new((ptr, self.free), loaded, status, plain), states))
    }
}
