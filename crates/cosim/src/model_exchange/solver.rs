//! The integration between two events: diffsol's BDF on the FMU's equations, and what it
//! carries across a communication point at which nothing happened.
//!
//! A communication step that ends with no event at its end leaves the BDF's state (its
//! Nordsieck history, order and step size) in a [`Carry`], with the derivatives and the
//! Real inputs at that point. The next step continues from it when, after its event
//! iteration, the FMU's states, derivatives and Real inputs at that point are the same
//! bits and no state jumped: no input changed and no event happened there, so the
//! equations the history was built on still hold. Anything else restarts the BDF at order
//! 1, with diffsol's estimate of a first step. The carry is part
//! of a checkpoint ([`MeRun::carry`], [`MeRun::set_carry`]), so a restored run repeats bit
//! for bit.

use std::cell::RefCell;

use diffsol::{
    BdfState, NalgebraLU, NalgebraMat, NalgebraVec, OdeBuilder, OdeSolverMethod, OdeSolverState,
    OdeSolverStopReason, Vector, VectorCommon,
};

use super::eval::{completed_step, same_bits, Eval};
use super::{Ended, MeRun, Tolerance};
use crate::Error;

/// The most the BDF's step size grows at once (diffsol's default: 2). diffsol changes the
/// step size only by at least its minimum growth (2) or shrink, after `order + 1` steps at
/// one size, so after a restart at order 1 with its estimate of a first step (1e-10 s
/// after a brake switch of the plant, where its ring needs 1e-5 s) doubling is some 17
/// changes of 2 to 6 steps each. At 4 the plant's Fig. 5 takes 179 012 steps for
/// 10 s where 2 took 222 446, within the same counts of its Co-Simulation
/// (docs/model-exchange.md).
const MAX_STEP_GROWTH: f64 = 4.0;

/// The BDF's state between two integrations.
type Bdf = BdfState<NalgebraVec<f64>>;

/// What the integrator carries from one communication step to the next; part of a
/// checkpoint.
#[derive(Clone, Default)]
pub struct Carry {
    /// The BDF at the communication point the last step ended at, if no event happened
    /// at its end.
    at_point: Option<Box<AtPoint>>,
    /// The last Jacobian the integrator computed whole, column-major: a new integration's
    /// solver starts from it (diffsol computes it anew when Newton converges slowly or
    /// fails, and after a number of steps).
    jacobian: Option<Vec<f64>>,
}

/// The BDF's state at a communication point, and what its equations were there.
#[derive(Clone)]
struct AtPoint {
    bdf: Bdf,
    /// The derivatives at the point and the Real inputs of the step that ended there.
    rate: Vec<f64>,
    inputs: Vec<f64>,
}

/// How an integration starts.
pub(super) enum Start {
    /// At order 1.
    Fresh,
    /// Continuing the BDF's state.
    Carried(Box<Bdf>),
}

impl Carry {
    /// Nothing carried past the current communication point.
    pub(super) fn forget(&mut self) {
        self.at_point = None;
    }
}

impl MeRun {
    /// What the integrator carries to the next communication point (for a checkpoint).
    pub fn carry(&self) -> Carry {
        self.carry.clone()
    }

    /// Back to a carry taken with [`MeRun::carry`] (restoring a checkpoint).
    pub fn set_carry(&mut self, carry: Carry) {
        self.carry = carry;
    }

    /// The FMU's Real inputs now.
    pub(super) fn read_inputs(&mut self) -> Result<Vec<f64>, Error> {
        let mut values = vec![0.0; self.inputs.len()];
        if !self.inputs.is_empty() {
            self.fmu.get_real(&self.inputs, &mut values)?;
        }
        Ok(values)
    }

    /// How the integration from the communication point `t` starts, in Continuous-Time
    /// Mode after the point's event iteration (`jumped`: it changed the states; `inputs`:
    /// the Real inputs now): the carried BDF if the states, derivatives and inputs at `t`
    /// are those it ended with, else afresh.
    pub(super) fn start_at(
        &mut self,
        t: f64,
        h: f64,
        jumped: bool,
        inputs: &[f64],
    ) -> Result<Start, Error> {
        let Some(mut p) = self.carry.at_point.take() else { return Ok(Start::Fresh) };
        let state = p.bdf.as_ref();
        // The master's `t` (k · h) and the last step's `t + h` may differ in the last bits.
        if jumped || (state.t - t).abs() > 1e-9 * h || !same_bits(&p.inputs, inputs) {
            return Ok(Start::Fresh);
        }
        let nx = self.fmu.nx();
        let mut x = vec![0.0; nx];
        self.fmu.get_continuous_states(&mut x)?;
        if !same_bits(&x, state.y.inner().as_slice()) {
            return Ok(Start::Fresh);
        }
        let mut rate = vec![0.0; nx];
        self.fmu.get_derivatives(&mut rate)?;
        self.stats.derivatives += 1;
        if !same_bits(&rate, &p.rate) {
            return Ok(Start::Fresh);
        }
        *p.bdf.as_mut().t = t;
        Ok(Start::Carried(Box::new(p.bdf)))
    }

    /// Keeps `bdf`, the integrator's state at the communication point it reached with no
    /// event, for the next step, with the derivatives there and the step's `inputs`.
    fn keep(&mut self, bdf: Bdf, inputs: &[f64]) -> Result<(), Error> {
        let mut rate = vec![0.0; self.fmu.nx()];
        self.fmu.get_derivatives(&mut rate)?;
        self.stats.derivatives += 1;
        self.carry.at_point = Some(Box::new(AtPoint { bdf, rate, inputs: inputs.to_vec() }));
        Ok(())
    }

    /// From `t0` toward `t1` in Continuous-Time Mode, from `start`: where it ended and
    /// why. The FMU is left at that time with the states there. An integration that
    /// reaches `t1` with `keep` set leaves its state in the carry (with `inputs`).
    pub(super) fn integrate(
        &mut self,
        t0: f64,
        t1: f64,
        start: Start,
        keep: Option<&[f64]>,
    ) -> Result<(f64, Ended), Error> {
        let (nx, nz) = (self.fmu.nx(), self.fmu.nz());
        if t1 <= t0 {
            return Ok((t0, Ended::Target));
        }
        if nx == 0 {
            return self.without_states(t1);
        }
        let mut x0 = vec![0.0; nx];
        self.fmu.get_continuous_states(&mut x0)?;
        let call = self.call("fmi2GetContinuousStates", "fmi3GetContinuousStates");
        for (i, &x) in x0.iter().enumerate() {
            self.fmu_value(t0, call, || format!("state {i}"), x, None)?;
        }
        if let Some(flag) = &self.stop {
            flag.check()?;
        }
        let Tolerance { rtol, atol } = self.tolerance;
        // Each nominal is in limits::NOMINAL and atol in limits::ATOL: the product is a
        // normal positive number.
        let atol: Vec<f64> = self.nominals.iter().map(|n| atol * n).collect();
        let directional = self.fmu.provides_directional_derivative();
        let completed_not_needed = self.fmu.completed_integrator_step_not_needed();
        let name = self.name.clone();
        let error = |time: f64, message: String| Error::Integration {
            component: name.clone(),
            time,
            message,
        };
        let failed =
            |e: diffsol::DiffsolError, t: f64| error(t, format!("the BDF integrator failed: {e}"));
        let cell = RefCell::new(Eval {
            fmu: &mut self.fmu,
            error: None,
            stats: self.stats,
            states: &self.states,
            derivatives: &self.derivatives,
            directional,
            scratch: Vec::new(),
            shifted: Vec::new(),
            name: &name,
            stop: self.stop.as_ref(),
            given_t: None,
            given_x: Vec::with_capacity(nx),
            jacobian: &mut self.carry.jacobian,
            reuse: false,
            columns: Vec::with_capacity(nx * nx),
        });
        let take = |cell: &RefCell<Eval<'_>>| cell.borrow_mut().error.take();
        let (outcome, kept) = {
            let problem = OdeBuilder::<NalgebraMat<f64>>::new()
                .t0(t0)
                .h0((t1 - t0) * 1e-3)
                .rtol(rtol)
                .atol(atol)
                .rhs_implicit(
                    |x, _p, t, dx| cell.borrow_mut().derivatives(t, x, dx),
                    |x, _p, t, v, out| cell.borrow_mut().jacobian_product(t, x, v, out),
                )
                .init(|_p, _t, x| x.copy_from_slice(&x0), nx)
                .root(|x, _p, t, z| cell.borrow_mut().indicators(t, x, z), nz.max(1))
                .build()
                .map_err(|e| failed(e, t0))?;
            let state = match start {
                Start::Carried(bdf) => Ok(*bdf),
                Start::Fresh => problem.bdf_state::<NalgebraLU<f64>>(),
            };
            if let Some(e) = take(&cell) {
                return Err(e);
            }
            // The solver forms its first Jacobian from the last one kept, if any.
            cell.borrow_mut().reuse = true;
            let solver = state.and_then(|s| problem.bdf_solver::<NalgebraLU<f64>>(s));
            cell.borrow_mut().reuse = false;
            if let Some(e) = take(&cell) {
                return Err(e);
            }
            let mut solver = solver.map_err(|e| failed(e, t0))?;
            solver.set_stop_time(t1).map_err(|e| failed(e, t0))?;
            solver.config_mut().maximum_timestep_growth = MAX_STEP_GROWTH;
            let mut y = solver.state().y.clone();
            // The step size of the last internal step.
            let mut h_step = solver.state().h;
            let outcome = loop {
                let r = solver.step();
                if let Some(e) = take(&cell) {
                    return Err(e);
                }
                let at = solver.state().t;
                // The state of the step's end (or of the root) into `y`, which lives as long
                // as this integration: no allocation per accepted step.
                let (t, ended) = match r.map_err(|e| failed(e, at))? {
                    OdeSolverStopReason::InternalTimestep => {
                        y.copy_from(solver.state().y);
                        h_step = solver.state().h;
                        (at, None)
                    }
                    OdeSolverStopReason::TstopReached => {
                        y.copy_from(solver.state().y);
                        (t1, Some(Ended::Target))
                    }
                    OdeSolverStopReason::RootFound(t, _) => {
                        solver.interpolate_inplace(t, &mut y).map_err(|e| failed(e, t))?;
                        (t, Some(Ended::StateEvent))
                    }
                };
                let mut eval = cell.borrow_mut();
                eval.stats.steps += 1;
                // The step boundary: a stop asked for during the step ends the run here.
                eval.ready(t, y.inner().as_slice())?;
                eval.at(t, y.inner().as_slice())?;
                let step_event = completed_step(eval.fmu, completed_not_needed, &name, t)?;
                match (ended, step_event) {
                    (Some(e), _) => break (t, e),
                    (None, true) => break (t, Ended::StepEvent),
                    (None, false) => {}
                }
            };
            // A history whose last step was cut short to land on `t1` would start the next
            // communication step at that step size; below half the step size before it, a
            // restart's own estimate is the better start.
            let kept = match (outcome.1, keep) {
                (Ended::Target, Some(_)) if solver.state().h >= 0.5 * h_step => {
                    Some(solver.into_state())
                }
                _ => None,
            };
            (outcome, kept)
        };
        self.stats = cell.into_inner().stats;
        if let (Some(bdf), Some(inputs)) = (kept, keep) {
            self.keep(bdf, inputs)?;
        }
        Ok(outcome)
    }

    /// An FMU without continuous states: its time moves to `t1`, and a sign change of an
    /// event indicator over the interval is an event at its end.
    fn without_states(&mut self, t1: f64) -> Result<(f64, Ended), Error> {
        let nz = self.fmu.nz();
        let mut before = vec![0.0; nz];
        self.fmu.get_event_indicators(&mut before)?;
        self.fmu.set_time(t1)?;
        let mut after = vec![0.0; nz];
        self.fmu.get_event_indicators(&mut after)?;
        self.stats.steps += 1;
        let crossed = before.iter().zip(&after).any(|(a, b)| (*a > 0.0) != (*b > 0.0));
        let not_needed = self.fmu.completed_integrator_step_not_needed();
        let event = completed_step(&mut self.fmu, not_needed, &self.name, t1)?;
        Ok((
            t1,
            match (crossed, event) {
                (true, _) => Ended::StateEvent,
                (false, true) => Ended::StepEvent,
                (false, false) => Ended::Target,
            },
        ))
    }
}
