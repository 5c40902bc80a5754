//! Model Exchange for both standards: the calls whose C shapes FMI 2.0 and FMI 3.0 share
//! (enter event mode, enter continuous-time mode, set time, set states, the four vector
//! getters) are resolved into one table under each standard's names; the three whose
//! shapes differ (the discrete-state update, the completed integrator step, the
//! directional derivative) are one `match` arm per standard below, nothing else.

use std::os::raw::{c_int, c_void};

use inchworm_fmi_abi::fmi2::{
    fmi2Boolean, fmi2CompletedIntegratorStepTYPE, fmi2EnterEventModeTYPE, fmi2EventInfo,
    fmi2GetDirectionalDerivativeTYPE, fmi2GetRealVectorTYPE, fmi2NewDiscreteStatesTYPE,
    fmi2SetContinuousStatesTYPE, fmi2SetTimeTYPE,
};
use inchworm_fmi_abi::fmi3::{
    fmi3CompletedIntegratorStepTYPE, fmi3EnterEventModeTYPE, fmi3GetDirectionalDerivativeTYPE,
    fmi3GetFloat64VectorTYPE, fmi3SetContinuousStatesTYPE, fmi3SetTimeTYPE,
    fmi3UpdateDiscreteStatesTYPE,
};

use super::{Calls, Done};
use crate::binary::Binary;
use crate::{FmuError, ImportError, Status};

type InstanceOnly = unsafe extern "C" fn(*mut c_void) -> c_int;
type SetTime = unsafe extern "C" fn(*mut c_void, f64) -> c_int;
type SetVector = unsafe extern "C" fn(*mut c_void, *const f64, usize) -> c_int;
type GetVector = unsafe extern "C" fn(*mut c_void, *mut f64, usize) -> c_int;

// This compiles only if both standards' signatures are exactly these shapes.
#[allow(clippy::type_complexity)]
const _SAME_SHAPES: [fn(
    (fmi2EnterEventModeTYPE, fmi2SetTimeTYPE, fmi2SetContinuousStatesTYPE, fmi2GetRealVectorTYPE),
    (fmi3EnterEventModeTYPE, fmi3SetTimeTYPE, fmi3SetContinuousStatesTYPE, fmi3GetFloat64VectorTYPE),
) -> [(InstanceOnly, SetTime, SetVector, GetVector); 2]; 1] = [|a, b| [a, b]];

/// The vectors a Model Exchange FMU hands out, in the order of [`Names::vectors`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Vector {
    Derivatives,
    EventIndicators,
    States,
    Nominals,
}

/// What the discrete-state update (`fmi2NewDiscreteStates`, `fmi3UpdateDiscreteStates`)
/// says.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EventUpdate {
    /// Another update is needed before leaving event mode (FMI 2.0
    /// `newDiscreteStatesNeeded`, FMI 3.0 `discreteStatesNeedUpdate`).
    pub needs_update: bool,
    pub terminate: bool,
    pub nominals_changed: bool,
    pub states_changed: bool,
    /// The next time event, if the FMU has one.
    pub next_event_time: Option<f64>,
}

/// One standard's names of the Model Exchange calls.
pub(crate) struct Names {
    pub enter_event: &'static str,
    pub enter_continuous: &'static str,
    pub set_time: &'static str,
    pub set_states: &'static str,
    /// Derivatives, event indicators, states, nominals (the order of [`Vector`]).
    pub vectors: [&'static str; 4],
    pub update: &'static str,
    pub completed: &'static str,
    pub directional: &'static str,
    pub directional_flag: &'static str,
}

pub(crate) static FMI2: Names = Names {
    enter_event: "fmi2EnterEventMode",
    enter_continuous: "fmi2EnterContinuousTimeMode",
    set_time: "fmi2SetTime",
    set_states: "fmi2SetContinuousStates",
    vectors: [
        "fmi2GetDerivatives",
        "fmi2GetEventIndicators",
        "fmi2GetContinuousStates",
        "fmi2GetNominalsOfContinuousStates",
    ],
    update: "fmi2NewDiscreteStates",
    completed: "fmi2CompletedIntegratorStep",
    directional: "fmi2GetDirectionalDerivative",
    directional_flag: "providesDirectionalDerivative",
};

pub(crate) static FMI3: Names = Names {
    enter_event: "fmi3EnterEventMode",
    enter_continuous: "fmi3EnterContinuousTimeMode",
    set_time: "fmi3SetTime",
    set_states: "fmi3SetContinuousStates",
    vectors: [
        "fmi3GetContinuousStateDerivatives",
        "fmi3GetEventIndicators",
        "fmi3GetContinuousStates",
        "fmi3GetNominalsOfContinuousStates",
    ],
    update: "fmi3UpdateDiscreteStates",
    completed: "fmi3CompletedIntegratorStep",
    directional: "fmi3GetDirectionalDerivative",
    directional_flag: "providesDirectionalDerivatives",
};

/// The calls whose shapes differ between the standards.
#[derive(Clone, Copy)]
enum Own {
    Fmi2 {
        update: fmi2NewDiscreteStatesTYPE,
        completed: fmi2CompletedIntegratorStepTYPE,
        directional: Option<fmi2GetDirectionalDerivativeTYPE>,
    },
    Fmi3 {
        update: fmi3UpdateDiscreteStatesTYPE,
        completed: fmi3CompletedIntegratorStepTYPE,
        directional: Option<fmi3GetDirectionalDerivativeTYPE>,
    },
}

/// One Model Exchange instance's calls.
pub(crate) struct Me {
    names: &'static Names,
    status: fn(c_int) -> Status,
    instance: *mut c_void,
    enter_event: InstanceOnly,
    enter_continuous: InstanceOnly,
    set_time: SetTime,
    set_states: SetVector,
    vectors: [GetVector; 4],
    own: Own,
}

impl Me {
    /// Resolves the Model Exchange functions of `binary` (every required one; the
    /// directional derivative if `directional` is declared).
    ///
    /// # Safety
    /// `binary` implements the standard `fmi3` says (FMI 3.0 if true, else FMI 2.0).
    pub unsafe fn resolve(
        binary: &Binary,
        fmi3: bool,
        status: fn(c_int) -> Status,
        directional: bool,
    ) -> Result<Me, ImportError> {
        let names = if fmi3 { &FMI3 } else { &FMI2 };
        let [d, e, s, n] = names.vectors;
        let (flag, declared) = (names.directional_flag, directional);
        let own = if fmi3 {
            Own::Fmi3 {
                update: binary.required(names.update)?,
                completed: binary.required(names.completed)?,
                directional: binary.capability(names.directional, flag, declared)?,
            }
        } else {
            Own::Fmi2 {
                update: binary.required(names.update)?,
                completed: binary.required(names.completed)?,
                directional: binary.capability(names.directional, flag, declared)?,
            }
        };
        Ok(Me {
            names,
            status,
            instance: std::ptr::null_mut(),
            enter_event: binary.required(names.enter_event)?,
            enter_continuous: binary.required(names.enter_continuous)?,
            set_time: binary.required(names.set_time)?,
            set_states: binary.required(names.set_states)?,
            vectors: [
                binary.required(d)?,
                binary.required(e)?,
                binary.required(s)?,
                binary.required(n)?,
            ],
            own,
        })
    }

    /// The calls of `setup`'s instance if it is made for Model Exchange.
    ///
    /// # Safety
    /// As for [`Me::resolve`].
    pub unsafe fn for_setup(
        binary: &Binary,
        setup: &super::Setup<'_>,
        status: fn(c_int) -> Status,
    ) -> Result<Option<Me>, ImportError> {
        match &setup.md.model_exchange {
            Some(m) if setup.model_exchange() => {
                let fmi3 = setup.md.is_fmi3();
                Ok(Some(Me::resolve(binary, fmi3, status, m.provides_directional_derivative)?))
            }
            _ => Ok(None),
        }
    }

    /// The instance the calls go to, once it exists.
    pub fn bind(&mut self, instance: *mut c_void) {
        self.instance = instance;
    }

    pub fn names(&self) -> &'static Names {
        self.names
    }
}

// SAFETY of every call below: the standard's own functions, resolved from its library for
// these shapes, on the live instance `bind` gave, with buffers of the lengths passed.
impl Me {
    pub fn enter_event_mode(&self, cx: &mut Calls) -> Done {
        let (i, f) = (self.instance, self.enter_event);
        cx.call(self.names.enter_event, || (self.status)(unsafe { f(i) }))
    }

    pub fn enter_continuous_time_mode(&self, cx: &mut Calls) -> Done {
        let (i, f) = (self.instance, self.enter_continuous);
        cx.call(self.names.enter_continuous, || (self.status)(unsafe { f(i) }))
    }

    pub fn set_time(&self, cx: &mut Calls, t: f64) -> Done {
        let (i, f) = (self.instance, self.set_time);
        cx.call(self.names.set_time, || (self.status)(unsafe { f(i, t) }))
    }

    pub fn set_states(&self, cx: &mut Calls, x: &[f64]) -> Done {
        let (i, f) = (self.instance, self.set_states);
        cx.call(self.names.set_states, || (self.status)(unsafe { f(i, x.as_ptr(), x.len()) }))
    }

    pub fn get(&self, cx: &mut Calls, which: Vector, out: &mut [f64]) -> Done {
        let (i, f, name) =
            (self.instance, self.vectors[which as usize], self.names.vectors[which as usize]);
        cx.call(name, || (self.status)(unsafe { f(i, out.as_mut_ptr(), out.len()) }))
    }

    pub fn update_discrete_states(&self, cx: &mut Calls) -> Result<EventUpdate, FmuError> {
        let (i, name) = (self.instance, self.names.update);
        match self.own {
            Own::Fmi2 { update, .. } => {
                let mut info = fmi2EventInfo::default();
                cx.call(name, || (self.status)(unsafe { update(i, &mut info) }))?;
                Ok(EventUpdate {
                    needs_update: info.newDiscreteStatesNeeded != 0,
                    terminate: info.terminateSimulation != 0,
                    nominals_changed: info.nominalsOfContinuousStatesChanged != 0,
                    states_changed: info.valuesOfContinuousStatesChanged != 0,
                    next_event_time: (info.nextEventTimeDefined != 0).then_some(info.nextEventTime),
                })
            }
            Own::Fmi3 { update, .. } => {
                // Read as bytes: a value other than 0 or 1 must not make an invalid bool.
                let mut flags = [0u8; 5];
                let mut next = 0.0;
                cx.call(name, || {
                    let p = flags.as_mut_ptr().cast::<bool>();
                    // SAFETY: five distinct one-byte slots.
                    (self.status)(unsafe {
                        update(i, p, p.add(1), p.add(2), p.add(3), p.add(4), &mut next)
                    })
                })?;
                let [needs, terminate, nominals, states, defined] = flags.map(|b| b != 0);
                Ok(EventUpdate {
                    needs_update: needs,
                    terminate,
                    nominals_changed: nominals,
                    states_changed: states,
                    next_event_time: defined.then_some(next),
                })
            }
        }
    }

    /// `(enter event mode, terminate simulation)`.
    pub fn completed_integrator_step(
        &self,
        cx: &mut Calls,
        no_prior: bool,
    ) -> Result<(bool, bool), FmuError> {
        let (i, name) = (self.instance, self.names.completed);
        match self.own {
            Own::Fmi2 { completed, .. } => {
                let (mut event, mut end): (fmi2Boolean, fmi2Boolean) = (0, 0);
                cx.call(name, || {
                    (self.status)(unsafe { completed(i, no_prior.into(), &mut event, &mut end) })
                })?;
                Ok((event != 0, end != 0))
            }
            Own::Fmi3 { completed, .. } => {
                let mut flags = [0u8; 2];
                cx.call(name, || {
                    let p = flags.as_mut_ptr().cast::<bool>();
                    // SAFETY: two distinct one-byte slots.
                    (self.status)(unsafe { completed(i, no_prior, p, p.add(1)) })
                })?;
                Ok((flags[0] != 0, flags[1] != 0))
            }
        }
    }

    /// `out[j] = Σ_k ∂unknowns[j]/∂knowns[k] · seed[k]`.
    pub fn directional_derivative(
        &self,
        cx: &mut Calls,
        (unknowns, knowns): (&[u32], &[u32]),
        seed: &[f64],
        out: &mut [f64],
    ) -> Done {
        let (i, name) = (self.instance, self.names.directional);
        let missing = || cx.unsupported(name, self.names.directional_flag);
        let (u, nu, k, nk) = (unknowns.as_ptr(), unknowns.len(), knowns.as_ptr(), knowns.len());
        match self.own {
            Own::Fmi2 { directional, .. } => {
                let f = directional.ok_or_else(missing)?;
                cx.call(name, || {
                    (self.status)(unsafe { f(i, u, nu, k, nk, seed.as_ptr(), out.as_mut_ptr()) })
                })
            }
            Own::Fmi3 { directional, .. } => {
                let f = directional.ok_or_else(missing)?;
                cx.call(name, || {
                    (self.status)(unsafe {
                        f(i, u, nu, k, nk, seed.as_ptr(), seed.len(), out.as_mut_ptr(), out.len())
                    })
                })
            }
        }
    }
}
