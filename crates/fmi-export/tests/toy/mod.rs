//! A toy model for the layer's own tests, in the manner of Reference-FMUs' Dahlquist:
//! `dx/dt = u - k x`, one explicit Euler step per communication step, with one variable of
//! every type and role the layer handles, and deliberate failures on chosen inputs (a
//! step refusal, a model failure, a panic) so that every path of the layer is reachable.
//!
//! As Model Exchange it is the same equation with `x` the continuous state, and one event
//! with a jump, like Reference-FMUs' BouncingBall: when `x` rises through [`LEVEL`] (the
//! indicator `x - LEVEL` turns non-negative) the event update resets `x` to 0 and counts
//! the reset in `steps`. [`CsToy`] is the same model without Model Exchange.

/// Runs each generic test of a test file, once per standard.
macro_rules! for_both {
    ($($test:ident),* $(,)?) => {
        mod fmi2 { $( #[test] fn $test() { super::$test::<super::Fmi2>() } )* }
        mod fmi3 { $( #[test] fn $test() { super::$test::<super::Fmi3>() } )* }
    };
}

use inchworm_fmi_export::{
    ContinuousState, EventUpdate, Kind, Model, ModelExchange, ModelInfo, Reader, Row, StepLog,
    Unit, Variable, Writer,
};

pub const U: u32 = 1;
pub const GAIN: u32 = 2;
pub const HOLD: u32 = 3;
pub const X: u32 = 10;
pub const STEPS: u32 = 11;
pub const POSITIVE: u32 = 12;
pub const DER_X: u32 = 13;
pub const ABOVE_LEVEL: u32 = 14;
pub const K: u32 = 100;
pub const EVENT_EVERY: u32 = 101;
pub const CLAMP_X: u32 = 102;

/// `u` values that make `do_step` fail, or panic.
pub const FAIL: f64 = 7.0;
pub const PANIC: f64 = 6.0;
/// The largest step `check_step` takes.
pub const MAX_STEP: f64 = 1.0;
/// Where Model Exchange resets `x`.
pub const LEVEL: f64 = 5.0;
/// The nominal of `x`.
pub const X_NOMINAL: f64 = 2.0;

static ME: ModelExchange = ModelExchange {
    states: &[ContinuousState { value: X, derivative: DER_X, nominal: X_NOMINAL }],
    event_indicators: &[ABOVE_LEVEL],
    directional_derivatives: true,
};

/// The table of `Toy<$me>`: one per type, as a `static` cannot be generic.
macro_rules! toy_table {
    ($me:literal) => {
        impl ToyTable for Toy<$me> {
            fn rows() -> &'static [Row<Self>] {
                static TABLE: [Row<Toy<$me>>; 11] = [
                    Variable::input("u", U, 0.0, Some("V"), "Drive")
                        .with_range(0.0, 10.0)
                        .worded("drive volts", "drive range")
                        .real(|m| m.u, |m, x| m.u = x),
                    Variable::integer_input("gain", GAIN, 1, None, "Integer gain on u")
                        .integer(|m| m.gain, |m, x| m.gain = x),
                    Variable::boolean_input("hold", HOLD, false, "Freeze x while true")
                        .boolean(|m| m.hold, |m, x| m.hold = x),
                    Variable::output("x", X, Kind::Real, Some("V"), "State").real_out(|m| m.x),
                    Variable::output("steps", STEPS, Kind::Integer, None, "Steps taken")
                        .integer_out(|m| m.steps),
                    Variable::output("positive", POSITIVE, Kind::Boolean, None, "x > 0")
                        .boolean_out(|m| m.x > 0.0),
                    Variable::local("der(x)", DER_X, Some("V/s"), "dx/dt")
                        .real_out(|m| m.derivative()),
                    Variable::local(
                        "above_level",
                        ABOVE_LEVEL,
                        Some("V"),
                        "x - LEVEL: the reset's indicator",
                    )
                    .real_out(|m| m.x - LEVEL),
                    Variable::parameter("k", K, 1.0, Some("1/s"), "Decay rate, > 0")
                        .real(|m| m.k, |m, x| m.k = x),
                    Variable::integer_parameter(
                        "event_every",
                        EVENT_EVERY,
                        10,
                        None,
                        "Steps between logged events",
                    )
                    .integer(|m| m.event_every, |m, x| m.event_every = x),
                    Variable::boolean_parameter(
                        "clamp_x",
                        CLAMP_X,
                        false,
                        "Clamp x to [-100, 100]",
                    )
                    .boolean(|m| m.clamp_x, |m, x| m.clamp_x = x),
                ];
                &TABLE
            }
        }
    };
}

pub trait ToyTable: Sized + 'static {
    fn rows() -> &'static [Row<Self>];
}
toy_table!(true);
toy_table!(false);

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
        Unit { name: "V/s", kg: 1, m: 2, s: -4, a: -1 },
    ],
    log_events: "Every event_every steps",
    documentation_html: "<p>Toy</p>",
};

/// The toy; `Toy<false>` declares no Model Exchange interface.
#[derive(Clone, Debug, Default)]
pub struct Toy<const WITH_ME: bool = true> {
    u: f64,
    gain: i32,
    hold: bool,
    x: f64,
    steps: i32,
    k: f64,
    event_every: i32,
    clamp_x: bool,
}

pub type CsToy = Toy<false>;

impl<const WITH_ME: bool> Toy<WITH_ME> {
    fn derivative(&self) -> f64 {
        match self.hold {
            true => 0.0,
            false => f64::from(self.gain) * self.u - self.k * self.x,
        }
    }
    /// The deliberate failures.
    fn check_drive(&self) -> Result<(), String> {
        if self.u == PANIC {
            panic!("the toy panics on u = {PANIC}");
        }
        match self.u == FAIL {
            true => Err(format!("the toy fails on u = {FAIL}")),
            false => Ok(()),
        }
    }
}

impl<const WITH_ME: bool> Model for Toy<WITH_ME>
where
    Toy<WITH_ME>: ToyTable,
{
    fn info() -> &'static ModelInfo {
        &INFO
    }
    fn table() -> &'static [Row<Self>] {
        Self::rows()
    }
    fn new() -> Self {
        Toy { gain: 1, k: 1.0, event_every: 10, ..Toy::default() }
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
        self.check_drive()?;
        self.x += h * self.derivative();
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
    fn model_exchange() -> Option<&'static ModelExchange> {
        WITH_ME.then_some(&ME)
    }
    fn set_continuous_states(&mut self, x: &[f64]) -> Result<(), String> {
        self.x = x[0];
        Ok(())
    }
    fn update_discrete_states(&mut self, t: f64, log: &mut StepLog) -> Result<EventUpdate, String> {
        self.check_drive()?;
        let reset = self.x >= LEVEL;
        if reset {
            self.x = 0.0;
            self.steps += 1;
            log.event(format_args!("reset {} at t = {t}", self.steps));
        }
        Ok(EventUpdate { states_changed: reset, next_event_time: None })
    }
    fn directional_derivative(
        &self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), String> {
        let moving = f64::from(u8::from(!self.hold));
        for (o, &unknown) in out.iter_mut().zip(unknowns) {
            *o = 0.0;
            for (&known, s) in knowns.iter().zip(seed) {
                let partial = match (unknown, known) {
                    (DER_X, X) => -self.k * moving,
                    (DER_X, U) => f64::from(self.gain) * moving,
                    (X | ABOVE_LEVEL, X) => 1.0,
                    (X | ABOVE_LEVEL, U) => 0.0,
                    _ => return Err(format!("no derivative of {unknown} with respect to {known}")),
                };
                *o += partial * s;
            }
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
