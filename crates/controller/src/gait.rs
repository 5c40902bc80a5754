//! The stepping gait (docs/model.md §3.2): seven segments of DAC volts per step, forward and
//! backward, scaled to any number of samples per step.

/// Direction of one step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    Forward,
    Backward,
}

/// Segment starts of the 100-sample gait (docs/model.md §3.2), 1-based.
const STARTS_100: [usize; 7] = [1, 15, 30, 44, 59, 72, 87];

/// Where the segments and the averaging windows of a step lie for `n` samples per step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Timing {
    pub samples: usize,
    /// 1-based first sample of each segment.
    pub starts: [usize; 7],
    /// 1-based inclusive averaging window of each segment (docs/model.md §3.3).
    pub windows: [(usize, usize); 7],
}

impl Timing {
    /// `n` ≥ 7 samples per step; segments and windows scale with `n` and are exactly the
    /// model's (docs/model.md §3.2) at `n` = 100.
    pub fn new(n: usize) -> Timing {
        assert!(n >= 7, "a step needs at least one sample per segment");
        let starts = STARTS_100.map(|s| 1 + ((s - 1) * n + 50) / 100);
        // The windows end one sample before the next segment (the last sample of a segment
        // may already see the next switch through the analog chain) and are 5 % of a step.
        let skip = (n + 50) / 100;
        let len = ((5 * n + 50) / 100).max(1);
        let windows = std::array::from_fn(|i| {
            let end_of_segment = if i < 6 { starts[i + 1] - 1 } else { n };
            let end = end_of_segment.saturating_sub(skip).max(starts[i]);
            (end.saturating_sub(len - 1).max(starts[i]), end)
        });
        Timing { samples: n, starts, windows }
    }

    /// Segment (1..=7) of the 1-based sample `k`.
    pub fn segment(&self, k: usize) -> usize {
        self.starts.iter().rposition(|&s| s <= k).map_or(1, |i| i + 1)
    }

    /// DAC volts (earth, non-earth, extension) of sample `k` of a step with amplitude `y`
    /// (forward: `y` in [0, 1]; backward: `a = |y|`).
    pub fn volts(&self, direction: Direction, y: f64, k: usize) -> [f64; 3] {
        let a = y.abs().min(1.0);
        let seg = self.segment(k);
        match direction {
            Direction::Forward => {
                let e = if (3..=4).contains(&seg) { 10.0 } else { 0.0 };
                let n = if (2..=5).contains(&seg) { 10.0 } else { 0.0 };
                let x = if (4..=6).contains(&seg) { 10.0 * a } else { 0.0 };
                [e, n, x]
            }
            Direction::Backward => {
                let e = if (4..=5).contains(&seg) { 10.0 } else { 0.0 };
                let n = if (3..=6).contains(&seg) { 10.0 } else { 0.0 };
                let x = if (2..=4).contains(&seg) { 10.0 * a } else { 0.0 };
                [e, n, x]
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spec_timing_at_100_samples() {
        let t = Timing::new(100);
        assert_eq!(t.starts, STARTS_100);
        assert_eq!(
            t.windows,
            [(9, 13), (24, 28), (38, 42), (53, 57), (66, 70), (81, 85), (95, 99)]
        );
    }

    #[test]
    fn ten_sample_gait_sample_by_sample() {
        let t = Timing::new(10);
        // Starts 1, 15, 30, 44, 59, 72, 87 of 100 scale to 1, 2, 4, 5, 7, 8, 10; every
        // segment keeps at least one sample and its window is its last sample.
        assert_eq!(t.starts, [1, 2, 4, 5, 7, 8, 10]);
        assert_eq!(t.windows, [(1, 1), (3, 3), (4, 4), (6, 6), (7, 7), (9, 9), (10, 10)]);
        let fwd = |y: f64| {
            [
                [0.0, 0.0, 0.0],
                [0.0, 10.0, 0.0],
                [0.0, 10.0, 0.0],
                [10.0, 10.0, 0.0],
                [10.0, 10.0, 10.0 * y],
                [10.0, 10.0, 10.0 * y],
                [0.0, 10.0, 10.0 * y],
                [0.0, 0.0, 10.0 * y],
                [0.0, 0.0, 10.0 * y],
                [0.0, 0.0, 0.0],
            ]
        };
        let bwd = |a: f64| {
            [
                [0.0, 0.0, 0.0],
                [0.0, 0.0, 10.0 * a],
                [0.0, 0.0, 10.0 * a],
                [0.0, 10.0, 10.0 * a],
                [10.0, 10.0, 10.0 * a],
                [10.0, 10.0, 10.0 * a],
                [10.0, 10.0, 0.0],
                [0.0, 10.0, 0.0],
                [0.0, 10.0, 0.0],
                [0.0, 0.0, 0.0],
            ]
        };
        for y in [1.0, 0.3] {
            for k in 1..=10 {
                assert_eq!(
                    t.volts(Direction::Forward, y, k),
                    fwd(y)[k - 1],
                    "forward y = {y}, sample {k}"
                );
                assert_eq!(
                    t.volts(Direction::Backward, -y, k),
                    bwd(y)[k - 1],
                    "backward a = {y}, sample {k}"
                );
            }
        }
    }

    #[test]
    fn sample_one_is_parked_and_amplitudes_clamp_to_a_full_step() {
        for n in [7, 10, 33, 100, 250] {
            let t = Timing::new(n);
            for d in [Direction::Forward, Direction::Backward] {
                assert_eq!(t.volts(d, 1.0, 1), [0.0; 3], "n = {n}: sample 1 parked");
                assert_eq!(t.volts(d, 1.0, n), [0.0; 3], "n = {n}: sample n parked");
                // Every segment has a sample, in order.
                assert!(t.starts.windows(2).all(|w| w[0] < w[1]), "n = {n}: {:?}", t.starts);
            }
        }
        let t = Timing::new(100);
        assert_eq!(t.volts(Direction::Forward, 1.7, 50)[2], 10.0, "DAC full scale is a full step");
        assert_eq!(t.volts(Direction::Backward, -1.0, 20)[2], 10.0);
    }

    #[test]
    fn tables_of_spec_3_2_sample_by_sample() {
        let t = Timing::new(100);
        let expect_fwd = |k: usize, y: f64| match k {
            1..=14 => [0.0, 0.0, 0.0],
            15..=29 => [0.0, 10.0, 0.0],
            30..=43 => [10.0, 10.0, 0.0],
            44..=58 => [10.0, 10.0, 10.0 * y],
            59..=71 => [0.0, 10.0, 10.0 * y],
            72..=86 => [0.0, 0.0, 10.0 * y],
            _ => [0.0, 0.0, 0.0],
        };
        let expect_bwd = |k: usize, a: f64| match k {
            1..=14 => [0.0, 0.0, 0.0],
            15..=29 => [0.0, 0.0, 10.0 * a],
            30..=43 => [0.0, 10.0, 10.0 * a],
            44..=58 => [10.0, 10.0, 10.0 * a],
            59..=71 => [10.0, 10.0, 0.0],
            72..=86 => [0.0, 10.0, 0.0],
            _ => [0.0, 0.0, 0.0],
        };
        for y in [1.0, 0.3, 0.0] {
            for k in 1..=100 {
                assert_eq!(
                    t.volts(Direction::Forward, y, k),
                    expect_fwd(k, y),
                    "forward y = {y}, sample {k}"
                );
                assert_eq!(
                    t.volts(Direction::Backward, -y, k),
                    expect_bwd(k, y),
                    "backward a = {y}, sample {k}"
                );
            }
        }
    }
}
