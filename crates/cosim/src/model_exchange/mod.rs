//! Model Exchange components: the master integrates them itself over each communication
//! step, so that their outputs join the same Jacobi or Gauss–Seidel exchange as those of
//! Co-Simulation components (docs/model-exchange.md).
//!
//! Between two communication steps an ME component is in Event Mode: right after
//! initialization (both standards leave Initialization Mode for Event Mode) and at the end
//! of every [`MeRun::advance`]. So the master may set any input at a communication point,
//! continuous or discrete, and an input's jump is an event the FMU sees. A step from `t`
//! to `t + h` then is:
//!
//! 1. the event iteration at `t` (`fmi2NewDiscreteStates` / `fmi3UpdateDiscreteStates`
//!    until no further pass is asked for), which also gives the next time event;
//! 2. Continuous-Time Mode, and diffsol's BDF (variable order 1–5, Newton with the
//!    Jacobian from the FMU's directional derivatives, finite differences if it has none,
//!    a new solver starting from the last one computed whole)
//!    from `t` to the next time event or `t + h`, with root finding on the event
//!    indicators; `fmi*CompletedIntegratorStep` after each accepted step;
//! 3. at a state event (a root), a step event or a time event before `t + h`: Event Mode,
//!    the event iteration, the states read back (they may have jumped), and the BDF
//!    restarted from there;
//! 4. Event Mode at `t + h`, and an event iteration there, so that discrete outputs
//!    (updated only in an event iteration) are those of `t + h` when the master reads
//!    them. A time event exactly at `t + h` is left to step 1 of the next communication
//!    step instead, after the master has set that point's inputs, as a Co-Simulation FMU
//!    sees them at the start of its `doStep` (a sampled controller samples the inputs of
//!    its sampling instant).
//!
//! Every loop is bounded: an event iteration that does not settle in
//! [`MAX_EVENT_ITERATIONS`] passes, or more than [`MAX_EVENTS_PER_STEP`] events in one
//! communication step, is an [`Error::Integration`] that says so, as is a non-finite
//! derivative or event indicator, or the integrator's own failure; the FMU's refusals keep
//! their names ([`crate::fmu::FmuError`]). The BDF continues across a communication point
//! at which no Real input changed, no state jumped and the derivatives are the same bits,
//! and restarts elsewhere ([`solver`]); what it carries is part of a checkpoint, so a run
//! restored from one repeats bit for bit.

mod eval;
mod solver;
#[cfg(test)]
mod tests;

pub use solver::Carry;

use crate::fmu::{Causality, MeFmu, VarType};
use crate::limits::{self, ATOL, NOMINAL, RTOL, STEP};
use crate::{Error, StopFlag};
use solver::Start;

/// The most passes of one event iteration before the master gives up.
pub const MAX_EVENT_ITERATIONS: usize = 1000;
/// The most events (state, step and time events) in one communication step.
pub const MAX_EVENTS_PER_STEP: usize = 100_000;

/// The integrator's tolerances: a state's error is held to `rtol · |x| + atol · nominal`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerance {
    pub rtol: f64,
    pub atol: f64,
}

// 1e-8 / 1e-10 left 3 counts on 20 s of the staircase against the exact plant; these
// hold it to 2 (docs/model-exchange.md), at about the same cost.
impl Default for Tolerance {
    fn default() -> Self {
        Tolerance { rtol: 1e-9, atol: 1e-11 }
    }
}

impl Tolerance {
    /// Both tolerances within their ranges ([`limits::RTOL`], [`limits::ATOL`]), or an
    /// [`Error::OutOfRange`] naming the field.
    pub fn check(&self) -> Result<(), Error> {
        RTOL.check("the Model Exchange tolerance's rtol", self.rtol)?;
        ATOL.check("the Model Exchange tolerance's atol", self.atol)?;
        Ok(())
    }
}

/// What the integration of one component cost so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MeStats {
    /// Accepted integrator steps.
    pub steps: u64,
    /// Derivative evaluations (`fmi*GetDerivatives`).
    pub derivatives: u64,
    /// Jacobian-vector products (directional derivatives or finite differences).
    pub jacobian_products: u64,
    pub state_events: u64,
    pub time_events: u64,
    pub step_events: u64,
}

/// One line for a log or a command line's summary: `inchworm run` prints it for each ME
/// component.
impl std::fmt::Display for MeStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = self;
        write!(
            f,
            "{} integrator steps, {} derivative and {} Jacobian-product evaluations, {} state, {} time and {} step events",
            s.steps, s.derivatives, s.jacobian_products, s.state_events, s.time_events, s.step_events
        )
    }
}

/// One Model Exchange component and how it is integrated.
pub struct MeRun {
    pub(crate) fmu: MeFmu,
    tolerance: Tolerance,
    name: String,
    stats: MeStats,
    /// The value references of the states and of their derivatives (directional
    /// derivatives `∂ẋ/∂x`).
    states: Vec<u32>,
    derivatives: Vec<u32>,
    nominals: Vec<f64>,
    /// The value references of the Real inputs, read at each communication point.
    inputs: Box<[u32]>,
    /// What the integrator carries to the next communication point.
    carry: Carry,
    /// Ends an integration at its next step once set ([`MeRun::stop_when`]).
    stop: Option<StopFlag>,
}

/// Why an integration ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ended {
    /// At the time asked for.
    Target,
    /// At a root of an event indicator.
    StateEvent,
    /// `fmi*CompletedIntegratorStep` asked for Event Mode.
    StepEvent,
}

impl MeRun {
    /// `fmu`, initialized (in Event Mode), integrated to `tolerance`; `name`: the
    /// component's, for the errors. Refused: a tolerance out of its range, or an FMU with
    /// more continuous states or event indicators than [`limits`] allows (a master that
    /// loads FMUs itself checks those before unpacking them: [`limits::check_description`]).
    pub fn new(fmu: MeFmu, name: &str, tolerance: Tolerance) -> Result<MeRun, Error> {
        tolerance.check()?;
        limits::check_description(name, fmu.description(), true)?;
        let states = fmu.continuous_states().iter().map(|s| s.state).collect();
        let derivatives = fmu.continuous_states().iter().map(|s| s.derivative).collect();
        let inputs = fmu
            .variables()
            .filter(|v| v.causality == Causality::Input && v.ty == VarType::Real)
            .map(|v| v.vr)
            .collect();
        Ok(MeRun {
            fmu,
            tolerance,
            name: name.to_owned(),
            stats: MeStats::default(),
            states,
            derivatives,
            nominals: Vec::new(),
            inputs,
            carry: Carry::default(),
            stop: None,
        })
    }

    /// Makes [`MeRun::advance`] end with [`Error::Stopped`] at the integrator's next step
    /// (or its next evaluation of the FMU) once `flag` is set: a run stops inside a long
    /// communication step too.
    pub fn stop_when(&mut self, flag: Option<StopFlag>) {
        self.stop = flag;
    }

    /// The name of the call of this FMU's standard: `fmi2` or `fmi3`.
    fn call(&self, fmi2: &'static str, fmi3: &'static str) -> &'static str {
        if self.fmu.description().is_fmi3() {
            fmi3
        } else {
            fmi2
        }
    }

    /// `value`, returned by the FMU's `call` as `what`, is finite (and in `range` if one
    /// is given), or an [`Error::FmuValue`] that says so.
    fn fmu_value(
        &self,
        t: f64,
        call: &'static str,
        what: impl FnOnce() -> String,
        value: f64,
        range: Option<limits::Range>,
    ) -> Result<f64, Error> {
        let fine = match range {
            Some(r) => r.contains(value),
            None => value.is_finite(),
        };
        if fine {
            return Ok(value);
        }
        Err(Error::FmuValue {
            component: self.name.clone(),
            time: t,
            call,
            what: what(),
            value,
            range,
        })
    }

    /// What the integration cost so far.
    pub fn stats(&self) -> MeStats {
        self.stats
    }

    fn error(&self, time: f64, message: impl Into<String>) -> Error {
        Error::Integration { component: self.name.clone(), time, message: message.into() }
    }

    /// Passes of the discrete-state update until none more is needed: the next time
    /// event, if any, and whether a pass changed the continuous states.
    fn event_iteration(&mut self, t: f64) -> Result<(Option<f64>, bool), Error> {
        let f = self.call("fmi2NewDiscreteStates", "fmi3UpdateDiscreteStates");
        let mut jumped = false;
        for _ in 0..MAX_EVENT_ITERATIONS {
            let u = self.fmu.update_discrete_states()?;
            jumped |= u.states_changed;
            if u.terminate {
                return Err(self.error(t, format!("{f} asked to terminate the simulation")));
            }
            if u.nominals_changed || self.nominals.is_empty() {
                self.nominals = vec![0.0; self.fmu.nx()];
                self.fmu.get_nominals(&mut self.nominals)?;
                let call = self
                    .call("fmi2GetNominalsOfContinuousStates", "fmi3GetNominalsOfContinuousStates");
                for (i, &n) in self.nominals.iter().enumerate() {
                    self.fmu_value(
                        t,
                        call,
                        || format!("the nominal of state {i}"),
                        n,
                        Some(NOMINAL),
                    )?;
                }
            }
            if !u.needs_update {
                if let Some(te) = u.next_event_time {
                    let what = || "the next event time (nextEventTime, defined)".to_string();
                    self.fmu_value(t, f, what, te, None)?;
                }
                return Ok((u.next_event_time, jumped));
            }
        }
        Err(self.error(
            t,
            format!("the event iteration did not converge: {f} still asked for another pass after {MAX_EVENT_ITERATIONS}"),
        ))
    }

    /// From `t` (in Event Mode, the inputs of `t` set) to `t + h`, in Event Mode again.
    pub fn advance(&mut self, t: f64, h: f64) -> Result<(), Error> {
        if !STEP.contains(h) {
            // Said only when refused: the check costs no allocation per step.
            STEP.check(&format!("component {}: the communication step", self.name), h)?;
        }
        let end = t + h;
        if !end.is_finite() || end <= t {
            return Err(self.error(t, format!("a step of {h} s does not advance the time {t} s")));
        }
        self.fmu.set_time(t)?;
        let (next, jumped) = self.event_iteration(t)?;
        self.fmu.enter_continuous_time_mode()?;
        let inputs = self.read_inputs()?;
        let start = self.start_at(t, h, jumped, &inputs)?;
        self.segments(t, h, next, start, &inputs)
    }

    /// The integration of the step from `t` to `t + h` (the FMU in Continuous-Time Mode at
    /// `t`, `next` its next time event), segment by segment between the events, from
    /// `start`; `inputs`: the step's Real inputs.
    fn segments(
        &mut self,
        t: f64,
        h: f64,
        mut next: Option<f64>,
        mut start: Start,
        inputs: &[f64],
    ) -> Result<(), Error> {
        let end = t + h;
        let mut now = t;
        // A time event this close to the communication point is at the point: `t + h`
        // and the FMU's own `k · period` may differ in the last bits.
        let at_end = |te: f64| (te - end).abs() <= 1e-9 * h;
        for _ in 0..MAX_EVENTS_PER_STEP {
            let time_event = next.filter(|&te| te < end && !at_end(te));
            if let Some(te) = time_event {
                if te < now {
                    return Err(self
                        .error(now, format!("the FMU's next time event ({te} s) is in the past")));
                }
            }
            let target = time_event.unwrap_or(end);
            // The BDF's state is carried past the point only if no event is due there.
            let keep = (time_event.is_none() && !next.is_some_and(at_end)).then_some(inputs);
            let from = std::mem::replace(&mut start, Start::Fresh);
            let (reached, ended) = self.integrate(now, target, from, keep)?;
            now = reached;
            match ended {
                Ended::Target if time_event.is_none() => {
                    self.fmu.enter_event_mode()?;
                    // The values at the communication point: an FMU may update its
                    // discrete outputs (the plant's encoder counts) only in an event
                    // iteration. A time event due at the point waits for the next step's,
                    // after the master has set the point's inputs.
                    if !next.is_some_and(at_end) && self.event_iteration(end)?.1 {
                        // The states jumped at the point: nothing is carried past it.
                        self.carry.forget();
                    }
                    return Ok(());
                }
                Ended::Target => self.stats.time_events += 1,
                Ended::StateEvent => self.stats.state_events += 1,
                Ended::StepEvent => self.stats.step_events += 1,
            }
            self.fmu.enter_event_mode()?;
            next = self.event_iteration(now)?.0;
            self.fmu.enter_continuous_time_mode()?;
        }
        Err(self.error(
            now,
            format!("more than {MAX_EVENTS_PER_STEP} events in the communication step from {t} s (chattering?)"),
        ))
    }
}
