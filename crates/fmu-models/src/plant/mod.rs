//! The `InchwormPlant` and `InchwormPlantFull` FMUs: the plant of docs/model.md §2 behind the
//! Co-Simulation and Model Exchange interfaces of docs/model.md §5. Both share this file's
//! variable rows, Co-Simulation (the exact solver, bit for bit the same) and the mapping of
//! value references onto `inchworm_plant`; they differ in the formulation a Model Exchange
//! master integrates ([`Formulation`]): `InchwormPlant` the reduced one of 11 states
//! (docs/model.md §5.1, [`reduced`]), `InchwormPlantFull` the model's 17 ([`full`]). All FMI
//! behaviour lives in `inchworm-fmi-export`.

mod full;
mod reduced;

use inchworm_fmi_export::{
    ContinuousState, EventUpdate, Model, ModelExchange, ModelInfo, Reader, Row, StepLog, Unit,
    Writer,
};
use inchworm_plant::continuous::{EventBudget, EventReport, Jacobian};
use inchworm_plant::{Dac, Mode, Outputs, Plant, PlantParams, StepReport};

pub use full::PlantFullFmu;
pub use reduced::PlantFmu;

/// The rows both FMUs have, with the rows of a formulation's continuous states and of
/// their derivatives in between. Value references: inputs 1.., outputs 10.., parameters
/// 100.. (arrays contiguous), the model's continuous states 200.., their derivatives
/// 220.. (the order of `inchworm_plant::continuous`), the event indicators 240.. The names
/// the rows use (`Variable`, `Kind`, `M`, `V`, the board's constants) resolve where it is
/// invoked.
macro_rules! plant_table {
    ($model:ty; states { $($sid:ident: $srow:expr),* $(,)? } derivatives { $($did:ident: $drow:expr),* $(,)? }) => {
        #[rustfmt::skip]
        inchworm_fmi_export::table!($model, TABLE;
        DAC_EARTH: Variable::input("dac_earth", 1, 0.0, V, "Earth-brake DAC output, held over the step (0-10 V)").with_range(0.0, DAC_FULL_SCALE).worded("DAC volts", "DAC range").real(|m| m.dac.earth, |m, x| m.dac.earth = x),
        DAC_NONEARTH: Variable::input("dac_nonearth", 2, 0.0, V, "Non-earth-brake DAC output, held over the step (0-10 V)").with_range(0.0, DAC_FULL_SCALE).worded("DAC volts", "DAC range").real(|m| m.dac.nonearth, |m, x| m.dac.nonearth = x),
        DAC_EXTENSION: Variable::input("dac_extension", 3, 0.0, V, "Extension DAC output, held over the step (0-10 V)").with_range(0.0, DAC_FULL_SCALE).worded("DAC volts", "DAC range").real(|m| m.dac.extension, |m, x| m.dac.extension = x),
        ENCODER_COUNTS: Variable::output("encoder_counts", 10, Kind::Integer, None, "Encoder reading: round((x4 - L_r)/q_enc), half away from zero").integer_out(|m| m.outputs().encoder_counts.clamp(i32::MIN as i64, i32::MAX as i64) as i32),
        ENCODER_POSITION: Variable::output("encoder_position", 11, Kind::Real, M, "encoder_counts * q_enc").real_out(|m| m.outputs().encoder_position),
        RUNNER_POSITION: Variable::output("runner_position", 12, Kind::Real, M, "True runner position x4 - L_r").real_out(|m| m.state(6)),
        EXTENSION: Variable::output("extension", 13, Kind::Real, M, "Extension stack elongation x3 - L_p").real_out(|m| m.state(4)),
        VOLTAGE_EARTH: Variable::output("voltage_earth", 14, Kind::Real, V, "Earth-brake PZT voltage after Bessel filter and amplifier").real_out(|m| m.state(13)),
        VOLTAGE_NONEARTH: Variable::output("voltage_nonearth", 15, Kind::Real, V, "Non-earth-brake PZT voltage after Bessel filter and amplifier").real_out(|m| m.state(16)),
        VOLTAGE_EXTENSION: Variable::output("voltage_extension", 16, Kind::Real, V, "Extension PZT voltage after Bessel filter and amplifier").real_out(|m| m.state(10)),
        MODE: Variable::output("mode", 17, Kind::Integer, None, "1 HOLD, 2 LOCKED, 3 DRIVE, 4 FREE").integer_out(|m| m.outputs().mode as i32),
        EARTH_CLOSED: Variable::output("earth_closed", 18, Kind::Boolean, None, "Earth brake clamps the runner (voltage_earth < V_th)").boolean_out(|m| m.outputs().earth_closed),
        NONEARTH_CLOSED: Variable::output("nonearth_closed", 19, Kind::Boolean, None, "Non-earth brake clamps the runner (voltage_nonearth >= V_th)").boolean_out(|m| m.outputs().nonearth_closed),
        SLIP_EVENTS: Variable::output("slip_events", 20, Kind::Integer, None, "Entries into FREE (both brakes open: not nominal)").integer_out(|m| m.outputs().slip_events.min(i32::MAX as u32) as i32),
        M_P: Variable::parameter("m_p", 100, 0.025, Some("kg"), "Extension PZT mass").with_range(1e-4, 10.0).real(|m| m.params.m_p, |m, x| m.params.m_p = x),
        K_P: Variable::parameter("k_p", 101, 3.0e7, Some("N/m"), "Extension PZT short-circuit stiffness").with_range(1e5, 1e10).real(|m| m.params.k_p, |m, x| m.params.k_p = x),
        C_P: Variable::parameter("c_p", 102, 15.0, Some("N.s/m"), "Extension PZT damping").with_range(0.0, 1e5).real(|m| m.params.c_p, |m, x| m.params.c_p = x),
        M_B: Variable::parameter("m_b", 103, 0.040, Some("kg"), "Non-earth brake mass on node 3").with_range(1e-4, 10.0).real(|m| m.params.m_b, |m, x| m.params.m_b = x),
        K_F: Variable::parameter("k_f", 104, 5.0e6, Some("N/m"), "Flexure stiffness").with_range(1000.0, 1e10).real(|m| m.params.k_f, |m, x| m.params.k_f = x),
        C_F: Variable::parameter("c_f", 105, 20.0, Some("N.s/m"), "Flexure damping").with_range(0.0, 1e5).real(|m| m.params.c_f, |m, x| m.params.c_f = x),
        M_R: Variable::parameter("m_r", 106, 0.150, Some("kg"), "Runner mass").with_range(1e-4, 100.0).real(|m| m.params.m_r, |m, x| m.params.m_r = x),
        K_E: Variable::parameter("k_e", 107, 2.0e4, Some("N/m"), "Environment stiffness on the runner").with_range(0.0, 1e9).real(|m| m.params.k_e, |m, x| m.params.k_e = x),
        C_E: Variable::parameter("c_e", 108, 10.0, Some("N.s/m"), "Environment damping on the runner").with_range(0.0, 1e5).real(|m| m.params.c_e, |m, x| m.params.c_e = x),
        L_P: Variable::parameter("L_p", 109, 0.036, M, "Extension PZT rest length").with_range(1e-4, 1.0).real(|m| m.params.l_p, |m, x| m.params.l_p = x),
        L_R: Variable::parameter("L_r", 110, 0.0, M, "Runner rest position").with_range(-1.0, 1.0).real(|m| m.params.l_r, |m, x| m.params.l_r = x),
        T_EM: Variable::parameter("T_em", 111, 8.8, Some("N/V"), "Electromechanical transformer ratio").with_range(0.001, 1000.0).real(|m| m.params.t_em, |m, x| m.params.t_em = x),
        C: Variable::parameter("C", 112, 4.0e-6, Some("F"), "PZT capacitance").with_range(1e-10, 0.01).real(|m| m.params.c, |m, x| m.params.c = x),
        PLAY_RADIUS_1: Variable::parameter("play_radius[1]", 113, 15.0, V, "Hysteresis element 1: slip radius of its stop operator (radii strictly increasing)").with_range(0.1, 1000.0).array("Slip radii of the five hysteresis elements' stop operators (strictly increasing)").real(|m| m.params.play_radius[0], |m, x| m.params.play_radius[0] = x),
        PLAY_RADIUS_2: Variable::parameter("play_radius[2]", 114, 30.0, V, "Hysteresis element 2: slip radius").with_range(0.1, 1000.0).real(|m| m.params.play_radius[1], |m, x| m.params.play_radius[1] = x),
        PLAY_RADIUS_3: Variable::parameter("play_radius[3]", 115, 45.0, V, "Hysteresis element 3: slip radius").with_range(0.1, 1000.0).real(|m| m.params.play_radius[2], |m, x| m.params.play_radius[2] = x),
        PLAY_RADIUS_4: Variable::parameter("play_radius[4]", 116, 60.0, V, "Hysteresis element 4: slip radius").with_range(0.1, 1000.0).real(|m| m.params.play_radius[3], |m, x| m.params.play_radius[3] = x),
        PLAY_RADIUS_5: Variable::parameter("play_radius[5]", 117, 75.0, V, "Hysteresis element 5: slip radius").with_range(0.1, 1000.0).real(|m| m.params.play_radius[4], |m, x| m.params.play_radius[4] = x),
        PLAY_WEIGHT_1: Variable::parameter("play_weight[1]", 118, 0.08, None, "Hysteresis element 1: weight (capacitance C / weight)").with_range(0.0, 10.0).array("Weights of the five hysteresis elements (capacitance C / weight)").real(|m| m.params.play_weight[0], |m, x| m.params.play_weight[0] = x),
        PLAY_WEIGHT_2: Variable::parameter("play_weight[2]", 119, 0.07, None, "Hysteresis element 2: weight (capacitance C / weight)").with_range(0.0, 10.0).real(|m| m.params.play_weight[1], |m, x| m.params.play_weight[1] = x),
        PLAY_WEIGHT_3: Variable::parameter("play_weight[3]", 120, 0.06, None, "Hysteresis element 3: weight (capacitance C / weight)").with_range(0.0, 10.0).real(|m| m.params.play_weight[2], |m, x| m.params.play_weight[2] = x),
        PLAY_WEIGHT_4: Variable::parameter("play_weight[4]", 121, 0.05, None, "Hysteresis element 4: weight (capacitance C / weight)").with_range(0.0, 10.0).real(|m| m.params.play_weight[3], |m, x| m.params.play_weight[3] = x),
        PLAY_WEIGHT_5: Variable::parameter("play_weight[5]", 122, 0.04, None, "Hysteresis element 5: weight (capacitance C / weight)").with_range(0.0, 10.0).real(|m| m.params.play_weight[4], |m, x| m.params.play_weight[4] = x),
        F_D0: Variable::parameter("F_d0", 123, 175.0, Some("N"), "Brake disturbance force in DRIVE").with_range(-1e4, 1e4).real(|m| m.params.f_d0, |m, x| m.params.f_d0 = x),
        GAMMA: Variable::parameter("gamma", 124, 0.0, None, "Growth of the brake disturbance with environment load").with_range(0.0, 100.0).real(|m| m.params.gamma, |m, x| m.params.gamma = x),
        V_TH: Variable::parameter("V_th", 125, 50.0, V, "Brake threshold voltage").with_range(0.001, 1e4).real(|m| m.params.v_th, |m, x| m.params.v_th = x),
        F_BESSEL: Variable::parameter("f_bessel", 126, 300.0, Some("Hz"), "Bessel filter -3 dB frequency").with_range(1.0, 1e6).real(|m| m.params.f_bessel, |m, x| m.params.f_bessel = x),
        AMP_GAIN: Variable::parameter("amp_gain", 127, 10.0, None, "PZT amplifier gain").with_range(0.001, 1000.0).real(|m| m.params.amp_gain, |m, x| m.params.amp_gain = x),
        F_AMP: Variable::parameter("f_amp", 128, 475.0, Some("Hz"), "PZT amplifier roll-off frequency").with_range(1.0, 1e6).real(|m| m.params.f_amp, |m, x| m.params.f_amp = x),
        Q_ENC: Variable::parameter("q_enc", 129, ENCODER_RESOLUTION, M, "Encoder resolution per count").with_range(1e-12, 0.001).real(|m| m.params.q_enc, |m, x| m.params.q_enc = x),
        REL_TOL: Variable::parameter("rel_tol", 130, 1.0e-9, Some("s"), "Event time resolution: brake switches and hysteresis slip events are located to this time (1e-12..1e-6)").with_range(1e-12, 1e-6).real(|m| m.params.rel_tol, |m, x| m.params.rel_tol = x),
        ENCODER_NOISE: Variable::parameter("encoder_noise", 131, 0.0, M, "Standard deviation of additive encoder noise (0 = off)").with_range(0.0, 0.001).real(|m| m.params.encoder_noise, |m, x| m.params.encoder_noise = x),
        NOISE_SEED: Variable::integer_parameter("noise_seed", 132, 1, None, "Seed of the encoder noise generator").integer(|m| m.params.noise_seed as i32, |m, x| m.params.noise_seed = x as u32 as u64),
        NODE1_DISPLACEMENT: Variable::local("node1_displacement", 200, Some("m"), "Node 1 displacement from rest, x1 - L_p/3 (a continuous state of the model's formulation)").real_out(|m| m.state(0)),
        NODE1_VELOCITY: Variable::local("node1_velocity", 201, Some("m/s"), "Node 1 velocity v1 (a continuous state of the model's formulation)").real_out(|m| m.state(1)),
        NODE2_DISPLACEMENT: Variable::local("node2_displacement", 202, Some("m"), "Node 2 displacement from rest, x2 - 2 L_p/3 (a continuous state of the model's formulation)").real_out(|m| m.state(2)),
        NODE2_VELOCITY: Variable::local("node2_velocity", 203, Some("m/s"), "Node 2 velocity v2 (a continuous state of the model's formulation)").real_out(|m| m.state(3)),
        NODE3_VELOCITY: Variable::local("node3_velocity", 204, Some("m/s"), "Node 3 (non-earth brake) velocity v3 (a continuous state of the model's formulation)").real_out(|m| m.state(5)),
        RUNNER_VELOCITY: Variable::local("runner_velocity", 205, Some("m/s"), "Runner velocity v4 (a continuous state of the model's formulation)").real_out(|m| m.state(7)),
        BESSEL_EXTENSION: Variable::local("bessel_extension", 206, Some("V"), "Extension channel: Bessel filter output (a continuous state of both formulations)").real_out(|m| m.state(8)),
        BESSEL_EXTENSION_RATE: Variable::local("bessel_extension_rate", 207, Some("V/s"), "Extension channel: rate of the Bessel filter output (a continuous state of both formulations)").real_out(|m| m.state(9)),
        BESSEL_EARTH: Variable::local("bessel_earth", 208, Some("V"), "Earth channel: Bessel filter output (a continuous state of both formulations)").real_out(|m| m.state(11)),
        BESSEL_EARTH_RATE: Variable::local("bessel_earth_rate", 209, Some("V/s"), "Earth channel: rate of the Bessel filter output (a continuous state of both formulations)").real_out(|m| m.state(12)),
        BESSEL_NONEARTH: Variable::local("bessel_nonearth", 210, Some("V"), "Non-earth channel: Bessel filter output (a continuous state of both formulations)").real_out(|m| m.state(14)),
        BESSEL_NONEARTH_RATE: Variable::local("bessel_nonearth_rate", 211, Some("V/s"), "Non-earth channel: rate of the Bessel filter output (a continuous state of both formulations)").real_out(|m| m.state(15)),
            $($sid: $srow,)*
            $($did: $drow,)*
        DER_BESSEL_EXTENSION: Variable::local("der(bessel_extension)", 228, Some("V/s"), "Rate of bessel_extension").real_out(|m| m.me_rate(8)),
        DER_BESSEL_EXTENSION_RATE: Variable::local("der(bessel_extension_rate)", 229, Some("V/s2"), "Rate of bessel_extension_rate").real_out(|m| m.me_rate(9)),
        DER_VOLTAGE_EXTENSION: Variable::local("der(voltage_extension)", 230, Some("V/s"), "Rate of voltage_extension").real_out(|m| m.me_rate(10)),
        DER_BESSEL_EARTH: Variable::local("der(bessel_earth)", 231, Some("V/s"), "Rate of bessel_earth").real_out(|m| m.me_rate(11)),
        DER_BESSEL_EARTH_RATE: Variable::local("der(bessel_earth_rate)", 232, Some("V/s2"), "Rate of bessel_earth_rate").real_out(|m| m.me_rate(12)),
        DER_VOLTAGE_EARTH: Variable::local("der(voltage_earth)", 233, Some("V/s"), "Rate of voltage_earth").real_out(|m| m.me_rate(13)),
        DER_BESSEL_NONEARTH: Variable::local("der(bessel_nonearth)", 234, Some("V/s"), "Rate of bessel_nonearth").real_out(|m| m.me_rate(14)),
        DER_BESSEL_NONEARTH_RATE: Variable::local("der(bessel_nonearth_rate)", 235, Some("V/s2"), "Rate of bessel_nonearth_rate").real_out(|m| m.me_rate(15)),
        DER_VOLTAGE_NONEARTH: Variable::local("der(voltage_nonearth)", 236, Some("V/s"), "Rate of voltage_nonearth").real_out(|m| m.me_rate(16)),
        EARTH_SWITCH: Variable::local("earth_switch", 240, Some("V"), "voltage_earth - V_th: the earth brake switches where it changes sign").real_out(|m| m.indicator(0)),
        NONEARTH_SWITCH: Variable::local("nonearth_switch", 241, Some("V"), "voltage_nonearth - V_th: the non-earth brake switches where it changes sign").real_out(|m| m.indicator(1)),
        SLIP_ONSET_UP: Variable::local("slip_onset_up", 242, Some("V"), "xi - the next slip onset above: an element starts to slip upward where it reaches 0").real_out(|m| m.indicator(2)),
        SLIP_ONSET_DOWN: Variable::local("slip_onset_down", 243, Some("V"), "The next slip onset below - xi: an element starts to slip downward where it reaches 0").real_out(|m| m.indicator(3)),
        SLIP_END: Variable::local("slip_end", 244, Some("V/s"), "-(rate of xi) in the slip direction while elements slip (-1 otherwise): the slip ends where it reaches 0").real_out(|m| m.indicator(4)),
        );
    };
}
use plant_table;

const V: Option<&str> = Some("V");
const M: Option<&str> = Some("m");

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

/// Everything of the FMUs' descriptions but their names and Model Exchange.
const INFO: ModelInfo = ModelInfo {
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
    documentation_html: include_str!("../plant.html"),
};

/// The channels' continuous states, the last nine of both formulations: the extension, earth
/// and non-earth channels, each its Bessel output, its rate and the amplifier volts (value
/// references of the states; of their derivatives, 220 + the model's index).
const CHANNELS: [ContinuousState; 9] = [
    ContinuousState { value: 206, derivative: 228, nominal: 10.0 },
    ContinuousState { value: 207, derivative: 229, nominal: 10000.0 },
    ContinuousState { value: 16, derivative: 230, nominal: 100.0 },
    ContinuousState { value: 208, derivative: 231, nominal: 10.0 },
    ContinuousState { value: 209, derivative: 232, nominal: 10000.0 },
    ContinuousState { value: 14, derivative: 233, nominal: 100.0 },
    ContinuousState { value: 210, derivative: 234, nominal: 10.0 },
    ContinuousState { value: 211, derivative: 235, nominal: 10000.0 },
    ContinuousState { value: 15, derivative: 236, nominal: 100.0 },
];

/// The plant as a Model Exchange master integrates it: the formulation's continuous states,
/// their rates and the events, over the [`Plant`] that holds the physical state. Its
/// states are the model's from index [`Formulation::FIRST`] on (the reduced formulation's
/// runner states are the slow parts of the model's).
pub trait Formulation: Clone + std::fmt::Debug + Send + Sized + 'static {
    /// The model's index (`inchworm_plant::continuous`) of the formulation's first state.
    const FIRST: usize;
    fn info() -> &'static ModelInfo;
    fn table() -> &'static [Row<PlantModel<Self>>];
    fn model_exchange() -> &'static ModelExchange;
    /// The formulation of `plant`'s state at the plant's time.
    fn build(plant: Plant) -> Result<Self, String>;
    /// The plant holding the physical state at the master's time.
    fn plant(&self) -> &Plant;
    fn set_time(&mut self, t: f64);
    fn continuous_state(&self, i: usize) -> f64;
    fn set_continuous_states(&mut self, x: &[f64]) -> Result<(), String>;
    /// The rate of continuous state `i` with `dac` held.
    fn derivative(&self, dac: Dac, i: usize) -> f64;
    /// The same before the plant is built: at rest (docs/model.md §2.7).
    fn derivative_at_rest(p: &PlantParams, dac: Dac, i: usize) -> f64;
    fn event_update(&mut self, dac: Dac, t: f64) -> EventReport;
    /// The directional derivatives of [`Model::directional_derivative`], through
    /// [`directional`] with the formulation's exact Jacobian.
    fn directional(
        &self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), String>;
    fn save_state(&self, out: &mut Vec<u8>);
    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String>;
}

/// What initialization has built: nothing yet, the exact solver's plant (Co-Simulation) or
/// the formulation (Model Exchange). Co-Simulation never builds the formulation.
///
/// One per instance, so the size of the empty variant is no waste worth a box (an
/// indirection on every Co-Simulation step).
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
enum Built<F> {
    Not,
    Cs(Plant),
    Me(F),
}

/// An FMU's model: parameters and inputs as set by the master, and the plant once
/// initialization has validated the parameters.
#[derive(Clone, Debug)]
pub struct PlantModel<F> {
    params: PlantParams,
    dac: Dac,
    built: Built<F>,
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

/// The first byte of the model's state after the DAC volts: what was built.
const NOT_BUILT: u8 = 0;
const CS_BUILT: u8 = 1;
const ME_BUILT: u8 = 2;

impl<F: Formulation> PlantModel<F> {
    /// A model that will run `params` (validated at initialization, as a master's).
    pub fn with_params(params: PlantParams) -> Self {
        PlantModel { params, ..Model::new() }
    }

    /// The plant holding the physical state, once built.
    fn physical(&self) -> Option<&Plant> {
        match &self.built {
            Built::Not => None,
            Built::Cs(p) => Some(p),
            Built::Me(f) => Some(f.plant()),
        }
    }

    fn outputs(&self) -> Outputs {
        self.physical().map_or(REST, Plant::outputs)
    }

    /// The model's continuous state `k` (at rest before initialization).
    fn state(&self, k: usize) -> f64 {
        self.physical().map_or(0.0, |p| p.continuous_states()[k])
    }

    /// The formulation's continuous state that stands for the model's state `k`: under
    /// Co-Simulation, which integrates no formulation, the model's state itself.
    fn me_state(&self, k: usize) -> f64 {
        match &self.built {
            Built::Me(f) => f.continuous_state(k - F::FIRST),
            _ => self.state(k),
        }
    }

    /// The rate of [`PlantModel::me_state`]`(k)`; under Co-Simulation the model's.
    fn me_rate(&self, k: usize) -> f64 {
        match &self.built {
            Built::Me(f) => f.derivative(self.dac, k - F::FIRST),
            Built::Cs(p) => p.derivatives(self.dac)[k],
            Built::Not => F::derivative_at_rest(&self.params, self.dac, k - F::FIRST),
        }
    }

    /// Event indicator `i`.
    fn indicator(&self, i: usize) -> f64 {
        match self.physical() {
            Some(p) => p.event_indicators()[i],
            None => inchworm_plant::continuous::at_rest(&self.params, self.dac).1[i],
        }
    }

    fn formulation(&mut self) -> Result<&mut F, String> {
        match &mut self.built {
            Built::Me(f) => Ok(f),
            _ => Err("the plant is not initialized for Model Exchange".into()),
        }
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

impl<F: Formulation> Model for PlantModel<F> {
    fn info() -> &'static ModelInfo {
        F::info()
    }

    fn table() -> &'static [Row<Self>] {
        F::table()
    }

    fn new() -> Self {
        PlantModel {
            params: PlantParams::fia20(),
            dac: Dac::default(),
            built: Built::Not,
            start: 0.0,
            budget: EventBudget::default(),
        }
    }

    fn exit_initialization(&mut self, start_time: f64) -> Result<(), String> {
        let plant = Plant::new(self.params.clone()).map_err(|e| format!("invalid {e}"))?;
        self.built = Built::Cs(plant);
        (self.start, self.budget) = (start_time, EventBudget::default());
        Ok(())
    }

    fn enter_model_exchange(&mut self) -> Result<(), String> {
        let Built::Cs(plant) = std::mem::replace(&mut self.built, Built::Not) else {
            return Err("the plant is built at exit from initialization".into());
        };
        let mut f = F::build(plant)?;
        f.set_time(self.start);
        self.built = Built::Me(f);
        Ok(())
    }

    fn do_step(&mut self, _t: f64, h: f64, log: &mut StepLog) -> Result<(), String> {
        let Built::Cs(plant) = &mut self.built else {
            return Err("the plant is not initialized for Co-Simulation".into());
        };
        let before = plant.mode();
        let report = plant.step(self.dac, h).map_err(|e| e.to_string())?;
        Self::report(plant, &report, before, log);
        Ok(())
    }

    fn model_exchange() -> Option<&'static ModelExchange> {
        Some(F::model_exchange())
    }

    fn set_time(&mut self, t: f64) {
        if let Built::Me(f) = &mut self.built {
            f.set_time(t);
        }
    }

    fn set_continuous_states(&mut self, x: &[f64]) -> Result<(), String> {
        self.formulation()?.set_continuous_states(x)
    }

    fn update_discrete_states(&mut self, t: f64, log: &mut StepLog) -> Result<EventUpdate, String> {
        let (start, dac) = (self.start, self.dac);
        self.budget.spend(t, start)?;
        let f = self.formulation()?;
        let before = f.plant().mode();
        let event = f.event_update(dac, t);
        Self::report(f.plant(), &event.step, before, log);
        Ok(EventUpdate { states_changed: event.states_changed, next_event_time: None })
    }

    /// Exact: the formulation's matrices. A Co-Simulation instance, which integrates no
    /// formulation, takes them from one built from its plant's state.
    fn directional_derivative(
        &self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), String> {
        match &self.built {
            Built::Me(f) => f.directional(unknowns, knowns, seed, out),
            Built::Cs(p) => F::build(p.clone())?.directional(unknowns, knowns, seed, out),
            Built::Not => Err("the plant is built at exit from initialization".into()),
        }
    }

    fn save_state(&self, w: &mut Writer) {
        for x in [self.dac.earth, self.dac.nonearth, self.dac.extension] {
            w.f64(x);
        }
        match &self.built {
            Built::Not => w.u8(NOT_BUILT),
            Built::Cs(p) => {
                w.u8(CS_BUILT);
                p.save_state(w.0);
            }
            Built::Me(f) => {
                w.u8(ME_BUILT);
                f.save_state(w.0);
            }
        }
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        // Three DAC volts and what was built, then the plant's or the formulation's bytes.
        let (head, rest) = bytes.split_at_checked(25).ok_or("plant FMU state truncated")?;
        let mut r = Reader::new(head, "plant FMU state");
        self.dac = Dac { earth: r.f64()?, nonearth: r.f64()?, extension: r.f64()? };
        let plant =
            || Plant::new(self.params.clone()).map_err(|e| format!("state holds invalid {e}"));
        self.built = match r.u8()? {
            NOT_BUILT if rest.is_empty() => Built::Not,
            NOT_BUILT => {
                return Err("plant FMU state: trailing bytes after an uninitialized plant".into())
            }
            CS_BUILT => {
                let mut p = plant()?;
                p.load_state(rest)?;
                Built::Cs(p)
            }
            ME_BUILT => {
                let mut f = F::build(plant()?)?;
                f.load_state(rest)?;
                Built::Me(f)
            }
            b => return Err(format!("plant FMU state: invalid plant marker {b}")),
        };
        self.budget = EventBudget::default();
        Ok(())
    }
}

/// `out[i] = Σ_j ∂unknowns[i]/∂knowns[j] · seed[j]` from the Jacobian `j` of the states
/// of `me`: unknowns among their derivatives and the states, knowns among the states and
/// the DAC inputs (`dacs`: the references of the extension, earth and non-earth volts, the
/// Jacobian's input columns).
fn directional<const S: usize>(
    me: &ModelExchange,
    j: &Jacobian<S>,
    dacs: [u32; 3],
    (unknowns, knowns, seed, out): (&[u32], &[u32], &[f64], &mut [f64]),
) -> Result<(), String> {
    let state = |r: u32| me.states.iter().position(|s| s.value == r);
    let input = |r: u32| dacs.iter().position(|&d| d == r);
    for (o, &u) in out.iter_mut().zip(unknowns) {
        let derivative = me.states.iter().position(|s| s.derivative == u);
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

#[cfg(test)]
mod tests {
    use super::*;
    use inchworm_fmi_export::{start_value, Causality, Kind};
    use inchworm_plant::continuous::reduced::Reduced;

    /// The table is the FMU's public description; the plant crate holds the defaults and the
    /// ranges. Every parameter's start and min/max must be the plant's own, in both FMUs.
    fn parameters_are_the_plant_crates<F: Formulation>() -> usize {
        let fmu = PlantModel::<F>::new();
        let mut ranged = 0;
        for r in F::table().iter().filter(|r| r.var.causality == Causality::Parameter) {
            let v = &r.var;
            assert_eq!(start_value(v), Some(r.get(&fmu)), "{}: start", v.name);
            if v.kind == Kind::Real {
                let base = v.name.split('[').next().unwrap();
                let (lo, hi, _) = inchworm_plant::params::range(base)
                    .unwrap_or_else(|| panic!("{} has no range in the plant crate", v.name));
                assert_eq!((v.min, v.max), (Some(lo), Some(hi)), "{}: range", v.name);
                ranged += 1;
            }
        }
        ranged
    }

    #[test]
    fn parameter_starts_and_ranges_are_the_plant_crates() {
        assert_eq!(parameters_are_the_plant_crates::<Reduced>(), 32);
        assert_eq!(parameters_are_the_plant_crates::<Plant>(), 32);
    }

    /// The two FMUs differ only in their formulation's states and rates: the reduced one's
    /// runner (212, 213 and their rates 238, 239), the model's the stack and the runner's
    /// rates (220-227); each declares exactly its states and their rates.
    #[test]
    fn the_fmus_differ_in_their_formulations_rows_only() {
        let reduced: Vec<u32> = PlantFmu::variables().map(|v| v.vr).collect();
        let full: Vec<u32> = PlantFullFmu::variables().map(|v| v.vr).collect();
        let only =
            |a: &[u32], b: &[u32]| a.iter().filter(|r| !b.contains(r)).copied().collect::<Vec<_>>();
        assert_eq!(only(&reduced, &full), [212, 213, 238, 239]);
        assert_eq!(only(&full, &reduced), (220..228).collect::<Vec<_>>());
        for (me, n) in [
            (<Reduced as Formulation>::model_exchange(), 11),
            (<Plant as Formulation>::model_exchange(), 17),
        ] {
            assert_eq!(me.states.len(), n);
            let table = if n == 11 { &reduced } else { &full };
            for s in me.states {
                assert!(table.contains(&s.value) && table.contains(&s.derivative), "{s:?}");
            }
        }
        assert_eq!(PlantFmu::info().model_identifier, "InchwormPlant");
        assert_eq!(PlantFullFmu::info().model_identifier, "InchwormPlantFull");
    }

    /// A model made from parameters holds them: what masters set from `parameter_values`.
    #[test]
    fn a_model_of_given_parameters_reads_them_back() {
        let fia6 = PlantFmu::with_params(PlantParams::fia6());
        let values: Vec<_> = inchworm_fmi_export::parameter_values(&fia6).collect();
        assert_eq!(values.len(), 33);
        assert!(values.contains(&(PlantFmu::T_EM.name(), inchworm_fmi_export::Value::Real(2.5))));
        assert!(values.contains(&("F_d0", inchworm_fmi_export::Value::Real(105.0))));
    }
}
