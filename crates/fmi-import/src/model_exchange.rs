//! [`MeFmu`]: an FMU instantiated for Model Exchange. It owns the [`Instance`] both
//! interfaces share (variables, initialization, FMU state, terminate, reset: its methods
//! are reached through `Deref`) and adds the Model Exchange calls. The vectors it reads
//! and writes must have the lengths the model description gives (number of continuous
//! states, number of event indicators): a wrong length is an
//! [`FmuError::InvalidArgument`] naming the call, never a C call with a short buffer.
//!
//! The interface is in the type: a Model Exchange instance has no `do_step`, and a
//! Co-Simulation one ([`crate::CsFmu`]) no continuous states.
//!
//! ```compile_fail,E0599
//! fn step(fmu: &mut inchworm_fmi_import::MeFmu) {
//!     fmu.do_step(0.001).unwrap();
//! }
//! ```
//!
//! ```compile_fail,E0599
//! fn states(fmu: &mut inchworm_fmi_import::CsFmu) {
//!     fmu.set_continuous_states(&[0.0]).unwrap();
//! }
//! ```

use std::ops::{Deref, DerefMut};
use std::path::Path;

use crate::backend::me::{Me, Vector};
use crate::{ContinuousState, EventUpdate, FmuError, Instance};

/// One instantiated Model Exchange FMU (FMI 2.0 or 3.0).
#[derive(Debug)]
pub struct MeFmu {
    fmu: Instance,
    states: Vec<ContinuousState>,
    event_indicators: usize,
}

impl Deref for MeFmu {
    type Target = Instance;
    fn deref(&self) -> &Instance {
        &self.fmu
    }
}

impl DerefMut for MeFmu {
    fn deref_mut(&mut self) -> &mut Instance {
        &mut self.fmu
    }
}

impl MeFmu {
    /// Unpacks `path`, loads the library of its `<ModelExchange>` and instantiates it for
    /// Model Exchange under `instance_name` (as [`crate::CsFmu::load`] does for
    /// Co-Simulation).
    pub fn load(path: &Path, instance_name: &str, logging_on: bool) -> Result<Self, FmuError> {
        Ok(Self::wrap(Instance::load(
            path,
            instance_name,
            (logging_on, |_| crate::Interface::ModelExchange),
        )?))
    }

    /// Another Model Exchange instance from the folder this one was unpacked in.
    pub fn instantiate_again(
        &self,
        instance_name: &str,
        logging_on: bool,
    ) -> Result<Self, FmuError> {
        Ok(Self::wrap(self.fmu.instantiate_again(instance_name, logging_on)?))
    }

    /// A Model Exchange wrapper of `fmu`, which was instantiated for Model Exchange.
    pub(crate) fn wrap(fmu: Instance) -> Self {
        let me = fmu.description.model_exchange.as_ref().expect("checked by from_description");
        let (states, event_indicators) = (me.states.clone(), me.number_of_event_indicators);
        MeFmu { fmu, states, event_indicators }
    }

    /// The continuous states (value references of each state and its derivative), in the
    /// order of the state vector.
    pub fn continuous_states(&self) -> &[ContinuousState] {
        &self.states
    }

    /// The number of continuous states.
    pub fn nx(&self) -> usize {
        self.states.len()
    }

    /// The number of event indicators.
    pub fn nz(&self) -> usize {
        self.event_indicators
    }

    /// Whether the FMU provides directional derivatives (the exact Jacobian).
    pub fn provides_directional_derivative(&self) -> bool {
        self.fmu
            .description
            .model_exchange
            .as_ref()
            .is_some_and(|me| me.provides_directional_derivative)
    }

    /// Whether `fmi*CompletedIntegratorStep` may be skipped.
    pub fn completed_integrator_step_not_needed(&self) -> bool {
        self.fmu
            .description
            .model_exchange
            .as_ref()
            .is_some_and(|me| me.completed_integrator_step_not_needed)
    }

    /// The instance's Model Exchange calls and its call state.
    fn me(&mut self) -> (&Me, &mut crate::backend::Calls) {
        let me = self.fmu.backend.me().expect("an MeFmu is instantiated for Model Exchange");
        (me, &mut self.fmu.cx)
    }

    /// Refuses a vector of another length than `expected` before any C call.
    fn length(
        &mut self,
        function: &'static str,
        len: usize,
        expected: usize,
    ) -> Result<(), FmuError> {
        self.fmu.cx.alive(function)?;
        if len != expected {
            return Err(self
                .fmu
                .cx
                .invalid(function, format!("a vector of {len} values, the FMU has {expected}")));
        }
        Ok(())
    }

    /// `fmi2EnterEventMode` / `fmi3EnterEventMode`.
    pub fn enter_event_mode(&mut self) -> Result<(), FmuError> {
        let (me, cx) = self.me();
        me.enter_event_mode(cx)
    }

    /// `fmi2EnterContinuousTimeMode` / `fmi3EnterContinuousTimeMode`.
    pub fn enter_continuous_time_mode(&mut self) -> Result<(), FmuError> {
        let (me, cx) = self.me();
        me.enter_continuous_time_mode(cx)
    }

    /// `fmi2NewDiscreteStates` / `fmi3UpdateDiscreteStates`: one pass of the event
    /// iteration.
    pub fn update_discrete_states(&mut self) -> Result<EventUpdate, FmuError> {
        let (me, cx) = self.me();
        me.update_discrete_states(cx)
    }

    /// `fmi2CompletedIntegratorStep` / `fmi3CompletedIntegratorStep`: `(enter event mode,
    /// terminate simulation)`. `no_prior`: no state of an earlier time will be restored.
    pub fn completed_integrator_step(&mut self, no_prior: bool) -> Result<(bool, bool), FmuError> {
        let no_prior = no_prior && self.fmu.states.is_empty();
        let (me, cx) = self.me();
        me.completed_integrator_step(cx, no_prior)
    }

    /// `fmi2SetTime` / `fmi3SetTime`; errors after it name this time. A time that is not
    /// finite is refused before the call: no FMU is handed a NaN time.
    pub fn set_time(&mut self, t: f64) -> Result<(), FmuError> {
        if !t.is_finite() {
            let f = self.me().0.names().set_time;
            self.fmu.cx.alive(f)?;
            return Err(self.fmu.cx.invalid(f, format!("the time {t} is not finite")));
        }
        let (me, cx) = self.me();
        me.set_time(cx, t)?;
        // The grid of a Co-Simulation instance is one point here: the time last set.
        (cx.start_time, cx.steps_done) = (t, 0);
        Ok(())
    }

    /// `fmi2SetContinuousStates` / `fmi3SetContinuousStates`.
    pub fn set_continuous_states(&mut self, x: &[f64]) -> Result<(), FmuError> {
        let f = self.me().0.names().set_states;
        self.length(f, x.len(), self.nx())?;
        let (me, cx) = self.me();
        me.set_states(cx, x)
    }

    fn vector(&mut self, which: Vector, out: &mut [f64]) -> Result<(), FmuError> {
        let f = self.me().0.names().vectors[which as usize];
        let n = if which == Vector::EventIndicators { self.nz() } else { self.nx() };
        self.length(f, out.len(), n)?;
        let (me, cx) = self.me();
        me.get(cx, which, out)
    }

    /// `fmi2GetDerivatives` / `fmi3GetContinuousStateDerivatives`.
    pub fn get_derivatives(&mut self, dx: &mut [f64]) -> Result<(), FmuError> {
        self.vector(Vector::Derivatives, dx)
    }

    /// `fmi2GetEventIndicators` / `fmi3GetEventIndicators`.
    pub fn get_event_indicators(&mut self, z: &mut [f64]) -> Result<(), FmuError> {
        self.vector(Vector::EventIndicators, z)
    }

    /// `fmi2GetContinuousStates` / `fmi3GetContinuousStates`.
    pub fn get_continuous_states(&mut self, x: &mut [f64]) -> Result<(), FmuError> {
        self.vector(Vector::States, x)
    }

    /// `fmi2GetNominalsOfContinuousStates` / `fmi3GetNominalsOfContinuousStates`.
    pub fn get_nominals(&mut self, nominals: &mut [f64]) -> Result<(), FmuError> {
        self.vector(Vector::Nominals, nominals)
    }

    /// `fmi2GetDirectionalDerivative` / `fmi3GetDirectionalDerivative`:
    /// `out[j] = Σ_k ∂unknowns[j]/∂knowns[k] · seed[k]`.
    pub fn directional_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), FmuError> {
        let f = self.me().0.names().directional;
        self.length(f, seed.len(), knowns.len())?;
        self.length(f, out.len(), unknowns.len())?;
        let (me, cx) = self.me();
        me.directional_derivative(cx, (unknowns, knowns), seed, out)
    }
}
