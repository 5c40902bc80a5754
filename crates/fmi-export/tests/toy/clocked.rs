//! A clocked toy for the FMI 3.0 clock tests: a periodic input clock `tick` (every
//! [`PERIOD`] s) whose partition adds the clocked input `u` to the clocked output `sum`,
//! and an output clock `third` that ticks at every third activation. Between ticks `x`
//! integrates `u` (`dx/dt = u`), so a step of an instance with event mode still computes.
//! A plain Co-Simulation step (no event mode) runs the partition at every tick in
//! `[t, t + h)`, as a sampled model does inside its step.

use inchworm_fmi_export::{Kind, Model, ModelInfo, Reader, Row, StepLog, Variable, Writer};

pub const TICK: u32 = 20;
pub const THIRD: u32 = 21;
pub const U: u32 = 1;
pub const SUM: u32 = 10;
pub const ACTIVATIONS: u32 = 11;
pub const X: u32 = 12;
/// The input clock's interval.
pub const PERIOD: f64 = 0.1;
/// A `u` that makes the partition fail.
pub const FAIL: f64 = 7.0;

static TABLE: [Row<ClockToy>; 6] = [
    Variable::input("u", U, 0.0, None, "Added to sum at each tick")
        .clocked_by(TICK)
        .real(|m| m.u, |m, x| m.u = x),
    Variable::output("sum", SUM, Kind::Real, None, "Sum of u at the ticks")
        .discrete()
        .clocked_by(TICK)
        .real_out(|m| m.sum),
    Variable::output("activations", ACTIVATIONS, Kind::Integer, None, "Ticks run")
        .clocked_by(TICK)
        .integer_out(|m| m.activations),
    Variable::output("x", X, Kind::Real, None, "Integral of u").real_out(|m| m.x),
    Variable::periodic_clock("tick", TICK, PERIOD, "The sample clock").clock_in(),
    Variable::output_clock("third", THIRD, "Every third tick").clock_out(|m| m.third),
];

static INFO: ModelInfo = ModelInfo {
    model_name: "ClockToy",
    model_identifier: "ClockToy",
    description: "sum += u at every tick",
    version: "1",
    default_start_time: 0.0,
    default_stop_time: 1.0,
    default_step_size: PERIOD,
    default_tolerance: 1e-6,
    units: &[],
    log_events: "Every third tick",
    documentation_html: "<p>ClockToy</p>",
};

#[derive(Clone, Debug, Default)]
pub struct ClockToy {
    u: f64,
    sum: f64,
    activations: i32,
    x: f64,
    third: bool,
    /// Ticks the plain step has run (its grid from t = 0).
    ticks_done: u64,
}

impl ClockToy {
    fn tick(&mut self, t: f64, log: &mut StepLog) -> Result<(), String> {
        if self.u == FAIL {
            return Err(format!("the clocked toy fails on u = {FAIL} at t = {t}"));
        }
        self.sum += self.u;
        self.activations += 1;
        if self.activations % 3 == 0 {
            self.third = true;
            log.event(format_args!("third tick at t = {t}"));
        }
        Ok(())
    }
}

impl Model for ClockToy {
    fn info() -> &'static ModelInfo {
        &INFO
    }
    fn table() -> &'static [Row<Self>] {
        &TABLE
    }
    fn new() -> Self {
        ClockToy::default()
    }
    fn exit_initialization(&mut self, _start_time: f64) -> Result<(), String> {
        Ok(())
    }
    fn do_step(&mut self, t: f64, h: f64, log: &mut StepLog) -> Result<(), String> {
        while (self.ticks_done as f64) * PERIOD < t + h - 1e-12 {
            let at = self.ticks_done as f64 * PERIOD;
            self.tick(at, log)?;
            self.ticks_done += 1;
        }
        self.step_between_ticks(t, h, log)
    }
    fn step_between_ticks(&mut self, _t: f64, h: f64, _log: &mut StepLog) -> Result<(), String> {
        self.x += h * self.u;
        Ok(())
    }
    fn activate_clock(&mut self, clock: u32, t: f64, log: &mut StepLog) -> Result<(), String> {
        assert_eq!(clock, TICK, "only the input clock is activated");
        self.tick(t, log)
    }
    fn clear_output_clocks(&mut self) {
        self.third = false;
    }
    fn save_state(&self, w: &mut Writer) {
        w.f64(self.u);
        w.f64(self.sum);
        w.f64(f64::from(self.activations));
        w.f64(self.x);
    }
    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        let mut r = Reader::new(bytes, "clocked toy state");
        self.u = r.f64()?;
        self.sum = r.f64()?;
        self.activations = r.f64()? as i32;
        self.x = r.f64()?;
        r.finish()
    }
}
