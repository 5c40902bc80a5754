//! A component whose clocks the master ticks ([`Clocked`]): its input clocks' schedule, read
//! from the FMU after initialization, the ticks of a step, and its output clocks. The
//! scheduler that runs their events is `clocks`.

use std::ops::{Deref, DerefMut};

use crate::fmu::{Causality, Instance, IntervalQualifier};
use crate::Error;

/// The most ticks of one component a communication step may hold: past it the step is
/// refused (a clock of 1 µs under a step of 100 s would make 10^8 events).
pub const MAX_TICKS_PER_STEP: u64 = 1_000_000;

/// The last tick number counted: past 2^53 `n · interval` is no longer exact in an `f64`.
const MAX_TICK: f64 = 9_007_199_254_740_992.0;

/// One input clock the master ticks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct InputClock {
    pub vr: u32,
    /// `priority` of the description, 0 the highest (0 where not declared).
    pub priority: u32,
    /// The first tick: the start time plus the clock's shift.
    pub origin: f64,
    pub interval: f64,
}

impl InputClock {
    fn tick(&self, n: u64) -> f64 {
        self.origin + n as f64 * self.interval
    }

    /// The ticks in `(t, end]` (both ends up to [`same_time`]), as tick numbers; a step
    /// holding more than [`MAX_TICKS_PER_STEP`] of them, or reaching past tick 2^53 (where
    /// `n · interval` is no longer exact), is refused before any is counted, so the work
    /// is bounded whatever the times.
    fn ticks_in(&self, t: f64, end: f64) -> Result<std::ops::Range<u64>, String> {
        let (from, to) = ((t - self.origin) / self.interval, (end - self.origin) / self.interval);
        if !(from.is_finite() && to.is_finite()) || to > MAX_TICK {
            return Err(format!(
                "t = {end:e} s is tick {to:e} of an input clock of {} s: past the 2^53 ticks this master counts exactly",
                self.interval
            ));
        }
        if to - from.max(0.0) > MAX_TICKS_PER_STEP as f64 + 2.0 {
            return Err(format!(
                "{:e} ticks of an input clock of {} s in one communication step of {} s, more than the {MAX_TICKS_PER_STEP} this master runs: take shorter steps",
                to - from.max(0.0),
                self.interval,
                end - t
            ));
        }
        let first = |x: f64| -> u64 {
            // The first n with tick(n) after x (not the same time as x); x is at most
            // tick 2^53, so neither walk runs more than a step or two.
            let mut n = ((x - self.origin) / self.interval).floor().max(0.0) as u64;
            while n > 0 && !(self.tick(n - 1) <= x || same_time(self.tick(n - 1), x)) {
                n -= 1;
            }
            while self.tick(n) <= x || same_time(self.tick(n), x) {
                n += 1;
            }
            n
        };
        let lo = if t < self.origin && !same_time(t, self.origin) { 0 } else { first(t) };
        let hi = first(end);
        Ok(lo..hi.max(lo))
    }

    /// Whether `t` is one of the clock's ticks.
    fn ticks_at(&self, t: f64) -> bool {
        let n = ((t - self.origin) / self.interval).round();
        n >= 0.0 && same_time(self.tick(n as u64), t)
    }
}

/// The master's rounding of times: two times within 1e-9 of their size (a few ulps at 0)
/// are one, as communication points from `k · h` and ticks from `n · interval` meet.
pub(super) fn same_time(a: f64, b: f64) -> bool {
    let scale = a.abs().max(b.abs());
    (a - b).abs() <= (1e-9 * scale).max(4.0 * f64::EPSILON * scale).max(f64::MIN_POSITIVE)
}

/// A component whose clocks the master ticks: its FMU (a [`crate::fmu::CsFmu`] with event
/// mode or a [`crate::fmu::SeFmu`]), its input clocks and output clocks.
pub(super) struct Clocked<F> {
    pub fmu: F,
    /// Read at initialization ([`Clocked::schedule`]).
    pub inputs: Vec<InputClock>,
    pub outputs: Vec<u32>,
    /// Ticks of the output clocks seen so far (`fmi3GetClock` after each event).
    pub output_ticks: u64,
}

impl<F: Deref<Target = Instance> + DerefMut> Clocked<F> {
    pub fn new(fmu: F) -> Clocked<F> {
        Clocked { fmu, inputs: Vec::new(), outputs: Vec::new(), output_ticks: 0 }
    }

    /// Reads the input clocks' intervals and shifts from the initialized FMU and the
    /// output clocks from its description; a clock the master cannot tick by time (a
    /// triggered or aperiodic input clock, an interval not known) is refused.
    pub fn schedule(&mut self, start: f64) -> Result<(), Error> {
        let md = self.fmu.description();
        let model = md.model_name.clone();
        let mut inputs = Vec::new();
        for c in md.clocks.iter().filter(|c| c.causality == Causality::Input) {
            if !c.is_periodic() {
                return Err(Error::Config(format!(
                    "{model}: input clock `{}` has intervalVariability=\"{}\": this master ticks periodic clocks only (constant, fixed, tunable)",
                    c.name, c.interval_variability
                )));
            }
            inputs.push((c.vr, c.priority.unwrap_or(0), c.name.clone()));
        }
        self.outputs =
            md.clocks.iter().filter(|c| c.causality == Causality::Output).map(|c| c.vr).collect();
        self.inputs.clear();
        for (vr, priority, name) in inputs {
            let interval = self.fmu.intervals(&[vr])?[0];
            let shift = self.fmu.shifts(&[vr])?[0];
            let known = interval.qualifier != IntervalQualifier::NotYetKnown;
            if !(known && interval.value.is_finite() && interval.value > 0.0) {
                return Err(Error::Config(format!(
                    "{model}: fmi3GetIntervalDecimal gives input clock `{name}` the interval {} s ({:?}): not a time the master can tick at",
                    interval.value, interval.qualifier
                )));
            }
            if !(shift.is_finite() && shift >= 0.0) {
                return Err(Error::Config(format!(
                    "{model}: fmi3GetShiftDecimal gives input clock `{name}` the shift {shift} s"
                )));
            }
            let origin = start + shift;
            self.inputs.push(InputClock { vr, priority, origin, interval: interval.value });
        }
        self.output_ticks = 0;
        Ok(())
    }

    /// Refuses, before the first step, a run whose ticks the master could not count or
    /// run: past tick 2^53 by the stop time, or more than [`MAX_TICKS_PER_STEP`] in a step
    /// of `h` (the same rules [`InputClock::ticks_in`] holds each step to).
    pub(super) fn check_run(&self, h: f64, stop: f64) -> Result<(), Error> {
        for c in &self.inputs {
            c.ticks_in(stop - h, stop)
                .map_err(|why| Error::Config(format!("{}: {why}", self.fmu.model_name())))?;
        }
        Ok(())
    }

    /// The input clocks that tick at `t`.
    pub(super) fn due_at(&self, t: f64) -> Vec<InputClock> {
        self.inputs.iter().copied().filter(|c| c.ticks_at(t)).collect()
    }

    /// The times of the ticks strictly inside `(t, end)`, in order, one entry per time.
    pub(super) fn ticks_within(&self, t: f64, end: f64) -> Result<Vec<f64>, Error> {
        let mut times: Vec<f64> = Vec::new();
        for c in &self.inputs {
            let range = c
                .ticks_in(t, end)
                .map_err(|why| Error::Config(format!("{}: {why}", self.fmu.model_name())))?;
            debug_assert!(range.end - range.start <= MAX_TICKS_PER_STEP + 2);
            times.extend(range.map(|n| c.tick(n)).filter(|&s| !same_time(s, end)));
        }
        times.sort_by(f64::total_cmp);
        times.dedup_by(|a, b| same_time(*a, *b));
        Ok(times)
    }

    /// Reads the output clocks (which resets them) and counts their ticks.
    pub(super) fn read_output_clocks(&mut self) -> Result<(), Error> {
        if self.outputs.is_empty() {
            return Ok(());
        }
        let mut ticked = vec![false; self.outputs.len()];
        self.fmu.get_clocks(&self.outputs, &mut ticked)?;
        self.output_ticks += ticked.iter().filter(|&&t| t).count() as u64;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_counted_and_meet_the_communication_points() {
        let c = InputClock { vr: 5, priority: 0, origin: 0.0, interval: 0.002 };
        // 0.1 ms steps: tick n at step 20 n, whatever the rounding of k · h.
        let h = 1e-4;
        let mut ends = Vec::new();
        for k in 0..100u64 {
            let (t, end) = (k as f64 * h, (k + 1) as f64 * h);
            let r = c.ticks_in(t, end).unwrap();
            assert!(r.end - r.start <= 1, "step {k}: {r:?}");
            if r.end > r.start {
                assert!(same_time(c.tick(r.start), end), "step {k}");
                ends.push(k + 1);
            }
        }
        assert_eq!(ends, [20, 40, 60, 80, 100]);
        // A 5 ms step holds the ticks at 2 and 4 ms inside it and none at its end.
        assert_eq!(c.ticks_in(0.0, 0.005), Ok(1..3));
        assert_eq!(c.ticks_in(0.004, 0.006), Ok(3..4));
        assert!(c.ticks_at(0.006) && !c.ticks_at(0.005) && c.ticks_at(0.0));
        // A shifted clock ticks first at its origin.
        let s = InputClock { origin: 0.001, ..c };
        assert_eq!(s.ticks_in(0.0, 0.001), Ok(0..1));
        assert_eq!(s.ticks_in(0.0, 0.0005), Ok(0..0));
    }

    #[test]
    fn a_step_of_too_many_ticks_or_past_tick_2_53_is_refused_before_counting() {
        let c = InputClock { vr: 5, priority: 0, origin: 0.0, interval: 0.002 };
        // 1e17 s and 1e300 s in one step: refused at once, not walked tick by tick.
        for end in [1e17, 1e300, f64::MAX] {
            let why = c.ticks_in(0.0, end).unwrap_err();
            assert!(why.contains("2^53 ticks"), "{why}");
        }
        let why = c.ticks_in(0.0, 2_001.0).unwrap_err();
        assert!(why.contains("more than the 1000000 this master runs"), "{why}");
        assert_eq!(c.ticks_in(0.0, 2_000.0).map(|r| r.end - r.start), Ok(1_000_000));
        // Later in a run, a million ticks on, a step counts as at the start.
        let t = 1e6 * 0.002;
        assert_eq!(c.ticks_in(t, t + 0.005), Ok(1_000_001..1_000_003));
    }
}
