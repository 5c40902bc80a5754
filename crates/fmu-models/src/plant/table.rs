//! The rows and the description both plant FMUs share: the variable table's common rows (a
//! macro that each formulation fills with its continuous states and their derivatives), the
//! units, the model information and the analog channels' continuous states.

use inchworm_fmi_export::{ModelInfo, Unit};

/// The rows both FMUs have, with the rows of a formulation's continuous states and of
/// their derivatives in between. Value references: inputs 1.. (the declared fields of
/// `inchworm_plant::Dac`), outputs 10.., parameters 100.. (the declared fields of
/// `PlantParams`, arrays contiguous), the model's continuous states 200.., their
/// derivatives 220.. (the order of `inchworm_plant::continuous`), the event indicators
/// 240.. The names the rows use (`Variable`, `Kind`, `M`, `V`, `Dac`, `PlantParams`)
/// resolve where it is invoked.
macro_rules! plant_table {
    ($model:ty; states { $($sid:ident: $srow:expr),* $(,)? } derivatives { $($did:ident: $drow:expr),* $(,)? }) => {
        #[rustfmt::skip]
        inchworm_fmi_export::table!($model, TABLE;
        fields(Dac, 1),
        {
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
        },
        fields(PlantParams, 100),
        {
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
        });

        impl $model {
            /// The DAC inputs (V), in the order of the plant's `Dac` fields.
            pub const DAC_INPUTS: [inchworm_fmi_export::Var<$model>; 3] =
                [Self::var(Dac::EARTH), Self::var(Dac::NONEARTH), Self::var(Dac::EXTENSION)];
            /// The channels' continuous states, the last nine of both formulations: the
            /// extension, earth and non-earth channels, each its Bessel output, its rate and
            /// the amplifier volts, with their derivatives' rows.
            pub(super) const CHANNELS: [inchworm_fmi_export::ContinuousState; 9] = [
                Self::me_state_of(Self::BESSEL_EXTENSION, Self::DER_BESSEL_EXTENSION, 10.0),
                Self::me_state_of(Self::BESSEL_EXTENSION_RATE, Self::DER_BESSEL_EXTENSION_RATE, 10000.0),
                Self::me_state_of(Self::VOLTAGE_EXTENSION, Self::DER_VOLTAGE_EXTENSION, 100.0),
                Self::me_state_of(Self::BESSEL_EARTH, Self::DER_BESSEL_EARTH, 10.0),
                Self::me_state_of(Self::BESSEL_EARTH_RATE, Self::DER_BESSEL_EARTH_RATE, 10000.0),
                Self::me_state_of(Self::VOLTAGE_EARTH, Self::DER_VOLTAGE_EARTH, 100.0),
                Self::me_state_of(Self::BESSEL_NONEARTH, Self::DER_BESSEL_NONEARTH, 10.0),
                Self::me_state_of(Self::BESSEL_NONEARTH_RATE, Self::DER_BESSEL_NONEARTH_RATE, 10000.0),
                Self::me_state_of(Self::VOLTAGE_NONEARTH, Self::DER_VOLTAGE_NONEARTH, 100.0),
            ];
            /// The event indicators, in the order of `inchworm_plant::continuous`'s.
            pub(super) const EVENT_INDICATORS: [u32; 5] = [
                Self::vr_of(Self::EARTH_SWITCH),
                Self::vr_of(Self::NONEARTH_SWITCH),
                Self::vr_of(Self::SLIP_ONSET_UP),
                Self::vr_of(Self::SLIP_ONSET_DOWN),
                Self::vr_of(Self::SLIP_END),
            ];
            /// The continuous state of row `value`, whose rate is row `derivative`.
            pub(super) const fn me_state_of(
                value: inchworm_fmi_export::Var<$model>,
                derivative: inchworm_fmi_export::Var<$model>,
                nominal: f64,
            ) -> inchworm_fmi_export::ContinuousState {
                inchworm_fmi_export::ContinuousState {
                    value: Self::vr_of(value),
                    derivative: Self::vr_of(derivative),
                    nominal,
                }
            }
            /// Every Real output.
            pub const REAL_OUTPUTS: [inchworm_fmi_export::Var<$model>; 6] = [
                Self::ENCODER_POSITION,
                Self::RUNNER_POSITION,
                Self::EXTENSION,
                Self::VOLTAGE_EARTH,
                Self::VOLTAGE_NONEARTH,
                Self::VOLTAGE_EXTENSION,
            ];
        }
    };
}
pub(super) use plant_table;

pub(super) const V: Option<&str> = Some("V");
pub(super) const M: Option<&str> = Some("m");

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
pub(super) const INFO: ModelInfo = ModelInfo {
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
