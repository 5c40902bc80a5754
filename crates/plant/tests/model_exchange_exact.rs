//! The Model Exchange equations (`inchworm_plant::continuous`) integrated without
//! integration error give the exact Co-Simulation solver's trajectory: the same counts and
//! modes, and in the Fig. 5 closed loop the same DAC volts at every sample over 10 s.
//!
//! Between events the ME right-hand side is affine, `ẋ = J x + c` (`J` the exact Jacobian,
//! `c` the derivatives at `x = 0`), so `e^{[J c; 0 0] τ}` propagates it exactly. The event
//! indicators are watched on a 0.5 µs scan (70 points per period of the fastest mode, the
//! stack's 28.7 kHz surge; a 0.25 µs scan moves no position by more than 4e-5 counts) and
//! each sign change is bisected to 1e-15 s, the update applied at the end where the
//! indicator has crossed, as an ME master's root finder leaves it. At every 2 ms instant the
//! master's sequence: an event update with the volts held before, the encoder read, the new
//! volts, a second update.
//!
//! This is what separates the ME formulation from the integrator a master runs on it: what
//! FMPy's CVode leaves (docs/model.md §5) is CVode's own error, which this integration has
//! not.

#[allow(dead_code)]
mod common;

use inchworm_controller::{Controller, Params};
use inchworm_plant::continuous::{N_INDICATORS, N_STATES};
use inchworm_plant::{Dac, Mode, Outputs, Plant, PlantParams};
use nalgebra::{SMatrix, SVector};

const N: usize = N_STATES + 1;
type Augmented = SMatrix<f64, N, N>;
type State = SVector<f64, N>;

const H: f64 = 0.002;
const SCAN: f64 = 0.5e-6;
const RESOLUTION: f64 = 1e-15;
/// The tight Co-Simulation run: events located to 1 ps (its scan 8× finer).
const CONVERGED: f64 = 1e-12;

/// An event between two values of the indicators: the brakes switch on a sign change either
/// way, the hysteresis indicators from negative to non-negative (`Plant::event_indicators`).
fn crossed(z0: &[f64; N_INDICATORS], z1: &[f64; N_INDICATORS]) -> bool {
    (0..2).any(|i| (z0[i] < 0.0) != (z1[i] < 0.0)) || (2..5).any(|i| z0[i] < 0.0 && z1[i] >= 0.0)
}

/// The plant driven as a Model Exchange master drives it, integrated exactly.
struct ExactMe {
    plant: Plant,
    dac: Dac,
    /// `[J c; 0 0]` of the current configuration, and its propagator over one scan step.
    a: Augmented,
    scan: Augmented,
    t: f64,
    state_events: u32,
}

impl ExactMe {
    fn new(p: PlantParams) -> ExactMe {
        let plant = Plant::new(p).unwrap();
        let zero = Augmented::zeros();
        let mut me =
            ExactMe { plant, dac: Dac::default(), a: zero, scan: zero, t: 0.0, state_events: 0 };
        me.update(0.0);
        me
    }

    fn state(&self) -> State {
        let x = self.plant.continuous_states();
        State::from_fn(|i, _| if i < N_STATES { x[i] } else { 1.0 })
    }

    fn indicators_at(&mut self, x: &State) -> [f64; N_INDICATORS] {
        self.plant.set_continuous_states(&std::array::from_fn(|i| x[i]));
        self.plant.event_indicators()
    }

    /// Event mode at `t`: the plant's update, then the dynamics of the configuration it left.
    fn update(&mut self, t: f64) {
        self.t = t;
        self.plant.event_update(self.dac, t);
        let j = self.plant.jacobian();
        let x = self.plant.continuous_states();
        self.plant.set_continuous_states(&[0.0; N_STATES]);
        let c = self.plant.derivatives(self.dac);
        self.plant.set_continuous_states(&x);
        self.a = Augmented::from_fn(|r, k| match (r < N_STATES, k < N_STATES) {
            (true, true) => j.states[(r, k)],
            (true, false) => c[r],
            _ => 0.0,
        });
        self.scan = (self.a * SCAN).exp();
    }

    /// Continuous time to `end`, stopping at every event on the way.
    fn advance_to(&mut self, end: f64) {
        while end - self.t > RESOLUTION {
            let tau = (end - self.t).min(SCAN);
            let x0 = self.state();
            let z0 = self.plant.event_indicators();
            let phi = if tau == SCAN { self.scan } else { (self.a * tau).exp() };
            let x1 = phi * x0;
            if !crossed(&z0, &self.indicators_at(&x1)) {
                self.t += tau;
                continue;
            }
            let (mut lo, mut hi) = (0.0, tau);
            while hi - lo > RESOLUTION {
                let mid = 0.5 * (lo + hi);
                let x = (self.a * mid).exp() * x0;
                if crossed(&z0, &self.indicators_at(&x)) {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            let x = (self.a * hi).exp() * x0;
            self.indicators_at(&x);
            self.state_events += 1;
            self.update(self.t + hi);
        }
        // The plant holds the state of `end`: the last indicators were taken on it.
        self.t = end;
    }

    /// The sample `[k h, (k + 1) h)` with `dac` held; the encoder is read at its end.
    fn sample(&mut self, dac: Dac, k: usize) {
        self.dac = dac;
        self.update(k as f64 * H);
        self.advance_to((k + 1) as f64 * H);
        self.update((k + 1) as f64 * H);
    }
}

/// Runner position difference in counts.
fn counts_apart(a: &Plant, b: &Plant) -> f64 {
    (a.outputs().runner_position - b.outputs().runner_position) / a.params().q_enc
}

#[test]
fn the_check_trace_integrated_exactly_is_the_converged_cs_trace() {
    let gaits = common::check_gaits();
    let mut me = ExactMe::new(PlantParams::fia20());
    let mut cs = Plant::new(PlantParams { rel_tol: CONVERGED, ..PlantParams::fia20() }).unwrap();
    let mut cs_default = Plant::new(PlantParams::fia20()).unwrap();
    let (mut worst, mut worst_default) = (0.0f64, 0.0f64);
    for (k, &dac) in gaits.iter().enumerate() {
        me.sample(dac, k);
        cs.step(dac, H).unwrap();
        cs_default.step(dac, H).unwrap();
        let t = (k + 1) as f64 * H;
        assert_eq!(
            me.plant.outputs().encoder_counts,
            cs.outputs().encoder_counts,
            "counts at {t} s"
        );
        assert_eq!(me.plant.mode(), cs.mode(), "mode at {t} s");
        worst = worst.max(counts_apart(&me.plant, &cs).abs());
        worst_default = worst_default.max(counts_apart(&cs_default, &cs).abs());
    }
    eprintln!(
        "check trace: exact ME within {worst:.1e} counts of CS at rel_tol {CONVERGED:e} \
         ({} state events); CS at its default rel_tol within {worst_default:.4} counts",
        me.state_events
    );
    // Measured 2e-5 and 0.0376: the ME equations carry no error of their own, and the
    // default CS run's is its 1 ns event location.
    assert!(worst < 1e-3, "exact ME {worst} counts from converged CS");
    assert!(worst_default > 10.0 * worst);
}

/// Fig. 5 full control for 10 s: the DAC volts held over each sample and the plant's
/// outputs at its end, the plant advanced by `sample(dac, k)`.
fn fig5(mut sample: impl FnMut(Dac, usize) -> Outputs) -> Vec<([f64; 3], Outputs)> {
    let mut ctrl = Controller::new(Params::default()).unwrap();
    let (mut held, mut counts) = ([0.0; 3], 0);
    (0..5000)
        .map(|k| {
            let s = ctrl.tick(counts, 100e-6);
            let o = sample(Dac { earth: held[0], nonearth: held[1], extension: held[2] }, k);
            counts = o.encoder_counts;
            let row = (held, o);
            held = s.dac;
            row
        })
        .collect()
}

#[test]
fn fig5_closed_loop_integrated_exactly_makes_the_converged_cs_decisions() {
    let mut me = ExactMe::new(PlantParams::fia20());
    let exact = fig5(|dac, k| {
        me.sample(dac, k);
        me.plant.outputs()
    });
    let mut cs = Plant::new(PlantParams { rel_tol: CONVERGED, ..PlantParams::fia20() }).unwrap();
    let converged = fig5(|dac, _| {
        cs.step(dac, H).unwrap();
        cs.outputs()
    });
    let mut worst = 0.0f64;
    for (k, (a, b)) in exact.iter().zip(&converged).enumerate() {
        let t = (k + 1) as f64 * H;
        assert_eq!(a.0, b.0, "DAC volts held up to {t} s");
        assert_eq!(a.1.encoder_counts, b.1.encoder_counts, "encoder counts at {t} s");
        assert_eq!(a.1.mode, b.1.mode, "mode at {t} s");
        worst = worst.max(((a.1.runner_position - b.1.runner_position) / 1.2e-9).abs());
    }
    let moves = exact.iter().filter(|r| r.1.mode == Mode::Drive).count();
    eprintln!("Fig. 5 full control, 10 s: exact ME within {worst:.1e} counts of CS at rel_tol {CONVERGED:e}, the same DAC volts and counts at all 5000 samples ({moves} ending in DRIVE, {} state events)", me.state_events);
    assert!(moves > 100, "the loop kept stepping: {moves} samples ending in DRIVE");
    // Measured 1.9e-4 counts.
    assert!(worst < 2e-3, "exact ME {worst} counts from converged CS");
}
