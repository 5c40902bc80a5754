//! How well the runner holds its position (docs/model.md §4.1), judged only at the samples
//! where it is held still: which samples those are ([`Parked`], and [`Held`] for the
//! controller options that also hold the runner in DRIVE), when the loop settles
//! ([`Settle`]) and the holding RMS error ([`HoldingRms`]).
//!
//! Each is a reducer fed one sample at a time, t_k = k h for k ≥ 1 (a trace's rows after
//! the t = 0 one) with the DAC volts held during `[t_{k-1}, t_k)`, so that one definition
//! serves both a whole run read at once (the closed-loop view of a trace) and a sweep's run
//! read as the master produces its rows (the sweep metrics).

/// The samples at which the runner is parked: all three DAC outputs zero over the sample
/// and the 7 before it (a step's gait has ended and the brakes hold), from the 9th sample on.
#[derive(Clone, Copy, Debug, Default)]
pub struct Parked {
    /// Samples judged so far.
    samples: usize,
    /// Consecutive samples, up to the latest, with all three DAC outputs zero.
    zeros: usize,
}

impl Parked {
    /// Whether the next sample is parked, given the DAC volts held during it.
    pub fn next(&mut self, held: &[f64; 3]) -> bool {
        self.zeros = if held.iter().all(|v| *v == 0.0) { self.zeros + 1 } else { 0 };
        let parked = self.samples >= 8 && self.zeros >= 8;
        self.samples += 1;
        parked
    }
}

/// The samples at which a position is judged under the options of docs/model.md §4.2:
/// parked (all DACs zero) over the sample and the one before it, i.e. the step boundaries
/// of any gait, or in analog hold (both brake DACs at 10 V over the sample and the 39
/// before it, longer than any DRIVE segment of a gait of up to 100 samples); from the 41st
/// sample on.
#[derive(Clone, Copy, Debug, Default)]
pub struct Held {
    samples: usize,
    /// Consecutive samples, up to the latest, with all three DAC outputs zero.
    zeros: usize,
    /// Consecutive samples, up to the latest, with both brake DACs at 10 V.
    analog: usize,
}

impl Held {
    /// Whether the next sample is held, given the DAC volts held during it.
    pub fn next(&mut self, dac: &[f64; 3]) -> bool {
        self.zeros = if *dac == [0.0; 3] { self.zeros + 1 } else { 0 };
        self.analog = if dac[0] == 10.0 && dac[1] == 10.0 { self.analog + 1 } else { 0 };
        let held = self.samples >= 40 && (self.zeros >= 2 || self.analog >= 40);
        self.samples += 1;
        held
    }
}

/// The settle time: the first time after which every judged sample is within the band;
/// none if the last one is outside it, or if no sample was judged.
#[derive(Clone, Copy, Debug, Default)]
pub struct Settle {
    /// The first judged sample's time.
    first: Option<f64>,
    /// Whether a judged sample was outside the band.
    outside: bool,
    /// The first judged time after the latest sample outside the band.
    after: Option<f64>,
}

impl Settle {
    /// A judged sample at time `t`, `outside` the band or not.
    pub fn push(&mut self, t: f64, outside: bool) {
        self.first.get_or_insert(t);
        if outside {
            self.outside = true;
            self.after = None;
        } else if self.outside && self.after.is_none() {
            self.after = Some(t);
        }
    }

    /// The settle time of the samples so far.
    pub fn time(&self) -> Option<f64> {
        if self.outside {
            self.after
        } else {
            self.first
        }
    }
}

/// The RMS position error of the judged samples in a window `[from, to)` s.
#[derive(Clone, Copy, Debug)]
pub struct HoldingRms {
    from: f64,
    to: f64,
    /// Σ e² of the samples in the window.
    sum: f64,
    /// Their count.
    n: usize,
}

impl HoldingRms {
    pub fn new(from: f64, to: f64) -> HoldingRms {
        HoldingRms { from, to, sum: 0.0, n: 0 }
    }

    /// A judged sample at time `t` with position error `error`.
    pub fn push(&mut self, t: f64, error: f64) {
        if t >= self.from && t < self.to {
            self.sum += error * error;
            self.n += 1;
        }
    }

    /// The RMS error of the samples so far; none if none fell in the window.
    pub fn value(&self) -> Option<f64> {
        (self.n > 0).then(|| (self.sum / self.n as f64).sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ZERO: [f64; 3] = [0.0; 3];
    const STEP: [f64; 3] = [10.0, 0.0, 3.0];

    #[test]
    fn a_sample_is_parked_after_eight_zero_dac_samples_from_the_ninth_on() {
        let mut p = Parked::default();
        let from_rest: Vec<bool> = (0..10).map(|_| p.next(&ZERO)).collect();
        // Sample 7 has 8 zero samples (0..=7) but is the 8th sample: not judged yet.
        assert_eq!(from_rest, [false, false, false, false, false, false, false, false, true, true]);
        assert!(!p.next(&STEP), "a step's sample");
        let after: Vec<bool> = (0..9).map(|_| p.next(&ZERO)).collect();
        assert_eq!(after, [false, false, false, false, false, false, false, true, true]);
    }

    #[test]
    fn a_sample_is_held_at_a_step_boundary_or_in_analog_hold_from_the_41st_on() {
        let mut h = Held::default();
        let analog = [10.0, 10.0, 4.0];
        let first: Vec<bool> = (0..41).map(|_| h.next(&analog)).collect();
        assert_eq!(first.iter().position(|&x| x), Some(40));
        assert!(!h.next(&STEP));
        assert!(!h.next(&ZERO), "one zero sample after a step");
        assert!(h.next(&ZERO), "two: a step boundary");
        let again: Vec<bool> = (0..40).map(|_| h.next(&analog)).collect();
        assert_eq!(again.iter().position(|&x| x), Some(39), "40 samples of analog hold");
    }

    #[test]
    fn settle_is_the_first_time_after_the_last_sample_outside_the_band() {
        let settle = |samples: &[(f64, bool)]| {
            let mut s = Settle::default();
            samples.iter().for_each(|&(t, out)| s.push(t, out));
            s.time()
        };
        assert_eq!(settle(&[]), None);
        assert_eq!(settle(&[(0.5, false), (0.7, false)]), Some(0.5));
        assert_eq!(settle(&[(0.5, true), (0.7, false), (0.9, true), (1.1, false)]), Some(1.1));
        assert_eq!(settle(&[(0.5, false), (0.7, true)]), None);
    }

    #[test]
    fn holding_rms_counts_the_samples_in_its_window_only() {
        let mut r = HoldingRms::new(1.0, 2.0);
        assert_eq!(r.value(), None);
        for (t, e) in [(0.5, 9.0), (1.0, 3.0), (1.5, -4.0), (2.0, 9.0)] {
            r.push(t, e);
        }
        assert_eq!(r.value(), Some(12.5f64.sqrt()));
    }
}
