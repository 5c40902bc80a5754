//! The closed-form checks of the edge sensors and the reconstructor (docs/phasing.md),
//! on mirrors of 7, 18 (no centre), 19, 37 and 91 segments, with and without the dihedral
//! term: a pistoned segment reads ±δ on exactly its sensors and reconstructs to itself with
//! the unseen modes removed; the whole mirror's piston, tip and tilt (and without the
//! dihedral term the focus mode) read zero and are exactly the near-zero singular modes; the noise multiplier from Monte Carlo is
//! the reconstructor's analytic figure.

use inchworm_phasing::reconstructor::unseen_modes;
use inchworm_phasing::{EdgeSensors, Mirror, Reconstructor, Sensor, DEFAULT_THRESHOLD};
use nalgebra::DVector;

const MIRRORS: [(u32, bool); 5] = [(1, true), (2, false), (2, true), (3, true), (5, true)];
/// Heights alone (the focus mode unseen too), and the default 5 mm dihedral gain.
const DIHEDRAL: [f64; 2] = [0.0, 0.005];
const THRESHOLD: f64 = DEFAULT_THRESHOLD;

fn setup(rings: u32, centre: bool, dihedral: f64) -> (Mirror, EdgeSensors, Reconstructor) {
    let m = Mirror::new(rings, centre, 1.44, 0.004).unwrap();
    let s = EdgeSensors::new(&m, dihedral).unwrap();
    let r = Reconstructor::new(&m, &s.interaction(m.centres()), THRESHOLD).unwrap();
    (m, s, r)
}

#[test]
fn one_pistoned_segment_reads_on_exactly_its_sensors_and_reconstructs_to_itself() {
    let delta = 100e-9;
    for (rings, centre) in MIRRORS {
        for h in DIHEDRAL {
            let (m, s, r) = setup(rings, centre, h);
            let a = s.interaction(m.centres());
            let g = unseen_modes(&m, h);
            for k in [0, m.segments() / 2, m.segments() - 1] {
                let mut poses = vec![[0.0; 3]; m.segments()];
                poses[k][0] = delta;
                let x = DVector::from_vec(s.coordinates(&poses));
                let readings = &a * &x;
                for (sensor, &reading) in s.sensors.iter().zip(readings.iter()) {
                    let want = if sensor.a == k {
                        delta
                    } else if sensor.b == k {
                        -delta
                    } else {
                        0.0
                    };
                    assert!(
                        (reading - want).abs() <= 1e-9 * delta,
                        "{} segments, sensor {sensor:?}: {reading}",
                        m.segments()
                    );
                }
                // The reconstruction is the pose less its part in the global modes.
                let want = &x - &g * (g.transpose() * &x);
                let got = DVector::from_vec(r.reconstruct(readings.as_slice()));
                let err = (&got - &want).amax();
                assert!(
                    err <= 1e-9 * delta,
                    "{} segments, h {h}: segment {k} off by {err:e} m",
                    m.segments()
                );
            }
        }
    }
}

#[test]
fn the_whole_mirrors_piston_tip_and_tilt_read_zero_and_are_the_unseen_modes() {
    println!("segments  dihedral (m)  unseen: σ/σmax                      weakest seen");
    for (rings, centre) in MIRRORS {
        for h in DIHEDRAL {
            let (m, s, r) = setup(rings, centre, h);
            let a = s.interaction(m.centres());
            let basis = unseen_modes(&m, h);
            let readings = &a * &basis;
            assert!(
                readings.amax() < 1e-13 * a.amax(),
                "{} segments: unseen modes read {:e}",
                m.segments(),
                readings.amax()
            );
            // Exactly those: as many excluded modes, at round-off, spanning the same space
            // (the reconstructor refuses to keep any part of a global mode).
            let excluded: Vec<_> = r.excluded().collect();
            assert_eq!(
                excluded.len(),
                basis.ncols(),
                "{} segments, h {h}: {:?}",
                m.segments(),
                &r.modes[..5]
            );
            assert!(excluded.iter().all(|mode| mode.relative < 1e-14), "{excluded:?}");
            let seen = r.modes[basis.ncols()];
            assert!(seen.relative > 1e-5, "{seen:?}");
            let list: Vec<String> =
                excluded.iter().map(|mode| format!("{:8.1e}", mode.relative)).collect();
            println!("{:8}  {h:12}  {:34}  {:.2e}", m.segments(), list.join(" "), seen.relative);
        }
    }
}

#[test]
fn the_monte_carlo_noise_multiplier_is_the_analytic_one() {
    for (rings, centre) in MIRRORS {
        let (m, _, r) = setup(rings, centre, 0.005);
        let analytic = r.noise_multiplier();
        let drawn = r.noise_multiplier_monte_carlo(4000, 7);
        println!(
            "{} segments: noise multiplier {analytic:.4} analytic, {drawn:.4} from 4000 draws",
            m.segments()
        );
        assert!(
            (drawn / analytic - 1.0).abs() < 0.05,
            "{} segments: {drawn} against {analytic}",
            m.segments()
        );
    }
}

#[test]
fn bad_thresholds_and_sensors_are_refused_with_a_message() {
    let m = Mirror::new(3, true, 1.44, 0.004).unwrap();
    let s = EdgeSensors::new(&m, 0.0).unwrap();
    let a = s.interaction(m.centres());
    let err = |t: f64| Reconstructor::new(&m, &a, t).unwrap_err().to_string();
    assert!(
        err(1e-20).starts_with("threshold = 1e-20 keeps the whole mirror's "),
        "{}",
        err(1e-20)
    );
    assert!(err(f64::NAN).starts_with("threshold = NaN: "));
    assert!(err(1.0).starts_with("threshold = 1: "));
    assert_eq!(
        EdgeSensors::new(&m, f64::NAN).unwrap_err().to_string(),
        "dihedral = NaN m: must be finite, 0 to 0.1 m"
    );
    // A sensor joining segments that share no edge (the centre and the second ring), and
    // one off its edge.
    let far = Sensor { a: 0, b: 7, at: [0.0, 0.0], normal: [1.0, 0.0] };
    assert_eq!(
        EdgeSensors::check_layout(&m, &[far]).unwrap_err().to_string(),
        "sensor 0 joins segments 0 and 7, which share no edge"
    );
    let mut off = s.sensors[0];
    off.at[0] += 0.01;
    assert!(EdgeSensors::check_layout(&m, &[s.sensors[1], off])
        .unwrap_err()
        .to_string()
        .starts_with("sensor 1 at ("));
    EdgeSensors::check_layout(&m, &s.sensors).unwrap();
}

#[test]
fn the_normal_equations_reconstruct_as_the_svd_does() {
    for (rings, centre) in MIRRORS {
        for dihedral in DIHEDRAL {
            let (m, s, svd) = setup(rings, centre, dihedral);
            let normal =
                Reconstructor::normal_equations(&m, &s.sparse(m.centres()), dihedral).unwrap();
            let mut state = 11;
            let y: Vec<f64> =
                (0..s.len()).map(|_| inchworm_plant::noise::gaussian(&mut state)).collect();
            let (a, b) =
                (DVector::from_vec(svd.reconstruct(&y)), DVector::from_vec(normal.reconstruct(&y)));
            let rel = (&a - &b).norm() / a.norm();
            let (alpha, beta) = (svd.noise_multiplier(), normal.noise_multiplier());
            println!(
                "{} segments, h = {dihedral} m: normal equations {rel:.1e} from the SVD, noise multiplier {alpha:.6} and {beta:.6}",
                m.segments()
            );
            assert!(rel < 1e-8, "{rel:e}");
            assert!((alpha / beta - 1.0).abs() < 1e-8, "{alpha} against {beta}");
        }
    }
}
