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

use inchworm_fmi_export::{Kind, Model, ModelInfo, Reader, Row, StepLog, Unit, Variable, Writer};

/// Points the table holds.
pub const MAX_POINTS: usize = 16;

/// `profile` values.
pub const PROFILE_TABLE: i32 = 0;
pub const PROFILE_STEP: i32 = 1;
pub const PROFILE_STAIRCASE: i32 = 2;

/// The Figs. 6-7 staircase: level k (µm) from `100 k` s.
pub const STAIRCASE_UM: [f64; 7] = [100.0, 60.0, 250.0, 245.0, 130.0, 131.5, 20.0];

const M: Option<&str> = Some("m");
const S: Option<&str> = Some("s");

#[rustfmt::skip]
inchworm_fmi_export::table!(ReferenceFmu, TABLE;
    REFERENCE: Variable::output("reference", 1, Kind::Real, M, "Reference position of the runner at the current communication point").discrete().real_out(|m| m.value(m.time)),
    PROFILE: Variable::integer_parameter("profile", 100, PROFILE_TABLE, None, "0 the table (times, positions), 1 the Fig. 5 step (100 um from t = 0), 2 the Figs. 6-7 staircase (100 s per level)").integer(|m| m.profile, |m, x| m.profile = x),
    N_POINTS: Variable::integer_parameter("n_points", 101, 1, None, "Points of the table used (1-16)").integer(|m| m.n_points, |m, x| m.n_points = x),
    RAMP_TIME: Variable::parameter("ramp_time", 102, 0.0, S, "Each change ramps linearly over this time from its point's time (0 = a step)").real(|m| m.ramp_time, |m, x| m.ramp_time = x),
    TIMES_1: Variable::parameter("times[1]", 200, 0.0, S, "Time of point 1 (used when n_points >= 1; increasing)").real(|m| m.times[0], |m, x| m.times[0] = x),
    TIMES_2: Variable::parameter("times[2]", 201, 0.0, S, "Time of point 2 (used when n_points >= 2; increasing)").real(|m| m.times[1], |m, x| m.times[1] = x),
    TIMES_3: Variable::parameter("times[3]", 202, 0.0, S, "Time of point 3 (used when n_points >= 3; increasing)").real(|m| m.times[2], |m, x| m.times[2] = x),
    TIMES_4: Variable::parameter("times[4]", 203, 0.0, S, "Time of point 4 (used when n_points >= 4; increasing)").real(|m| m.times[3], |m, x| m.times[3] = x),
    TIMES_5: Variable::parameter("times[5]", 204, 0.0, S, "Time of point 5 (used when n_points >= 5; increasing)").real(|m| m.times[4], |m, x| m.times[4] = x),
    TIMES_6: Variable::parameter("times[6]", 205, 0.0, S, "Time of point 6 (used when n_points >= 6; increasing)").real(|m| m.times[5], |m, x| m.times[5] = x),
    TIMES_7: Variable::parameter("times[7]", 206, 0.0, S, "Time of point 7 (used when n_points >= 7; increasing)").real(|m| m.times[6], |m, x| m.times[6] = x),
    TIMES_8: Variable::parameter("times[8]", 207, 0.0, S, "Time of point 8 (used when n_points >= 8; increasing)").real(|m| m.times[7], |m, x| m.times[7] = x),
    TIMES_9: Variable::parameter("times[9]", 208, 0.0, S, "Time of point 9 (used when n_points >= 9; increasing)").real(|m| m.times[8], |m, x| m.times[8] = x),
    TIMES_10: Variable::parameter("times[10]", 209, 0.0, S, "Time of point 10 (used when n_points >= 10; increasing)").real(|m| m.times[9], |m, x| m.times[9] = x),
    TIMES_11: Variable::parameter("times[11]", 210, 0.0, S, "Time of point 11 (used when n_points >= 11; increasing)").real(|m| m.times[10], |m, x| m.times[10] = x),
    TIMES_12: Variable::parameter("times[12]", 211, 0.0, S, "Time of point 12 (used when n_points >= 12; increasing)").real(|m| m.times[11], |m, x| m.times[11] = x),
    TIMES_13: Variable::parameter("times[13]", 212, 0.0, S, "Time of point 13 (used when n_points >= 13; increasing)").real(|m| m.times[12], |m, x| m.times[12] = x),
    TIMES_14: Variable::parameter("times[14]", 213, 0.0, S, "Time of point 14 (used when n_points >= 14; increasing)").real(|m| m.times[13], |m, x| m.times[13] = x),
    TIMES_15: Variable::parameter("times[15]", 214, 0.0, S, "Time of point 15 (used when n_points >= 15; increasing)").real(|m| m.times[14], |m, x| m.times[14] = x),
    TIMES_16: Variable::parameter("times[16]", 215, 0.0, S, "Time of point 16 (used when n_points >= 16; increasing)").real(|m| m.times[15], |m, x| m.times[15] = x),
    POSITIONS_1: Variable::parameter("positions[1]", 300, 100e-6, M, "Reference position from point 1").real(|m| m.positions[0], |m, x| m.positions[0] = x),
    POSITIONS_2: Variable::parameter("positions[2]", 301, 0.0, M, "Reference position from point 2").real(|m| m.positions[1], |m, x| m.positions[1] = x),
    POSITIONS_3: Variable::parameter("positions[3]", 302, 0.0, M, "Reference position from point 3").real(|m| m.positions[2], |m, x| m.positions[2] = x),
    POSITIONS_4: Variable::parameter("positions[4]", 303, 0.0, M, "Reference position from point 4").real(|m| m.positions[3], |m, x| m.positions[3] = x),
    POSITIONS_5: Variable::parameter("positions[5]", 304, 0.0, M, "Reference position from point 5").real(|m| m.positions[4], |m, x| m.positions[4] = x),
    POSITIONS_6: Variable::parameter("positions[6]", 305, 0.0, M, "Reference position from point 6").real(|m| m.positions[5], |m, x| m.positions[5] = x),
    POSITIONS_7: Variable::parameter("positions[7]", 306, 0.0, M, "Reference position from point 7").real(|m| m.positions[6], |m, x| m.positions[6] = x),
    POSITIONS_8: Variable::parameter("positions[8]", 307, 0.0, M, "Reference position from point 8").real(|m| m.positions[7], |m, x| m.positions[7] = x),
    POSITIONS_9: Variable::parameter("positions[9]", 308, 0.0, M, "Reference position from point 9").real(|m| m.positions[8], |m, x| m.positions[8] = x),
    POSITIONS_10: Variable::parameter("positions[10]", 309, 0.0, M, "Reference position from point 10").real(|m| m.positions[9], |m, x| m.positions[9] = x),
    POSITIONS_11: Variable::parameter("positions[11]", 310, 0.0, M, "Reference position from point 11").real(|m| m.positions[10], |m, x| m.positions[10] = x),
    POSITIONS_12: Variable::parameter("positions[12]", 311, 0.0, M, "Reference position from point 12").real(|m| m.positions[11], |m, x| m.positions[11] = x),
    POSITIONS_13: Variable::parameter("positions[13]", 312, 0.0, M, "Reference position from point 13").real(|m| m.positions[12], |m, x| m.positions[12] = x),
    POSITIONS_14: Variable::parameter("positions[14]", 313, 0.0, M, "Reference position from point 14").real(|m| m.positions[13], |m, x| m.positions[13] = x),
    POSITIONS_15: Variable::parameter("positions[15]", 314, 0.0, M, "Reference position from point 15").real(|m| m.positions[14], |m, x| m.positions[14] = x),
    POSITIONS_16: Variable::parameter("positions[16]", 315, 0.0, M, "Reference position from point 16").real(|m| m.positions[15], |m, x| m.positions[15] = x),
);

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

    fn table() -> &'static [Row<Self>] {
        &TABLE
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
