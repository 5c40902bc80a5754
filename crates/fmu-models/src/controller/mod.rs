//! The `InchwormController` FMU: the controller of docs/model.md §3 and §4 behind the FMI
//! 2.0 / 3.0 Co-Simulation interface of docs/model.md §5.
//!
//! Timing contract, that of a sampled controller on a board: the sample instants are
//! `s_n = t0 + n × 2 ms` (t0 the start time, n counted, never accumulated). At each
//! instant the board latches the inputs (`encoder_counts`, `reference`) and writes to the
//! DAC the sample computed from the inputs latched one instant earlier: sample n + 1
//! (held during `[s_(n+1), s_(n+2))`) comes from the inputs that held at `s_n`. That is
//! the one-sample delay the controller is designed with (docs/model.md §4, Timing).
//!
//! `fmi2DoStep(t, h)` accepts any `h > 0` and runs the instants its step reaches: the
//! latch at every `s_n` in `[t, t + h)` (the input held during the step is the value at
//! `s_n`) and the DAC write at every `s_n` in `(t, t + h]` (so the output the master reads
//! at `t + h` is the sample that holds from the last instant `<= t + h` on). An instant
//! within the layer's 1e-9 relative tolerance of `t + h` counts as `t + h`. Between
//! instants the outputs hold. At `h = k × 2 ms` this is exactly k ticks of the controller:
//! every step latches and writes k times, all from the inputs held at `t`, and ends with
//! the sample for `[t + h, t + h + 2 ms)`; a plain Jacobi master at 2 ms runs the loop
//! correctly. At `h = 2 ms / m` the loop is the 2 ms loop: the latch at `s_n` reads the
//! plant's encoder at `s_n` and the write reaches the plant at `s_(n+1)`. Other steps
//! add the master's staleness: a latch reads the value of the last communication point
//! `<= s_n` (< h old) and a write reaches the plant at the first one `>= s_(n+1)` (< h
//! late). docs/model.md §5 has the table.
//!
//! As Model Exchange the controller has no continuous states and one time event per
//! sample instant (`nextEventTime`). The event update at `T` runs what a step ending at `T`
//! runs (every write at an instant `<= T` not yet made), then the latch at `T` itself if `T`
//! is an instant: the same instants, inputs and samples as Co-Simulation, so a master that
//! hands the plant's encoder to the controller at each event closes the same loop as a
//! Jacobi master at 2 ms. Between events the outputs hold.
//!
//! In FMI 3.0 the sample instants are the ticks of the input clock `sample_clock`, and a
//! tick's activation (event mode's `fmi3UpdateDiscreteStates`, Scheduled Execution's
//! `fmi3ActivateModelPartition`) runs the event at its time, as above; between ticks a
//! step of an instance with event mode changes nothing. The output clock `gait_step` ticks
//! at the samples that end a gait step and update the estimator. docs/model.md §5, Clocks.

use inchworm_controller::analog::AnalogParams;
use inchworm_controller::compensator::Gains;
use inchworm_controller::estimator::Noise;
use inchworm_controller::{Controller, Params, Sample, SAMPLE_PERIOD};
// The layer's `same_time`: communication points within 1e-9 relative (a few ulps at 0) are
// one point, so an instant the master reaches up to rounding counts as reached.
use inchworm_fmi_export::same_time;
use inchworm_fmi_export::{EventUpdate, Model, ModelExchange, ModelInfo, Row, StepLog, Writer};

mod state;
mod table;

#[derive(Clone, Debug)]
pub struct ControllerFmu {
    params: Params,
    encoder_counts: i32,
    reference: f64,
    controller: Option<Controller>,
    last: Option<Sample>,
    clock: Clock,
    /// The output clock `gait_step`: a sample of the current activation ended a gait step
    /// and updated the estimator. Not saved with the state (it lasts one event).
    gait_ticked: bool,
}

// The parameters are the model's declared part: the table takes their rows from the
// declarations on `Params` and the structs it flattens.
inchworm_fmi_export::inchworm_declare::has!(ControllerFmu {
    Params => params,
    Gains => params.gains,
    Noise => params.noise,
    AnalogParams => params.analog_params,
});

/// Where the controller is on its sample grid `s_n = origin + n × SAMPLE_PERIOD`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Clock {
    /// `s_0`. `None` only in a state restored from format 1 (which held no clock and was
    /// always taken at a sample instant): the next step's `t` is then `s_0`.
    origin: Option<f64>,
    /// Samples written so far: the outputs are those of the write at `s_ticks`.
    ticks: u64,
    /// The inputs latched at `s_ticks` while the write at `s_(ticks+1)` is still ahead;
    /// `None` exactly when the communication point is a sample instant.
    latch: Option<(i32, f64)>,
}

/// `s` lies before `end` and is not `end` up to rounding.
fn before(s: f64, end: f64) -> bool {
    s < end && !same_time(s, end)
}

/// `s` lies after `end` and is not `end` up to rounding.
fn after(s: f64, end: f64) -> bool {
    s > end && !same_time(s, end)
}

/// The most sample instants one call runs: a step or an event update runs every instant
/// it passes (some 0.1 µs each here), so that no time a master gives makes a call take
/// more than about a second. 10^7 samples are 20 000 s of simulated time.
const MAX_SAMPLES_PER_CALL: f64 = 1e7;

impl ControllerFmu {
    /// A model that will run `params` (validated at initialization, as a master's).
    pub fn with_params(params: Params) -> Self {
        ControllerFmu { params, ..Model::new() }
    }

    /// Refuses an `end` more than [`MAX_SAMPLES_PER_CALL`] sample instants past the last
    /// sample written (before any is, `t` is the origin).
    fn within_reach(&self, t: f64, end: f64) -> Result<(), String> {
        let last = self.clock.origin.unwrap_or(t) + self.clock.ticks as f64 * SAMPLE_PERIOD;
        let samples = (end - last) / SAMPLE_PERIOD;
        if samples > MAX_SAMPLES_PER_CALL {
            return Err(format!(
                "{end} s is {samples:.4e} sample instants past the last sample at {last} s; one call runs at most {MAX_SAMPLES_PER_CALL:e} (take shorter steps, or stop at every time event)"
            ));
        }
        Ok(())
    }

    /// Runs the instants of a step from `t` to `end`: the latch at every `s_n` in
    /// `[t, end)`, the write at every `s_n` in `(t, end]`; only `end` and the clock decide
    /// which (`t` names the step in messages and anchors a clock restored from format 1).
    fn advance(&mut self, t: f64, end: f64, log: &mut StepLog) -> Result<(), String> {
        let c = self.controller.as_mut().ok_or("the controller is not initialized")?;
        let clock = &mut self.clock;
        let origin = *clock.origin.get_or_insert(t);
        // Counted instants: s_n is the same number whichever steps led to it.
        let instant = |n: u64| origin + n as f64 * SAMPLE_PERIOD;
        loop {
            let (counts, reference) = match clock.latch {
                Some(latched) => latched,
                // The latch at s_ticks, if this step holds it: [t, end).
                None if before(instant(clock.ticks), end) => (self.encoder_counts, self.reference),
                None => break,
            };
            // The write at s_(ticks+1), if this step reaches it: (t, end].
            if after(instant(clock.ticks + 1), end) {
                clock.latch = Some((counts, reference));
                break;
            }
            clock.latch = None;
            clock.ticks += 1;
            let s = c.tick(i64::from(counts), reference);
            if s.no_root {
                log.warning(format_args!(
                    "at t = {t} s the estimated inverse scale factor has no root for a full step in its bracket (non-monotone map): no full steps this move"
                ));
            }
            if s.iterated {
                log.event(format_args!(
                    "control iteration near t = {t} s: {} full step(s) and fraction {:.4}, disturbance estimate {:.4} um",
                    s.n_steps,
                    s.fraction,
                    s.disturbance_estimate * 1e6
                ));
            }
            self.gait_ticked |= c.estimated();
            self.last = Some(s);
        }
        Ok(())
    }

    /// What an event at `t` runs: every write at an instant `<= t` not yet made, then the
    /// latch at `t` if `t` is an instant. Returns the instant of the next event: the write
    /// at s_(ticks+1) when inputs are latched, else the latch at s_ticks.
    fn event(&mut self, t: f64, log: &mut StepLog) -> Result<f64, String> {
        self.advance(t, t, log)?;
        let origin = self.clock.origin.unwrap_or(t);
        let instant = |n: u64| origin + n as f64 * SAMPLE_PERIOD;
        if self.clock.latch.is_none() && same_time(instant(self.clock.ticks), t) {
            self.clock.latch = Some((self.encoder_counts, self.reference));
        }
        Ok(instant(self.clock.ticks + u64::from(self.clock.latch.is_some())))
    }

    /// `read` of the outputs now: the last sample written, read where it lies (a master
    /// reads the three DAC volts every 2 ms, and a `Sample` is some 170 bytes), or the
    /// parked one before the first write.
    fn with_sample<T>(&self, read: impl FnOnce(&Sample) -> T) -> T {
        match &self.last {
            Some(s) => read(s),
            None => read(&self.parked()),
        }
    }

    /// The outputs before the first write: the parked sample, estimates at their start,
    /// the servo error of the inputs latched at s_0 once a step has passed it (so the
    /// outputs hold until s_1), of the current inputs before.
    fn parked(&self) -> Sample {
        let (counts, reference) = self.clock.latch.unwrap_or((self.encoder_counts, self.reference));
        Sample {
            dac: [0.0; 3],
            codes: [0; 3],
            servo_error: reference - f64::from(counts) * self.params.q_enc,
            disturbance_estimate: self.params.disturbance_start,
            step_forward: 0.0,
            step_backward: 0.0,
            n_steps: 0,
            fraction: 0.0,
            scale_weights: self.params.scale_weights_start,
            moving: false,
            iterated: false,
            no_root: false,
        }
    }
}

impl Model for ControllerFmu {
    fn info() -> &'static ModelInfo {
        &table::INFO
    }

    fn table() -> &'static [Row<Self>] {
        &table::TABLE
    }

    fn new() -> Self {
        ControllerFmu {
            params: Params::default(),
            encoder_counts: 0,
            reference: 0.0,
            controller: None,
            last: None,
            clock: Clock::default(),
            gait_ticked: false,
        }
    }

    fn exit_initialization(&mut self, start_time: f64) -> Result<(), String> {
        if self.params.samples_per_step == 0 || self.params.samples_per_step > i32::MAX as u32 {
            return Err(format!(
                "invalid parameter samples_per_step: {}",
                self.params.samples_per_step
            ));
        }
        let c =
            Controller::new(self.params.clone()).map_err(|e| format!("invalid parameter {e}"))?;
        self.controller = Some(c);
        self.clock = Clock { origin: Some(start_time), ticks: 0, latch: None };
        Ok(())
    }

    fn check_step(&self, t: f64, h: f64) -> Result<(), String> {
        self.within_reach(t, t + h)
    }

    fn check_time(&self, t: f64) -> Result<(), String> {
        self.within_reach(t, t)
    }

    fn do_step(&mut self, t: f64, h: f64, log: &mut StepLog) -> Result<(), String> {
        self.advance(t, t + h, log)
    }

    fn model_exchange() -> Option<&'static ModelExchange> {
        static ME: ModelExchange =
            ModelExchange { states: &[], event_indicators: &[], directional_derivatives: false };
        Some(&ME)
    }

    fn update_discrete_states(&mut self, t: f64, log: &mut StepLog) -> Result<EventUpdate, String> {
        let next = self.event(t, log)?;
        Ok(EventUpdate { states_changed: false, next_event_time: Some(next) })
    }

    /// A tick of `sample_clock` (the only input clock) is the event at its time: the
    /// write of the sample from the inputs latched at the tick before, then the latch of
    /// the inputs set for this tick. So the activations at every tick run the instants,
    /// inputs and samples of 2 ms steps, bit for bit.
    fn activate_clock(&mut self, clock: u32, t: f64, log: &mut StepLog) -> Result<(), String> {
        debug_assert_eq!(clock, table::SAMPLE_CLOCK_VR, "the layer activates input clocks only");
        self.event(t, log).map(|_| ())
    }

    fn clear_output_clocks(&mut self) {
        self.gait_ticked = false;
    }

    /// Between ticks the outputs hold: the samples run at the clock's activations.
    fn step_between_ticks(&mut self, _t: f64, _h: f64, _log: &mut StepLog) -> Result<(), String> {
        match self.controller {
            Some(_) => Ok(()),
            None => Err("the controller is not initialized".into()),
        }
    }

    fn save_state(&self, w: &mut Writer) {
        self.save(w)
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.load(bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::state::{CLOCK_BYTES, SAMPLE_BYTES};
    use super::*;

    /// What `do_step(t, k × 2 ms)` must give: k ticks of the controller, all with the
    /// inputs held at t.
    fn former(c: &mut Controller, counts: i32, reference: f64, k: usize) -> Sample {
        (0..k).map(|_| c.tick(i64::from(counts), reference)).last().unwrap()
    }

    /// Whole-sample steps give those k ticks' outputs bit for bit, with the master's time
    /// accumulated as `t += h` (so the instants are met only up to rounding), and leave
    /// nothing latched: a state saved there is at a sample instant.
    #[test]
    fn whole_sample_steps_are_the_former_contract_bit_for_bit() {
        for k in [1, 2, 3, 7] {
            let mut fmu = ControllerFmu::new();
            fmu.reference = 60e-6;
            fmu.exit_initialization(0.0).unwrap();
            let mut c = Controller::new(Params::default()).unwrap();
            let (h, mut t, mut counts, mut moved) = (k as f64 * SAMPLE_PERIOD, 0.0, 0, 0);
            for _ in 0..1200 / k {
                fmu.encoder_counts = counts;
                fmu.do_step(t, h, &mut StepLog::new(false)).unwrap();
                let s = former(&mut c, counts, 60e-6, k);
                assert_eq!(
                    format!("{:?}", fmu.last.unwrap()),
                    format!("{s:?}"),
                    "k = {k}, t = {t}"
                );
                assert_eq!(fmu.clock.latch, None);
                counts += (s.dac[1] > 5.0) as i32 * 2;
                moved += s.moving as usize;
                t += h;
            }
            assert_eq!(fmu.clock.ticks, (1200 / k * k) as u64);
            assert!(moved > 0, "the synthetic loop moved");
        }
    }

    /// A format-1 state (controller marker 1, no clock) restores at a sample instant and
    /// anchors the grid at the next step's t.
    #[test]
    fn a_format_1_state_restores_and_anchors_the_grid_at_the_next_step() {
        let mut a = ControllerFmu::new();
        a.reference = 30e-6;
        a.exit_initialization(0.0).unwrap();
        let mut log = StepLog::new(false);
        for k in 0..40 {
            a.do_step(k as f64 * SAMPLE_PERIOD, SAMPLE_PERIOD, &mut log).unwrap();
        }
        let mut bytes = Vec::new();
        a.save_state(&mut Writer(&mut bytes));
        // Format 1: the same bytes with marker 1 and no clock.
        let at = 17 + SAMPLE_BYTES;
        assert_eq!(bytes[at], 2);
        let mut old = bytes[..at].to_vec();
        old.push(1);
        old.extend_from_slice(&bytes[at + 1 + CLOCK_BYTES..]);
        let mut b = ControllerFmu::new();
        b.load_state(&old).unwrap();
        assert_eq!(b.clock, Clock::default());
        let mut c = ControllerFmu::new();
        c.load_state(&bytes).unwrap();
        assert_eq!(c.clock, a.clock);
        // Half-sample steps from the restored instant: writes at the same instants.
        for k in 0..200 {
            let t = 0.08 + k as f64 * 0.001;
            a.do_step(t, 0.001, &mut log).unwrap();
            b.do_step(t, 0.001, &mut log).unwrap();
            c.do_step(t, 0.001, &mut log).unwrap();
            let s = format!("{:?}", a.last);
            assert_eq!((format!("{:?}", b.last), format!("{:?}", c.last)), (s.clone(), s));
        }
        assert_eq!(b.clock.ticks + 40, a.clock.ticks);
        let mut bad = bytes.clone();
        bad[at] = 3;
        assert_eq!(
            ControllerFmu::new().load_state(&bad),
            Err("controller FMU state: unknown controller marker 3".into())
        );
    }
}
