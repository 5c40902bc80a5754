//! Whatever the encoder and the reference do, the controller keeps producing valid DAC
//! samples: codes in range, volts equal to their codes, parked sample 1 of every step.

use inchworm_controller::{Controller, Params, NOMINAL_WEIGHTS};

#[test]
fn random_encoder_and_reference_give_valid_samples() {
    let mut seed = 42u64;
    let mut next = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    for p in [
        Params::default(),
        Params {
            prefilter: true,
            feedforward: false,
            scale_weights_start: NOMINAL_WEIGHTS,
            ..Params::default()
        },
        Params { samples_per_step: 10, deadband: 1e-6, ..Params::default() },
    ] {
        let n = p.samples_per_step as usize;
        let mut c = Controller::new(p).unwrap();
        let mut counts = 0i64;
        for k in 0..200_000 {
            // Encoder jumps by up to ±30 µm, references anywhere within ±5 mm.
            if next() < 0.05 {
                counts += ((next() - 0.5) * 50_000.0) as i64;
            }
            let reference = if next() < 0.01 { (next() - 0.5) * 1e-2 } else { 100e-6 };
            let s = c.tick(counts, reference);
            for (v, code) in s.dac.iter().zip(s.codes) {
                assert!(
                    (v - f64::from(code) * 10.0 / 65535.0).abs() < 1e-12,
                    "tick {k}: {v} V vs code {code}"
                );
            }
            assert!(
                s.fraction.abs() <= 1.0 && s.disturbance_estimate.is_finite(),
                "tick {k}: {s:?}"
            );
            assert!(s.scale_weights.iter().all(|w| w.is_finite()), "tick {k}");
            // The sample returned at tick k is held during interval k + 1; interval 1 of
            // every step (k + 1 ≡ 0 mod n) is parked.
            if (k + 1) % n == 0 {
                assert_eq!(s.codes, [0, 0, 0], "tick {k}: sample 1 of a step must be parked");
            }
        }
    }
}
