//! `InchwormPlantFull`: the plant whose Model Exchange is the model's own formulation, its
//! 17 continuous states (docs/model.md §5), `inchworm_plant::continuous`.

use super::{directional, plant_table, Formulation, PlantModel, INFO, M, V};
use inchworm_fmi_export::{Kind, ModelExchange, ModelInfo, Row, Variable};
use inchworm_plant::continuous::{self, EventReport, N_STATES};
use inchworm_plant::{Dac, Plant, PlantParams};

/// The model of `InchwormPlantFull`.
pub type PlantFullFmu = PlantModel<Plant>;

plant_table!(PlantFullFmu;
    states {}
    derivatives {
        DER_NODE1_DISPLACEMENT: Variable::local("der(node1_displacement)", 220, Some("m/s"), "Rate of node1_displacement").real_out(|m| m.me_rate(0)),
        DER_NODE1_VELOCITY: Variable::local("der(node1_velocity)", 221, Some("m/s2"), "Rate of node1_velocity").real_out(|m| m.me_rate(1)),
        DER_NODE2_DISPLACEMENT: Variable::local("der(node2_displacement)", 222, Some("m/s"), "Rate of node2_displacement").real_out(|m| m.me_rate(2)),
        DER_NODE2_VELOCITY: Variable::local("der(node2_velocity)", 223, Some("m/s2"), "Rate of node2_velocity").real_out(|m| m.me_rate(3)),
        DER_EXTENSION: Variable::local("der(extension)", 224, Some("m/s"), "Rate of extension").real_out(|m| m.me_rate(4)),
        DER_NODE3_VELOCITY: Variable::local("der(node3_velocity)", 225, Some("m/s2"), "Rate of node3_velocity").real_out(|m| m.me_rate(5)),
        DER_RUNNER_POSITION: Variable::local("der(runner_position)", 226, Some("m/s"), "Rate of runner_position").real_out(|m| m.me_rate(6)),
        DER_RUNNER_VELOCITY: Variable::local("der(runner_velocity)", 227, Some("m/s2"), "Rate of runner_velocity").real_out(|m| m.me_rate(7)),
    }
);

/// The 17 states in the order of `inchworm_plant::continuous`.
static ME: ModelExchange = ModelExchange {
    states: &{
        type F = PlantFullFmu;
        let mechanics = [
            F::me_state_of(F::NODE1_DISPLACEMENT, F::DER_NODE1_DISPLACEMENT, 1e-2),
            F::me_state_of(F::NODE1_VELOCITY, F::DER_NODE1_VELOCITY, 10.0),
            F::me_state_of(F::NODE2_DISPLACEMENT, F::DER_NODE2_DISPLACEMENT, 1e-2),
            F::me_state_of(F::NODE2_VELOCITY, F::DER_NODE2_VELOCITY, 10.0),
            F::me_state_of(F::EXTENSION, F::DER_EXTENSION, 1e-2),
            F::me_state_of(F::NODE3_VELOCITY, F::DER_NODE3_VELOCITY, 10.0),
            F::me_state_of(F::RUNNER_POSITION, F::DER_RUNNER_POSITION, 1e-2),
            F::me_state_of(F::RUNNER_VELOCITY, F::DER_RUNNER_VELOCITY, 10.0),
        ];
        let mut all = [F::CHANNELS[0]; N_STATES];
        let mut i = 0;
        while i < N_STATES {
            all[i] = if i < 8 { mechanics[i] } else { F::CHANNELS[i - 8] };
            i += 1;
        }
        all
    },
    event_indicators: &PlantFullFmu::EVENT_INDICATORS,
    directional_derivatives: true,
};

static INFO_FULL: ModelInfo = ModelInfo {
    model_name: "InchwormPlantFull",
    model_identifier: "InchwormPlantFull",
    description: "JPL flight inchworm actuator, the model's 17 continuous states for Model Exchange (InchwormPlant: 11): driver-board analog chain, three-element PZT with passive Maxwell-slip hysteresis, brakes with events at V_th, flexure, runner, brake disturbance, 1.2 nm encoder",
    ..INFO
};

impl Formulation for Plant {
    const FIRST: usize = 0;

    fn info() -> &'static ModelInfo {
        &INFO_FULL
    }

    fn table() -> &'static [Row<PlantModel<Self>>] {
        &TABLE
    }

    fn model_exchange() -> &'static ModelExchange {
        &ME
    }

    fn build(plant: Plant) -> Result<Self, String> {
        Ok(plant)
    }

    fn plant(&self) -> &Plant {
        self
    }

    /// The model's formulation has every state: nothing moves with time alone.
    fn set_time(&mut self, _t: f64) {}

    fn continuous_state(&self, i: usize) -> f64 {
        Plant::continuous_state(self, i)
    }

    fn set_continuous_states(&mut self, x: &[f64]) -> Result<(), String> {
        let x: &[f64; N_STATES] = x.try_into().map_err(|_| "wrong number of states")?;
        Plant::set_continuous_states(self, x);
        Ok(())
    }

    fn rates(&self, dac: Dac, out: &mut [f64]) {
        out.copy_from_slice(&self.derivatives(dac));
    }

    fn rates_at_rest(p: &PlantParams, dac: Dac, out: &mut [f64]) {
        out.copy_from_slice(&continuous::at_rest(p, dac).0);
    }

    fn event_update(&mut self, dac: Dac, t: f64) -> EventReport {
        Plant::event_update(self, dac, t)
    }

    fn directional(
        &self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), String> {
        let dacs = [
            PlantFullFmu::var(inchworm_plant::Dac::EXTENSION),
            PlantFullFmu::var(inchworm_plant::Dac::EARTH),
            PlantFullFmu::var(inchworm_plant::Dac::NONEARTH),
        ];
        directional(&ME, &self.jacobian(), dacs.map(|d| d.vr()), (unknowns, knowns, seed, out))
    }

    fn save_state(&self, out: &mut Vec<u8>) {
        Plant::save_state(self, out);
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        Plant::load_state(self, bytes)
    }
}
