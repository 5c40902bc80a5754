//! The reduced formulation for Model Exchange (docs/model.md §5.1): the integrator carries
//! the plant's slow motion only (the runner outside DRIVE and the three analog channels);
//! the lightly damped mechanical modes, the stack's surge (17 and 29 kHz) and node 3's ring
//! on the stack and flexure (the 2.2 kHz runner–flexure ring in DRIVE, 4.5 kHz in HOLD), are
//! carried by the plant itself, in closed form.
//!
//! In each configuration (mode and sliding set) the model is linear, `ż = A z`. Split `z`
//! into the stack's nodes `x1 = (y1, v1, y2, v2, y3, v3)` and the rest `x2`: the runner, the
//! extension channel and the held constants (`1`, the DAC volts, `c0`). The slow modes span
//! the invariant subspace `x1 = X x2`, `X` the solution of `X (A22 + A21 X) = A11 X + A12`
//! nearest the quasi-static `−A11⁻¹ A12`; in the coordinates
//!
//! `f = x1 − X x2` (fast), `s = x2 − Y f` (slow), `Y L − S Y = A21`, `L = A11 − X A21`,
//! `S = A22 + A21 X`,
//!
//! the dynamics separate exactly: `ṡ = S s`, `ḟ = L f`. The integrator integrates `s` (the
//! slow eigenvalues are the model's: the channels, the runner in FREE, the zeros of HOLD,
//! LOCKED and of the runner riding on node 3 in DRIVE); the fast part is
//! `f(t) = e^{L (t − t_e)} f(t_e)` from the last split at `t_e`, and the plant's physical
//! state is `x2 = s + Y f`, `x1 = X x2 + f`. At an event the model's jump conditions act on
//! the physical state, and `f` and `s` are taken anew in the configuration it leaves. The
//! formulation has no error of its own: only the integrator's, on `s`.
//!
//! LOCKED has no mechanics: there `s` is the physical state and the stack stays frozen.

use std::sync::Arc;

use nalgebra::{Complex, SMatrix};

use super::{rates, Jacobian, Slot, N_INDICATORS};
use crate::linear::{ix, Vector};
use crate::numerics::configs::every_configuration;
use crate::params::N_PLAYS;
use crate::{Dac, ParamError, Plant, PlantParams};

pub use super::EventReport;

/// Continuous states: the slow parts of `y4 v4` (the runner, a deviation from rest), the
/// extension channel (Bessel output, its rate, amplifier volts), then the earth and the
/// non-earth channel likewise: the model's states but for the stack's nodes.
pub const N_STATES: usize = 11;

/// The model's states ([`super::SLOTS`]) after its first six, the stack's nodes.
const REDUCED: [Slot; N_STATES] = {
    let mut slots = [Slot::Z(0); N_STATES];
    let mut i = 0;
    while i < N_STATES {
        slots[i] = super::SLOTS[super::N_STATES - N_STATES + i];
        i += 1;
    }
    slots
};

/// The stack's nodes, and everything else in `linear`'s state.
const FAST: [usize; 6] = [ix::Y1, ix::V1, ix::Y2, ix::V2, ix::Y3, ix::V3];
const SLOW: [usize; 8] = [ix::Y4, ix::V4, ix::BX1, ix::BX2, ix::VX, ix::ONE, ix::UX, ix::C0];

mod split;

use split::{reduce, Config, Split};

type Fast = SMatrix<f64, 6, 1>;
type Modal = SMatrix<Complex<f64>, 6, 1>;

/// `Re(V e)`, with the bits of nalgebra's `(V * e).map(|z| z.re)`: its product runs column
/// by column, `y ← (V_{·j} e_j) + y` (a sum has the same bits either way round), and a
/// complex product's real part is `v.re e.re − v.im e.im`; the imaginary parts, which
/// nothing reads, are not formed. (A zero of the sum may take the other sign than
/// nalgebra's, whose `1 · v` and `1 · y` can turn `−0` into `+0`; no later sum sees that.)
fn re_product(v: &SMatrix<Complex<f64>, 6, 6>, e: &Modal) -> Fast {
    let term = |i: usize, j: usize| v[(i, j)].re * e[j].re - v[(i, j)].im * e[j].im;
    let mut f = Fast::from_fn(|i, _| term(i, 0));
    for j in 1..6 {
        for i in 0..6 {
            f[i] += term(i, j);
        }
    }
    f
}

/// The rates a [`Reduced`] keeps between reads, with the DAC volts' bits they are for. A
/// mutex, not a `Cell`, so the plant stays `Sync` (a framework may share it between threads);
/// a read that finds it taken by another thread computes the rates without keeping them.
#[derive(Debug, Default)]
struct KeptRates(std::sync::Mutex<Option<([u64; 3], [f64; N_STATES])>>);

impl KeptRates {
    fn get(&self) -> Option<([u64; 3], [f64; N_STATES])> {
        self.0.try_lock().ok().and_then(|k| *k)
    }

    fn set(&self, key: [u64; 3], rates: [f64; N_STATES]) {
        if let Ok(mut k) = self.0.try_lock() {
            *k = Some((key, rates));
        }
    }

    fn clear(&mut self) {
        *self.0.get_mut().unwrap_or_else(|p| p.into_inner()) = None;
    }
}

impl Clone for KeptRates {
    fn clone(&self) -> Self {
        KeptRates(std::sync::Mutex::new(self.get()))
    }
}

/// The plant in the reduced formulation, driven through the Model Exchange calls below:
/// the integrator's slow states, the fast part in closed form, and the [`Plant`] holding
/// the physical state they make at the current time.
#[derive(Clone, Debug)]
pub struct Reduced {
    plant: Plant,
    /// The slow state over `linear`'s layout (the entries of `x1` unused).
    s: Vector,
    /// The fast part at the last split, and that time.
    fast: Fast,
    /// The fast part at the last split in its configuration's modes (`V⁻¹ f`), if it has them.
    modal: Option<Modal>,
    since: f64,
    /// The fast part at the time of the last [`Reduced::join`] (its bits): a master sets the
    /// time and then the states at it, and evaluates the rates and their Jacobian there, so
    /// one exponential serves them all.
    at: Option<(u64, Fast)>,
    /// The rates of the last [`Reduced::derivatives`], with the bits of the DAC volts
    /// they were taken for: a master reads the rates one variable at a time, each the
    /// same vector. Every `&mut self` method forgets them.
    rates: KeptRates,
    /// Every configuration's split, by the plant's configuration key.
    configs: Arc<Vec<Config>>,
}

impl Reduced {
    /// At rest (docs/model.md §2.7) at time 0; the parameters are validated, and refused
    /// if the stack's modes are not separated from the slow ones in some configuration (no
    /// nominal device comes near that).
    pub fn new(params: PlantParams) -> Result<Self, ParamError> {
        Reduced::from_plant(Plant::new(params)?)
    }

    /// The reduced formulation of `plant`'s state at its time.
    pub fn from_plant(plant: Plant) -> Result<Self, ParamError> {
        let p = plant.params();
        let mut configs = Vec::with_capacity(4 << N_PLAYS);
        for (mode, _, a) in every_configuration(p) {
            configs.push(reduce(&a, mode).ok_or_else(|| ParamError {
                field: "m_p".into(),
                reason: format!("in {mode:?} the stack's modes are not separated from the analog chain's and the runner's: the reduced formulation needs them several times faster"),
            })?);
        }
        let since = plant.state.time;
        let mut r = Reduced {
            s: plant.state.z,
            plant,
            fast: Fast::zeros(),
            modal: None,
            since,
            at: None,
            rates: KeptRates::default(),
            configs: Arc::new(configs),
        };
        r.split();
        Ok(r)
    }

    /// The plant: its physical state at the current time, outputs, mode and state bytes.
    pub fn plant(&self) -> &Plant {
        &self.plant
    }

    fn config(&self) -> &Config {
        &self.configs[self.plant.config_key()]
    }

    /// The fast part in the current configuration's modes, if it has them.
    fn modal_of_fast(&self) -> Option<Modal> {
        let m = self.config().split.as_ref()?.modes.as_ref()?;
        Some(m.v_inv * self.fast.map(|x| Complex::new(x, 0.0)))
    }

    /// Splits the physical state in the current configuration: the fast part from now on,
    /// and the slow state.
    fn split(&mut self) {
        self.rates.clear();
        self.s = self.plant.state.z;
        self.since = self.plant.state.time;
        self.fast = Fast::zeros();
        self.modal = None;
        self.at = None;
        if let Some(Split { x, y, .. }) = &self.configs[self.plant.config_key()].split {
            let z = &self.plant.state.z;
            let x2 = SMatrix::<f64, 8, 1>::from_fn(|i, _| z[SLOW[i]]);
            let x1 = Fast::from_fn(|i, _| z[FAST[i]]);
            self.fast = x1 - x * x2;
            self.modal = self.modal_of_fast();
            let s = x2 - y * self.fast;
            for (i, &k) in SLOW.iter().enumerate() {
                self.s[k] = s[i];
            }
        }
    }

    /// The physical state at the plant's time from the slow state and the fast part.
    fn join(&mut self) {
        self.rates.clear();
        let key = self.plant.config_key();
        let z = &mut self.plant.state.z;
        match &self.configs[key].split {
            Some(Split { x, y, l, modes }) => {
                let t = self.plant.state.time.to_bits();
                let tau = self.plant.state.time - self.since;
                let f = match (self.at, modes, &self.modal) {
                    (Some((at, f)), _, _) if at == t => f,
                    _ if tau == 0.0 => self.fast,
                    (_, Some(m), Some(c)) => {
                        let e = m.lambda.zip_map(c, |l, c| (l * tau).exp() * c);
                        let f = re_product(&m.v, &e);
                        self.at = Some((t, f));
                        f
                    }
                    _ => {
                        let f = (l * tau).exp() * self.fast;
                        self.at = Some((t, f));
                        f
                    }
                };
                let s = SMatrix::<f64, 8, 1>::from_fn(|i, _| self.s[SLOW[i]]);
                let x2 = s + y * f;
                let x1 = x * x2 + f;
                for (i, &k) in SLOW.iter().enumerate() {
                    z[k] = x2[i];
                }
                for (i, &k) in FAST.iter().enumerate() {
                    z[k] = x1[i];
                }
            }
            None => {
                for &k in &SLOW {
                    z[k] = self.s[k];
                }
            }
        }
    }

    /// The master's time: the fast part moves with it.
    pub fn set_time(&mut self, t: f64) {
        self.plant.state.time = t;
        self.join();
    }

    pub fn continuous_states(&self) -> [f64; N_STATES] {
        REDUCED.map(|slot| match slot {
            Slot::Z(i) => self.s[i],
            Slot::Earth(i) => self.plant.state.earth[i],
            Slot::Nonearth(i) => self.plant.state.nonearth[i],
        })
    }

    /// Sets the continuous states (the integrator's); the physical state follows, the
    /// discrete state stays.
    pub fn set_continuous_states(&mut self, x: &[f64; N_STATES]) {
        for (slot, v) in REDUCED.iter().zip(x) {
            match *slot {
                Slot::Z(i) => self.s[i] = *v,
                Slot::Earth(i) => self.plant.state.earth[i] = *v,
                Slot::Nonearth(i) => self.plant.state.nonearth[i] = *v,
            }
        }
        self.join();
    }

    /// The rate of every continuous state with `dac` held, in the current configuration.
    pub fn derivatives(&self, dac: Dac) -> [f64; N_STATES] {
        let key = [dac.extension, dac.earth, dac.nonearth].map(f64::to_bits);
        if let Some((k, rates)) = self.rates.get() {
            if k == key {
                return rates;
            }
        }
        let r = self.rates_now(dac);
        self.rates.set(key, r);
        r
    }

    /// [`Reduced::derivatives`] computed anew.
    fn rates_now(&self, dac: Dac) -> [f64; N_STATES] {
        let (held, e, n) = self.plant.held(dac);
        let mut s = self.s;
        s[ix::UX] = held[ix::UX];
        rates(&REDUCED, &self.config().a, &self.plant.solver.chain.a, (&s, &e, &n))
    }

    /// The exact Jacobian of [`Reduced::derivatives`]: the configuration's matrices.
    pub fn jacobian(&self) -> Jacobian<N_STATES> {
        self.plant.jacobian_of(&REDUCED, &self.config().a)
    }

    /// The model's event indicators on the physical state ([`Plant::event_indicators`]).
    pub fn event_indicators(&self) -> [f64; N_INDICATORS] {
        self.plant.event_indicators()
    }

    /// Event mode at time `t` with `dac` held: the model's update on the physical state
    /// ([`Plant::event_update`]), then, if it changed the physical state or the
    /// configuration, the state split anew in the configuration it leaves.
    pub fn event_update(&mut self, dac: Dac, t: f64) -> EventReport {
        self.rates.clear();
        let before = self.continuous_states();
        if t.to_bits() != self.plant.state.time.to_bits() {
            self.set_time(t);
        }
        let physical = (self.plant.state.z, self.plant.config_key());
        let mut report = self.plant.event_update(dac, t);
        if physical != (self.plant.state.z, self.plant.config_key()) {
            self.split();
        }
        let after = self.continuous_states();
        report.states_changed = before.iter().zip(&after).any(|(a, b)| a.to_bits() != b.to_bits());
        report
    }

    /// Appends the dynamic state: the slow state, the fast part and the time of its split,
    /// then the plant's own bytes ([`Plant::save_state`]), so that a restored formulation
    /// continues bit for bit.
    pub fn save_state(&self, out: &mut Vec<u8>) {
        let mut w = inchworm_state_bytes::Writer(out);
        for &k in &SLOW {
            w.f64(self.s[k]);
        }
        for v in self.fast.iter() {
            w.f64(*v);
        }
        w.f64(self.since);
        self.plant.save_state(out);
    }

    /// Restores what [`Reduced::save_state`] wrote into a formulation of the same
    /// parameters; on error it is unchanged.
    pub fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        const HEAD: usize = 8 * (SLOW.len() + 6 + 1);
        let (head, plant) = bytes.split_at_checked(HEAD).ok_or("reduced plant state truncated")?;
        let mut r = inchworm_state_bytes::Reader::new(head, "reduced plant state");
        let mut next = self.clone();
        for &k in &SLOW {
            next.s[k] = r.f64()?;
        }
        for v in next.fast.iter_mut() {
            *v = r.f64()?;
        }
        next.since = r.f64()?;
        r.finish()?;
        next.plant.load_state(plant)?;
        next.modal = next.modal_of_fast();
        next.at = None;
        next.rates.clear();
        *self = next;
        Ok(())
    }
}

/// The derivatives and indicators of the reduced plant at rest (docs/model.md §2.7) with
/// `dac` held, as a plant built from `p` has them after its first event update: before one
/// is built, a master may already read them.
pub fn at_rest(
    p: &PlantParams,
    dac: Dac,
) -> Result<([f64; N_STATES], [f64; N_INDICATORS]), ParamError> {
    let mut r = Reduced::new(p.clone())?;
    r.event_update(dac, 0.0);
    Ok((r.derivatives(dac), r.event_indicators()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rates kept between two reads are those computed anew, through every call that
    /// changes what they depend on: the states, the time, the DAC volts, an event update
    /// (a drive that closes the brakes and starts the runner), a restored state.
    #[test]
    fn kept_rates_are_the_rates_of_now() {
        let bits = |r: [f64; N_STATES]| r.map(f64::to_bits);
        let mut r = Reduced::new(PlantParams::fia20()).unwrap();
        let (rest, drive) = (Dac::default(), Dac { earth: 10.0, nonearth: 0.0, extension: 5.0 });
        r.event_update(rest, 0.0);
        let same = |r: &Reduced, dac: Dac| {
            let kept = r.derivatives(dac);
            assert_eq!(bits(kept), bits(r.rates_now(dac)));
            assert_eq!(bits(r.derivatives(dac)), bits(kept), "read twice");
            kept
        };
        let at_rest = same(&r, rest);
        let driven = same(&r, drive);
        assert_ne!(bits(at_rest), bits(driven), "the DAC volts move the rates");
        r.event_update(drive, 1e-3);
        let after_event = same(&r, drive);
        let saved = {
            let mut out = Vec::new();
            r.save_state(&mut out);
            out
        };
        let mut x = r.continuous_states();
        for (i, v) in x.iter_mut().enumerate() {
            *v += 1e-6 * (i + 1) as f64;
        }
        r.set_continuous_states(&x);
        let moved = same(&r, drive);
        assert_ne!(bits(moved), bits(after_event), "the states move the rates");
        r.set_time(2e-3);
        same(&r, drive);
        r.load_state(&saved).unwrap();
        assert_eq!(bits(same(&r, drive)), bits(after_event), "restored");
    }

    /// The real part of the modal product has nalgebra's bits: on random matrices and
    /// vectors of every sign and magnitude, and on every configuration's own modes.
    #[test]
    fn the_real_product_is_nalgebras() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let unit = (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            unit * 10f64.powi((seed % 17) as i32 - 8)
        };
        let check = |v: &SMatrix<Complex<f64>, 6, 6>, e: &Modal| {
            let ours = re_product(v, e);
            let theirs = (v * e).map(|z| z.re);
            assert_eq!(ours.map(f64::to_bits), theirs.map(f64::to_bits), "{v} {e}");
        };
        for _ in 0..2000 {
            let v = SMatrix::<Complex<f64>, 6, 6>::from_fn(|_, _| Complex::new(next(), next()));
            let e = Modal::from_fn(|_, _| Complex::new(next(), next()));
            check(&v, &e);
        }
        let r = Reduced::new(PlantParams::fia20()).unwrap();
        let mut modal = 0;
        for config in r.configs.iter() {
            let Some(m) = config.split.as_ref().and_then(|s| s.modes.as_ref()) else { continue };
            for tau in [1e-6, 3.7e-5, 1e-3] {
                let c = Modal::from_fn(|_, _| Complex::new(next(), 0.0));
                let e = m.lambda.zip_map(&(m.v_inv * c), |l, c| (l * tau).exp() * c);
                check(&m.v, &e);
            }
            modal += 1;
        }
        assert!(modal > 0);
    }
}
