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
use crate::linear::{self, ix, Matrix, Vector};
use crate::params::N_PLAYS;
use crate::{Dac, Mode, ParamError, Plant, PlantParams};

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

/// Iterations of the invariant-subspace equations before the modes count as not separated.
/// Each shrinks the error by about the ratio of the slow to the fast frequencies (the
/// amplifier's 475 Hz to the 2.2 kHz DRIVE ring, 0.21, for the nominal devices): 30 or so
/// reach rounding.
const MAX_ITERATIONS: usize = 400;

type Fast = SMatrix<f64, 6, 1>;
type Modal = SMatrix<Complex<f64>, 6, 1>;

/// One configuration's split into slow and fast parts.
#[derive(Clone, Debug)]
struct Split {
    x: SMatrix<f64, 6, 8>,
    y: SMatrix<f64, 8, 6>,
    l: SMatrix<f64, 6, 6>,
    /// `L`'s eigendecomposition, if it has one that reproduces `L`.
    modes: Option<Modes>,
}

/// `L = V Λ V⁻¹`, so that `e^{L τ} f = Re(V (e^{λ τ} ∘ V⁻¹ f))`: six complex exponentials
/// where the matrix exponential takes a Padé approximant and its squarings.
#[derive(Clone, Debug)]
struct Modes {
    lambda: Modal,
    v: SMatrix<Complex<f64>, 6, 6>,
    v_inv: SMatrix<Complex<f64>, 6, 6>,
}

/// The largest relative error of `V Λ V⁻¹` against `L` (balanced) with which the modes stand in for
/// the matrix exponential.
const MODES_TOLERANCE: f64 = 1e-12;

/// `l`'s eigendecomposition (each eigenvector the null vector of `L − λ I`, from its SVD),
/// or `None` if it does not reproduce `l` to [`MODES_TOLERANCE`] (repeated or nearly
/// repeated eigenvalues).
fn modes(l: &SMatrix<f64, 6, 6>) -> Option<Modes> {
    // Balanced first (`D⁻¹ L D`, the rows' and columns' norms made alike): positions and
    // velocities differ by the modes' frequencies, and the eigenvectors of the balanced
    // matrix are accurate where those of `L` are not.
    let mut d = [1.0f64; 6];
    let mut b = *l;
    for _ in 0..20 {
        for i in 0..6 {
            let c: f64 = (0..6).filter(|&k| k != i).map(|k| b[(k, i)].abs()).sum();
            let r: f64 = (0..6).filter(|&k| k != i).map(|k| b[(i, k)].abs()).sum();
            if c > 0.0 && r > 0.0 {
                let f = (r / c).sqrt();
                d[i] *= f;
                for k in 0..6 {
                    b[(k, i)] *= f;
                    b[(i, k)] /= f;
                }
            }
        }
    }
    let lambda = b.complex_eigenvalues();
    let bc = b.map(|x| Complex::new(x, 0.0));
    let mut w = SMatrix::<Complex<f64>, 6, 6>::zeros();
    for k in 0..6 {
        let shifted = bc - SMatrix::<Complex<f64>, 6, 6>::identity() * lambda[k];
        let svd = shifted.svd(false, true);
        let v_t = svd.v_t?;
        let smallest = svd.singular_values.argmin().0;
        w.set_column(k, &v_t.row(smallest).adjoint());
    }
    let w_inv = w.try_inverse()?;
    let back = w * SMatrix::from_diagonal(&lambda) * w_inv;
    let error = (back - bc).norm() / bc.norm();
    // V = D W, V⁻¹ = W⁻¹ D⁻¹.
    let v = SMatrix::<Complex<f64>, 6, 6>::from_fn(|i, j| w[(i, j)] * d[i]);
    let v_inv = SMatrix::<Complex<f64>, 6, 6>::from_fn(|i, j| w_inv[(i, j)] / d[j]);
    (error <= MODES_TOLERANCE).then_some(Modes { lambda, v, v_inv })
}

/// One configuration's reduced dynamics.
#[derive(Clone, Debug)]
struct Config {
    /// `S` over `linear`'s state: the rows of `x2` the slow dynamics, those of `x1` zero.
    a: Matrix,
    /// `None` in LOCKED.
    split: Option<Split>,
}

fn block<const R: usize, const C: usize>(
    a: &Matrix,
    rows: &[usize; R],
    cols: &[usize; C],
) -> SMatrix<f64, R, C> {
    SMatrix::from_fn(|r, c| a[(rows[r], cols[c])])
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

/// Iterates `m ← step(m)` to its fixed point; `None` if it doesn't settle (rounding leaves
/// a relative change of 1e-14 or so there) or leaves the finite numbers.
fn fixed_point<const R: usize, const C: usize>(
    mut m: SMatrix<f64, R, C>,
    step: impl Fn(&SMatrix<f64, R, C>) -> SMatrix<f64, R, C>,
) -> Option<SMatrix<f64, R, C>> {
    for _ in 0..MAX_ITERATIONS {
        let next = step(&m);
        if !next.iter().all(|v| v.is_finite()) {
            return None;
        }
        let settled = next.iter().zip(m.iter()).all(|(n, o)| (n - o).abs() <= 1e-12 * n.abs());
        m = next;
        if settled {
            return Some(m);
        }
    }
    None
}

/// The split of the model's rate matrix `a`; `None` if its fast and slow modes are not
/// separated.
fn reduce(a: &Matrix, mode: Mode) -> Option<Config> {
    if mode == Mode::Locked {
        return Some(Config { a: *a, split: None });
    }
    let (a11, a12) = (block(a, &FAST, &FAST), block(a, &FAST, &SLOW));
    let (a21, a22) = (block(a, &SLOW, &FAST), block(a, &SLOW, &SLOW));
    let a11_inv = a11.try_inverse()?;
    let x = fixed_point(-a11_inv * a12, |x| a11_inv * (x * (a22 + a21 * x) - a12))?;
    let l = a11 - x * a21;
    let l_inv = l.try_inverse()?;
    let s = a22 + a21 * x;
    let y = fixed_point(a21 * l_inv, |y| (a21 + s * y) * l_inv)?;
    let mut r = Matrix::zeros();
    for (i, &row) in SLOW.iter().enumerate() {
        for (j, &col) in SLOW.iter().enumerate() {
            r[(row, col)] = s[(i, j)];
        }
    }
    let modes = modes(&l);
    r.iter()
        .all(|v| v.is_finite())
        .then_some(Config { a: r, split: Some(Split { x, y, l, modes }) })
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
        for mode in [Mode::Hold, Mode::Locked, Mode::Drive, Mode::Free] {
            for sliding in 0..1u32 << N_PLAYS {
                let w: f64 = (0..N_PLAYS)
                    .filter(|&i| sliding & (1 << i) == 0)
                    .map(|i| p.play_weight[i])
                    .sum();
                let a = linear::system_matrix(p, mode, w);
                configs.push(reduce(&a, mode).ok_or_else(|| ParamError {
                    field: "m_p".into(),
                    reason: format!("in {mode:?} the stack's modes are not separated from the analog chain's and the runner's: the reduced formulation needs them several times faster"),
                })?);
            }
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
                        let f = (m.v * e).map(|z| z.re);
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
        rates(&REDUCED, &self.config().a, &self.plant.chain.a, (&s, &e, &n))
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
    use nalgebra::{Complex, DMatrix};
    use std::f64::consts::PI;

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

    /// Every configuration of the nominal devices has modes, and `Re(V (e^{λ τ} ∘ V⁻¹ f))`
    /// is the matrix exponential's `e^{L τ} f` to 1e-12 of `|f|` over 1 µs to 10 ms.
    #[test]
    fn the_modes_give_the_matrix_exponential() {
        let p = PlantParams::default();
        for (mode, _, config) in configurations(&p) {
            let Some(split) = config.split else { continue };
            let m = modes(&split.l).unwrap_or_else(|| panic!("{mode:?}: no modes"));
            let f = Fast::from_fn(|i, _| [1e-9, -2e-3, 3e-9, 1e-3, -5e-10, 4e-4][i]);
            let c = m.v_inv * f.map(|x| Complex::new(x, 0.0));
            for tau in [1e-6, 3.7e-5, 1e-4, 1e-3, 1e-2] {
                let exact = (split.l * tau).exp() * f;
                let modal = (m.v * m.lambda.zip_map(&c, |l, c| (l * tau).exp() * c)).map(|z| z.re);
                let e = (modal - exact).norm() / f.norm();
                assert!(e < 1e-12, "{mode:?} at {tau} s: {e:e}");
            }
        }
    }

    /// Every configuration of the default devices: its mode, the model's matrix and the
    /// reduced one.
    fn configurations(p: &PlantParams) -> Vec<(Mode, Matrix, Config)> {
        let r = Reduced::new(p.clone()).unwrap();
        let modes = [Mode::Hold, Mode::Locked, Mode::Drive, Mode::Free];
        (0..4usize << N_PLAYS)
            .map(|key| {
                let (mode, sliding) = (modes[key >> N_PLAYS], key & ((1 << N_PLAYS) - 1));
                let w: f64 = (0..N_PLAYS)
                    .filter(|&i| sliding & (1 << i) == 0)
                    .map(|i| p.play_weight[i])
                    .sum();
                (mode, linear::system_matrix(p, mode, w), r.configs[key].clone())
            })
            .collect()
    }

    /// Eigenvalues (rad/s) of the rows and columns `idx` of `a`.
    fn eigenvalues(a: &Matrix, idx: &[usize]) -> Vec<Complex<f64>> {
        let m = DMatrix::from_fn(idx.len(), idx.len(), |r, c| a[(idx[r], idx[c])]);
        m.complex_eigenvalues().iter().copied().collect()
    }

    /// The states that move: the mechanics and the extension channel.
    const MOVING: [usize; 11] =
        [ix::Y1, ix::V1, ix::Y2, ix::V2, ix::Y3, ix::V3, ix::Y4, ix::V4, ix::BX1, ix::BX2, ix::VX];

    #[test]
    fn the_slow_eigenvalues_are_the_models_and_no_fast_one_is_left() {
        for p in [PlantParams::fia20(), PlantParams::fia6()] {
            let (mut fastest_full, mut fastest_reduced, mut worst) = (0.0f64, 0.0f64, 0.0f64);
            for (mode, full, reduced) in configurations(&p) {
                if mode == Mode::Locked {
                    assert!(reduced.split.is_none() && reduced.a == full);
                    continue;
                }
                let ef = eigenvalues(&full, &MOVING);
                let er = eigenvalues(&reduced.a, &MOVING[6..]);
                let hz = |l: &Complex<f64>| l.norm() / (2.0 * PI);
                fastest_full = ef.iter().map(hz).fold(fastest_full, f64::max);
                fastest_reduced = er.iter().map(hz).fold(fastest_reduced, f64::max);
                // Each reduced eigenvalue is one of the model's, to rounding.
                for l in &er {
                    let nearest = ef.iter().map(|m| (m - l).norm()).fold(f64::INFINITY, f64::min);
                    // Relative, and absolute below 1000 rad/s (DRIVE's pair at 0, a Jordan block
                    // the solver splits by ~1e-5 rad/s).
                    let e = nearest / l.norm().max(1000.0);
                    worst = worst.max(e);
                    // The eigenvalue solver's own error on the model's badly scaled matrix
                    // (entries from 1 to 1e10) is of this order.
                    assert!(e < 1e-6, "{mode:?}: {l} is not an eigenvalue of the model ({e:e})");
                }
                // And the model's 6 fastest (node 3's ring, 2.1-4.6 kHz, and the surge) are
                // the ones left out: the rest is 475 Hz or slower.
                let mut by_size: Vec<f64> = ef.iter().map(hz).collect();
                by_size.sort_by(f64::total_cmp);
                let n = by_size.len();
                assert!(by_size[n - 7] < 500.0 && by_size[n - 6] > 2e3, "{mode:?}: {by_size:?}");
            }
            eprintln!("T_em = {}: fastest mode {fastest_full:.0} Hz in the model, {fastest_reduced:.0} Hz reduced; reduced eigenvalues within {worst:.1e} of the model's", p.t_em);
            assert!(fastest_full > 28e3, "{fastest_full}");
            assert!(fastest_reduced < 500.0, "{fastest_reduced}");
        }
    }

    /// The propagator over 1.024 s, where every mode has decayed by e⁻³³ or more: 1 ms
    /// exponentiated (its norm small enough to be exact), squared ten times.
    fn settle(a: &Matrix) -> Matrix {
        let mut m = (a * 1e-3).exp();
        for _ in 0..10 {
            m = m * m;
        }
        m
    }

    #[test]
    fn the_static_solution_is_the_models() {
        let p = PlantParams::fia20();
        let mut worst = 0.0f64;
        for (mode, full, reduced) in configurations(&p) {
            let Some(Split { x, y, .. }) = &reduced.split else { continue };
            // A state away from rest: moving, the amplifier at 65 V, an offset c0.
            let mut z = Vector::zeros();
            (z[ix::ONE], z[ix::UX], z[ix::BX1], z[ix::VX], z[ix::C0]) = (1.0, 7.0, 6.0, 65.0, -3.0);
            (z[ix::Y1], z[ix::V1], z[ix::Y2], z[ix::V2]) = (0.3e-6, -0.02, 1.9e-6, 0.03);
            (z[ix::Y3], z[ix::V3], z[ix::Y4], z[ix::V4]) = (2e-6, 0.01, 5e-6, 0.01);
            if mode == Mode::Drive {
                z[ix::V4] = z[ix::V3];
            }
            let settled = settle(&full) * z;
            let x2 = SMatrix::<f64, 8, 1>::from_fn(|i, _| z[SLOW[i]]);
            let f = Fast::from_fn(|i, _| z[FAST[i]]) - x * x2;
            let mut s = Vector::zeros();
            for (i, &k) in SLOW.iter().enumerate() {
                s[k] = (x2 - y * f)[i];
            }
            // Settled, the fast part is gone: the physical state is `x2 = s`, `x1 = X x2`.
            let mut s_settled = settle(&reduced.a) * s;
            let x1 = x * SMatrix::<f64, 8, 1>::from_fn(|i, _| s_settled[SLOW[i]]);
            for (i, &k) in FAST.iter().enumerate() {
                s_settled[k] = x1[i];
            }
            for &k in &[ix::Y1, ix::Y2, ix::Y3, ix::Y4, ix::VX] {
                let scale = if k == ix::VX { 100.0 } else { 1e-5 };
                let e = (settled[k] - s_settled[k]).abs() / scale;
                worst = worst.max(e);
                // The settling products' rounding on the model's stiff matrix is of this order.
                assert!(e < 1e-6, "{mode:?}, state {k}: {} against {}", settled[k], s_settled[k]);
            }
            assert!(settled[ix::Y3].abs() > 1e-6, "{mode:?}: the stack is loaded");
        }
        eprintln!("static solutions within {worst:.1e} (of 10 µm, 100 V)");
    }
}
