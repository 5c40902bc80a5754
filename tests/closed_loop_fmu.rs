//! The closed loop three ways gives one trace: (a) the crates coupled directly and (b) the
//! two packaged FMUs in `InchwormSystem.ssp`, run by the project's master on a 2 ms Jacobi
//! grid, record bit-identical values in every column (the FMPy loop (c) is in
//! tests/python).

use inchworm_cosim::trace::Trace;
use inchworm_scenarios::closed_loop::{recorded, LoopView, ITERATED};
use inchworm_scenarios::scenario::{self, Via};

fn ssp() -> std::path::PathBuf {
    inchworm_dist::path("InchwormSystem.ssp")
}

/// Every recorded column equal, bit for bit, at every communication point from t = 0.
fn assert_same(direct: &Trace, fmus: &Trace, what: &str) {
    assert_eq!(direct.times(), fmus.times(), "{what}: communication points");
    for name in recorded() {
        let (d, f) = (direct.column(&name).unwrap(), fmus.column(&name).unwrap());
        let first = d.iter().zip(&f).position(|(a, b)| a.to_bits() != b.to_bits());
        assert_eq!(first, None, "{what}: {name} differs first at row {first:?}");
    }
}

#[test]
fn fig5_through_the_fmus_equals_the_direct_coupling_bit_for_bit() {
    let s = scenario::by_name("fig5").unwrap();
    let ssp = ssp();
    let direct = s.run(Via::Direct).unwrap();
    let fmus = s.run(Via::System(&ssp)).unwrap();
    assert_eq!(direct.len(), 2, "full control and feedback only");
    for ((d, f), v) in direct.iter().zip(&fmus).zip(&s.variants) {
        assert_same(d, f, &v.name);
        // The master records no plan flag: the view derives it from the plan outputs.
        assert!(d.index(ITERATED).is_some() && f.index(ITERATED).is_none());
        let (dv, fv) = (LoopView::new(d).unwrap(), LoopView::new(f).unwrap());
        assert_eq!(dv.dac, fv.dac);
        assert_eq!(dv.scale_weights, fv.scale_weights);
        assert_eq!(dv.settle_time(1e-6), fv.settle_time(1e-6));
        assert!(fv.settle_time(1e-6).is_some(), "{}: settles within 1 µm", v.name);
    }
}

/// fia6: the plant's parameters reach the FMU from `PlantParams::fia6()` and the
/// controller's from its own fia6 configuration, and give the direct coupling's trace.
#[test]
fn fia6_through_the_fmus_equals_the_direct_coupling_bit_for_bit() {
    let s = scenario::by_name("fia6").unwrap();
    let ssp = ssp();
    let (direct, fmus) = (s.run(Via::Direct).unwrap(), s.run(Via::System(&ssp)).unwrap());
    assert_same(&direct[0], &fmus[0], "fia6");
}
