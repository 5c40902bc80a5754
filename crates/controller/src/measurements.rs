//! Raw measurements of one step (docs/model.md §3.3) from its encoder and extension samples.

use crate::gait::{Direction, Timing};

/// Segment averages and the three raw measurements, positions in metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Raw {
    pub s: [f64; 7],
    pub e: [f64; 7],
    /// Commanded extension, fraction of a full step (negative backward).
    pub ext_cmd: f64,
    /// Runner motion due to the extension (m).
    pub ext_moved: f64,
    /// Brake disturbance: the rest of the motion over the step (m).
    pub bd: f64,
}

impl Raw {
    /// The runner position after the step (the `s7` average).
    pub fn position_after(&self) -> f64 {
        self.s[6]
    }
}

/// `enc[k-1]` is `w_enc(k)` in metres, `ext[k-1]` is `w_ext(k)`.
pub fn raw(timing: &Timing, direction: Direction, enc: &[f64], ext: &[f64]) -> Raw {
    let avg =
        |v: &[f64], (a, b): (usize, usize)| v[a - 1..b].iter().sum::<f64>() / (b - a + 1) as f64;
    let s = timing.windows.map(|w| avg(enc, w));
    let e = timing.windows.map(|w| avg(ext, w));
    let (ext_cmd, ext_moved) = match direction {
        Direction::Forward => (e[3] - e[2], s[3] - s[2]),
        Direction::Backward => (e[4] - e[3], s[4] - s[3]),
    };
    Raw { s, e, ext_cmd, ext_moved, bd: (s[6] - s[0]) - ext_moved }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn synthetic_forward_and_backward_steps() {
        let t = Timing::new(100);
        // Forward: 1 µm at rest, +18 µm during segment 4, +4.5 µm more by segment 7.
        let enc: Vec<f64> = (1..=100)
            .map(|k| match t.segment(k) {
                1..=3 => 1e-6,
                4..=6 => 19e-6,
                _ => 23.5e-6,
            })
            .collect();
        let ext: Vec<f64> =
            (1..=100).map(|k| t.volts(Direction::Forward, 0.9, k)[2] / 10.0).collect();
        let r = raw(&t, Direction::Forward, &enc, &ext);
        assert!((r.ext_cmd - 0.9).abs() < 1e-15);
        assert!((r.ext_moved - 18e-6).abs() < 1e-15);
        assert!((r.bd - 4.5e-6).abs() < 1e-15);
        // Backward: moves -17 µm between segments 4 and 5.
        let enc: Vec<f64> = (1..=100)
            .map(|k| {
                if t.segment(k) <= 4 {
                    0.0
                } else {
                    -17e-6 + if t.segment(k) == 7 { 4e-6 } else { 0.0 }
                }
            })
            .collect();
        let ext: Vec<f64> =
            (1..=100).map(|k| t.volts(Direction::Backward, -1.0, k)[2] / 10.0).collect();
        let r = raw(&t, Direction::Backward, &enc, &ext);
        assert_eq!(r.ext_cmd, -1.0);
        assert!((r.ext_moved + 17e-6).abs() < 1e-15);
        assert!((r.bd - 4e-6).abs() < 1e-15);
    }

    #[test]
    fn ten_sample_step_reads_single_sample_windows() {
        let t = Timing::new(10);
        // Backward step of amplitude 0.6 at 10 samples: the encoder reads 2 µm until
        // DRIVE, 2 + 4.2 µm (disturbance) in segment 4, then −9.8 µm more when the
        // extension retracts; ±0.6 µm of noise off the windows must not matter.
        let enc = [2.0, 2.6, 2.0, 2.0, 6.2, 6.2, -3.6, -3.6, -3.6, -3.6].map(|u: f64| u * 1e-6);
        let ext: Vec<f64> =
            (1..=10).map(|k| t.volts(Direction::Backward, -0.6, k)[2] / 10.0).collect();
        let r = raw(&t, Direction::Backward, &enc, &ext);
        assert_eq!(r.e, [0.0, 0.6, 0.6, 0.6, 0.0, 0.0, 0.0]);
        assert!((r.ext_cmd + 0.6).abs() < 1e-15, "EXT_cmd = e5 − e4 = {}", r.ext_cmd);
        assert!((r.ext_moved + 9.8e-6).abs() < 1e-15, "EXT_moved = s5 − s4 = {}", r.ext_moved);
        assert!((r.bd - 4.2e-6).abs() < 1e-15, "BD = (s7 − s1) − EXT_moved = {}", r.bd);
        assert!((r.position_after() + 3.6e-6).abs() < 1e-15);
    }
}
