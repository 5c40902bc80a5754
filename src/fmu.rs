//! A small FMI 2.0 Co-Simulation import layer on the `fmi` crate.
//!
//! The `fmi` crate owns the unsafe part (unpacking the archive, `dlopen`, the raw `fmi2*`
//! calls and the logger callback); this module adds what a master needs on top of it:
//! variables looked up by name with their type checked against `modelDescription.xml`,
//! value-reference/value slices that always have matching lengths (the raw calls trust the
//! caller on that), the communication time kept as `k · h` so it never drifts from the
//! FMU's own clock, and errors that name the FMU, the call, the variable and the time.
//!
//! Messages the FMU sends through its logger callback arrive as `log` records whose
//! target is the instance name (the `fmi` crate forwards them); the binary prints them.

use std::fmt;
use std::path::{Path, PathBuf};

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common, InstanceCS};
use fmi::fmi2::schema::ScalarVariableElement;
use fmi::fmi2::Fmi2Error;
use fmi::traits::FmiImport;

/// Everything that can go wrong between a path on disk and a finished step.
#[derive(Debug)]
pub enum FmuError {
    /// The FMU file is not there (the usual cause: it has not been built yet).
    Missing(PathBuf),
    /// The archive could not be unpacked, its `modelDescription.xml` parsed or its binary loaded.
    Import { path: PathBuf, source: fmi::Error },
    /// The FMU offers no Co-Simulation interface.
    NotCoSimulation { model: String },
    /// No variable of that name in `modelDescription.xml`.
    UnknownVariable { model: String, name: String },
    /// The variable exists but has another type than the call needs.
    WrongType {
        model: String,
        name: String,
        expected: VarType,
        found: VarType,
    },
    /// An `fmi2*` call returned `fmi2Discard`, `fmi2Error` or `fmi2Fatal`.
    Call {
        model: String,
        function: &'static str,
        time: f64,
        status: Fmi2Error,
    },
}

impl fmt::Display for FmuError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FmuError::Missing(p) => write!(f, "{}: no such FMU file", p.display()),
            FmuError::Import { path, source } => write!(f, "{}: cannot import the FMU: {source}", path.display()),
            FmuError::NotCoSimulation { model } => {
                write!(
                    f,
                    "{model}: the FMU has no Co-Simulation interface (modelDescription.xml lacks <CoSimulation>)"
                )
            }
            FmuError::UnknownVariable { model, name } => {
                write!(f, "{model}: no variable named `{name}` in modelDescription.xml")
            }
            FmuError::WrongType {
                model,
                name,
                expected,
                found,
            } => {
                write!(f, "{model}: variable `{name}` is {found:?}, expected {expected:?}")
            }
            FmuError::Call {
                model,
                function,
                time,
                status,
            } => {
                write!(
                    f,
                    "{model}: {function} returned {status:?} at t = {time} s (the FMU's log messages above say why)"
                )
            }
        }
    }
}

impl std::error::Error for FmuError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            FmuError::Import { source, .. } => Some(source),
            FmuError::Call { status, .. } => Some(status),
            _ => None,
        }
    }
}

/// The FMI 2.0 base type of a scalar variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VarType {
    Real,
    Integer,
    Boolean,
    String,
    Enumeration,
}

/// A variable resolved against the model description.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Var {
    pub vr: u32,
    pub ty: VarType,
}

/// One instantiated Co-Simulation FMU, stepped with a fixed communication step.
pub struct CsFmu {
    // Field order is drop order: the instance (which frees the component and unloads the
    // library) must go before the import, whose drop deletes the unpacked archive.
    instance: InstanceCS,
    import: Fmi2Import,
    model: String,
    start_time: f64,
    steps_done: u64,
    step_size: f64,
}

impl CsFmu {
    /// Unpacks `path`, loads its `binaries/<platform>/` library and instantiates it for
    /// Co-Simulation under `instance_name`. `logging_on` is the FMI `loggingOn` flag
    /// (debug messages); warnings and errors reach the logger either way.
    pub fn load(path: &Path, instance_name: &str, logging_on: bool) -> Result<Self, FmuError> {
        if !path.is_file() {
            return Err(FmuError::Missing(path.to_path_buf()));
        }
        let import: Fmi2Import = fmi::import::from_path(path).map_err(|source| FmuError::Import {
            path: path.to_path_buf(),
            source,
        })?;
        let md = import.model_description();
        let model = md.model_name.clone();
        if md.co_simulation.is_none() {
            return Err(FmuError::NotCoSimulation { model });
        }
        let instance = import
            .instantiate_cs(instance_name, false, logging_on)
            .map_err(|source| FmuError::Import {
                path: path.to_path_buf(),
                source,
            })?;
        Ok(Self {
            instance,
            import,
            model,
            start_time: 0.0,
            steps_done: 0,
            step_size: 0.0,
        })
    }

    /// The model name from `modelDescription.xml`.
    pub fn model_name(&self) -> &str {
        &self.model
    }

    /// The default experiment's step size, if the FMU declares one.
    pub fn default_step_size(&self) -> Option<f64> {
        self.import
            .model_description()
            .default_experiment
            .as_ref()
            .and_then(|e| e.step_size())
    }

    /// Resolves a variable by name.
    pub fn var(&self, name: &str) -> Result<Var, FmuError> {
        let sv = self
            .import
            .model_description()
            .model_variable_by_name(name)
            .map_err(|_| FmuError::UnknownVariable {
                model: self.model.clone(),
                name: name.to_owned(),
            })?;
        let ty = match sv.elem {
            ScalarVariableElement::Real(_) => VarType::Real,
            ScalarVariableElement::Integer(_) => VarType::Integer,
            ScalarVariableElement::Boolean(_) => VarType::Boolean,
            ScalarVariableElement::String => VarType::String,
            ScalarVariableElement::Enumeration => VarType::Enumeration,
        };
        Ok(Var {
            vr: sv.value_reference,
            ty,
        })
    }

    /// Resolves a variable by name and checks its type.
    pub fn var_of(&self, name: &str, expected: VarType) -> Result<Var, FmuError> {
        let v = self.var(name)?;
        if v.ty != expected {
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

    fn check<T>(&self, function: &'static str, r: Result<T, Fmi2Error>) -> Result<T, FmuError> {
        r.map_err(|status| FmuError::Call {
            model: self.model.clone(),
            function,
            time: self.time(),
            status,
        })
    }

    /// `fmi2SetupExperiment` + `fmi2EnterInitializationMode`: parameters and start values
    /// may be set after this and before [`CsFmu::exit_initialization`].
    pub fn enter_initialization(
        &mut self,
        tolerance: Option<f64>,
        start_time: f64,
        stop_time: Option<f64>,
    ) -> Result<(), FmuError> {
        self.start_time = start_time;
        self.steps_done = 0;
        let r = Common::setup_experiment(&mut self.instance, tolerance, start_time, stop_time);
        self.check("fmi2SetupExperiment", r)?;
        let r = Common::enter_initialization_mode(&mut self.instance);
        self.check("fmi2EnterInitializationMode", r)?;
        Ok(())
    }

    /// `fmi2ExitInitializationMode`: the FMU is ready to step from the start time.
    pub fn exit_initialization(&mut self) -> Result<(), FmuError> {
        let r = Common::exit_initialization_mode(&mut self.instance);
        self.check("fmi2ExitInitializationMode", r).map(drop)
    }

    /// The current communication point, `start + k · h` after k steps of size h.
    pub fn time(&self) -> f64 {
        self.start_time + self.steps_done as f64 * self.step_size
    }

    /// One `fmi2DoStep` of `h` seconds from the current communication point. The step
    /// size is fixed by the first step: the time is kept as `start + k · h` (not summed) so
    /// that it stays exactly on the grid the FMU compares it with.
    pub fn do_step(&mut self, h: f64) -> Result<(), FmuError> {
        if self.steps_done == 0 {
            self.step_size = h;
        } else {
            assert_eq!(
                h, self.step_size,
                "CsFmu::do_step: the communication step is fixed at the first step"
            );
        }
        let t = self.time();
        let r = CoSimulation::do_step(&self.instance, t, h, true);
        self.check("fmi2DoStep", r)?;
        self.steps_done += 1;
        Ok(())
    }

    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Result<(), FmuError> {
        assert_eq!(
            vrs.len(),
            values.len(),
            "set_real: value references and values differ in length"
        );
        let r = Common::set_real(&mut self.instance, vrs, values);
        self.check("fmi2SetReal", r).map(drop)
    }

    pub fn get_real(&mut self, vrs: &[u32], values: &mut [f64]) -> Result<(), FmuError> {
        assert_eq!(
            vrs.len(),
            values.len(),
            "get_real: value references and values differ in length"
        );
        let r = Common::get_real(&mut self.instance, vrs, values);
        self.check("fmi2GetReal", r).map(drop)
    }

    pub fn get_integer(&mut self, vrs: &[u32], values: &mut [i32]) -> Result<(), FmuError> {
        assert_eq!(
            vrs.len(),
            values.len(),
            "get_integer: value references and values differ in length"
        );
        let r = Common::get_integer(&mut self.instance, vrs, values);
        self.check("fmi2GetInteger", r).map(drop)
    }

    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Result<(), FmuError> {
        assert_eq!(vrs.len(), values.len(), "set_integer: value references and values differ in length");
        let r = Common::set_integer(&mut self.instance, vrs, values);
        self.check("fmi2SetInteger", r).map(drop)
    }

    pub fn set_boolean(&mut self, vrs: &[u32], values: &[bool]) -> Result<(), FmuError> {
        assert_eq!(vrs.len(), values.len(), "set_boolean: value references and values differ in length");
        let values: Vec<i32> = values.iter().map(|&b| i32::from(b)).collect();
        let r = Common::set_boolean(&mut self.instance, vrs, &values);
        self.check("fmi2SetBoolean", r).map(drop)
    }

    pub fn get_boolean(&mut self, vrs: &[u32], values: &mut [bool]) -> Result<(), FmuError> {
        assert_eq!(vrs.len(), values.len(), "get_boolean: value references and values differ in length");
        let mut raw = vec![0i32; vrs.len()];
        let r = Common::get_boolean(&mut self.instance, vrs, &mut raw);
        self.check("fmi2GetBoolean", r)?;
        for (v, r) in values.iter_mut().zip(raw) {
            *v = r != 0;
        }
        Ok(())
    }

    /// Causality of a variable by name ("input", "output", "parameter", …).
    pub fn causality(&self, name: &str) -> Option<String> {
        self.import.model_description().model_variable_by_name(name).ok().map(|v| format!("{:?}", v.causality).to_lowercase())
    }

    /// Names of the variables with the given causality ("input", "output", …).
    pub fn names_with_causality(&self, causality: &str) -> Vec<String> {
        self.import
            .model_description()
            .model_variables
            .variables
            .iter()
            .filter(|v| format!("{:?}", v.causality).eq_ignore_ascii_case(causality))
            .map(|v| v.name.clone())
            .collect()
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
        let r = Common::terminate(&mut self.instance);
        self.check("fmi2Terminate", r).map(drop)
    }
}
