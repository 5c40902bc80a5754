//! The plant in continuous time, for a master that integrates it (FMI Model Exchange).
//!
//! Between events the plant is the linear system the exact solver exponentiates: the
//! mechanics and the extension channel `ż = A z` with `A = linear::system_matrix` of the
//! current mode and sticking weight, each brake channel `ċ = M c` with
//! `M = linear::chain_matrix`, the DAC volts held in the augmented entries. The continuous
//! states are the non-augmented entries ([`N_STATES`]); the augmented ones (`1`, the held
//! volts, the hysteresis offset `c0`) and the mode, sticking set, play memories, drive
//! offset and encoder are the discrete state, changed only by [`Plant::event_update`].
//!
//! The events are those the exact solver locates, as sign changes of
//! [`Plant::event_indicators`], each a linear functional of the state between events:
//! each brake's amplifier voltage against `V_th`; `ξ` against the next slip onset up and
//! down; and while elements slip, `ξ̇` in the slip direction (the slip ends where it turns).
//! At an event, [`Plant::event_update`] applies what the solver applies at a located
//! event: the jump conditions of the brakes (docs/model.md §2.2), then the hysteresis
//! re-derived from the exact `ξ` and the sign of `ξ̇`.
//!
//! These are the model's equations, the stack as its three elements; its surge modes (17
//! and 29 kHz) hold a BDF integrator's steps to a few µs (docs/model.md §5). [`reduced`] is
//! the same plant with those modes carried in closed form and only the slow ones left to
//! the integrator; it shares the slots, the rates and the Jacobian's layout with this one.

use nalgebra::SMatrix;

use crate::hysteresis::Hysteresis;
use crate::linear::{self, ix, Chain, ChainMatrix, Vector};
use crate::numerics::kernels::mul_vec;
use crate::numerics::solver::held_volts;
use crate::{Dac, Mode, Plant, PlantParams, StepReport};

pub mod next_event;
pub mod reduced;

/// Continuous states: the mechanics (`y1 v1 y2 v2 y3 v3 y4 v4`, positions as deviations
/// from rest), the extension channel (Bessel output, its rate, amplifier volts), then the
/// earth and the non-earth channel likewise.
pub const N_STATES: usize = 17;
/// Event indicators: earth volts − `V_th`, non-earth volts − `V_th`, `ξ` − next onset up,
/// next onset down − `ξ`, and `ξ̇` in the slip direction.
pub const N_INDICATORS: usize = 5;

/// Where a continuous state lives in the plant.
#[derive(Clone, Copy)]
enum Slot {
    Z(usize),
    Earth(usize),
    Nonearth(usize),
}

impl Slot {
    /// The DAC channel held in the state's block: extension, earth, non-earth.
    fn input(self) -> usize {
        match self {
            Slot::Z(_) => 0,
            Slot::Earth(_) => 1,
            Slot::Nonearth(_) => 2,
        }
    }
}

const SLOTS: [Slot; N_STATES] = {
    use Slot::*;
    [
        Z(ix::Y1),
        Z(ix::V1),
        Z(ix::Y2),
        Z(ix::V2),
        Z(ix::Y3),
        Z(ix::V3),
        Z(ix::Y4),
        Z(ix::V4),
        Z(ix::BX1),
        Z(ix::BX2),
        Z(ix::VX),
        Earth(0),
        Earth(1),
        Earth(2),
        Nonearth(0),
        Nonearth(1),
        Nonearth(2),
    ]
};

/// `∂ẋ/∂x` and `∂ẋ/∂u` of the current configuration, `u` = (extension, earth, non-earth)
/// DAC volts, for a formulation of `S` states.
#[derive(Clone, Debug, PartialEq)]
pub struct Jacobian<const S: usize = N_STATES> {
    pub states: SMatrix<f64, S, S>,
    pub inputs: SMatrix<f64, S, 3>,
}

/// What one event update did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EventReport {
    /// Brake switches and entries into FREE, as a step reports them.
    pub step: StepReport,
    /// A jump condition changed the continuous states (velocities at a brake switch).
    pub states_changed: bool,
}

impl Plant {
    pub fn continuous_states(&self) -> [f64; N_STATES] {
        std::array::from_fn(|k| self.continuous_state(k))
    }

    /// Continuous state `k` of [`Plant::continuous_states`] alone, for a getter of one
    /// variable. Panics for `k >= N_STATES`.
    #[inline]
    pub fn continuous_state(&self, k: usize) -> f64 {
        match SLOTS[k] {
            Slot::Z(i) => self.state.z[i],
            Slot::Earth(i) => self.state.earth[i],
            Slot::Nonearth(i) => self.state.nonearth[i],
        }
    }

    /// Sets the continuous states (the integrator's); the discrete state stays.
    pub fn set_continuous_states(&mut self, x: &[f64; N_STATES]) {
        for (s, v) in SLOTS.iter().zip(x) {
            match *s {
                Slot::Z(i) => self.state.z[i] = *v,
                Slot::Earth(i) => self.state.earth[i] = *v,
                Slot::Nonearth(i) => self.state.nonearth[i] = *v,
            }
        }
    }

    /// The state and chains with `dac` in their held-input entries, as a step holds it.
    fn held(&self, dac: Dac) -> (Vector, Chain, Chain) {
        let (mut z, mut e, mut n) = (self.state.z, self.state.earth, self.state.nonearth);
        z[ix::UX] = held_volts(dac.extension);
        e[3] = held_volts(dac.earth);
        n[3] = held_volts(dac.nonearth);
        (z, e, n)
    }

    fn system_matrix(&self) -> linear::Matrix {
        match &self.solver.configs[self.config_key()] {
            Some(cfg) => cfg.a,
            None => linear::system_matrix(
                &self.params,
                self.state.mode,
                self.state.hysteresis.sticking_weight(),
            ),
        }
    }

    /// The rate of every continuous state with `dac` held, in the current configuration.
    pub fn derivatives(&self, dac: Dac) -> [f64; N_STATES] {
        let (z, e, n) = self.held(dac);
        rates(&SLOTS, &self.system_matrix(), &self.solver.chain.a, (&z, &e, &n))
    }

    /// The exact Jacobian of [`Plant::derivatives`]: the configuration's matrices.
    pub fn jacobian(&self) -> Jacobian {
        self.jacobian_of(&SLOTS, &self.system_matrix())
    }

    /// The Jacobian of the rates of the states `slots` under the rate matrix `a` of the
    /// mechanics and the extension channel and the plant's channel matrix.
    fn jacobian_of<const S: usize>(&self, slots: &[Slot; S], a: &linear::Matrix) -> Jacobian<S> {
        let m = &self.solver.chain.a;
        let mut j = Jacobian { states: SMatrix::zeros(), inputs: SMatrix::zeros() };
        for (r, sr) in slots.iter().enumerate() {
            for (c, sc) in slots.iter().enumerate() {
                j.states[(r, c)] = match (*sr, *sc) {
                    (Slot::Z(a_r), Slot::Z(a_c)) => a[(a_r, a_c)],
                    (Slot::Earth(a_r), Slot::Earth(a_c))
                    | (Slot::Nonearth(a_r), Slot::Nonearth(a_c)) => m[(a_r, a_c)],
                    _ => 0.0,
                };
            }
            // Held volts inside 0-10 V enter linearly; the layer clamps inputs to that range.
            j.inputs[(r, sr.input())] = match *sr {
                Slot::Z(a_r) => a[(a_r, ix::UX)],
                Slot::Earth(a_r) | Slot::Nonearth(a_r) => m[(a_r, 3)],
            };
        }
        j
    }

    /// The event indicators; an event is a sign change of one of them (from negative to
    /// non-negative for the hysteresis ones, either way for the brakes).
    pub fn event_indicators(&self) -> [f64; N_INDICATORS] {
        indicators(
            &self.params,
            self.state.mode,
            &self.state.hysteresis,
            (&self.state.z, &self.state.earth, &self.state.nonearth),
        )
    }

    /// Event mode at time `t` with `dac` held: the brakes decided on the current volts (the
    /// jump conditions of a mode change), the hysteresis re-derived, the encoder sampled;
    /// what the exact solver does at a located event and at the end of a step.
    pub fn event_update(&mut self, dac: Dac, t: f64) -> EventReport {
        let before = self.continuous_states();
        (self.state.z, self.state.earth, self.state.nonearth) = self.held(dac);
        self.state.time = t;
        let mut step = StepReport::default();
        self.handle_event(&mut step);
        if self.state.mode == Mode::Drive {
            // The runner rides on node 3, as at the end of a step.
            self.state.z[ix::Y4] = self.state.z[ix::Y3] + self.state.drive_offset;
            self.state.z[ix::V4] = self.state.z[ix::V3];
        }
        self.sample_encoder();
        let after = self.continuous_states();
        let changed = before.iter().zip(&after).any(|(a, b)| a.to_bits() != b.to_bits());
        EventReport { step, states_changed: changed }
    }
}

/// The rates of the states `slots` of `(z, e, n)` under the system matrix `a` and the
/// channel matrix `m`.
fn rates<const S: usize>(
    slots: &[Slot; S],
    a: &linear::Matrix,
    m: &ChainMatrix,
    (z, e, n): (&Vector, &Chain, &Chain),
) -> [f64; S] {
    let dz = mul_vec(a, z);
    let (de, dn) = (mul_vec(m, e), mul_vec(m, n));
    slots.map(|s| match s {
        Slot::Z(i) => dz[i],
        Slot::Earth(i) => de[i],
        Slot::Nonearth(i) => dn[i],
    })
}

fn indicators(
    p: &PlantParams,
    mode: Mode,
    h: &Hysteresis,
    (z, e, n): (&Vector, &Chain, &Chain),
) -> [f64; N_INDICATORS] {
    let xi = linear::xi_row(p, h.sticking_weight()).dot(z);
    let rate = linear::drive_rate_row(p, mode).dot(z);
    let (up, down) = h.next_thresholds();
    // Thresholds at infinity (every element slips that way) can't be reached: a constant
    // that never changes sign stands for them.
    let finite_or = |v: f64| if v.is_finite() { v } else { -1.0 };
    let sliding = h.sliding != 0;
    [
        e[2] - p.v_th,
        n[2] - p.v_th,
        finite_or(xi - up),
        finite_or(down - xi),
        if sliding { -f64::from(h.direction) * rate } else { -1.0 },
    ]
}

/// The derivatives and indicators of the plant at rest (docs/model.md §2.7) with `dac`
/// held, which a plant built from `p` would have: before one is built, a master may
/// already read them.
pub fn at_rest(p: &PlantParams, dac: Dac) -> ([f64; N_STATES], [f64; N_INDICATORS]) {
    let mut z = Vector::zeros();
    (z[ix::ONE], z[ix::UX]) = (1.0, held_volts(dac.extension));
    let (mut e, mut n) = (Chain::zeros(), Chain::zeros());
    (e[3], n[3]) = (held_volts(dac.earth), held_volts(dac.nonearth));
    let h = Hysteresis::new(p.play_radius, p.play_weight);
    let a = linear::system_matrix(p, Mode::Hold, h.sticking_weight());
    let rest = (&z, &e, &n);
    (rates(&SLOTS, &a, &linear::chain_matrix(p), rest), indicators(p, Mode::Hold, &h, rest))
}

/// Event-mode updates a Model Exchange plant takes per 2 ms window, the Co-Simulation
/// solver's budget of located events per 2 ms (a nominal gait makes a few dozen). Beyond
/// it a master is locating an endless sequence of events at one threshold (chattering): the
/// FMU can't suspend the master's root finding as the exact solver suspends its own, so
/// the update fails instead of letting the master spin.
pub const EVENTS_PER_2_MS: u32 = crate::numerics::solver::EVENTS_PER_2_MS;

/// Counts the event updates of the 2 ms window `[t0 + 2k ms, t0 + 2(k + 1) ms)` the master
/// is in.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EventBudget {
    window: i64,
    used: u32,
}

impl EventBudget {
    /// Spends one update at time `t` of a run that started at `t0`; `Err` with the reason
    /// once the window's [`EVENTS_PER_2_MS`] are spent.
    pub fn spend(&mut self, t: f64, t0: f64) -> Result<(), String> {
        // Saturating float-to-int: a window index needs no more than the time can say.
        let window = ((t - t0) / 0.002).floor() as i64;
        if window != self.window {
            *self = EventBudget { window, used: 0 };
        }
        if self.used >= EVENTS_PER_2_MS {
            let start = t0 + 0.002 * window as f64;
            return Err(format!("more than {EVENTS_PER_2_MS} event updates in the 2 ms from t = {start} s (at t = {t} s): the master is locating an endless sequence of events at one threshold (chattering)"));
        }
        self.used += 1;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_budget_is_per_2_ms_window_from_the_start() {
        let mut b = EventBudget::default();
        let t0 = 0.5;
        for _ in 0..EVENTS_PER_2_MS {
            assert_eq!(b.spend(0.5011, t0), Ok(()));
        }
        let why = b.spend(0.5019, t0).unwrap_err();
        assert!(
            why.contains(
                "more than 20000 event updates in the 2 ms from t = 0.5 s (at t = 0.5019 s)"
            ),
            "{why}"
        );
        // The next window starts afresh; so does a window the master returns to later.
        assert_eq!(b.spend(0.5021, t0), Ok(()));
        assert_eq!(b.used, 1);
        assert_eq!(b.spend(0.5011, t0), Ok(()));
        assert_eq!(b.used, 1);
    }
}
