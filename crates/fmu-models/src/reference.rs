//! The `InchwormReference` FMU: the reference trajectory of the closed loop as its own
//! component, so a system needs no external input. The reference is a table of
//! `(time, position)` points held piecewise constant (optionally ramped over `ramp_time`),
//! or one of the named profiles of the paper; its output `reference` (m) feeds the
//! controller's input of the same name.
//!
//! Timing: before the first step the output is the value at the start time; after
//! `fmi2DoStep(t, h)` it is the value at `t + h`, so a master that reads the outputs after
//! initialization hands the controller the reference of each communication point at that
//! point (the inchworm master, Ecos and libcosim do; FMPy's starts every connector at 0).

use inchworm_fmi_export::{Kind, Model, ModelInfo, Reader, StepLog, Unit, Variable, Writer};

/// Points the table holds.
pub const MAX_POINTS: usize = 16;

/// `profile` values.
pub const PROFILE_TABLE: i32 = 0;
pub const PROFILE_STEP: i32 = 1;
pub const PROFILE_STAIRCASE: i32 = 2;

/// The Figs. 6-7 staircase: level k (µm) from `100 k` s.
pub const STAIRCASE_UM: [f64; 7] = [100.0, 60.0, 250.0, 245.0, 130.0, 131.5, 20.0];

mod vr {
    pub const REFERENCE: u32 = 1;
    pub const PROFILE: u32 = 100;
    pub const N_POINTS: u32 = 101;
    pub const RAMP_TIME: u32 = 102;
    pub const TIMES: u32 = 200; // ..=215
    pub const POSITIONS: u32 = 300; // ..=315
}

const M: Option<&str> = Some("m");
const S: Option<&str> = Some("s");

#[rustfmt::skip]
static VARIABLES: [Variable; 4 + 2 * MAX_POINTS] = [
    Variable::output("reference", vr::REFERENCE, Kind::Real, M, "Reference position of the runner at the current communication point").discrete(),
    Variable::integer_parameter("profile", vr::PROFILE, PROFILE_TABLE, None, "0 the table (times, positions), 1 the Fig. 5 step (100 um from t = 0), 2 the Figs. 6-7 staircase (100 s per level)"),
    Variable::integer_parameter("n_points", vr::N_POINTS, 1, None, "Points of the table used (1-16)"),
    Variable::parameter("ramp_time", vr::RAMP_TIME, 0.0, S, "Each change ramps linearly over this time from its point's time (0 = a step)"),
    Variable::parameter("times[1]", vr::TIMES, 0.0, S, "Time of point 1 (used when n_points >= 1; increasing)"),
    Variable::parameter("times[2]", vr::TIMES + 1, 0.0, S, "Time of point 2 (used when n_points >= 2; increasing)"),
    Variable::parameter("times[3]", vr::TIMES + 2, 0.0, S, "Time of point 3 (used when n_points >= 3; increasing)"),
    Variable::parameter("times[4]", vr::TIMES + 3, 0.0, S, "Time of point 4 (used when n_points >= 4; increasing)"),
    Variable::parameter("times[5]", vr::TIMES + 4, 0.0, S, "Time of point 5 (used when n_points >= 5; increasing)"),
    Variable::parameter("times[6]", vr::TIMES + 5, 0.0, S, "Time of point 6 (used when n_points >= 6; increasing)"),
    Variable::parameter("times[7]", vr::TIMES + 6, 0.0, S, "Time of point 7 (used when n_points >= 7; increasing)"),
    Variable::parameter("times[8]", vr::TIMES + 7, 0.0, S, "Time of point 8 (used when n_points >= 8; increasing)"),
    Variable::parameter("times[9]", vr::TIMES + 8, 0.0, S, "Time of point 9 (used when n_points >= 9; increasing)"),
    Variable::parameter("times[10]", vr::TIMES + 9, 0.0, S, "Time of point 10 (used when n_points >= 10; increasing)"),
    Variable::parameter("times[11]", vr::TIMES + 10, 0.0, S, "Time of point 11 (used when n_points >= 11; increasing)"),
    Variable::parameter("times[12]", vr::TIMES + 11, 0.0, S, "Time of point 12 (used when n_points >= 12; increasing)"),
    Variable::parameter("times[13]", vr::TIMES + 12, 0.0, S, "Time of point 13 (used when n_points >= 13; increasing)"),
    Variable::parameter("times[14]", vr::TIMES + 13, 0.0, S, "Time of point 14 (used when n_points >= 14; increasing)"),
    Variable::parameter("times[15]", vr::TIMES + 14, 0.0, S, "Time of point 15 (used when n_points >= 15; increasing)"),
    Variable::parameter("times[16]", vr::TIMES + 15, 0.0, S, "Time of point 16 (used when n_points >= 16; increasing)"),
    Variable::parameter("positions[1]", vr::POSITIONS, 100e-6, M, "Reference position from point 1"),
    Variable::parameter("positions[2]", vr::POSITIONS + 1, 0.0, M, "Reference position from point 2"),
    Variable::parameter("positions[3]", vr::POSITIONS + 2, 0.0, M, "Reference position from point 3"),
    Variable::parameter("positions[4]", vr::POSITIONS + 3, 0.0, M, "Reference position from point 4"),
    Variable::parameter("positions[5]", vr::POSITIONS + 4, 0.0, M, "Reference position from point 5"),
    Variable::parameter("positions[6]", vr::POSITIONS + 5, 0.0, M, "Reference position from point 6"),
    Variable::parameter("positions[7]", vr::POSITIONS + 6, 0.0, M, "Reference position from point 7"),
    Variable::parameter("positions[8]", vr::POSITIONS + 7, 0.0, M, "Reference position from point 8"),
    Variable::parameter("positions[9]", vr::POSITIONS + 8, 0.0, M, "Reference position from point 9"),
    Variable::parameter("positions[10]", vr::POSITIONS + 9, 0.0, M, "Reference position from point 10"),
    Variable::parameter("positions[11]", vr::POSITIONS + 10, 0.0, M, "Reference position from point 11"),
    Variable::parameter("positions[12]", vr::POSITIONS + 11, 0.0, M, "Reference position from point 12"),
    Variable::parameter("positions[13]", vr::POSITIONS + 12, 0.0, M, "Reference position from point 13"),
    Variable::parameter("positions[14]", vr::POSITIONS + 13, 0.0, M, "Reference position from point 14"),
    Variable::parameter("positions[15]", vr::POSITIONS + 14, 0.0, M, "Reference position from point 15"),
    Variable::parameter("positions[16]", vr::POSITIONS + 15, 0.0, M, "Reference position from point 16"),
];

static UNITS: [Unit; 2] =
    [Unit { name: "m", kg: 0, m: 1, s: 0, a: 0 }, Unit { name: "s", kg: 0, m: 0, s: 1, a: 0 }];

static INFO: ModelInfo = ModelInfo {
    model_name: "InchwormReference",
    model_identifier: "InchwormReference",
    description: "Reference trajectory of the inchworm actuator: a table of (time, position) points held piecewise constant or ramped, or a named profile (Fig. 5 step, Figs. 6-7 staircase)",
    version: env!("CARGO_PKG_VERSION"),
    default_start_time: 0.0,
    default_stop_time: 10.0,
    default_step_size: 0.002,
    default_tolerance: 1e-9,
    units: &UNITS,
    log_events: "Model events: the reference changes level",
    documentation_html: include_str!("reference.html"),
};

#[derive(Clone, Debug)]
pub struct ReferenceFmu {
    profile: i32,
    n_points: i32,
    ramp_time: f64,
    times: [f64; MAX_POINTS],
    positions: [f64; MAX_POINTS],
    /// The points in use, built at initialization from the profile or the table.
    points: Vec<(f64, f64)>,
    time: f64,
}

impl ReferenceFmu {
    /// The reference at `t`: 0 before the first point; from each point's time it moves
    /// from where it is to the point's position over `ramp_time` (at once if 0), a later
    /// point taking over from wherever an unfinished ramp has got to.
    pub fn value(&self, t: f64) -> f64 {
        // A master computes the grid as k h or by accumulation: a point at 0.2 s is
        // reached by a time that rounds a few ulps below it.
        let reached = t + 1e-9 * t.abs().max(1e-3);
        let ramp = |from: f64, to: f64, dt: f64| {
            if self.ramp_time <= 0.0 || dt >= self.ramp_time {
                to
            } else {
                from + (to - from) * (dt / self.ramp_time)
            }
        };
        let mut from = 0.0;
        for (k, &(ti, pi)) in self.points.iter().enumerate() {
            if reached < ti {
                break;
            }
            match self.points.get(k + 1) {
                Some(&(next, _)) if reached >= next => from = ramp(from, pi, next - ti),
                _ => return ramp(from, pi, (t - ti).max(0.0)),
            }
        }
        from
    }

    fn build_points(&self) -> Result<Vec<(f64, f64)>, String> {
        Ok(match self.profile {
            PROFILE_TABLE => {
                let n = self.n_points;
                if !(1..=MAX_POINTS as i32).contains(&n) {
                    return Err(format!("invalid parameter n_points: {n} (1-{MAX_POINTS})"));
                }
                let n = n as usize;
                for i in 1..n {
                    if self.times[i] <= self.times[i - 1] {
                        return Err(format!(
                            "invalid parameter times[{}]: {} s is not after times[{i}] = {} s (the times must increase)",
                            i + 1,
                            self.times[i],
                            self.times[i - 1]
                        ));
                    }
                }
                (0..n).map(|i| (self.times[i], self.positions[i])).collect()
            }
            PROFILE_STEP => vec![(0.0, 100e-6)],
            PROFILE_STAIRCASE => STAIRCASE_UM
                .iter()
                .enumerate()
                .map(|(k, um)| (k as f64 * 100.0, um * 1e-6))
                .collect(),
            p => {
                return Err(format!(
                    "invalid parameter profile: {p} (0 table, 1 step, 2 staircase)"
                ))
            }
        })
    }
}

impl Model for ReferenceFmu {
    fn info() -> &'static ModelInfo {
        &INFO
    }

    fn variables() -> &'static [Variable] {
        &VARIABLES
    }

    fn new() -> Self {
        let mut positions = [0.0; MAX_POINTS];
        positions[0] = 100e-6;
        ReferenceFmu {
            profile: PROFILE_TABLE,
            n_points: 1,
            ramp_time: 0.0,
            times: [0.0; MAX_POINTS],
            positions,
            points: vec![(0.0, 100e-6)],
            time: 0.0,
        }
    }

    fn get_real(&self, r: u32) -> Result<f64, String> {
        let i = |base: u32| (r - base) as usize;
        Ok(match r {
            vr::REFERENCE => self.value(self.time),
            vr::RAMP_TIME => self.ramp_time,
            r if (vr::TIMES..vr::TIMES + MAX_POINTS as u32).contains(&r) => {
                self.times[i(vr::TIMES)]
            }
            r if (vr::POSITIONS..vr::POSITIONS + MAX_POINTS as u32).contains(&r) => {
                self.positions[i(vr::POSITIONS)]
            }
            _ => return Err(format!("no Real variable with value reference {r}")),
        })
    }

    fn get_integer(&self, r: u32) -> Result<i32, String> {
        match r {
            vr::PROFILE => Ok(self.profile),
            vr::N_POINTS => Ok(self.n_points),
            _ => Err(format!("no Integer variable with value reference {r}")),
        }
    }

    fn get_boolean(&self, r: u32) -> Result<bool, String> {
        Err(format!("no Boolean variable with value reference {r}"))
    }

    fn set_real(&mut self, r: u32, value: f64) -> Result<(), String> {
        let i = |base: u32| (r - base) as usize;
        match r {
            vr::RAMP_TIME => self.ramp_time = value,
            r if (vr::TIMES..vr::TIMES + MAX_POINTS as u32).contains(&r) => {
                self.times[i(vr::TIMES)] = value
            }
            r if (vr::POSITIONS..vr::POSITIONS + MAX_POINTS as u32).contains(&r) => {
                self.positions[i(vr::POSITIONS)] = value
            }
            _ => return Err(format!("no settable Real variable with value reference {r}")),
        }
        // The output before initialization follows the table as it is set.
        if let Ok(p) = self.build_points() {
            self.points = p;
        }
        Ok(())
    }

    fn set_integer(&mut self, r: u32, value: i32) -> Result<(), String> {
        match r {
            vr::PROFILE => self.profile = value,
            vr::N_POINTS => self.n_points = value,
            _ => return Err(format!("no settable Integer variable with value reference {r}")),
        }
        if let Ok(p) = self.build_points() {
            self.points = p;
        }
        Ok(())
    }

    fn set_boolean(&mut self, r: u32, _value: bool) -> Result<(), String> {
        Err(format!("no settable Boolean variable with value reference {r}"))
    }

    fn exit_initialization(&mut self, start_time: f64) -> Result<(), String> {
        if self.ramp_time < 0.0 {
            return Err(format!(
                "invalid parameter ramp_time: {} s (must be >= 0)",
                self.ramp_time
            ));
        }
        self.points = self.build_points()?;
        self.time = start_time;
        Ok(())
    }

    fn do_step(&mut self, t: f64, h: f64, log: &mut StepLog) -> Result<(), String> {
        let before = self.value(t);
        self.time = t + h;
        let after = self.value(self.time);
        if after != before {
            log.event(format_args!("reference {:.4} um at t = {} s", after * 1e6, self.time));
        }
        Ok(())
    }

    fn save_state(&self, w: &mut Writer) {
        w.f64(self.time);
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        let mut r = Reader::new(bytes, "reference FMU state");
        self.time = r.f64()?;
        // The parameters were restored through the setters; rebuild what they define.
        self.points = self.build_points()?;
        r.finish()
    }
}
