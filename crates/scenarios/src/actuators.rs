//! Every actuator of a system that has many (a segmented mirror's `seg{k}_plant_a`, …),
//! found by its components' names and reduced to the sweep's metrics ([`crate::metrics`])
//! as the run's rows come: what `inchworm run --spread` reports, one row an actuator.
//!
//! An actuator is a plant component `{a}plant{b}` whose encoder position is recorded; its
//! controller is `{a}controller{b}` and its reference `{a}reference{b}`. Its columns are
//! read under the single closed loop's names (`plant.…`, `controller.…`,
//! `reference.reference`), so a metric means for each actuator what it means in a sweep
//! of `InchwormSystem.ssp`.

use std::collections::BTreeMap;

use inchworm_cosim::Error;

use crate::closed_loop::ENCODER_POSITION;
use crate::metrics::{LoopMetrics, Reducer};

/// One actuator: its plant component's name, the columns of the run's rows it reads (in
/// the order of its local names) and its metrics so far.
#[derive(Clone, Debug)]
struct Actuator {
    plant: String,
    columns: Vec<usize>,
    reducer: Reducer,
}

/// The metrics of every actuator of a run, fed row by row.
#[derive(Clone, Debug)]
pub struct Spread {
    metrics: Vec<String>,
    actuators: Vec<Actuator>,
    /// One actuator's values of a row, reused.
    scratch: Vec<f64>,
}

/// The closed loop's component names that an actuator's components stand for.
const ROLES: [&str; 3] = ["plant", "controller", "reference"];

impl Spread {
    /// The actuators among `recorded` (the run's recorded names, in row order), in that
    /// order, each reduced to `metrics`. Refuses a run with no actuator, and an actuator
    /// without a column a metric reads (naming it).
    pub fn new(metrics: &LoopMetrics, recorded: &[String]) -> Result<Spread, Error> {
        let (role, position) = ENCODER_POSITION.split_once('.').expect("component.variable");
        // Each component's recorded variables: (column, variable).
        let mut by_component: BTreeMap<&str, Vec<(usize, &str)>> = BTreeMap::new();
        for (i, n) in recorded.iter().enumerate() {
            if let Some((component, variable)) = n.split_once('.') {
                by_component.entry(component).or_default().push((i, variable));
            }
        }
        let mut actuators = Vec::new();
        for name in recorded {
            let Some((plant, _)) = name.split_once('.').filter(|(_, v)| *v == position) else {
                continue;
            };
            let Some((a, b)) = plant.split_once(role) else { continue };
            let (mut columns, mut local) = (Vec::new(), Vec::new());
            for r in ROLES {
                for &(i, variable) in
                    by_component.get(format!("{a}{r}{b}").as_str()).into_iter().flatten()
                {
                    columns.push(i);
                    local.push(format!("{r}.{variable}"));
                }
            }
            let reducer =
                metrics.reducer(&local).map_err(|e| e.context(format!("actuator {plant}")))?;
            actuators.push(Actuator { plant: plant.to_string(), columns, reducer });
        }
        if actuators.is_empty() {
            return Err(Error::Config(format!(
                "no actuator recorded: --spread needs a plant `…{role}…` recorded with its `{position}`"
            )));
        }
        let metrics = metrics.metrics.iter().map(|m| m.name.clone()).collect();
        Ok(Spread { metrics, actuators, scratch: Vec::new() })
    }

    /// The row at time `t`, t = 0 first.
    pub fn push(&mut self, t: f64, row: &[f64]) {
        for a in &mut self.actuators {
            self.scratch.clear();
            self.scratch.extend(a.columns.iter().map(|&i| row[i]));
            a.reducer.push(t, &self.scratch);
        }
    }

    /// The metrics' names, in order.
    pub fn metrics(&self) -> &[String] {
        &self.metrics
    }

    /// Each actuator's plant component and its metrics (`None` where it has none).
    pub fn finish(&self) -> Vec<(String, Vec<Option<f64>>)> {
        self.actuators.iter().map(|a| (a.plant.clone(), a.reducer.finish())).collect()
    }

    /// `actuator,<metric>,…`, one row an actuator, an empty field where it has no value.
    pub fn csv(&self) -> String {
        let mut s = format!("actuator,{}\n", self.metrics.join(","));
        for (plant, values) in self.finish() {
            s.push_str(&plant);
            for v in values {
                s.push(',');
                if let Some(v) = v {
                    s.push_str(&v.to_string());
                }
            }
            s.push('\n');
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::closed_loop::{self, DAC, DISTURBANCE_ESTIMATE};
    use inchworm_fmu_models::{MountFmu, ReferenceFmu};

    /// The columns an actuator `{a}…{b}` needs for settle, rms and disturbance.
    fn actuator(a: &str, b: &str) -> Vec<String> {
        let mut v = vec![format!("{a}reference{b}.{}", ReferenceFmu::REFERENCE.name())];
        let own = |n: &str| {
            let (c, var) = n.split_once('.').unwrap();
            format!("{a}{c}{b}.{var}")
        };
        v.push(own(ENCODER_POSITION));
        v.extend(DAC.iter().map(|n| own(n)));
        v.push(own(DISTURBANCE_ESTIMATE));
        v
    }

    #[test]
    fn each_actuator_reads_its_own_columns_under_the_loop_names() {
        let metrics = LoopMetrics::parse(&["settle:1e-6", "disturbance"]).unwrap();
        let mut recorded = vec![format!("seg0_mount.{}", MountFmu::PISTON.name())];
        recorded.extend(actuator("seg0_", "_a"));
        recorded.extend(actuator("seg1_", "_a"));
        let mut spread = Spread::new(&metrics, &recorded).unwrap();
        assert_eq!(spread.metrics(), ["settle:1e-6", "disturbance"]);
        // Actuator seg0_a parks at 1 µm + 0.5 µm (outside the band until 0.1 s), seg1_a at
        // the reference from the start; their disturbance estimates 3 µm and 5 µm.
        let n = recorded.len();
        for k in 0..=100 {
            let t = k as f64 / 500.0;
            let mut row = vec![0.0; n];
            row[1] = 1e-6;
            row[2] = if t < 0.1 { 2.5e-6 } else { 1e-6 };
            row[6] = 3e-6;
            row[7] = 1e-6;
            row[8] = 1e-6;
            row[12] = 5e-6;
            spread.push(t, &row);
        }
        let result = spread.finish();
        assert_eq!(result[0].0, "seg0_plant_a");
        assert_eq!(result[1].0, "seg1_plant_a");
        let settle0 = result[0].1[0].unwrap();
        assert!((settle0 - 0.1).abs() < 1e-12, "{settle0}");
        assert_eq!(result[0].1[1], Some(3e-6));
        assert_eq!(result[1].1[1], Some(5e-6));
        // Parked from the 9th sample on, always in the band: settled at the first.
        assert!((result[1].1[0].unwrap() - 0.018).abs() < 1e-12);
        let csv = spread.csv();
        assert!(csv.starts_with("actuator,settle:1e-6,disturbance\nseg0_plant_a,0.1"), "{csv}");
        assert!(csv.ends_with("seg1_plant_a,0.018,0.000005\n"), "{csv}");
    }

    #[test]
    fn a_single_loop_is_one_actuator_and_a_missing_column_is_named() {
        let metrics = LoopMetrics::parse(&["disturbance"]).unwrap();
        let single = actuator("", "");
        let spread = Spread::new(&metrics, &single).unwrap();
        assert_eq!(spread.finish().len(), 1);
        assert_eq!(single[0], closed_loop::REFERENCE_OUTPUT);
        let without: Vec<String> =
            single.iter().filter(|n| !n.ends_with("estimate")).cloned().collect();
        let e = Spread::new(&metrics, &without).unwrap_err().to_string();
        assert!(e.contains("plant") && e.contains(DISTURBANCE_ESTIMATE), "{e}");
        let mount = [format!("mount.{}", MountFmu::PISTON.name())];
        let none = Spread::new(&metrics, &mount).unwrap_err().to_string();
        assert!(none.contains("no actuator"), "{none}");
    }
}
