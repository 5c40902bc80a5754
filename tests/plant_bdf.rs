//! The plant's two Model Exchange formulations under an off-the-shelf stiff integrator:
//! diffsol's BDF (the project's master's, docs/model-exchange.md) driven the way a Model
//! Exchange master drives an FMU, at FMPy's default tolerance (rtol 1e-8, atol = rtol ×
//! each state's nominal), against the exact Co-Simulation plant (docs/model.md §5.1).
//!
//! The model's formulation (`inchworm_plant::continuous`, 17 states) holds the BDF's steps
//! to a few µs with the stack's surge modes; the reduced one
//! (`inchworm_plant::continuous::reduced`, 11 states) carries those and node 3's ring in
//! closed form, and the BDF steps with the analog chain.

use std::cell::RefCell;

use diffsol::{
    NalgebraLU, NalgebraMat, OdeBuilder, OdeSolverMethod, OdeSolverStopReason, Vector, VectorCommon,
};
use inchworm_controller::gait::{Direction, Timing};
use inchworm_plant::continuous::next_event::EventProbe;
use inchworm_plant::continuous::reduced::Reduced;
use inchworm_plant::continuous::N_INDICATORS;
use inchworm_plant::{Dac, Plant, PlantParams};

const H: f64 = 0.002;
const RTOL: f64 = 1e-8;

/// A formulation as a master sees it through the Model Exchange calls.
trait Formulation {
    /// The states' nominals: the plant FMU's (1e-2 m, 10 m/s, 10 V, 1e4 V/s, 100 V) for the
    /// model's formulation; the same channels and 1e-5 m, 0.1 m/s for the reduced one's
    /// runner, the magnitudes of a gait (at 1e-2 m and 10 m/s its runner is 1.3 counts off
    /// after 30 gaits at γ = 40, at these 0.05, in the same steps).
    const NOMINALS: &'static [f64];
    fn states(&self) -> Vec<f64>;
    /// The master's time and the integrator's states at it.
    fn set(&mut self, t: f64, x: &[f64]);
    fn rates(&self, dac: Dac) -> Vec<f64>;
    fn jacobian_product(&self, v: &[f64]) -> Vec<f64>;
    fn indicators(&self) -> [f64; N_INDICATORS];
    fn update(&mut self, dac: Dac, t: f64);
    fn plant(&self) -> &Plant;
}

const CHANNELS: [f64; 9] = [10.0, 1e4, 100.0, 10.0, 1e4, 100.0, 10.0, 1e4, 100.0];

impl Formulation for Plant {
    const NOMINALS: &'static [f64] = &{
        let mut n = [0.0; 17];
        let mut i = 0;
        while i < 8 {
            n[i] = if i % 2 == 0 { 1e-2 } else { 10.0 };
            i += 1;
        }
        while i < 17 {
            n[i] = CHANNELS[i - 8];
            i += 1;
        }
        n
    };
    fn states(&self) -> Vec<f64> {
        self.continuous_states().to_vec()
    }
    fn set(&mut self, _t: f64, x: &[f64]) {
        self.set_continuous_states(x.try_into().unwrap());
    }
    fn rates(&self, dac: Dac) -> Vec<f64> {
        self.derivatives(dac).to_vec()
    }
    fn jacobian_product(&self, v: &[f64]) -> Vec<f64> {
        let v = nalgebra::SVector::<f64, 17>::from_column_slice(v);
        (self.jacobian().states * v).iter().copied().collect()
    }
    fn indicators(&self) -> [f64; N_INDICATORS] {
        self.event_indicators()
    }
    fn update(&mut self, dac: Dac, t: f64) {
        self.event_update(dac, t);
    }
    fn plant(&self) -> &Plant {
        self
    }
}

impl Formulation for Reduced {
    const NOMINALS: &'static [f64] = &{
        let mut n = [1e-5, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let mut i = 2;
        while i < 11 {
            n[i] = CHANNELS[i - 2];
            i += 1;
        }
        n
    };
    fn states(&self) -> Vec<f64> {
        self.continuous_states().to_vec()
    }
    fn set(&mut self, t: f64, x: &[f64]) {
        self.set_time(t);
        self.set_continuous_states(x.try_into().unwrap());
    }
    fn rates(&self, dac: Dac) -> Vec<f64> {
        self.derivatives(dac).to_vec()
    }
    fn jacobian_product(&self, v: &[f64]) -> Vec<f64> {
        let v = nalgebra::SVector::<f64, 11>::from_column_slice(v);
        (self.jacobian().states * v).iter().copied().collect()
    }
    fn indicators(&self) -> [f64; N_INDICATORS] {
        self.event_indicators()
    }
    fn update(&mut self, dac: Dac, t: f64) {
        self.event_update(dac, t);
    }
    fn plant(&self) -> &Plant {
        Reduced::plant(self)
    }
}

/// What a run made: BDF steps, state events, time events, and the encoder and runner
/// position at the end of every sample.
struct Run {
    steps: u64,
    events: u64,
    time_events: u64,
    samples: Vec<(i64, f64)>,
}

/// `dacs` (one per 2 ms sample) through `m` as an ME master runs the plant FMU: at each
/// sample an event update with its volts, the BDF to the sample's end with root finding on
/// the indicators, stopping at the FMU's next time event (its next event of the exact
/// propagation, `EventProbe::next_time_event`, announced after every update); at a root or
/// a time event the update there and the BDF restarted; an update at the end (the encoder).
fn run<F: Formulation>(mut m: F, dacs: &[Dac]) -> Run {
    let atol: Vec<f64> = F::NOMINALS.iter().map(|n| n * RTOL).collect();
    let (mut steps, mut events, mut samples) = (0, 0, Vec::with_capacity(dacs.len()));
    let mut time_events = 0;
    let mut probe = EventProbe::new(m.plant());
    for (k, &dac) in dacs.iter().enumerate() {
        let (mut t0, t1) = (k as f64 * H, (k + 1) as f64 * H);
        m.update(dac, t0);
        loop {
            let next = probe.next_time_event(m.plant(), dac);
            // A time event this close to the sample's end is at it (as the master has it).
            let stop = next.filter(|&te| te < t1 - 1e-9 * H).unwrap_or(t1);
            let x0 = m.states();
            let cell = RefCell::new(&mut m);
            let problem = OdeBuilder::<NalgebraMat<f64>>::new()
                .t0(t0)
                .h0((t1 - t0) * 1e-3)
                .rtol(RTOL)
                .atol(atol.clone())
                .rhs_implicit(
                    |x, _p, t, dx| {
                        let mut f = cell.borrow_mut();
                        f.set(t, x);
                        dx.copy_from_slice(&f.rates(dac));
                    },
                    |x, _p, t, v, out| {
                        let mut f = cell.borrow_mut();
                        f.set(t, x);
                        out.copy_from_slice(&f.jacobian_product(v));
                    },
                )
                .init(|_p, _t, x| x.copy_from_slice(&x0), x0.len())
                .root(
                    |x, _p, t, z| {
                        let mut f = cell.borrow_mut();
                        f.set(t, x);
                        z.copy_from_slice(&f.indicators());
                    },
                    N_INDICATORS,
                )
                .build()
                .unwrap();
            let mut solver = problem.bdf::<NalgebraLU<f64>>().unwrap();
            solver.set_stop_time(stop).unwrap();
            let mut y = solver.state().y.clone();
            let (t, root) = loop {
                let reason = solver.step().unwrap();
                steps += 1;
                match reason {
                    OdeSolverStopReason::InternalTimestep => {}
                    OdeSolverStopReason::TstopReached => {
                        y.copy_from(solver.state().y);
                        break (stop, false);
                    }
                    OdeSolverStopReason::RootFound(t, _) => {
                        solver.interpolate_inplace(t, &mut y).unwrap();
                        break (t, true);
                    }
                }
            };
            drop(solver);
            let m = cell.into_inner();
            m.set(t, y.inner().as_slice());
            if root {
                events += 1;
            } else if stop < t1 {
                time_events += 1;
            } else {
                break;
            }
            m.update(dac, t);
            t0 = t;
        }
        m.update(dac, t1);
        let o = m.plant().outputs();
        samples.push((o.encoder_counts, o.runner_position));
    }
    Run { steps, events, time_events, samples }
}

/// The largest encoder and runner-position differences (counts) from the CS plant.
fn against_cs(p: &PlantParams, dacs: &[Dac], run: &Run) -> (i64, f64) {
    let mut cs = Plant::new(p.clone()).unwrap();
    let (mut counts, mut position) = (0, 0.0f64);
    for (dac, (c, x)) in dacs.iter().zip(&run.samples) {
        cs.step(*dac, H).unwrap();
        let o = cs.outputs();
        counts = counts.max((c - o.encoder_counts).abs());
        position = position.max(((x - o.runner_position) / p.q_enc).abs());
    }
    (counts, position)
}

#[test]
fn the_reduced_formulation_takes_a_tenth_of_the_steps_and_keeps_the_count() {
    let p = PlantParams::fia20();
    let dacs = common_gaits();
    let reduced = run(Reduced::new(p.clone()).unwrap(), &dacs);
    let full = run(Plant::new(p.clone()).unwrap(), &dacs);
    let (rc, rp) = against_cs(&p, &dacs, &reduced);
    let (fc, fp) = against_cs(&p, &dacs, &full);
    eprintln!("check trace under diffsol's BDF at rtol {RTOL:e}: reduced {} steps, {} state and {} time events, encoder within {rc} of CS (runner {rp:.3} counts); model's formulation {} steps, {} state and {} time events, encoder within {fc} (runner {fp:.3} counts)", reduced.steps, reduced.events, reduced.time_events, full.steps, full.events, full.time_events);
    assert!(rc <= 1 && rp < 0.5, "reduced: {rc} counts, runner {rp}");
    assert!(10 * reduced.steps < full.steps, "{} against {} steps", reduced.steps, full.steps);
}

/// `n` full forward gaits.
fn forward(n: usize) -> Vec<Dac> {
    let timing = Timing::new(100);
    (0..n)
        .flat_map(|_| (1..=100).map(move |k| timing.volts(Direction::Forward, 1.0, k)))
        .map(|[earth, nonearth, extension]| Dac { earth, nonearth, extension })
        .collect()
}

#[test]
fn the_reduced_formulation_through_a_slip_and_a_load_dependent_disturbance() {
    let mut slip = forward(2);
    slip.extend([Dac { earth: 10.0, nonearth: 0.0, extension: 0.0 }; 15]);
    slip.extend([Dac::default(); 20]);
    slip.extend(forward(1));
    let gamma = PlantParams { gamma: 40.0, ..PlantParams::fia20() };
    for (what, p, dacs) in [
        ("slip episode", PlantParams::fia20(), slip),
        ("γ = 40, 30 forward gaits", gamma, forward(30)),
    ] {
        let r = run(Reduced::new(p.clone()).unwrap(), &dacs);
        let (c, x) = against_cs(&p, &dacs, &r);
        eprintln!("{what} under diffsol's BDF, reduced: {} steps over {} s, {} state and {} time events, encoder within {c} of CS (runner {x:.3} counts)", r.steps, dacs.len() as f64 * H, r.events, r.time_events);
        assert!(c <= 2, "{what}: {c} counts");
    }
}

/// The check trace's gaits (docs/model.md §2.9).
fn common_gaits() -> Vec<Dac> {
    let path =
        concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/plant-check-trace-fia20-passive.csv");
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            Dac { earth: f[1], nonearth: f[2], extension: f[3] }
        })
        .collect()
}

/// 60 s of forward gaits at γ = 40, whose stall amplifies an error per gait about 50-fold
/// (docs/model.md §5.1): on the state events alone, without the FMU's time events, the
/// BDF ended 11 counts off.
#[test]
fn sixty_seconds_of_a_load_dependent_disturbance() {
    let p = PlantParams { gamma: 40.0, ..PlantParams::fia20() };
    let dacs = forward(300);
    let r = run(Reduced::new(p.clone()).unwrap(), &dacs);
    let (c, x) = against_cs(&p, &dacs, &r);
    // The runner at the end of every gait (parked, the ring gone).
    let mut cs = Plant::new(p.clone()).unwrap();
    let mut parked = 0.0f64;
    for (k, (dac, (_, y))) in dacs.iter().zip(&r.samples).enumerate() {
        cs.step(*dac, H).unwrap();
        if k % 100 == 99 {
            parked = parked.max(((y - cs.outputs().runner_position) / p.q_enc).abs());
        }
    }
    eprintln!("γ = 40, 60 s of forward gaits under diffsol's BDF, reduced: {} steps, {} state and {} time events, encoder within {c} of CS (runner {x:.3} counts; {parked:.3} at the gaits' ends)", r.steps, r.events, r.time_events);
    assert!(c <= 2, "{c} counts, {parked} at the gaits' ends");
}
