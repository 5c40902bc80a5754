//! `InchwormPlant`: the plant whose Model Exchange is the reduced formulation of
//! docs/model.md §5.1, 11 continuous states (the slow parts of the runner's position and
//! velocity, and the three channels), `inchworm_plant::continuous::reduced`.

use super::{directional, plant_table, Formulation, PlantModel, INFO, M, V};
use inchworm_fmi_export::{Kind, ModelExchange, ModelInfo, Row, Variable};
use inchworm_plant::continuous::reduced::{self, Reduced, N_STATES};
use inchworm_plant::continuous::EventReport;
use inchworm_plant::{Dac, Plant, PlantParams};

/// The model of `InchwormPlant`.
pub type PlantFmu = PlantModel<Reduced>;

plant_table!(PlantFmu;
    states {
        RUNNER_SLOW: Variable::local("runner_slow", 212, M, "Slow part of the runner position x4 - L_r (a continuous state of Model Exchange; Co-Simulation does not split the plant and reads runner_position)").real_out(|m| m.me_state(6)),
        RUNNER_SLOW_VELOCITY: Variable::local("runner_slow_velocity", 213, Some("m/s"), "Slow part of the runner velocity v4 (a continuous state of Model Exchange; Co-Simulation reads runner_velocity)").real_out(|m| m.me_state(7)),
    }
    derivatives {
        DER_RUNNER_SLOW: Variable::local("der(runner_slow)", 238, Some("m/s"), "Rate of runner_slow").real_out(|m| m.me_rate(6)),
        DER_RUNNER_SLOW_VELOCITY: Variable::local("der(runner_slow_velocity)", 239, Some("m/s2"), "Rate of runner_slow_velocity").real_out(|m| m.me_rate(7)),
    }
);

/// The 11 states in the order of `inchworm_plant::continuous::reduced`. The runner's
/// nominals are a gait's magnitudes (10 µm, 0.1 m/s): they cost the integrator no steps
/// and keep its error on the runner a fraction of a count (docs/model.md §5.1).
static ME: ModelExchange = ModelExchange {
    states: &{
        type F = PlantFmu;
        let runner = [
            F::me_state_of(F::RUNNER_SLOW, F::DER_RUNNER_SLOW, 1e-5),
            F::me_state_of(F::RUNNER_SLOW_VELOCITY, F::DER_RUNNER_SLOW_VELOCITY, 0.1),
        ];
        let mut all = [F::CHANNELS[0]; N_STATES];
        let mut i = 0;
        while i < N_STATES {
            all[i] = if i < 2 { runner[i] } else { F::CHANNELS[i - 2] };
            i += 1;
        }
        all
    },
    event_indicators: &PlantFmu::EVENT_INDICATORS,
    directional_derivatives: true,
};

impl Formulation for Reduced {
    /// The model's states without the stack's six.
    const FIRST: usize = 6;

    fn info() -> &'static ModelInfo {
        &INFO
    }

    fn table() -> &'static [Row<PlantModel<Self>>] {
        &TABLE
    }

    fn model_exchange() -> &'static ModelExchange {
        &ME
    }

    fn build(plant: Plant) -> Result<Self, String> {
        Reduced::from_plant(plant).map_err(|e| format!("invalid {e}"))
    }

    fn plant(&self) -> &Plant {
        Reduced::plant(self)
    }

    fn set_time(&mut self, t: f64) {
        Reduced::set_time(self, t);
    }

    fn continuous_state(&self, i: usize) -> f64 {
        self.continuous_states()[i]
    }

    fn set_continuous_states(&mut self, x: &[f64]) -> Result<(), String> {
        let x: &[f64; N_STATES] = x.try_into().map_err(|_| "wrong number of states")?;
        Reduced::set_continuous_states(self, x);
        Ok(())
    }

    fn rates(&self, dac: Dac, out: &mut [f64]) {
        out.copy_from_slice(&self.derivatives(dac));
    }

    fn rates_at_rest(p: &PlantParams, dac: Dac, out: &mut [f64]) {
        match reduced::at_rest(p, dac) {
            Ok((d, _)) => out.copy_from_slice(&d),
            Err(_) => out.fill(f64::NAN),
        }
    }

    fn event_update(&mut self, dac: Dac, t: f64) -> EventReport {
        Reduced::event_update(self, dac, t)
    }

    fn directional(
        &self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), String> {
        let dacs = [
            PlantFmu::var(inchworm_plant::Dac::EXTENSION),
            PlantFmu::var(inchworm_plant::Dac::EARTH),
            PlantFmu::var(inchworm_plant::Dac::NONEARTH),
        ];
        directional(&ME, &self.jacobian(), dacs.map(|d| d.vr()), (unknowns, knowns, seed, out))
    }

    fn save_state(&self, out: &mut Vec<u8>) {
        Reduced::save_state(self, out);
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        Reduced::load_state(self, bytes)
    }
}
