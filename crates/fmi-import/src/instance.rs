//! [`Instance`]: what an FMU instance is in both interfaces, Co-Simulation and Model
//! Exchange: its loading and unloading, its description and variables by name,
//! initialization, terminate and reset. Its values (`values`) and FMU states
//! (`fmu_state`) are in their own modules; the interface's own calls are on the
//! wrapper that owns it, [`crate::CsFmu`] or [`crate::MeFmu`].

use std::collections::HashMap;
use std::mem::ManuallyDrop;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use crate::archive::{self, Unpacked};
use crate::backend::fmi2::Fmi2Backend;
use crate::backend::fmi3::Fmi3Backend;
use crate::backend::{self, Backend, Calls, Experiment, Plain, Setup};
use crate::binary::{self, Binary};
use crate::fmu_state::Saved;
use crate::{
    fmi2_platform, fmi3_platform, ArrayElement, FmuError, ImportError, ModelDescription, VarType,
    Variable,
};

/// A variable resolved against the model description.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Var {
    pub vr: u32,
    pub ty: VarType,
}

/// The interface an instance is made for. FMI 3.0 adds Co-Simulation with event mode
/// (`eventModeUsed`: steps end at clock ticks, events and clocks are handled in event
/// mode) and Scheduled Execution (the importer activates the model partitions of the
/// input clocks); FMI 2.0 has neither, nor clocks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Interface {
    CoSimulation,
    CoSimulationEventMode,
    ModelExchange,
    ScheduledExecution,
}

impl Interface {
    /// The element of `modelDescription.xml` (and attribute) that offers it.
    pub fn declared_by(self) -> &'static str {
        match self {
            Interface::CoSimulation => "<CoSimulation>",
            Interface::CoSimulationEventMode => "<CoSimulation hasEventMode=\"true\">",
            Interface::ModelExchange => "<ModelExchange>",
            Interface::ScheduledExecution => "<ScheduledExecution>",
        }
    }

    /// An error that says why, if `md` does not offer it.
    pub(crate) fn check_offered(self, md: &ModelDescription) -> Result<(), FmuError> {
        if self.offered_by(md) {
            return Ok(());
        }
        let model = md.model_name.clone();
        Err(match self {
            Interface::CoSimulation => FmuError::NotCoSimulation { model },
            Interface::ModelExchange => FmuError::NotModelExchange { model },
            interface => {
                FmuError::NotOffered { model, interface, fmi_version: md.fmi_version.clone() }
            }
        })
    }

    /// Whether `md` offers it (event mode and Scheduled Execution only in FMI 3.0).
    pub fn offered_by(self, md: &ModelDescription) -> bool {
        match self {
            Interface::CoSimulation => md.co_simulation.is_some(),
            Interface::CoSimulationEventMode => {
                md.is_fmi3() && md.co_simulation.as_ref().is_some_and(|cs| cs.has_event_mode)
            }
            Interface::ModelExchange => md.model_exchange.is_some(),
            Interface::ScheduledExecution => md.is_fmi3() && md.scheduled_execution.is_some(),
        }
    }
}

/// The owner tag of the next instance: an [`crate::FmuState`] names the instance it was
/// taken from by it.
static NEXT_OWNER: AtomicU64 = AtomicU64::new(1);

/// One instantiated FMU (FMI 2.0 or 3.0), for Co-Simulation or Model Exchange: what the two
/// interfaces share. It is owned by a [`crate::CsFmu`] or a [`crate::MeFmu`], which add
/// their interface's calls; the methods here are reached through either.
pub struct Instance {
    pub(crate) cx: Calls,
    pub(crate) interface: Interface,
    // Dropped by hand: after a Fatal it is leaked, as neither standard allows freeing.
    pub(crate) backend: ManuallyDrop<Box<dyn Backend>>,
    pub(crate) description: ModelDescription,
    pub(crate) owner: u64,
    pub(crate) states: HashMap<u64, Saved>,
    pub(crate) next_state: u64,
    /// The handles of FMI 3.0 array elements ([`ArrayElement`]), by handle.
    pub(crate) elements: HashMap<u32, ArrayElement>,
    /// The smallest element handle (`u32::MAX` with none): the handles count down from
    /// the top, so a reference below it is a scalar without a lookup.
    pub(crate) lowest_handle: u32,
    // Last: the unpacked directory goes after the library is unloaded. Shared by the
    // instances made with `instantiate_again`; removed with the last of them.
    unpacked: Arc<Unpacked>,
}

impl Drop for Instance {
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

impl std::fmt::Debug for Instance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Instance")
            .field("model", &self.cx.model)
            .field("instance", &self.cx.instance)
            .field("fmi_version", &self.description.fmi_version)
            .field("library", &self.backend.instance().binary.full_path)
            .field("time", &self.cx.time())
            .finish_non_exhaustive()
    }
}

/// The error of `path`'s import step that failed.
pub(crate) fn importing(path: &Path) -> impl Fn(ImportError) -> FmuError + Copy + '_ {
    |source| FmuError::Import { path: path.to_path_buf(), source }
}

impl Instance {
    /// Unpacks `path`, loads its library (`binaries/<platform>/` of FMI 2.0 or FMI 3.0, by
    /// the description's `fmiVersion`) and instantiates it under `instance_name` for the
    /// interface `pick` chooses from its description. `logging_on` is the FMI `loggingOn`
    /// flag (debug messages); warnings and errors reach the logger either way.
    pub(crate) fn load(
        path: &Path,
        instance_name: &str,
        (logging_on, model_exchange): (bool, impl FnOnce(&ModelDescription) -> Interface),
    ) -> Result<Self, FmuError> {
        if !path.is_file() {
            return Err(FmuError::Missing(path.to_path_buf()));
        }
        let unpacked = archive::unpack(path).map_err(importing(path))?;
        Self::from_unpacked(path, Arc::new(unpacked), instance_name, (logging_on, model_exchange))
    }

    /// Whether `instantiate_again` (of [`crate::CsFmu`] or [`crate::MeFmu`]) may make more
    /// instances from this one's unpacked folder and library: not for an FMU that declares
    /// `canBeInstantiatedOnlyOncePerProcess`, whose every instance needs a library of its
    /// own (a copy unpacked apart, as `load` makes).
    pub fn can_instantiate_again(&self) -> bool {
        let md = &self.description;
        let once = match self.interface {
            Interface::ModelExchange => {
                md.model_exchange.as_ref().map(|me| me.can_be_instantiated_only_once_per_process)
            }
            Interface::ScheduledExecution => md
                .scheduled_execution
                .as_ref()
                .map(|se| se.can_be_instantiated_only_once_per_process),
            _ => md.co_simulation.as_ref().map(|cs| cs.can_be_instantiated_only_once_per_process),
        };
        once == Some(false)
    }

    /// Whether the instance was made for Model Exchange (it is then an [`crate::MeFmu`]'s).
    pub fn is_model_exchange(&self) -> bool {
        self.interface == Interface::ModelExchange
    }

    /// The interface the instance was made for.
    pub fn interface(&self) -> Interface {
        self.interface
    }

    /// Another instance of the same FMU under `instance_name`, from the folder this one
    /// was unpacked in: a system that uses one FMU many times unpacks it once.
    pub(crate) fn instantiate_again(
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
        let interface = self.interface;
        Self::from_unpacked(
            self.unpacked.dir(),
            Arc::clone(&self.unpacked),
            instance_name,
            (logging_on, |_| interface),
        )
    }

    /// An instance for the interface `pick` chooses from the FMU's description; an
    /// interface the FMU lacks is refused.
    pub(crate) fn from_unpacked(
        path: &Path,
        unpacked: Arc<Unpacked>,
        instance_name: &str,
        (logging_on, model_exchange): (bool, impl FnOnce(&ModelDescription) -> Interface),
    ) -> Result<Self, FmuError> {
        let import = importing(path);
        let description = ModelDescription::parse(&unpacked.model_description).map_err(import)?;
        Self::from_description(
            path,
            unpacked,
            description,
            instance_name,
            (logging_on, model_exchange),
        )
    }

    /// [`Instance::from_unpacked`] with the description already read (from the archive,
    /// before it was unpacked).
    pub(crate) fn from_description(
        path: &Path,
        unpacked: Arc<Unpacked>,
        description: ModelDescription,
        instance_name: &str,
        (logging_on, pick): (bool, impl FnOnce(&ModelDescription) -> Interface),
    ) -> Result<Self, FmuError> {
        let import = importing(path);
        let model = description.model_name.clone();
        let interface = pick(&description);
        interface.check_offered(&description)?;
        let identifier = match interface {
            Interface::ModelExchange => {
                description.model_exchange.as_ref().map(|m| &m.model_identifier)
            }
            Interface::ScheduledExecution => {
                description.scheduled_execution.as_ref().map(|s| &s.model_identifier)
            }
            _ => description.co_simulation.as_ref().map(|c| &c.model_identifier),
        }
        .expect("offered_by checked the element");
        let fmi3 = description.is_fmi3();
        let platform = if fmi3 { fmi3_platform() } else { fmi2_platform() };
        let library =
            binary::library_path_for(platform, unpacked.dir(), identifier).map_err(import)?;
        let binary = Binary::load(unpacked.dir(), &library).map_err(import)?;
        let resources = unpacked.dir().join("resources");
        let setup =
            Setup { md: &description, resources: &resources, instance_name, logging_on, interface };
        let backend: Box<dyn Backend> = if fmi3 {
            Box::new(Fmi3Backend::instantiate(binary, &setup).map_err(import)?)
        } else {
            Box::new(Fmi2Backend::instantiate(binary, &setup).map_err(import)?)
        };
        let elements: HashMap<u32, ArrayElement> =
            description.variables.iter().filter_map(|v| v.element.map(|e| (v.vr, e))).collect();
        Ok(Instance {
            cx: Calls::new(model, instance_name.to_owned(), fmi3),
            interface,
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

    /// The instance name given at loading (the target of the FMU's log records).
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
    /// before [`Instance::exit_initialization`].
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

    /// `fmi*Terminate`. The instance is freed when `self` is dropped.
    pub fn terminate(&mut self) -> Result<(), FmuError> {
        self.backend.instance().call(&mut self.cx, Plain::Terminate)
    }

    /// `fmi*Reset`: back to the state right after instantiation (the time grid restarts
    /// at the next [`Instance::enter_initialization`]). Saved states stay valid.
    pub fn reset(&mut self) -> Result<(), FmuError> {
        self.backend.instance().call(&mut self.cx, Plain::Reset)?;
        self.cx.steps_done = 0;
        self.cx.step_size = 0.0;
        Ok(())
    }
}
