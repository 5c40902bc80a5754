use super::*;
use crate::PlantParams;

/// `Watch::xi` and `Watch::rate` give the values of the dense dot products of the
/// watched rows, bit for bit (but the sign of a zero), in every mode and sticking weight.
#[test]
fn sparse_watched_rows_are_the_dense_dot_products() {
    let p = PlantParams::fia20();
    let mut rng = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        // Spread over many binades, both signs, and some exact zeros.
        let m = (rng >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
        if rng.is_multiple_of(7) {
            0.0
        } else {
            m * 2f64.powi((rng % 40) as i32 - 30)
        }
    };
    let mut compared = 0;
    for mode in [Mode::Hold, Mode::Locked, Mode::Drive, Mode::Free] {
        for w_s in [0.0, 0.04, 0.3] {
            let (xi_row, rate_row) = (linear::xi_row(&p, w_s), linear::drive_rate_row(&p, mode));
            let watch = Watch {
                vth: p.v_th,
                earth_closed: true,
                nonearth_closed: false,
                xi_row: &xi_row,
                rate_row: &rate_row,
                direction: 0.0,
                up: 1.0,
                down: -1.0,
            };
            for _ in 0..2000 {
                let z = Vector::from_fn(|_, _| next());
                assert_eq!(watch.xi(&z), xi_row.dot(&z));
                assert_eq!(watch.rate(&z), rate_row.dot(&z));
                compared += 1;
            }
        }
    }
    assert_eq!(compared, 24_000);
}
