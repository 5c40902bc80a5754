//! The `InchwormPlant` and `InchwormPlantFull` FMUs: the plant of docs/model.md §2 behind the
//! Co-Simulation and Model Exchange interfaces of docs/model.md §5. Both share the variable
//! rows of [`table`], this file's Co-Simulation (the exact solver, bit for bit the same)
//! and the mapping of value references onto `inchworm_plant`; they differ in the
//! formulation a Model Exchange master integrates ([`Formulation`]): `InchwormPlant` the
//! reduced one of 11 states (docs/model.md §5.1, [`reduced`]), `InchwormPlantFull` the
//! model's 17 ([`full`]). All FMI behaviour lives in `inchworm-fmi-export`.

mod full;
mod reduced;
mod table;

use inchworm_fmi_export::entry::Array;
use inchworm_fmi_export::{
    EventUpdate, Model, ModelExchange, ModelInfo, Reader, Row, StepLog, Writer,
};
use inchworm_plant::continuous::next_event::EventProbe;
use inchworm_plant::continuous::{self, EventBudget, EventReport, Jacobian, N_INDICATORS};
use inchworm_plant::{Dac, Mode, Outputs, Plant, PlantParams, StepReport};

pub use full::PlantFullFmu;
pub use reduced::PlantFmu;
use table::{plant_table, INFO, M, V};

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
    /// The rates of the continuous states with `dac` held, into `out` (one per state).
    fn rates(&self, dac: Dac, out: &mut [f64]);
    /// The same before the plant is built: at rest (docs/model.md §2.7).
    fn rates_at_rest(p: &PlantParams, dac: Dac, out: &mut [f64]);
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
    /// Model Exchange: the exact propagation that finds the next event after an update,
    /// announced as the next time event (docs/model.md §5.1). A cache, not FMU state.
    probe: Option<EventProbe>,
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

/// The parameters and the DAC inputs are the model's declared parts: the table takes
/// their rows from their fields' declarations.
impl<F> inchworm_fmi_export::inchworm_declare::Has<PlantParams> for PlantModel<F> {
    fn part(&self) -> &PlantParams {
        &self.params
    }
    fn part_mut(&mut self) -> &mut PlantParams {
        &mut self.params
    }
}

impl<F> inchworm_fmi_export::inchworm_declare::Has<Dac> for PlantModel<F> {
    fn part(&self) -> &Dac {
        &self.dac
    }
    fn part_mut(&mut self) -> &mut Dac {
        &mut self.dac
    }
}

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
        self.physical().map_or(0.0, |p| p.continuous_state(k))
    }

    /// The formulation's continuous state that stands for the model's state `k`: under
    /// Co-Simulation, which integrates no formulation, the model's state itself.
    fn me_state(&self, k: usize) -> f64 {
        match &self.built {
            Built::Me(f) => f.continuous_state(k - F::FIRST),
            _ => self.state(k),
        }
    }

    /// The rates of every [`PlantModel::me_state`] into `out`, in the formulation's order;
    /// under Co-Simulation the model's.
    fn me_rates(&self, out: &mut [f64]) {
        match &self.built {
            Built::Me(f) => f.rates(self.dac, out),
            Built::Cs(p) => out.copy_from_slice(&p.derivatives(self.dac)[F::FIRST..]),
            Built::Not => F::rates_at_rest(&self.params, self.dac, out),
        }
    }

    /// The rate of [`PlantModel::me_state`]`(k)`: a row's read of [`PlantModel::me_rates`].
    fn me_rate(&self, k: usize) -> f64 {
        let mut rates = [0.0; continuous::N_STATES];
        let n = F::model_exchange().states.len();
        self.me_rates(&mut rates[..n]);
        rates[k - F::FIRST]
    }

    /// The event indicators.
    fn indicators(&self) -> [f64; N_INDICATORS] {
        match self.physical() {
            Some(p) => p.event_indicators(),
            None => continuous::at_rest(&self.params, self.dac).1,
        }
    }

    /// Event indicator `i`.
    fn indicator(&self, i: usize) -> f64 {
        self.indicators()[i]
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
            probe: None,
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
        self.probe = Some(EventProbe::new(&plant));
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

    /// The derivatives and the event indicators in one evaluation each (a row reads one
    /// element of the same evaluation).
    fn me_array(&self, array: Array, out: &mut [f64]) -> bool {
        match array {
            Array::Derivatives => self.me_rates(out),
            Array::EventIndicators => out.copy_from_slice(&self.indicators()),
            Array::States | Array::Nominals => return false,
        }
        true
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
        let (Built::Me(f), Some(probe)) = (&mut self.built, &mut self.probe) else {
            return Err("the plant is not initialized for Model Exchange".into());
        };
        let before = f.plant().mode();
        let event = f.event_update(dac, t);
        Self::report(f.plant(), &event.step, before, log);
        // The next event of the exact propagation with these volts held: a master stops
        // there whatever its steps, and its update applies it.
        let next = probe.next_time_event(f.plant(), dac);
        Ok(EventUpdate { states_changed: event.states_changed, next_event_time: next })
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
                let p = plant()?;
                self.probe = Some(EventProbe::new(&p));
                let mut f = F::build(p)?;
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

    /// The parameter rows are the plant crate's declarations, at value references 100 on in
    /// declaration order: every start value is what a new model holds, and every declared
    /// range is the one `PlantParams::validate` enforces (a value just outside either end is
    /// refused, naming the row's variable).
    fn parameters_are_the_plant_crates<F: Formulation>() -> usize {
        use inchworm_fmi_export::inchworm_declare::Declared;
        let fmu = PlantModel::<F>::new();
        let rows: Vec<_> =
            F::table().iter().filter(|r| r.var.causality == Causality::Parameter).collect();
        assert_eq!(rows.len(), PlantParams::FIELDS.len());
        let mut ranged = 0;
        for (k, (r, f)) in rows.iter().zip(PlantParams::FIELDS).enumerate() {
            let v = &r.var;
            assert_eq!((v.name, v.vr, v.description), (f.name, 100 + k as u32, f.description));
            assert_eq!(start_value(v), Some(r.get(&fmu)), "{}: start", v.name);
            let (Some(lo), Some(hi)) = (v.min, v.max) else { continue };
            assert_eq!(v.kind, Kind::Real, "{}", v.name);
            for outside in [lo - lo.abs().max(1e-300) * 1e-9, hi + hi.abs() * 1e-9] {
                let mut m = PlantModel::<F>::new();
                r.set(&mut m, inchworm_fmi_export::Value::Real(outside)).unwrap();
                let e = m.params.validate().expect_err(v.name);
                assert_eq!(e.field, v.name, "{outside:e}: {e}");
            }
            ranged += 1;
        }
        ranged
    }

    #[test]
    fn parameter_starts_and_ranges_are_the_plant_crates() {
        use inchworm_fmi_export::inchworm_declare::Declared;
        let ranged = PlantParams::FIELDS.iter().filter(|f| f.min.is_some()).count();
        assert!(ranged >= 32, "the fia20 parameters are ranged: {ranged}");
        assert_eq!(parameters_are_the_plant_crates::<Reduced>(), ranged);
        assert_eq!(parameters_are_the_plant_crates::<Plant>(), ranged);
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

    /// A Model Exchange array read whole has the bits of its rows read one by one, in every
    /// state a master reads it in: before the plant is built, under Co-Simulation after
    /// steps across brake switches, and integrated, at a moved time and states.
    fn whole_arrays_are_the_rows<F: Formulation>() {
        let me = F::model_exchange();
        let check = |m: &PlantModel<F>, when: &str| {
            for (array, vrs) in [
                (Array::Derivatives, me.states.iter().map(|s| s.derivative).collect::<Vec<_>>()),
                (Array::EventIndicators, me.event_indicators.to_vec()),
            ] {
                let mut whole = vec![f64::NAN; vrs.len()];
                assert!(m.me_array(array, &mut whole), "{array:?} {when}");
                for (vr, w) in vrs.iter().zip(&whole) {
                    let row = inchworm_fmi_export::row_of::<PlantModel<F>>(*vr).unwrap();
                    let by_row = row.get(m).real();
                    assert_eq!(w.to_bits(), by_row.to_bits(), "{} {when}", row.var.name);
                }
            }
            let mut out = vec![0.0; me.states.len()];
            assert!(!m.me_array(Array::States, &mut out) && !m.me_array(Array::Nominals, &mut out));
        };
        let mut m = PlantModel::<F>::new();
        m.dac = Dac { extension: 3.0, earth: 2.0, nonearth: 8.0 };
        check(&m, "before initialization");
        m.exit_initialization(0.0).unwrap();
        let mut log = StepLog::new(false);
        for k in 0..60 {
            m.dac.earth = if k % 20 < 10 { 10.0 } else { 0.0 };
            m.dac.extension = 0.1 * k as f64;
            m.do_step(k as f64 * 2e-3, 2e-3, &mut log).unwrap();
        }
        check(&m, "under Co-Simulation");
        let mut m = PlantModel::<F>::new();
        m.dac = Dac { extension: 5.0, earth: 10.0, nonearth: 0.0 };
        m.exit_initialization(0.0).unwrap();
        m.enter_model_exchange().unwrap();
        m.update_discrete_states(0.0, &mut log).unwrap();
        m.set_time(1e-4);
        let mut x = vec![0.0; me.states.len()];
        for (i, s) in me.states.iter().enumerate() {
            x[i] = inchworm_fmi_export::row_of::<PlantModel<F>>(s.value).unwrap().get(&m).real();
        }
        x[0] += 1e-7;
        m.set_continuous_states(&x).unwrap();
        check(&m, "integrated");
    }

    #[test]
    fn model_exchange_arrays_read_whole_are_the_rows() {
        whole_arrays_are_the_rows::<Reduced>();
        whole_arrays_are_the_rows::<Plant>();
    }

    /// A model made from parameters holds them: what masters set from `parameter_values`.
    #[test]
    fn a_model_of_given_parameters_reads_them_back() {
        let fia6 = PlantFmu::with_params(PlantParams::fia6());
        let values: Vec<_> = inchworm_fmi_export::parameter_values(&fia6).collect();
        use inchworm_fmi_export::inchworm_declare::Declared;
        assert_eq!(values.len(), PlantParams::FIELDS.len());
        assert!(values.contains(&(
            PlantFmu::var(inchworm_plant::PlantParams::T_EM).name(),
            inchworm_fmi_export::Value::Real(2.5)
        )));
        let f_d0 = PlantParams::F_D0.name();
        assert!(values.contains(&(f_d0, inchworm_fmi_export::Value::Real(105.0))));
    }
}
