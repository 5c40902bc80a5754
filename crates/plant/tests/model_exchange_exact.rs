//! The Model Exchange equations (`inchworm_plant::continuous`) integrated without
//! integration error give the exact Co-Simulation solver's trajectory: the same counts and
//! modes, and in the Fig. 5 closed loop the same DAC volts at every sample over 10 s.
//!
//! The integration is `common/exact_me.rs`'s, on a 0.5 µs scan (70 points per period of
//! the fastest mode, the stack's 28.7 kHz surge; a 0.25 µs scan moves no position by more
//! than 4e-5 counts).
//!
//! This is what separates the ME formulation from the integrator a master runs on it: what
//! FMPy's CVode leaves (docs/model.md §5) is CVode's own error, which this integration has
//! not.

#[allow(dead_code)]
mod common;
#[allow(dead_code)]
#[path = "common/exact_me.rs"]
mod exact_me;

use exact_me::{ExactMe, H};
use inchworm_controller::{Controller, Params};
use inchworm_plant::{Dac, Mode, Outputs, Plant, PlantParams};

const SCAN: f64 = 0.5e-6;
/// The tight Co-Simulation run: events located to 1 ps (its scan 8× finer).
const CONVERGED: f64 = 1e-12;

/// Runner position difference in counts.
fn counts_apart(a: &Plant, b: &Plant) -> f64 {
    (a.outputs().runner_position - b.outputs().runner_position) / a.params().q_enc
}

#[test]
fn the_check_trace_integrated_exactly_is_the_converged_cs_trace() {
    let gaits = common::check_gaits();
    let mut me = ExactMe::<Plant>::new(PlantParams::fia20(), SCAN);
    let mut cs = Plant::new(PlantParams { rel_tol: CONVERGED, ..PlantParams::fia20() }).unwrap();
    let mut cs_default = Plant::new(PlantParams::fia20()).unwrap();
    let (mut worst, mut worst_default) = (0.0f64, 0.0f64);
    for (k, &dac) in gaits.iter().enumerate() {
        me.sample(dac, k);
        cs.step(dac, H).unwrap();
        cs_default.step(dac, H).unwrap();
        let t = (k + 1) as f64 * H;
        assert_eq!(
            me.plant().outputs().encoder_counts,
            cs.outputs().encoder_counts,
            "counts at {t} s"
        );
        assert_eq!(me.plant().mode(), cs.mode(), "mode at {t} s");
        worst = worst.max(counts_apart(me.plant(), &cs).abs());
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
    let mut me = ExactMe::<Plant>::new(PlantParams::fia20(), SCAN);
    let exact = fig5(|dac, k| {
        me.sample(dac, k);
        me.plant().outputs()
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
