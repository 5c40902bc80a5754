//! The `InchwormPlant` FMU: the plant of docs/model.md §2 behind the FMI 2.0 Co-Simulation
//! interface of docs/model.md §5. This file is the variable table and the mapping of value
//! references onto `inchworm_plant`; all FMI behaviour lives in `inchworm-fmi-export`.

use inchworm_fmi_export::{
    ContinuousState, EventUpdate, Kind, Model, ModelExchange, ModelInfo, Reader, StepLog, Unit,
    Variable, Writer,
};
use inchworm_plant::continuous::{EventBudget, N_INDICATORS, N_STATES};
use inchworm_plant::{Dac, Mode, Outputs, Plant, PlantParams, StepReport, N_PLAYS};

/// Value references. Inputs 1.., outputs 10.., parameters 100.. (play arrays contiguous).
mod vr {
    pub const DAC_EARTH: u32 = 1;
    pub const DAC_NONEARTH: u32 = 2;
    pub const DAC_EXTENSION: u32 = 3;
    pub const ENCODER_COUNTS: u32 = 10;
    pub const ENCODER_POSITION: u32 = 11;
    pub const RUNNER_POSITION: u32 = 12;
    pub const EXTENSION: u32 = 13;
    pub const VOLTAGE_EARTH: u32 = 14;
    pub const VOLTAGE_NONEARTH: u32 = 15;
    pub const VOLTAGE_EXTENSION: u32 = 16;
    pub const MODE: u32 = 17;
    pub const EARTH_CLOSED: u32 = 18;
    pub const NONEARTH_CLOSED: u32 = 19;
    pub const SLIP_EVENTS: u32 = 20;
    pub const M_P: u32 = 100;
    pub const K_P: u32 = 101;
    pub const C_P: u32 = 102;
    pub const M_B: u32 = 103;
    pub const K_F: u32 = 104;
    pub const C_F: u32 = 105;
    pub const M_R: u32 = 106;
    pub const K_E: u32 = 107;
    pub const C_E: u32 = 108;
    pub const L_P: u32 = 109;
    pub const L_R: u32 = 110;
    pub const T_EM: u32 = 111;
    pub const C: u32 = 112;
    pub const PLAY_RADIUS: u32 = 113; // ..=117
    pub const PLAY_WEIGHT: u32 = 118; // ..=122
    pub const F_D0: u32 = 123;
    pub const GAMMA: u32 = 124;
    pub const V_TH: u32 = 125;
    pub const F_BESSEL: u32 = 126;
    pub const AMP_GAIN: u32 = 127;
    pub const F_AMP: u32 = 128;
    pub const Q_ENC: u32 = 129;
    pub const REL_TOL: u32 = 130;
    pub const ENCODER_NOISE: u32 = 131;
    pub const NOISE_SEED: u32 = 132;
    /// Model Exchange: derivatives `DERIVATIVE + i` of the continuous states in order, the
    /// event indicators `INDICATOR + i`.
    pub const DERIVATIVE: u32 = 220;
    pub const INDICATOR: u32 = 240;
}

const V: Option<&str> = Some("V");
const M: Option<&str> = Some("m");

static VARIABLES: [Variable; 81] = [
    Variable::input("dac_earth", vr::DAC_EARTH, 0.0, V, "Earth-brake DAC output, held over the step (0-10 V)").with_range(0.0, 10.0).worded("DAC volts", "DAC range"),
    Variable::input("dac_nonearth", vr::DAC_NONEARTH, 0.0, V, "Non-earth-brake DAC output, held over the step (0-10 V)").with_range(0.0, 10.0).worded("DAC volts", "DAC range"),
    Variable::input("dac_extension", vr::DAC_EXTENSION, 0.0, V, "Extension DAC output, held over the step (0-10 V)").with_range(0.0, 10.0).worded("DAC volts", "DAC range"),
    Variable::output("encoder_counts", vr::ENCODER_COUNTS, Kind::Integer, None, "Encoder reading: round((x4 - L_r)/q_enc), half away from zero"),
    Variable::output("encoder_position", vr::ENCODER_POSITION, Kind::Real, M, "encoder_counts * q_enc"),
    Variable::output("runner_position", vr::RUNNER_POSITION, Kind::Real, M, "True runner position x4 - L_r"),
    Variable::output("extension", vr::EXTENSION, Kind::Real, M, "Extension stack elongation x3 - L_p"),
    Variable::output("voltage_earth", vr::VOLTAGE_EARTH, Kind::Real, V, "Earth-brake PZT voltage after Bessel filter and amplifier"),
    Variable::output("voltage_nonearth", vr::VOLTAGE_NONEARTH, Kind::Real, V, "Non-earth-brake PZT voltage after Bessel filter and amplifier"),
    Variable::output("voltage_extension", vr::VOLTAGE_EXTENSION, Kind::Real, V, "Extension PZT voltage after Bessel filter and amplifier"),
    Variable::output("mode", vr::MODE, Kind::Integer, None, "1 HOLD, 2 LOCKED, 3 DRIVE, 4 FREE"),
    Variable::output("earth_closed", vr::EARTH_CLOSED, Kind::Boolean, None, "Earth brake clamps the runner (voltage_earth < V_th)"),
    Variable::output("nonearth_closed", vr::NONEARTH_CLOSED, Kind::Boolean, None, "Non-earth brake clamps the runner (voltage_nonearth >= V_th)"),
    Variable::output("slip_events", vr::SLIP_EVENTS, Kind::Integer, None, "Entries into FREE (both brakes open: not nominal)"),
    Variable::parameter("m_p", vr::M_P, 0.025, Some("kg"), "Extension PZT mass").with_range(1e-4, 10.0),
    Variable::parameter("k_p", vr::K_P, 3.0e7, Some("N/m"), "Extension PZT short-circuit stiffness").with_range(1e5, 1e10),
    Variable::parameter("c_p", vr::C_P, 15.0, Some("N.s/m"), "Extension PZT damping").with_range(0.0, 1e5),
    Variable::parameter("m_b", vr::M_B, 0.040, Some("kg"), "Non-earth brake mass on node 3").with_range(1e-4, 10.0),
    Variable::parameter("k_f", vr::K_F, 5.0e6, Some("N/m"), "Flexure stiffness").with_range(1000.0, 1e10),
    Variable::parameter("c_f", vr::C_F, 20.0, Some("N.s/m"), "Flexure damping").with_range(0.0, 1e5),
    Variable::parameter("m_r", vr::M_R, 0.150, Some("kg"), "Runner mass").with_range(1e-4, 100.0),
    Variable::parameter("k_e", vr::K_E, 2.0e4, Some("N/m"), "Environment stiffness on the runner").with_range(0.0, 1e9),
    Variable::parameter("c_e", vr::C_E, 10.0, Some("N.s/m"), "Environment damping on the runner").with_range(0.0, 1e5),
    Variable::parameter("L_p", vr::L_P, 0.036, M, "Extension PZT rest length").with_range(1e-4, 1.0),
    Variable::parameter("L_r", vr::L_R, 0.0, M, "Runner rest position").with_range(-1.0, 1.0),
    Variable::parameter("T_em", vr::T_EM, 8.8, Some("N/V"), "Electromechanical transformer ratio").with_range(0.001, 1000.0),
    Variable::parameter("C", vr::C, 4.0e-6, Some("F"), "PZT capacitance").with_range(1e-10, 0.01),
    Variable::parameter("play_radius[1]", vr::PLAY_RADIUS, 15.0, V, "Hysteresis element 1: slip radius of its stop operator (radii strictly increasing)").with_range(0.1, 1000.0).array("Slip radii of the five hysteresis elements' stop operators (strictly increasing)"),
    Variable::parameter("play_radius[2]", vr::PLAY_RADIUS + 1, 30.0, V, "Hysteresis element 2: slip radius").with_range(0.1, 1000.0),
    Variable::parameter("play_radius[3]", vr::PLAY_RADIUS + 2, 45.0, V, "Hysteresis element 3: slip radius").with_range(0.1, 1000.0),
    Variable::parameter("play_radius[4]", vr::PLAY_RADIUS + 3, 60.0, V, "Hysteresis element 4: slip radius").with_range(0.1, 1000.0),
    Variable::parameter("play_radius[5]", vr::PLAY_RADIUS + 4, 75.0, V, "Hysteresis element 5: slip radius").with_range(0.1, 1000.0),
    Variable::parameter("play_weight[1]", vr::PLAY_WEIGHT, 0.08, None, "Hysteresis element 1: weight (capacitance C / weight)").with_range(0.0, 10.0).array("Weights of the five hysteresis elements (capacitance C / weight)"),
    Variable::parameter("play_weight[2]", vr::PLAY_WEIGHT + 1, 0.07, None, "Hysteresis element 2: weight (capacitance C / weight)").with_range(0.0, 10.0),
    Variable::parameter("play_weight[3]", vr::PLAY_WEIGHT + 2, 0.06, None, "Hysteresis element 3: weight (capacitance C / weight)").with_range(0.0, 10.0),
    Variable::parameter("play_weight[4]", vr::PLAY_WEIGHT + 3, 0.05, None, "Hysteresis element 4: weight (capacitance C / weight)").with_range(0.0, 10.0),
    Variable::parameter("play_weight[5]", vr::PLAY_WEIGHT + 4, 0.04, None, "Hysteresis element 5: weight (capacitance C / weight)").with_range(0.0, 10.0),
    Variable::parameter("F_d0", vr::F_D0, 175.0, Some("N"), "Brake disturbance force in DRIVE").with_range(-1e4, 1e4),
    Variable::parameter("gamma", vr::GAMMA, 0.0, None, "Growth of the brake disturbance with environment load").with_range(0.0, 100.0),
    Variable::parameter("V_th", vr::V_TH, 50.0, V, "Brake threshold voltage").with_range(0.001, 1e4),
    Variable::parameter("f_bessel", vr::F_BESSEL, 300.0, Some("Hz"), "Bessel filter -3 dB frequency").with_range(1.0, 1e6),
    Variable::parameter("amp_gain", vr::AMP_GAIN, 10.0, None, "PZT amplifier gain").with_range(0.001, 1000.0),
    Variable::parameter("f_amp", vr::F_AMP, 475.0, Some("Hz"), "PZT amplifier roll-off frequency").with_range(1.0, 1e6),
    Variable::parameter("q_enc", vr::Q_ENC, 1.2e-9, M, "Encoder resolution per count").with_range(1e-12, 0.001),
    Variable::parameter("rel_tol", vr::REL_TOL, 1.0e-9, Some("s"), "Event time resolution: brake switches and hysteresis slip events are located to this time (1e-12..1e-6)").with_range(1e-12, 1e-6),
    Variable::parameter("encoder_noise", vr::ENCODER_NOISE, 0.0, M, "Standard deviation of additive encoder noise (0 = off)").with_range(0.0, 0.001),
    Variable::integer_parameter("noise_seed", vr::NOISE_SEED, 1, None, "Seed of the encoder noise generator"),
    Variable::local("node1_displacement", 200, Some("m"), "Node 1 displacement from rest, x1 - L_p/3 (a continuous state of Model Exchange)"),
    Variable::local("node1_velocity", 201, Some("m/s"), "Node 1 velocity v1 (a continuous state of Model Exchange)"),
    Variable::local("node2_displacement", 202, Some("m"), "Node 2 displacement from rest, x2 - 2 L_p/3 (a continuous state of Model Exchange)"),
    Variable::local("node2_velocity", 203, Some("m/s"), "Node 2 velocity v2 (a continuous state of Model Exchange)"),
    Variable::local("node3_velocity", 204, Some("m/s"), "Node 3 (non-earth brake) velocity v3 (a continuous state of Model Exchange)"),
    Variable::local("runner_velocity", 205, Some("m/s"), "Runner velocity v4 (a continuous state of Model Exchange)"),
    Variable::local("bessel_extension", 206, Some("V"), "Extension channel: Bessel filter output (a continuous state of Model Exchange)"),
    Variable::local("bessel_extension_rate", 207, Some("V/s"), "Extension channel: rate of the Bessel filter output (a continuous state of Model Exchange)"),
    Variable::local("bessel_earth", 208, Some("V"), "Earth channel: Bessel filter output (a continuous state of Model Exchange)"),
    Variable::local("bessel_earth_rate", 209, Some("V/s"), "Earth channel: rate of the Bessel filter output (a continuous state of Model Exchange)"),
    Variable::local("bessel_nonearth", 210, Some("V"), "Non-earth channel: Bessel filter output (a continuous state of Model Exchange)"),
    Variable::local("bessel_nonearth_rate", 211, Some("V/s"), "Non-earth channel: rate of the Bessel filter output (a continuous state of Model Exchange)"),
    Variable::local("der(node1_displacement)", 220, Some("m/s"), "Rate of node1_displacement"),
    Variable::local("der(node1_velocity)", 221, Some("m/s2"), "Rate of node1_velocity"),
    Variable::local("der(node2_displacement)", 222, Some("m/s"), "Rate of node2_displacement"),
    Variable::local("der(node2_velocity)", 223, Some("m/s2"), "Rate of node2_velocity"),
    Variable::local("der(extension)", 224, Some("m/s"), "Rate of extension"),
    Variable::local("der(node3_velocity)", 225, Some("m/s2"), "Rate of node3_velocity"),
    Variable::local("der(runner_position)", 226, Some("m/s"), "Rate of runner_position"),
    Variable::local("der(runner_velocity)", 227, Some("m/s2"), "Rate of runner_velocity"),
    Variable::local("der(bessel_extension)", 228, Some("V/s"), "Rate of bessel_extension"),
    Variable::local("der(bessel_extension_rate)", 229, Some("V/s2"), "Rate of bessel_extension_rate"),
    Variable::local("der(voltage_extension)", 230, Some("V/s"), "Rate of voltage_extension"),
    Variable::local("der(bessel_earth)", 231, Some("V/s"), "Rate of bessel_earth"),
    Variable::local("der(bessel_earth_rate)", 232, Some("V/s2"), "Rate of bessel_earth_rate"),
    Variable::local("der(voltage_earth)", 233, Some("V/s"), "Rate of voltage_earth"),
    Variable::local("der(bessel_nonearth)", 234, Some("V/s"), "Rate of bessel_nonearth"),
    Variable::local("der(bessel_nonearth_rate)", 235, Some("V/s2"), "Rate of bessel_nonearth_rate"),
    Variable::local("der(voltage_nonearth)", 236, Some("V/s"), "Rate of voltage_nonearth"),
    Variable::local("earth_switch", 240, Some("V"), "voltage_earth - V_th: the earth brake switches where it changes sign"),
    Variable::local("nonearth_switch", 241, Some("V"), "voltage_nonearth - V_th: the non-earth brake switches where it changes sign"),
    Variable::local("slip_onset_up", 242, Some("V"), "xi - the next slip onset above: an element starts to slip upward where it reaches 0"),
    Variable::local("slip_onset_down", 243, Some("V"), "The next slip onset below - xi: an element starts to slip downward where it reaches 0"),
    Variable::local("slip_end", 244, Some("V/s"), "-(rate of xi) in the slip direction while elements slip (-1 otherwise): the slip ends where it reaches 0"),
];

/// Model Exchange (docs/model.md §5): the continuous states in the order of
/// `inchworm_plant::continuous` (value references of the states and of their derivatives
/// `der(…)`, 220 + index), and the event indicators, 240 + index.
static ME: ModelExchange = ModelExchange {
    states: &[
        ContinuousState { value: 200, derivative: 220, nominal: 1e-2 },
        ContinuousState { value: 201, derivative: 221, nominal: 10.0 },
        ContinuousState { value: 202, derivative: 222, nominal: 1e-2 },
        ContinuousState { value: 203, derivative: 223, nominal: 10.0 },
        ContinuousState { value: 13, derivative: 224, nominal: 1e-2 },
        ContinuousState { value: 204, derivative: 225, nominal: 10.0 },
        ContinuousState { value: 12, derivative: 226, nominal: 1e-2 },
        ContinuousState { value: 205, derivative: 227, nominal: 10.0 },
        ContinuousState { value: 206, derivative: 228, nominal: 10.0 },
        ContinuousState { value: 207, derivative: 229, nominal: 10000.0 },
        ContinuousState { value: 16, derivative: 230, nominal: 100.0 },
        ContinuousState { value: 208, derivative: 231, nominal: 10.0 },
        ContinuousState { value: 209, derivative: 232, nominal: 10000.0 },
        ContinuousState { value: 14, derivative: 233, nominal: 100.0 },
        ContinuousState { value: 210, derivative: 234, nominal: 10.0 },
        ContinuousState { value: 211, derivative: 235, nominal: 10000.0 },
        ContinuousState { value: 15, derivative: 236, nominal: 100.0 },
    ],
    event_indicators: &[240, 241, 242, 243, 244],
    directional_derivatives: true,
};

static UNITS: [Unit; 14] = [
    Unit { name: "s", kg: 0, m: 0, s: 1, a: 0 },
    Unit { name: "m", kg: 0, m: 1, s: 0, a: 0 },
    Unit { name: "V", kg: 1, m: 2, s: -3, a: -1 },
    Unit { name: "kg", kg: 1, m: 0, s: 0, a: 0 },
    Unit { name: "N", kg: 1, m: 1, s: -2, a: 0 },
    Unit { name: "N/m", kg: 1, m: 0, s: -2, a: 0 },
    Unit { name: "N.s/m", kg: 1, m: 0, s: -1, a: 0 },
    Unit { name: "N/V", kg: 0, m: -1, s: 1, a: 1 },
    Unit { name: "F", kg: -1, m: -2, s: 4, a: 2 },
    Unit { name: "Hz", kg: 0, m: 0, s: -1, a: 0 },
    Unit { name: "m/s", kg: 0, m: 1, s: -1, a: 0 },
    Unit { name: "m/s2", kg: 0, m: 1, s: -2, a: 0 },
    Unit { name: "V/s", kg: 1, m: 2, s: -4, a: -1 },
    Unit { name: "V/s2", kg: 1, m: 2, s: -5, a: -1 },
];

static INFO: ModelInfo = ModelInfo {
    model_name: "InchwormPlant",
    model_identifier: "InchwormPlant",
    description: "JPL flight inchworm actuator: driver-board analog chain, three-element PZT with passive Maxwell-slip hysteresis, brakes with events at V_th, flexure, runner, brake disturbance, 1.2 nm encoder",
    version: env!("CARGO_PKG_VERSION"),
    default_start_time: 0.0,
    default_stop_time: 1.0,
    default_step_size: 0.002,
    default_tolerance: 1e-8,
    units: &UNITS,
    log_events: "Model events: brake switches, mode changes, slips",
    documentation_html: include_str!("plant.html"),
};

/// The FMU's model: parameters and inputs as set by the master, and the plant once
/// initialization has validated the parameters.
#[derive(Clone, Debug)]
pub struct PlantFmu {
    params: PlantParams,
    dac: Dac,
    plant: Option<Plant>,
    /// Model Exchange: the start time and the event updates of the current 2 ms window.
    /// Not part of the FMU state: a restored state starts a fresh window.
    start: f64,
    budget: EventBudget,
}

/// Outputs before the plant exists (instantiated / initialization mode): at rest, docs/model.md §2.7.
const REST: Outputs = Outputs {
    encoder_counts: 0,
    encoder_position: 0.0,
    runner_position: 0.0,
    extension: 0.0,
    voltage_earth: 0.0,
    voltage_nonearth: 0.0,
    voltage_extension: 0.0,
    mode: Mode::Hold,
    earth_closed: true,
    nonearth_closed: false,
    slip_events: 0,
};

impl PlantFmu {
    fn outputs(&self) -> Outputs {
        self.plant.as_ref().map_or(REST, Plant::outputs)
    }

    fn built(&self) -> Result<&Plant, String> {
        self.plant.as_ref().ok_or_else(|| "the plant is built at exit from initialization".into())
    }

    /// A Model Exchange Real: a continuous state (at rest before initialization), its
    /// derivative or an event indicator; `None` for any other reference.
    fn continuous(&self, r: u32) -> Option<Result<f64, String>> {
        if let Some(i) = ME.states.iter().position(|s| s.value == r) {
            let x = self.plant.as_ref().map_or([0.0; N_STATES], Plant::continuous_states);
            return Some(Ok(x[i]));
        }
        let at =
            |base: u32, n: usize| (base..base + n as u32).contains(&r).then(|| (r - base) as usize);
        let plant = self.plant.as_ref();
        let rest = || inchworm_plant::continuous::at_rest(&self.params, self.dac);
        let value = if let Some(i) = at(vr::DERIVATIVE, N_STATES) {
            plant.map_or_else(|| rest().0, |p| p.derivatives(self.dac))[i]
        } else {
            let i = at(vr::INDICATOR, N_INDICATORS)?;
            plant.map_or_else(|| rest().1, Plant::event_indicators)[i]
        };
        Some(match value.is_finite() {
            true => Ok(value),
            false => Err(format!("value reference {r} is not finite ({value}): the state has left what the plant can represent")),
        })
    }

    /// Logs what a step or an event update reported.
    fn report(plant: &Plant, report: &StepReport, before: Mode, log: &mut StepLog) {
        if report.brake_events > 0 {
            log.event(format_args!(
                "{} brake switch(es) in the step ending at t = {} s, first at {:?} s; mode {:?} -> {:?}",
                report.brake_events,
                plant.time(),
                report.first_brake_event,
                before,
                plant.mode()
            ));
        }
        if report.slips > 0 {
            log.warning(format_args!(
                "both brakes open: the runner slipped (FREE entered {} time(s), {} in all) before t = {} s",
                report.slips,
                plant.outputs().slip_events,
                plant.time()
            ));
        }
        if report.event_budget_exhausted {
            log.warning(format_args!("event detection suspended in the step ending at t = {} s: too many events (chattering at a threshold)", plant.time()));
        }
    }
}

/// The input or Real parameter behind a value reference: one mapping serves get and set.
fn real_field<'a>(d: &'a mut Dac, p: &'a mut PlantParams, vr: u32) -> Option<&'a mut f64> {
    Some(match vr {
        vr::DAC_EARTH => &mut d.earth,
        vr::DAC_NONEARTH => &mut d.nonearth,
        vr::DAC_EXTENSION => &mut d.extension,
        vr::M_P => &mut p.m_p,
        vr::K_P => &mut p.k_p,
        vr::C_P => &mut p.c_p,
        vr::M_B => &mut p.m_b,
        vr::K_F => &mut p.k_f,
        vr::C_F => &mut p.c_f,
        vr::M_R => &mut p.m_r,
        vr::K_E => &mut p.k_e,
        vr::C_E => &mut p.c_e,
        vr::L_P => &mut p.l_p,
        vr::L_R => &mut p.l_r,
        vr::T_EM => &mut p.t_em,
        vr::C => &mut p.c,
        r if (vr::PLAY_RADIUS..vr::PLAY_RADIUS + N_PLAYS as u32).contains(&r) => {
            &mut p.play_radius[(r - vr::PLAY_RADIUS) as usize]
        }
        r if (vr::PLAY_WEIGHT..vr::PLAY_WEIGHT + N_PLAYS as u32).contains(&r) => {
            &mut p.play_weight[(r - vr::PLAY_WEIGHT) as usize]
        }
        vr::F_D0 => &mut p.f_d0,
        vr::GAMMA => &mut p.gamma,
        vr::V_TH => &mut p.v_th,
        vr::F_BESSEL => &mut p.f_bessel,
        vr::AMP_GAIN => &mut p.amp_gain,
        vr::F_AMP => &mut p.f_amp,
        vr::Q_ENC => &mut p.q_enc,
        vr::REL_TOL => &mut p.rel_tol,
        vr::ENCODER_NOISE => &mut p.encoder_noise,
        _ => return None,
    })
}

impl Model for PlantFmu {
    fn info() -> &'static ModelInfo {
        &INFO
    }

    fn variables() -> &'static [Variable] {
        &VARIABLES
    }

    fn new() -> Self {
        PlantFmu {
            params: PlantParams::fia20(),
            dac: Dac::default(),
            plant: None,
            start: 0.0,
            budget: EventBudget::default(),
        }
    }

    fn get_real(&self, r: u32) -> Result<f64, String> {
        if let Some(v) = self.continuous(r) {
            return v;
        }
        let o = self.outputs();
        Ok(match r {
            vr::ENCODER_POSITION => o.encoder_position,
            vr::RUNNER_POSITION => o.runner_position,
            vr::EXTENSION => o.extension,
            vr::VOLTAGE_EARTH => o.voltage_earth,
            vr::VOLTAGE_NONEARTH => o.voltage_nonearth,
            vr::VOLTAGE_EXTENSION => o.voltage_extension,
            _ => *real_field(&mut self.dac.clone(), &mut self.params.clone(), r)
                .ok_or_else(|| format!("no Real variable with value reference {r}"))?,
        })
    }

    fn get_integer(&self, r: u32) -> Result<i32, String> {
        let o = self.outputs();
        match r {
            // The encoder is a 32-bit counter on the board: ±2.5 m at 1.2 nm, far beyond
            // the stroke, so saturation here only guards nonsense parameters.
            vr::ENCODER_COUNTS => {
                Ok(o.encoder_counts.clamp(i32::MIN as i64, i32::MAX as i64) as i32)
            }
            vr::MODE => Ok(o.mode as i32),
            vr::SLIP_EVENTS => Ok(o.slip_events.min(i32::MAX as u32) as i32),
            vr::NOISE_SEED => Ok(self.params.noise_seed as i32),
            _ => Err(format!("no Integer variable with value reference {r}")),
        }
    }

    fn get_boolean(&self, r: u32) -> Result<bool, String> {
        let o = self.outputs();
        match r {
            vr::EARTH_CLOSED => Ok(o.earth_closed),
            vr::NONEARTH_CLOSED => Ok(o.nonearth_closed),
            _ => Err(format!("no Boolean variable with value reference {r}")),
        }
    }

    fn set_real(&mut self, r: u32, value: f64) -> Result<(), String> {
        // Parameters are validated as a whole at fmi2ExitInitializationMode, where the
        // relations between them (sorted play radii) can be checked.
        *real_field(&mut self.dac, &mut self.params, r)
            .ok_or_else(|| format!("no settable Real with value reference {r}"))? = value;
        Ok(())
    }

    fn set_integer(&mut self, r: u32, value: i32) -> Result<(), String> {
        match r {
            vr::NOISE_SEED => self.params.noise_seed = value as u32 as u64,
            _ => return Err(format!("no settable Integer with value reference {r}")),
        }
        Ok(())
    }

    fn set_boolean(&mut self, r: u32, _value: bool) -> Result<(), String> {
        Err(format!("no settable Boolean with value reference {r}"))
    }

    fn exit_initialization(&mut self, start_time: f64) -> Result<(), String> {
        let plant = Plant::new(self.params.clone()).map_err(|e| format!("invalid {e}"))?;
        self.plant = Some(plant);
        (self.start, self.budget) = (start_time, EventBudget::default());
        Ok(())
    }

    fn do_step(&mut self, _t: f64, h: f64, log: &mut StepLog) -> Result<(), String> {
        let plant = self.plant.as_mut().ok_or("the plant is not initialized")?;
        let before = plant.mode();
        let report = plant.step(self.dac, h).map_err(|e| e.to_string())?;
        PlantFmu::report(plant, &report, before, log);
        Ok(())
    }

    fn model_exchange() -> Option<&'static ModelExchange> {
        Some(&ME)
    }

    fn set_continuous_states(&mut self, x: &[f64]) -> Result<(), String> {
        let plant = self.plant.as_mut().ok_or("the plant is not initialized")?;
        let x: &[f64; N_STATES] = x.try_into().map_err(|_| "wrong number of states")?;
        plant.set_continuous_states(x);
        Ok(())
    }

    fn update_discrete_states(&mut self, t: f64, log: &mut StepLog) -> Result<EventUpdate, String> {
        let plant = self.plant.as_mut().ok_or("the plant is not initialized")?;
        self.budget.spend(t, self.start)?;
        let before = plant.mode();
        let event = plant.event_update(self.dac, t);
        PlantFmu::report(plant, &event.step, before, log);
        Ok(EventUpdate { states_changed: event.states_changed, next_event_time: None })
    }

    fn directional_derivative(
        &self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), String> {
        let j = self.built()?.jacobian();
        let state = |r: u32| ME.states.iter().position(|s| s.value == r);
        let input = |r: u32| {
            [vr::DAC_EXTENSION, vr::DAC_EARTH, vr::DAC_NONEARTH].iter().position(|&d| d == r)
        };
        for (o, &u) in out.iter_mut().zip(unknowns) {
            let derivative = (vr::DERIVATIVE..vr::DERIVATIVE + N_STATES as u32)
                .contains(&u)
                .then(|| (u - vr::DERIVATIVE) as usize);
            *o = 0.0;
            for (&k, s) in knowns.iter().zip(seed) {
                let partial = match (derivative, state(u), state(k), input(k)) {
                    (Some(i), _, Some(c), _) => j.states[(i, c)],
                    (Some(i), _, _, Some(c)) => j.inputs[(i, c)],
                    (None, Some(i), Some(c), _) => f64::from(u8::from(i == c)),
                    (None, Some(_), _, Some(_)) => 0.0,
                    _ => return Err(format!("no directional derivative of value reference {u} with respect to {k} (unknowns: state derivatives and continuous states; knowns: continuous states and DAC inputs)")),
                };
                *o += partial * s;
            }
        }
        Ok(())
    }

    fn save_state(&self, w: &mut Writer) {
        for x in [self.dac.earth, self.dac.nonearth, self.dac.extension] {
            w.f64(x);
        }
        w.u8(u8::from(self.plant.is_some()));
        if let Some(p) = &self.plant {
            p.save_state(w.0);
        }
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        // Three DAC volts and the plant marker, then the plant's own bytes.
        let (head, plant) = bytes.split_at_checked(25).ok_or("plant FMU state truncated")?;
        let mut r = Reader::new(head, "plant FMU state");
        self.dac = Dac { earth: r.f64()?, nonearth: r.f64()?, extension: r.f64()? };
        if r.bool()? {
            let mut p =
                Plant::new(self.params.clone()).map_err(|e| format!("state holds invalid {e}"))?;
            p.load_state(plant)?;
            self.plant = Some(p);
        } else if !plant.is_empty() {
            return Err("plant FMU state: trailing bytes after an uninitialized plant".into());
        }
        self.budget = EventBudget::default();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use inchworm_fmi_export::{Causality, Start};

    /// The table is the FMU's public description; the plant crate holds the defaults and the
    /// ranges. Every parameter's start and min/max must be the plant's own.
    #[test]
    fn parameter_starts_and_ranges_are_the_plant_crates() {
        let fmu = PlantFmu::new();
        let mut checked = 0;
        for v in VARIABLES.iter().filter(|v| v.causality == Causality::Parameter) {
            let base = v.name.split('[').next().unwrap();
            match v.start {
                Start::Real(start) => {
                    assert_eq!(start, fmu.get_real(v.vr).unwrap(), "{}: start", v.name);
                    let (lo, hi, _) = inchworm_plant::params::range(base)
                        .unwrap_or_else(|| panic!("{} has no range in the plant crate", v.name));
                    assert_eq!((v.min, v.max), (Some(lo), Some(hi)), "{}: range", v.name);
                    checked += 1;
                }
                Start::Integer(start) => {
                    assert_eq!(start, fmu.get_integer(v.vr).unwrap(), "{}: start", v.name)
                }
                _ => panic!("{}: unexpected start {:?}", v.name, v.start),
            }
        }
        assert_eq!(checked, 32);
    }
}
