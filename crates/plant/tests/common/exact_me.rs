//! A formulation of the plant in continuous time driven as a Model Exchange master drives
//! it, integrated without integration error.
//!
//! Between events the right-hand side is affine, `ẋ = J x + c` (`J` the exact Jacobian,
//! `c` the derivatives at `x = 0`), so `e^{[J c; 0 0] τ}` propagates it exactly. The event
//! indicators are watched on a scan of a given interval and each sign change is bisected
//! to 1e-15 s, the update applied at the end where the indicator has crossed, as an ME
//! master's root finder leaves it. At every 2 ms instant the master's sequence: an event
//! update with the volts held before, the encoder read, the new volts, a second update.
//! What an integrator leaves on top of this is its own error.

use inchworm_plant::continuous::{self, reduced::Reduced, N_INDICATORS};
use inchworm_plant::{Dac, Plant, PlantParams};
use nalgebra::{SMatrix, SVector};

/// Room for the largest formulation's states and the constant 1 after them; a smaller
/// formulation's unused entries stay 0 (their rows and columns are 0).
const N: usize = continuous::N_STATES + 1;
type Augmented = SMatrix<f64, N, N>;
type State = SVector<f64, N>;

pub const H: f64 = 0.002;
const RESOLUTION: f64 = 1e-15;

/// What the integration needs of a formulation: the Model Exchange calls.
pub trait Formulation {
    fn new(p: PlantParams) -> Self;
    fn states(&self) -> Vec<f64>;
    fn set_states(&mut self, x: &[f64]);
    fn derivatives(&self, dac: Dac) -> Vec<f64>;
    /// `∂ẋ/∂x`, row by row.
    fn jacobian(&self) -> Vec<Vec<f64>>;
    fn indicators(&self) -> [f64; N_INDICATORS];
    /// The master's time, before the states at that time are set.
    fn set_time(&mut self, t: f64);
    fn update(&mut self, dac: Dac, t: f64);
    fn plant(&self) -> &Plant;
}

impl Formulation for Plant {
    fn new(p: PlantParams) -> Self {
        Plant::new(p).unwrap()
    }
    fn states(&self) -> Vec<f64> {
        self.continuous_states().to_vec()
    }
    fn set_states(&mut self, x: &[f64]) {
        self.set_continuous_states(x.try_into().unwrap());
    }
    fn derivatives(&self, dac: Dac) -> Vec<f64> {
        Plant::derivatives(self, dac).to_vec()
    }
    fn jacobian(&self) -> Vec<Vec<f64>> {
        let j = Plant::jacobian(self).states;
        j.row_iter().map(|r| r.iter().copied().collect()).collect()
    }
    fn indicators(&self) -> [f64; N_INDICATORS] {
        self.event_indicators()
    }
    /// The model is autonomous between events.
    fn set_time(&mut self, _: f64) {}
    fn update(&mut self, dac: Dac, t: f64) {
        self.event_update(dac, t);
    }
    fn plant(&self) -> &Plant {
        self
    }
}

impl Formulation for Reduced {
    fn new(p: PlantParams) -> Self {
        Reduced::new(p).unwrap()
    }
    fn states(&self) -> Vec<f64> {
        self.continuous_states().to_vec()
    }
    fn set_states(&mut self, x: &[f64]) {
        self.set_continuous_states(x.try_into().unwrap());
    }
    fn derivatives(&self, dac: Dac) -> Vec<f64> {
        Reduced::derivatives(self, dac).to_vec()
    }
    fn jacobian(&self) -> Vec<Vec<f64>> {
        let j = Reduced::jacobian(self).states;
        j.row_iter().map(|r| r.iter().copied().collect()).collect()
    }
    fn indicators(&self) -> [f64; N_INDICATORS] {
        self.event_indicators()
    }
    fn set_time(&mut self, t: f64) {
        Reduced::set_time(self, t);
    }
    fn update(&mut self, dac: Dac, t: f64) {
        self.event_update(dac, t);
    }
    fn plant(&self) -> &Plant {
        Reduced::plant(self)
    }
}

/// An event between two values of the indicators: the brakes switch on a sign change either
/// way, the hysteresis indicators from negative to non-negative (`Plant::event_indicators`).
fn crossed(z0: &[f64; N_INDICATORS], z1: &[f64; N_INDICATORS]) -> bool {
    (0..2).any(|i| (z0[i] < 0.0) != (z1[i] < 0.0)) || (2..5).any(|i| z0[i] < 0.0 && z1[i] >= 0.0)
}

/// The formulation `F` driven as a Model Exchange master drives it, integrated exactly.
pub struct ExactMe<F> {
    pub model: F,
    dac: Dac,
    /// States of the formulation.
    n: usize,
    /// The scan interval (s).
    scan_step: f64,
    /// `[J c; 0 0]` of the current configuration, and its propagator over one scan step.
    a: Augmented,
    scan: Augmented,
    t: f64,
    pub state_events: u32,
}

impl<F: Formulation> ExactMe<F> {
    pub fn new(p: PlantParams, scan_step: f64) -> Self {
        let model = F::new(p);
        let n = model.states().len();
        assert!(n < N);
        let zero = Augmented::zeros();
        let dac = Dac::default();
        let mut me =
            ExactMe { model, dac, n, scan_step, a: zero, scan: zero, t: 0.0, state_events: 0 };
        me.update(0.0);
        me
    }

    pub fn plant(&self) -> &Plant {
        self.model.plant()
    }

    fn state(&self) -> State {
        let x = self.model.states();
        State::from_fn(|i, _| if i < self.n { x[i] } else { f64::from(u8::from(i == N - 1)) })
    }

    fn indicators_at(&mut self, t: f64, x: &State) -> [f64; N_INDICATORS] {
        self.model.set_time(t);
        self.model.set_states(&x.as_slice()[..self.n]);
        self.model.indicators()
    }

    /// Event mode at `t`: the formulation's update, then the dynamics of the configuration
    /// it left.
    fn update(&mut self, t: f64) {
        self.t = t;
        self.model.update(self.dac, t);
        let j = self.model.jacobian();
        let x = self.model.states();
        self.model.set_states(&vec![0.0; self.n]);
        let c = self.model.derivatives(self.dac);
        self.model.set_states(&x);
        let n = self.n;
        self.a = Augmented::from_fn(|r, k| match (r < n, k < n, k == N - 1) {
            (true, true, _) => j[r][k],
            (true, false, true) => c[r],
            _ => 0.0,
        });
        self.scan = (self.a * self.scan_step).exp();
    }

    /// Continuous time to `end`, stopping at every event on the way.
    pub fn advance_to(&mut self, end: f64) {
        while end - self.t > RESOLUTION {
            let tau = (end - self.t).min(self.scan_step);
            let x0 = self.state();
            let z0 = self.model.indicators();
            let phi = if tau == self.scan_step { self.scan } else { (self.a * tau).exp() };
            let x1 = phi * x0;
            if !crossed(&z0, &self.indicators_at(self.t + tau, &x1)) {
                self.t += tau;
                continue;
            }
            let (mut lo, mut hi) = (0.0, tau);
            while hi - lo > RESOLUTION {
                let mid = 0.5 * (lo + hi);
                let x = (self.a * mid).exp() * x0;
                if crossed(&z0, &self.indicators_at(self.t + mid, &x)) {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            let x = (self.a * hi).exp() * x0;
            self.indicators_at(self.t + hi, &x);
            self.state_events += 1;
            self.update(self.t + hi);
        }
        // The model holds the state of `end`: the last indicators were taken on it.
        self.t = end;
    }

    /// The sample `[k h, (k + 1) h)` with `dac` held; the encoder is read at its end.
    pub fn sample(&mut self, dac: Dac, k: usize) {
        self.dac = dac;
        self.update(k as f64 * H);
        self.advance_to((k + 1) as f64 * H);
        self.update((k + 1) as f64 * H);
    }

    /// The first `tau` seconds of the sample `[k h, (k + 1) h)` with `dac` held, in
    /// continuous time at the end.
    pub fn sample_part(&mut self, dac: Dac, k: usize, tau: f64) {
        self.dac = dac;
        self.update(k as f64 * H);
        self.advance_to(k as f64 * H + tau);
    }
}
