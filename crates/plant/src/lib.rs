//! The JPL inchworm actuator plant (docs/model.md §2): plain Rust, no FFI, no I/O.
//!
//! The physics and its data live at this floor: the public types and the plant's state
//! (`Dynamics`) here, the parameters in `params`, the analog chain in `analog`, the
//! hysteresis in `hysteresis`, the equations of every mode in `linear`, the state bytes
//! in `state`, the encoder noise in `noise`; the same plant in continuous time, for a
//! master that integrates it (Model Exchange), in `continuous`. How the equations are
//! solved (the event-driven exact propagation, its caches and AVX kernels) is `numerics`,
//! behind [`Plant::step`].

pub mod analog;
pub mod continuous;
pub mod hysteresis;
pub mod linear;
pub mod noise;
mod numerics;
pub mod params;
pub mod rk4;
mod state;

use inchworm_board::DAC_FULL_SCALE;
use inchworm_declare::Declare;

use hysteresis::Hysteresis;
use linear::{ix, Chain, Vector};
use numerics::solver::Armed;
pub use numerics::solver::{StepError, MAX_STEP};
use numerics::Solver;
pub use params::{ParamError, PlantParams, N_PLAYS};

/// Mechanical mode, decided by the two brakes (docs/model.md §2.2). The discriminant is the FMU's `mode` output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    Hold = 1,
    Locked = 2,
    Drive = 3,
    Free = 4,
}

/// DAC output volts driving the three channels, valid range 0–10 V: the plant's inputs,
/// declared once here (value references 1, 2, 3 in this order).
#[derive(Clone, Copy, Debug, Default, PartialEq, Declare)]
pub struct Dac {
    /// Earth-brake DAC output, held over the step (0-10 V)
    #[var(name = "dac_earth", input, unit = "V", start = 0.0, min = 0.0, max = DAC_FULL_SCALE, quantity = "DAC volts", range_name = "DAC range")]
    pub earth: f64,
    /// Non-earth-brake DAC output, held over the step (0-10 V)
    #[var(name = "dac_nonearth", input, unit = "V", start = 0.0, min = 0.0, max = DAC_FULL_SCALE, quantity = "DAC volts", range_name = "DAC range")]
    pub nonearth: f64,
    /// Extension DAC output, held over the step (0-10 V)
    #[var(name = "dac_extension", input, unit = "V", start = 0.0, min = 0.0, max = DAC_FULL_SCALE, quantity = "DAC volts", range_name = "DAC range")]
    pub extension: f64,
}

/// What the plant shows at the current communication point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outputs {
    pub encoder_counts: i64,
    /// encoder_counts × q_enc (m)
    pub encoder_position: f64,
    /// true runner position x4 − L_r (m)
    pub runner_position: f64,
    /// stack elongation x3 − L_p (m)
    pub extension: f64,
    pub voltage_earth: f64,
    pub voltage_nonearth: f64,
    pub voltage_extension: f64,
    pub mode: Mode,
    pub earth_closed: bool,
    pub nonearth_closed: bool,
    /// Number of entries into FREE since the start.
    pub slip_events: u32,
}

/// What happened during one `Plant::step`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepReport {
    /// Brake threshold crossings handled.
    pub brake_events: u32,
    /// Entries into FREE (the runner slipped: not nominal).
    pub slips: u32,
    /// Time (s) of the first brake switch in this step.
    pub first_brake_event: Option<f64>,
    /// Time (s) of the first located event in this step (a brake switch, a slip onset or
    /// end): where the step first changed the discrete state inside it.
    pub first_event: Option<f64>,
    /// The step needed more events than a step may have (chattering at a threshold), so
    /// the rest of it ran without looking for events.
    pub event_budget_exhausted: bool,
}

impl Mode {
    /// The mode the two brakes make (docs/model.md §2.2 table).
    pub fn from_brakes(earth_closed: bool, nonearth_closed: bool) -> Mode {
        match (earth_closed, nonearth_closed) {
            (true, false) => Mode::Hold,
            (true, true) => Mode::Locked,
            (false, true) => Mode::Drive,
            (false, false) => Mode::Free,
        }
    }

    fn index(self) -> usize {
        self as usize - 1
    }
}

/// What changes as the plant runs, and only that: a step that fails restores it whole
/// (`Plant::step`), and `save_state` writes it. The rest of `Plant` is its parameters and
/// caches derived from them.
#[derive(Clone, Debug)]
pub(crate) struct Dynamics {
    time: f64,
    z: Vector,
    earth: Chain,
    nonearth: Chain,
    earth_closed: bool,
    nonearth_closed: bool,
    mode: Mode,
    hysteresis: Hysteresis,
    /// What the event loop watches for in the hysteresis, derived from `hysteresis`
    /// whenever it changes (`sync_hysteresis`, `load_state`).
    armed: Armed,
    /// Runner offset `x4 − x3` frozen at the last entry into DRIVE.
    drive_offset: f64,
    slip_events: u32,
    encoder_counts: i64,
    rng: u64,
}

/// The inchworm plant of docs/model.md §2, advanced by exact piecewise-linear propagation
/// between located events (see `linear`).
#[derive(Clone, Debug)]
pub struct Plant {
    params: PlantParams,
    state: Dynamics,
    /// The propagators and their caches (`numerics`), derived from `params`.
    solver: Solver,
}

/// How many long scans ran and how many the bound proved clear without scanning, how
/// many steps the quiet step took, and how many stops (located events and turns of `ξ`)
/// the event loop made: what a step's cost follows.
#[doc(hidden)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScanStats {
    pub scanned: u64,
    pub skipped: u64,
    pub quiet: u64,
    pub stops: u64,
}

impl Plant {
    /// A plant at rest (docs/model.md §2.7) at time 0; the parameters are validated.
    pub fn new(params: PlantParams) -> Result<Self, ParamError> {
        params.validate()?;
        let mut z = Vector::zeros();
        z[ix::ONE] = 1.0;
        let solver = Solver::new(&params);
        let hysteresis = Hysteresis::new(params.play_radius, params.play_weight);
        let rng = params.noise_seed;
        let armed = Armed::of(&hysteresis);
        Ok(Plant {
            params,
            state: Dynamics {
                time: 0.0,
                z,
                earth: Chain::zeros(),
                nonearth: Chain::zeros(),
                earth_closed: true,
                nonearth_closed: false,
                mode: Mode::Hold,
                hysteresis,
                armed,
                drive_offset: 0.0,
                slip_events: 0,
                encoder_counts: 0,
                rng,
            },
            solver,
        })
    }

    pub fn params(&self) -> &PlantParams {
        &self.params
    }

    /// Simulated time (s).
    pub fn time(&self) -> f64 {
        self.state.time
    }

    pub fn mode(&self) -> Mode {
        self.state.mode
    }

    /// With `true`, every step goes through the event loop (no quiet step) and every scan
    /// looks at every point, as the solver did before the quiet-step bound; the results are
    /// bit-identical either way (the golden-trace and quiet-step tests hold both paths to
    /// the same bits). For benchmarks and tests.
    #[doc(hidden)]
    pub fn set_scan_always(&mut self, on: bool) {
        self.solver.scan_always = on;
    }

    /// Counts of long scans run and skipped so far. For benchmarks and tests.
    #[doc(hidden)]
    pub fn scan_stats(&self) -> ScanStats {
        self.solver.scan_stats
    }

    /// Sets the mechanical state: positions as deviations from rest (`x_i − i L_p/3`,
    /// `x4 − L_r`, m) and velocities (m/s), keeping the mode. In DRIVE the runner's offset
    /// to node 3 is taken from `y`. For tests that start a ring from a given energy.
    #[doc(hidden)]
    pub fn set_mechanics(&mut self, y: [f64; 4], v: [f64; 4]) {
        for (i, j) in [ix::Y1, ix::Y2, ix::Y3, ix::Y4].into_iter().enumerate() {
            self.state.z[j] = y[i];
        }
        for (i, j) in [ix::V1, ix::V2, ix::V3, ix::V4].into_iter().enumerate() {
            self.state.z[j] = v[i];
        }
        self.state.drive_offset = y[3] - y[2];
    }

    /// Play memories (V), for inspection and tests.
    pub fn play_memories(&self) -> [f64; N_PLAYS] {
        self.state.hysteresis.memory
    }

    pub fn outputs(&self) -> Outputs {
        let p = &self.params;
        Outputs {
            encoder_counts: self.state.encoder_counts,
            encoder_position: self.state.encoder_counts as f64 * p.q_enc,
            runner_position: self.state.z[ix::Y4],
            extension: self.state.z[ix::Y3],
            voltage_earth: self.state.earth[2],
            voltage_nonearth: self.state.nonearth[2],
            voltage_extension: self.state.z[ix::VX],
            mode: self.state.mode,
            earth_closed: self.state.earth_closed,
            nonearth_closed: self.state.nonearth_closed,
            slip_events: self.state.slip_events,
        }
    }

    /// Absolute node positions `x1..x4` (m), as docs/model.md §2.3 writes them.
    pub fn positions(&self) -> [f64; 4] {
        let l = self.params.l_p / 3.0;
        [
            l + self.state.z[ix::Y1],
            2.0 * l + self.state.z[ix::Y2],
            3.0 * l + self.state.z[ix::Y3],
            self.params.l_r + self.state.z[ix::Y4],
        ]
    }

    /// `ξ`, the PZT charge in volts (docs/model.md §2.4).
    pub fn charge_voltage(&self) -> f64 {
        linear::xi_row(&self.params, self.state.hysteresis.sticking_weight()).dot(&self.state.z)
    }

    /// Velocities `v1..v4` (m/s).
    pub fn velocities(&self) -> [f64; 4] {
        [self.state.z[ix::V1], self.state.z[ix::V2], self.state.z[ix::V3], self.state.z[ix::V4]]
    }
}
