//! A toy model for the layer's own tests, in the manner of Reference-FMUs' Dahlquist:
//! `dx/dt = u - k x`, one explicit Euler step per communication step, with one variable of
//! every type and role the layer handles, and deliberate failures on chosen inputs (a
//! step refusal, a model failure, a panic) so that every path of the layer is reachable.

use inchworm_fmi_export::{Kind, Model, ModelInfo, Reader, StepLog, Unit, Variable, Writer};

pub const U: u32 = 1;
pub const GAIN: u32 = 2;
pub const HOLD: u32 = 3;
pub const X: u32 = 10;
pub const STEPS: u32 = 11;
pub const POSITIVE: u32 = 12;
pub const K: u32 = 100;
pub const EVENT_EVERY: u32 = 101;
pub const CLAMP_X: u32 = 102;

/// `u` values that make `do_step` fail, or panic.
pub const FAIL: f64 = 7.0;
pub const PANIC: f64 = 6.0;
/// The largest step `check_step` takes.
pub const MAX_STEP: f64 = 1.0;

static VARIABLES: [Variable; 9] = [
    Variable::input("u", U, 0.0, Some("V"), "Drive")
        .with_range(0.0, 10.0)
        .worded("drive volts", "drive range"),
    Variable::integer_input("gain", GAIN, 1, None, "Integer gain on u"),
    Variable::boolean_input("hold", HOLD, false, "Freeze x while true"),
    Variable::output("x", X, Kind::Real, Some("V"), "State"),
    Variable::output("steps", STEPS, Kind::Integer, None, "Steps taken"),
    Variable::output("positive", POSITIVE, Kind::Boolean, None, "x > 0"),
    Variable::parameter("k", K, 1.0, Some("1/s"), "Decay rate, > 0"),
    Variable::integer_parameter(
        "event_every",
        EVENT_EVERY,
        10,
        None,
        "Steps between logged events",
    ),
    Variable::boolean_parameter("clamp_x", CLAMP_X, false, "Clamp x to [-100, 100]"),
];

static INFO: ModelInfo = ModelInfo {
    model_name: "Toy",
    model_identifier: "Toy",
    description: "dx/dt = u - k x",
    version: "1",
    default_start_time: 0.0,
    default_stop_time: 1.0,
    default_step_size: 0.01,
    default_tolerance: 1e-6,
    units: &[
        Unit { name: "V", kg: 1, m: 2, s: -3, a: -1 },
        Unit { name: "1/s", kg: 0, m: 0, s: -1, a: 0 },
    ],
    log_events: "Every event_every steps",
    documentation_html: "<p>Toy</p>",
};

#[derive(Clone, Debug, Default)]
pub struct Toy {
    u: f64,
    gain: i32,
    hold: bool,
    x: f64,
    steps: i32,
    k: f64,
    event_every: i32,
    clamp_x: bool,
}

impl Model for Toy {
    fn info() -> &'static ModelInfo {
        &INFO
    }
    fn variables() -> &'static [Variable] {
        &VARIABLES
    }
    fn new() -> Self {
        Toy { gain: 1, k: 1.0, event_every: 10, ..Toy::default() }
    }
    fn get_real(&self, vr: u32) -> Result<f64, String> {
        match vr {
            U => Ok(self.u),
            X => Ok(self.x),
            K => Ok(self.k),
            _ => Err(format!("no Real {vr}")),
        }
    }
    fn get_integer(&self, vr: u32) -> Result<i32, String> {
        match vr {
            GAIN => Ok(self.gain),
            STEPS => Ok(self.steps),
            EVENT_EVERY => Ok(self.event_every),
            _ => Err(format!("no Integer {vr}")),
        }
    }
    fn get_boolean(&self, vr: u32) -> Result<bool, String> {
        match vr {
            HOLD => Ok(self.hold),
            POSITIVE => Ok(self.x > 0.0),
            CLAMP_X => Ok(self.clamp_x),
            _ => Err(format!("no Boolean {vr}")),
        }
    }
    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), String> {
        match vr {
            U => self.u = value,
            K => self.k = value,
            _ => return Err(format!("no settable Real {vr}")),
        }
        Ok(())
    }
    fn set_integer(&mut self, vr: u32, value: i32) -> Result<(), String> {
        match vr {
            GAIN => self.gain = value,
            EVENT_EVERY => self.event_every = value,
            _ => return Err(format!("no settable Integer {vr}")),
        }
        Ok(())
    }
    fn set_boolean(&mut self, vr: u32, value: bool) -> Result<(), String> {
        match vr {
            HOLD => self.hold = value,
            CLAMP_X => self.clamp_x = value,
            _ => return Err(format!("no settable Boolean {vr}")),
        }
        Ok(())
    }
    fn exit_initialization(&mut self, _start_time: f64) -> Result<(), String> {
        match self.k > 0.0 && self.event_every > 0 {
            true => Ok(()),
            false => {
                Err(format!("k = {} and event_every = {} must be > 0", self.k, self.event_every))
            }
        }
    }
    fn check_step(&self, _t: f64, h: f64) -> Result<(), String> {
        match h <= MAX_STEP {
            true => Ok(()),
            false => Err(format!("step {h} s is longer than {MAX_STEP} s")),
        }
    }
    fn do_step(&mut self, _t: f64, h: f64, log: &mut StepLog) -> Result<(), String> {
        if self.u == PANIC {
            panic!("the toy panics on u = {PANIC}");
        }
        if self.u == FAIL {
            return Err(format!("the toy fails on u = {FAIL}"));
        }
        if !self.hold {
            self.x += h * (f64::from(self.gain) * self.u - self.k * self.x);
        }
        if self.clamp_x {
            self.x = self.x.clamp(-100.0, 100.0);
        }
        self.steps += 1;
        if self.steps % self.event_every == 0 {
            log.event(format_args!("step {}", self.steps));
        }
        if self.x > 9.5 {
            log.warning(format_args!("x = {} is close to its limit", self.x));
        }
        Ok(())
    }
    fn save_state(&self, w: &mut Writer) {
        w.f64(self.u);
        w.f64(f64::from(self.gain));
        w.u8(u8::from(self.hold));
        w.f64(self.x);
        w.f64(f64::from(self.steps));
    }
    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        let mut r = Reader::new(bytes, "toy state");
        self.u = r.f64()?;
        self.gain = r.f64()? as i32;
        self.hold = r.bool()?;
        self.x = r.f64()?;
        self.steps = r.f64()? as i32;
        r.finish()
    }
}
