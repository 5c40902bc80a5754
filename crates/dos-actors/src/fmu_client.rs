//! [`FmuClient`]: any FMI 2.0 or 3.0 Co-Simulation FMU as a dos-actors client, through the
//! project's import layer (`inchworm-fmi-import`).
//!
//! Each UID the client reads or writes is one FMU variable, by name (the UID's
//! [`FmiName`], or another one given with [`FmuClient::rename`]) and by type (the UID's
//! data type: `f64` a Real or Float64, `i32` an Integer, `bool` a Boolean). Per actor
//! iteration the inputs the actor collected are set, the FMU steps by the client's period,
//! and every output a UID has asked for is read once: one `fmi*DoStep` and one get per
//! output, the same calls a co-simulation master makes at a communication point.
//!
//! The FMU instance lives on a thread of its own, which loads it, makes every call and
//! frees it: FMI lets a master call an instance from one thread at a time, and some FMUs
//! keep thread-local state, so the instance never moves between the runtime's worker
//! threads. A call that fails (the FMU refuses a step, a name it does not have, a value of
//! the wrong type) comes back as [`Error`] through `TryRead`, `TryUpdate` or `TryWrite`, and
//! the framework ends the model's run with it.

use std::any::TypeId;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::thread::JoinHandle;

use inchworm_fmi_import::{CsFmu, FmuError, Var, VarType};
use interface::{TryUpdate, UniqueIdentifier};

use crate::{Error, FmiName};

/// A value an FMU variable holds, carried as `f64` between the client and its thread
/// (exact for every `i32` and `bool`).
pub trait FmuValue: Copy + Send + Sync + 'static {
    const TYPE: VarType;
    fn to_f64(self) -> f64;
    fn from_f64(x: f64) -> Self;
}

impl FmuValue for f64 {
    const TYPE: VarType = VarType::Real;
    fn to_f64(self) -> f64 {
        self
    }
    fn from_f64(x: f64) -> Self {
        x
    }
}

impl FmuValue for i32 {
    const TYPE: VarType = VarType::Integer;
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
    fn from_f64(x: f64) -> Self {
        x as i32
    }
}

impl FmuValue for bool {
    const TYPE: VarType = VarType::Boolean;
    fn to_f64(self) -> f64 {
        f64::from(u8::from(self))
    }
    fn from_f64(x: f64) -> Self {
        x != 0.0
    }
}

type Job = Box<dyn FnOnce(&mut CsFmu) + Send>;

/// The phases of the instance: loaded, in initialization mode (parameters), stepping.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Phase {
    Loaded,
    Initializing,
    Stepping,
}

pub struct FmuClient {
    client: String,
    period: f64,
    stop_time: Option<f64>,
    phase: Phase,
    jobs: Option<mpsc::Sender<Job>>,
    thread: Option<JoinHandle<()>>,
    /// FMU variable names given to UIDs with [`FmuClient::rename`].
    names: HashMap<TypeId, String>,
    /// Each UID's variable, resolved at its first use.
    vars: HashMap<TypeId, Var>,
    /// Inputs collected since the last step, set just before the next one.
    pending: Vec<(Var, f64)>,
    /// The outputs read after every step, and their values now.
    outputs: Vec<(TypeId, Var)>,
    values: HashMap<TypeId, f64>,
}

impl std::fmt::Debug for FmuClient {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FmuClient")
            .field("client", &self.client)
            .field("period", &self.period)
            .field("phase", &self.phase)
            .finish_non_exhaustive()
    }
}

impl FmuClient {
    /// Loads the FMU at `path` as instance `instance`, stepped by `period` seconds at each
    /// actor iteration (the actor's rate times the model's base sample period).
    pub fn load(path: impl AsRef<Path>, instance: &str, period: f64) -> Result<Self, Error> {
        let path: PathBuf = path.as_ref().to_path_buf();
        let client = format!("{} ({instance})", path.display());
        if !(period.is_finite() && period > 0.0) {
            let message = format!("the period {period} s must be finite and > 0");
            return Err(Error::Usage { client, message });
        }
        let (jobs, inbox) = mpsc::channel::<Job>();
        let (ready, loaded) = mpsc::channel::<Result<(), FmuError>>();
        let name = instance.to_owned();
        let spawned =
            std::thread::Builder::new().name(format!("fmu {instance}")).spawn(move || {
                let mut fmu = match CsFmu::load(&path, &name, false) {
                    Ok(fmu) => {
                        let _ = ready.send(Ok(()));
                        fmu
                    }
                    Err(e) => {
                        let _ = ready.send(Err(e));
                        return;
                    }
                };
                // Until the client is dropped; the instance is freed on this thread.
                for job in inbox {
                    job(&mut fmu);
                }
            });
        let thread = spawned.map_err(|e| Error::Usage {
            client: client.clone(),
            message: format!("cannot start the FMU's thread: {e}"),
        })?;
        let lost = || Error::Usage {
            client: client.clone(),
            message: "the FMU's thread ended while loading it".into(),
        };
        let model = match loaded.recv() {
            Ok(Ok(())) => None,
            Ok(Err(source)) => Some(Error::Fmu { client: client.clone(), source }),
            Err(_) => Some(lost()),
        };
        if let Some(e) = model {
            let _ = thread.join();
            return Err(e);
        }
        Ok(FmuClient {
            client,
            period,
            stop_time: None,
            phase: Phase::Loaded,
            jobs: Some(jobs),
            thread: Some(thread),
            names: HashMap::new(),
            vars: HashMap::new(),
            pending: Vec::new(),
            outputs: Vec::new(),
            values: HashMap::new(),
        })
    }

    /// The name errors give this client: the FMU's path and the instance name.
    pub fn name(&self) -> &str {
        &self.client
    }

    /// Runs `f` on the FMU's thread and waits for its answer.
    fn call<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut CsFmu) -> Result<R, FmuError> + Send + 'static,
    ) -> Result<R, Error> {
        let (reply, answer) = mpsc::sync_channel(1);
        let job: Job = Box::new(move |fmu| {
            let _ = reply.send(f(fmu));
        });
        let gone = || Error::Usage {
            client: self.client.clone(),
            message: "the FMU's thread has ended (a call on it panicked)".into(),
        };
        self.jobs.as_ref().ok_or_else(gone)?.send(job).map_err(|_| gone())?;
        match answer.recv() {
            Ok(r) => r.map_err(|source| Error::Fmu { client: self.client.clone(), source }),
            Err(_) => Err(gone()),
        }
    }

    fn usage(&self, message: String) -> Error {
        Error::Usage { client: self.client.clone(), message }
    }

    /// Sets the stop time the FMU is told at initialization (none by default): a step past
    /// it is the FMU's to refuse. Only before the first parameter.
    pub fn stop_time(mut self, stop: f64) -> Result<Self, Error> {
        if self.phase != Phase::Loaded {
            return Err(self.usage("the stop time is set before any parameter".into()));
        }
        self.stop_time = Some(stop);
        Ok(self)
    }

    fn initializing(&mut self) -> Result<(), Error> {
        if self.phase == Phase::Loaded {
            let stop = self.stop_time;
            self.call(move |f| f.enter_initialization(None, 0.0, stop))?;
            self.phase = Phase::Initializing;
        }
        Ok(())
    }

    /// Sets a parameter or start value by name, before the first step; its type is the
    /// variable's: a Real takes `value`, an Integer or a Boolean a whole number (0 or 1).
    pub fn parameter(mut self, name: &str, value: f64) -> Result<Self, Error> {
        self.set_parameter(name, value)?;
        Ok(self)
    }

    /// [`FmuClient::parameter`] from text, as an SSP parameter binding writes it (`true`,
    /// `false` or a number).
    pub fn parameter_text(mut self, name: &str, text: &str) -> Result<Self, Error> {
        let value = crate::table::ssp_value(text).ok_or_else(|| {
            self.usage(format!("parameter `{name}`: `{text}` is neither a number nor a Boolean"))
        })?;
        self.set_parameter(name, value)?;
        Ok(self)
    }

    fn set_parameter(&mut self, name: &str, value: f64) -> Result<(), Error> {
        if self.phase == Phase::Stepping {
            let message = format!("parameter `{name}` after the first step or output");
            return Err(self.usage(message));
        }
        self.initializing()?;
        let owned = name.to_owned();
        let var = self.call(move |f| f.var(&owned))?;
        let whole = value.fract() == 0.0 && value.abs() <= f64::from(i32::MAX);
        match var.ty {
            VarType::Real => self.call(move |f| f.set_real(&[var.vr], &[value])),
            VarType::Integer | VarType::Enumeration if whole => {
                self.call(move |f| f.set_integer(&[var.vr], &[value as i32]))
            }
            VarType::Boolean if value == 0.0 || value == 1.0 => {
                self.call(move |f| f.set_boolean(&[var.vr], &[value == 1.0]))
            }
            ty => Err(self.usage(format!("parameter `{name}` is {ty}: {value} is not one"))),
        }
    }

    /// Gives UID `U` the FMU variable `name` in this client instead of `U`'s own name (a
    /// mount's `position_a` takes a runner position).
    pub fn rename<U: 'static>(mut self, name: &str) -> Self {
        self.names.insert(TypeId::of::<U>(), name.to_owned());
        self
    }

    /// Leaves initialization mode (if not yet): the outputs are the start values and the
    /// first step starts at 0.
    pub fn start(&mut self) -> Result<(), Error> {
        if self.phase != Phase::Stepping {
            self.initializing()?;
            self.call(|f| f.exit_initialization())?;
            self.phase = Phase::Stepping;
        }
        Ok(())
    }

    /// The variable of UID `U`, resolved by name and type at its first use.
    pub fn variable<U>(&mut self) -> Result<Var, Error>
    where
        U: UniqueIdentifier + FmiName + 'static,
        U::DataType: FmuValue,
    {
        let id = TypeId::of::<U>();
        if let Some(v) = self.vars.get(&id) {
            return Ok(*v);
        }
        let name = self.names.get(&id).cloned().unwrap_or_else(|| U::NAME.to_owned());
        let ty = <U::DataType as FmuValue>::TYPE;
        let var = self.call(move |f| f.var_of(&name, ty))?;
        self.vars.insert(id, var);
        Ok(var)
    }

    /// `U`'s input value, set on the FMU just before its next step.
    pub fn set_input<U>(&mut self, value: U::DataType) -> Result<(), Error>
    where
        U: UniqueIdentifier + FmiName + 'static,
        U::DataType: FmuValue,
    {
        let var = self.variable::<U>()?;
        self.pending.push((var, value.to_f64()));
        Ok(())
    }

    /// `U`'s output value at the current communication point.
    pub fn output<U>(&mut self) -> Result<U::DataType, Error>
    where
        U: UniqueIdentifier + FmiName + 'static,
        U::DataType: FmuValue,
    {
        self.start()?;
        let id = TypeId::of::<U>();
        if let Some(v) = self.values.get(&id) {
            return Ok(<U::DataType as FmuValue>::from_f64(*v));
        }
        let var = self.variable::<U>()?;
        let value = self.call(move |f| read(f, &[var]))?[0];
        self.outputs.push((id, var));
        self.values.insert(id, value);
        Ok(<U::DataType as FmuValue>::from_f64(value))
    }

    /// Sets the collected inputs, steps by the period and reads the outputs.
    pub fn step(&mut self) -> Result<(), Error> {
        self.start()?;
        let inputs = std::mem::take(&mut self.pending);
        let vars: Vec<Var> = self.outputs.iter().map(|(_, v)| *v).collect();
        let h = self.period;
        let values = self.call(move |f| {
            for (var, x) in inputs {
                write(f, var, x)?;
            }
            f.do_step(h)?;
            read(f, &vars)
        })?;
        for ((id, _), x) in self.outputs.iter().zip(values) {
            self.values.insert(*id, x);
        }
        Ok(())
    }
}

fn write(f: &mut CsFmu, var: Var, x: f64) -> Result<(), FmuError> {
    match var.ty {
        VarType::Real => f.set_real(&[var.vr], &[x]),
        VarType::Boolean => f.set_boolean(&[var.vr], &[x != 0.0]),
        _ => f.set_integer(&[var.vr], &[x as i32]),
    }
}

fn read(f: &mut CsFmu, vars: &[Var]) -> Result<Vec<f64>, FmuError> {
    vars.iter()
        .map(|var| {
            Ok(match var.ty {
                VarType::Real => {
                    let mut x = [0.0];
                    f.get_real(&[var.vr], &mut x)?;
                    x[0]
                }
                VarType::Boolean => {
                    let mut b = [false];
                    f.get_boolean(&[var.vr], &mut b)?;
                    f64::from(u8::from(b[0]))
                }
                _ => {
                    let mut i = [0];
                    f.get_integer(&[var.vr], &mut i)?;
                    f64::from(i[0])
                }
            })
        })
        .collect()
}

impl Drop for FmuClient {
    fn drop(&mut self) {
        // Closing the queue ends the thread, which frees the instance and removes the
        // unpacked files; waiting for it keeps that within the client's lifetime.
        self.jobs.take();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl TryUpdate for FmuClient {
    type Error = Error;
    fn try_update(&mut self) -> Result<&mut Self, Error> {
        self.step()?;
        Ok(self)
    }
}

/// Makes UIDs readable and writable by [`FmuClient`]: `fmu_io!(MyInput, MyOutput);` for
/// UIDs implementing [`FmiName`] with an `f64`, `i32` or `bool` data type. (The client
/// cannot implement the framework's `TryRead`/`TryWrite` for every UID at once: the
/// framework already does for every `Read`/`Write` client.)
#[macro_export]
macro_rules! fmu_io {
    ($($uid:ty),+ $(,)?) => { $( $crate::fmu_io!(@one [] $uid); )+ };
    (@one [$($g:tt)*] $uid:ty) => {
        impl<$($g)*> $crate::interface::TryRead<$uid> for $crate::FmuClient {
            type Error = $crate::Error;
            fn try_read(
                &mut self,
                data: $crate::interface::Data<$uid>,
            ) -> ::std::result::Result<&mut Self, $crate::Error> {
                self.set_input::<$uid>(*data)?;
                Ok(self)
            }
        }
        impl<$($g)*> $crate::interface::TryWrite<$uid> for $crate::FmuClient {
            type Error = $crate::Error;
            fn try_write(
                &mut self,
            ) -> ::std::result::Result<::std::option::Option<$crate::interface::Data<$uid>>, $crate::Error> {
                self.output::<$uid>().map(|x| Some($crate::interface::Data::new(x)))
            }
        }
    };
}
