//! What the integrator's closures call: the FMU's derivatives, Jacobian-vector products
//! (directional derivatives, or finite differences) and event indicators, each checked
//! finite, the first error kept for after the step.

use crate::fmu::{FmuError, MeFmu};
use crate::{Error, StopFlag};

use super::MeStats;

/// What the integrator's closures share: the FMU, the first error it gave (the closures
/// cannot return one; they return NaN and the error is raised after the step) and counts.
pub(super) struct Eval<'f> {
    pub(super) fmu: &'f mut MeFmu,
    pub(super) error: Option<Error>,
    pub(super) stats: MeStats,
    pub(super) states: &'f [u32],
    pub(super) derivatives: &'f [u32],
    pub(super) directional: bool,
    /// `f(x)` and the shifted state of [`Eval::finite_difference`], reused.
    pub(super) scratch: Vec<f64>,
    pub(super) shifted: Vec<f64>,
    pub(super) name: &'f str,
    pub(super) stop: Option<&'f StopFlag>,
    /// The time and the states the FMU holds from this integration's last
    /// [`Eval::at`] (their bits; `None` and empty before the first): an evaluation at the
    /// same time or at the same states leaves them as they are, so the root function
    /// after the step's last Newton evaluation, and the step's end after the root
    /// function, cost no second `fmi*SetTime` or `fmi*SetContinuousStates`.
    pub(super) given_t: Option<u64>,
    pub(super) given_x: Vec<f64>,
    /// The last Jacobian computed whole (column-major), which a new solver starts from
    /// while [`Eval::reuse`] is set; and the columns of the one being computed.
    pub(super) jacobian: &'f mut Option<Vec<f64>>,
    pub(super) reuse: bool,
    pub(super) columns: Vec<f64>,
}

impl Eval<'_> {
    fn fail(&mut self, e: Error, out: &mut [f64]) {
        if self.error.is_none() {
            self.error = Some(e);
        }
        out.fill(f64::NAN);
    }

    /// The FMU at time `t` with the states `x`: each set unless it holds them already.
    pub(super) fn at(&mut self, t: f64, x: &[f64]) -> Result<(), FmuError> {
        if self.given_t != Some(t.to_bits()) {
            self.given_t = None;
            self.fmu.set_time(t)?;
            self.given_t = Some(t.to_bits());
        }
        if !same_bits(&self.given_x, x) {
            self.given_x.clear();
            self.fmu.set_continuous_states(x)?;
            self.given_x.extend_from_slice(x);
        }
        Ok(())
    }

    /// Before an evaluation: the run's stop flag (a dense Jacobian is `nx` products, and
    /// the flag is not left waiting for them), and the integrator's time and state, which
    /// must be finite before the FMU is handed them.
    pub(super) fn ready(&self, t: f64, x: &[f64]) -> Result<(), Error> {
        // The common case, in one pass and no `Result` built along it.
        let stopped = self.stop.is_some_and(StopFlag::is_set);
        if !stopped && t.is_finite() && all_finite(x) {
            return Ok(());
        }
        if let Some(flag) = self.stop {
            flag.check()?;
        }
        integrator_finite(self.name, t, x)
    }

    /// `what` (a call's result, `out`) must be finite.
    fn finite(&self, what: &str, t: f64, out: &[f64]) -> Result<(), Error> {
        if all_finite(out) {
            return Ok(());
        }
        match out.iter().position(|v| !v.is_finite()) {
            None => Ok(()),
            Some(i) => Err(Error::Integration {
                component: self.name.to_owned(),
                time: t,
                message: format!("{what} {i} is {} (not finite)", out[i]),
            }),
        }
    }

    pub(super) fn derivatives(&mut self, t: f64, x: &[f64], dx: &mut [f64]) {
        self.stats.derivatives += 1;
        let r = self.ready(t, x).and_then(|()| {
            self.at(t, x).and_then(|()| self.fmu.get_derivatives(dx)).map_err(Error::from)
        });
        let r = r.and_then(|()| self.finite("the derivative", t, dx));
        if let Err(e) = r {
            self.fail(e, dx);
        }
    }

    /// `∂ẋ/∂x · v` into `out`. diffsol forms a dense Jacobian from the products with
    /// `e_0 … e_(n−1)` in turn: those columns are kept as they come, and while
    /// [`Eval::reuse`] is set a unit seed is answered from the last Jacobian kept instead of
    /// the FMU.
    pub(super) fn jacobian_product(&mut self, t: f64, x: &[f64], v: &[f64], out: &mut [f64]) {
        let unit = unit_seed(v);
        if let (true, Some(j), Some(kept)) = (self.reuse, unit, self.jacobian.as_ref()) {
            out.copy_from_slice(&kept[j * out.len()..(j + 1) * out.len()]);
            return;
        }
        self.evaluate_product(t, x, v, out);
        if self.error.is_some() {
            return;
        }
        let n = out.len();
        match unit {
            // The next column in turn: kept; the last one completes a Jacobian.
            Some(j) if j * n == self.columns.len() => {
                self.columns.extend_from_slice(out);
                if j + 1 == v.len() {
                    let whole = std::mem::take(&mut self.columns);
                    match self.jacobian.as_mut() {
                        Some(kept) => kept.copy_from_slice(&whole),
                        None => *self.jacobian = Some(whole.clone()),
                    }
                    self.columns = whole;
                    self.columns.clear();
                }
            }
            _ => self.columns.clear(),
        }
    }

    fn evaluate_product(&mut self, t: f64, x: &[f64], v: &[f64], out: &mut [f64]) {
        self.stats.jacobian_products += 1;
        let r = self.ready(t, x).and_then(|()| {
            if self.directional {
                self.at(t, x).and_then(|()| {
                    self.fmu.directional_derivative(self.derivatives, self.states, v, out)
                })
            } else {
                self.finite_difference(t, x, v, out)
            }
            .map_err(Error::from)
        });
        let r = r.and_then(|()| self.finite("the Jacobian product", t, out));
        if let Err(e) = r {
            self.fail(e, out);
        }
    }

    /// `(f(x + ε v) − f(x)) / ε`, with ε scaled to `x` and `v`.
    fn finite_difference(
        &mut self,
        t: f64,
        x: &[f64],
        v: &[f64],
        out: &mut [f64],
    ) -> Result<(), FmuError> {
        let norm = |a: &[f64]| a.iter().map(|e| e * e).sum::<f64>().sqrt();
        let (nx, nv) = (norm(x), norm(v));
        if nv == 0.0 {
            out.fill(0.0);
            return Ok(());
        }
        let eps = f64::EPSILON.sqrt() * (1.0 + nx) / nv;
        // `f(x)` and `x + ε v` in buffers kept across calls: no allocation per product.
        let (mut f0, mut shifted) =
            (std::mem::take(&mut self.scratch), std::mem::take(&mut self.shifted));
        f0.resize(x.len(), 0.0);
        shifted.clear();
        shifted.extend(x.iter().zip(v).map(|(a, b)| a + eps * b));
        self.at(t, x)?;
        self.fmu.get_derivatives(&mut f0)?;
        self.at(t, &shifted)?;
        self.fmu.get_derivatives(out)?;
        out.iter_mut().zip(&f0).for_each(|(o, f)| *o = (*o - f) / eps);
        (self.scratch, self.shifted) = (f0, shifted);
        Ok(())
    }

    pub(super) fn indicators(&mut self, t: f64, x: &[f64], z: &mut [f64]) {
        if self.fmu.nz() == 0 {
            // diffsol is given one constant root function for an FMU without indicators.
            z.fill(1.0);
            return;
        }
        let r = self.ready(t, x).and_then(|()| {
            self.at(t, x).and_then(|()| self.fmu.get_event_indicators(z)).map_err(Error::from)
        });
        let r = r.and_then(|()| self.finite("event indicator", t, z));
        if let Err(e) = r {
            self.fail(e, z);
        }
    }
}

/// `Some(j)` if `v` is the unit vector `e_j` (the bits of 1 at `j`, of 0 elsewhere).
pub(super) fn unit_seed(v: &[f64]) -> Option<usize> {
    let j = v.iter().position(|e| e.to_bits() == 1f64.to_bits())?;
    v.iter().enumerate().all(|(i, e)| i == j || e.to_bits() == 0).then_some(j)
}

/// Every element finite: a fold without an early exit, which the compiler vectorizes.
fn all_finite(a: &[f64]) -> bool {
    a.iter().fold(true, |ok, v| ok & v.is_finite())
}

/// The same length and the same bits, element by element.
pub(super) fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

/// The integrator's time `t` and state `x` are finite, or an error of `component` that
/// says they are not (the integrator's failure, not the FMU's: it is not handed them).
pub(super) fn integrator_finite(component: &str, t: f64, x: &[f64]) -> Result<(), Error> {
    let error =
        |message| Err(Error::Integration { component: component.to_owned(), time: t, message });
    if !t.is_finite() {
        return error(format!("the integrator reached the time {t} (not finite)"));
    }
    match x.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => error(format!("the integrator's state {i} is {} (not finite)", x[i])),
    }
}

/// `fmi*CompletedIntegratorStep` after an accepted step, unless the FMU said it needs none
/// (`not_needed`): whether the FMU asks for a step event. Its asking to terminate is an
/// error of `component` at `t`.
pub(super) fn completed_step(
    fmu: &mut MeFmu,
    not_needed: bool,
    component: &str,
    t: f64,
) -> Result<bool, Error> {
    if not_needed {
        return Ok(false);
    }
    let (event, terminate) = fmu.completed_integrator_step(true)?;
    if terminate {
        return Err(Error::Integration {
            component: component.to_owned(),
            time: t,
            message: "the FMU asked to terminate the simulation (completed integrator step)".into(),
        });
    }
    Ok(event)
}
