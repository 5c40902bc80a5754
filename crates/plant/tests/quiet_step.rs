//! The quiet step against the event loop: long quiet runs in every mode, at several step
//! lengths and both scan resolutions, the two paths compared bit for bit after every step
//! (the saved state, the outputs, the report).

use inchworm_plant::{Dac, Plant, PlantParams};

mod common;
use common::{check_gaits, uniform};

/// Gaits, then holds in each mode at random extension volts, each at one step length.
fn sequence() -> Vec<(Dac, f64)> {
    let mut rng = 0x2026_1201_u64;
    let mut seq: Vec<(Dac, f64)> = check_gaits().into_iter().map(|d| (d, 0.002)).collect();
    for h in [0.002, 0.001, 0.0005, 0.0037, 0.0001, 0.002] {
        for (earth, nonearth) in [(0.0, 0.0), (0.0, 10.0), (10.0, 10.0), (10.0, 0.0), (0.0, 0.0)] {
            let extension = 10.0 * uniform(&mut rng);
            let steps = (0.6 / h) as usize;
            seq.extend(std::iter::repeat_n((Dac { earth, nonearth, extension }, h), steps));
        }
    }
    seq
}

fn compare(params: PlantParams) {
    let mut quiet = Plant::new(params.clone()).unwrap();
    let mut reference = Plant::new(params).unwrap();
    reference.set_scan_always(true);
    let (mut a, mut b) = (Vec::new(), Vec::new());
    let seq = sequence();
    for (i, (d, h)) in seq.iter().enumerate() {
        let ra = quiet.step(*d, *h).unwrap();
        let rb = reference.step(*d, *h).unwrap();
        assert_eq!(ra, rb, "step {i}: reports differ");
        assert_eq!(quiet.outputs(), reference.outputs(), "step {i}: outputs differ");
        a.clear();
        b.clear();
        quiet.save_state(&mut a);
        reference.save_state(&mut b);
        assert!(a == b, "step {i}: states differ");
    }
    let s = quiet.scan_stats();
    assert!(
        s.quiet as usize > seq.len() / 2,
        "the quiet step took only {} of {} steps",
        s.quiet,
        seq.len()
    );
    assert_eq!(reference.scan_stats().quiet, 0, "the reference path never takes the quiet step");
}

#[test]
fn quiet_step_matches_the_event_loop_bit_for_bit() {
    compare(PlantParams::fia20());
}

#[test]
fn quiet_step_matches_the_event_loop_at_the_finer_scan() {
    compare(PlantParams { rel_tol: 1e-11, ..PlantParams::fia6() });
}
