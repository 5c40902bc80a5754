//! When two instants are one: the time rule of every step, event and clock tick.

/// Communication points from `t += h` and from `k · h` differ by rounding; they are the
/// same point when within 1e-9 of the time (and within a few ulps at t = 0). The rule of
/// every `DoStep`'s time, and of a model whose own instants must meet it (the controller's
/// sample clock).
///
/// On the path of every step of every model that keeps a clock: compares without
/// `f64::max`'s NaN handling, which changes no answer (a NaN time makes the difference NaN
/// and the answer false), and without the bound `4 ε · scale`, which `1e-9 · scale` always
/// exceeds unless both fall below `f64::MIN_POSITIVE`, where that takes over.
#[inline]
pub fn same_time(a: f64, b: f64) -> bool {
    let (x, y) = (a.abs(), b.abs());
    let tolerance = 1e-9 * if x > y { x } else { y };
    (a - b).abs() <= if tolerance > f64::MIN_POSITIVE { tolerance } else { f64::MIN_POSITIVE }
}

#[cfg(test)]
mod tests {
    use super::same_time;

    /// The rule as the standards' text of it reads: within 1e-9 of the larger time, or 4
    /// ulps of it, or the least normal number.
    fn rule(a: f64, b: f64) -> bool {
        let scale = a.abs().max(b.abs());
        (a - b).abs() <= (1e-9 * scale).max(4.0 * f64::EPSILON * scale).max(f64::MIN_POSITIVE)
    }

    #[test]
    fn same_time_answers_as_the_rule_does() {
        let special = [
            0.0,
            -0.0,
            f64::MIN_POSITIVE,
            f64::MIN_POSITIVE / 2.0,
            f64::from_bits(1),
            2.2e-299,
            1e-300,
            0.002,
            10.0,
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        let mut pairs: Vec<(f64, f64)> = Vec::new();
        for &a in &special {
            for &b in &special {
                pairs.push((a, b));
                pairs.push((-a, b));
            }
            for d in [0.0, 1e-12, 0.999e-9, 1.001e-9, 1e-6] {
                pairs.push((a, a * (1.0 + d)));
                pairs.push((a, a + d));
            }
        }
        let mut s = 0x2545_f491_4f6c_dd1du64;
        for k in 0..200_000u64 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let t = k as f64 * 0.002;
            let near = t + (s % 2001) as f64 * 1e-21 * (t + 1.0) * 1e3 - 1e-12 * t;
            pairs.push((t, near));
            pairs.push((f64::from_bits(s), f64::from_bits(s.rotate_left(7))));
        }
        let mut same = 0;
        for &(a, b) in &pairs {
            assert_eq!(same_time(a, b), rule(a, b), "{a:e} {b:e}");
            same += usize::from(rule(a, b));
        }
        // Both answers are tested, each many times.
        assert!(same > 100_000 && pairs.len() - same > 100_000, "{same} of {}", pairs.len());
    }
}
