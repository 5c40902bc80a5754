//! The disturbances against their definitions: the sensors' white noise, bias and drift
//! have their RMS, the cell's deformation leaves exactly its amplitude of co-phasing error
//! and grows as its ramp, and the wind's poses have their RMS and their correlation time
//! (docs/phasing.md, "Disturbances").

use inchworm_phasing::cophasing::cophasing_rms;
use inchworm_phasing::disturbances::{Buffeting, CellDeformation, SensorErrors, SensorNoise, Wind};
use inchworm_phasing::Mirror;

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

fn within(what: &str, got: f64, want: f64, rel: f64) {
    assert!((got / want - 1.0).abs() <= rel, "{what}: {got:e}, want {want:e} within {rel}");
}

#[test]
fn the_sensor_errors_have_their_white_bias_and_drift_rms() {
    let noise = SensorNoise { white: 1e-9, bias: 2e-9, drift: 3e-10, seed: 7 };
    let sensors = 20_000;
    let mut errors = SensorErrors::new(noise, sensors);
    let mut first = vec![0.0; sensors];
    errors.corrupt(&mut first);
    let mut second = vec![0.0; sensors];
    errors.corrupt(&mut second);
    // Two reads at one time differ by the white noise alone, √2 of it.
    let diff: Vec<f64> = first.iter().zip(&second).map(|(a, b)| a - b).collect();
    within("white", rms(&diff) / 2f64.sqrt(), 1e-9, 0.02);
    // Their mean is the bias plus half the white noise's variance.
    let mean: Vec<f64> = first.iter().zip(&second).map(|(a, b)| (a + b) / 2.0).collect();
    within("bias", rms(&mean), (4e-18f64 + 0.5e-18).sqrt(), 0.02);
    // After 100 s in steps of 0.1 s, the drift is a random walk of 3e-10 × 10 m RMS.
    let mut drifted = SensorErrors::new(SensorNoise { white: 0.0, bias: 0.0, ..noise }, sensors);
    for _ in 0..1_000 {
        drifted.advance(0.1);
    }
    let mut read = vec![0.0; sensors];
    drifted.corrupt(&mut read);
    within("drift", rms(&read), 3e-9, 0.03);
    // Seeded: the same seed, the same errors.
    let mut again = SensorErrors::new(noise, sensors);
    let mut replay = vec![0.0; sensors];
    again.corrupt(&mut replay);
    assert_eq!(replay, first);
}

#[test]
fn the_cells_deformation_leaves_its_amplitude_and_grows_over_its_ramp() {
    for rings in [1, 3, 6] {
        let mirror = Mirror::new(rings, true, 0.15, 0.003).unwrap();
        for seed in [1, 2, 3] {
            let cell = CellDeformation::new(1e-6, 10.0, seed).unwrap();
            let shape = cell.shape(&mirror);
            within("amplitude", cophasing_rms(&mirror, &shape), 1e-6, 1e-12);
        }
    }
    let cell = CellDeformation::new(1e-6, 10.0, 1).unwrap();
    assert_eq!(cell.growth(0.0), 0.0);
    within("half way", cell.growth(5.0), 0.5, 1e-15);
    assert_eq!(cell.growth(10.0), 1.0);
    assert_eq!(cell.growth(1e3), 1.0);
    let g: Vec<f64> = (0..=100).map(|k| cell.growth(0.1 * f64::from(k))).collect();
    assert!(g.windows(2).all(|w| w[1] >= w[0]), "the growth never falls");
}

#[test]
fn the_winds_poses_have_their_rms_and_correlation_time() {
    let wind = Wind::new(5e-9, 20e-9, 1.0, 3).unwrap();
    let segments = 200;
    let mut b = Buffeting::new(wind, segments);
    let (dt, steps) = (0.002, 20_000);
    let a = (-2.0 * std::f64::consts::PI * dt).exp();
    let (mut pistons, mut tips, mut lag) = (Vec::new(), Vec::new(), 0.0);
    let mut before: Vec<f64> = b.poses().iter().map(|p| p[0]).collect();
    for _ in 0..steps {
        b.advance(dt);
        let now: Vec<f64> = b.poses().iter().map(|p| p[0]).collect();
        lag += now.iter().zip(&before).map(|(x, y)| x * y).sum::<f64>();
        pistons.extend(&now);
        tips.extend(b.poses().iter().map(|p| p[1]));
        before = now;
    }
    within("piston", rms(&pistons), 5e-9, 0.03);
    within("tip", rms(&tips), 20e-9, 0.03);
    let correlation = lag / pistons.len() as f64 / rms(&pistons).powi(2);
    assert!((correlation - a).abs() < 2e-3, "lag-1 correlation {correlation}, want {a}");
}

#[test]
fn bad_disturbances_are_refused_naming_the_parameter() {
    for (err, name) in [
        (SensorNoise::new(f64::NAN, 0.0, 0.0, 1).unwrap_err(), "sensor_noise"),
        (SensorNoise::new(0.0, -1e-9, 0.0, 1).unwrap_err(), "sensor_bias"),
        (SensorNoise::new(0.0, 0.0, f64::INFINITY, 1).unwrap_err(), "sensor_drift"),
        (CellDeformation::new(1e-3, 10.0, 1).unwrap_err(), "cell_amplitude"),
        (CellDeformation::new(1e-6, 0.0, 1).unwrap_err(), "cell_ramp"),
        (Wind::new(f64::NAN, 0.0, 1.0, 1).unwrap_err(), "wind_piston"),
        (Wind::new(0.0, 1.0, 1.0, 1).unwrap_err(), "wind_angle"),
        (Wind::new(0.0, 0.0, 0.0, 1).unwrap_err(), "wind_corner"),
    ] {
        assert!(err.to_string().starts_with(&format!("{name} = ")), "{name}: {err}");
    }
}
