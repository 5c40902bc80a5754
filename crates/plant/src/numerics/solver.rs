//! The event-driven exact solver: propagation by the tabulated `e^{A 2^l tick}`, scans of
//! the watched functionals, bisection to the first event, and the jump conditions.

use super::configs::{product, table, ChainRemainder, Remainder, Whole};
use super::kernels::mul_vec;
use super::propagators::Propagators;
use super::ticks::{ticks_of, TICK};
use crate::hysteresis::Hysteresis;
use crate::linear::{self, ix, Chain, Vector};
use crate::noise::gaussian;
use crate::Dac;
use crate::{Mode, Plant, StepReport};

/// The longest step `Plant::step` takes (s): 1000 s of simulated time is at most 2¹⁹
/// top-level pieces, a fraction of a second of work.
pub const MAX_STEP: f64 = 1000.0;

/// Why `Plant::step` refused or undid a step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StepError {
    /// `h` is not in `(0, MAX_STEP]` (s).
    StepSize { h: f64 },
    /// The state would not have been finite after the step that starts at `time` (s).
    NonFinite { time: f64 },
}

impl std::fmt::Display for StepError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StepError::StepSize { h } => {
                write!(f, "step size {h} s is outside (0, {MAX_STEP}] s")
            }
            StepError::NonFinite { time } => write!(
                f,
                "the step from t = {time} s would leave a non-finite state (the parameters are outside what the solver can represent); the plant is unchanged"
            ),
        }
    }
}

impl std::error::Error for StepError {}

/// A sign change of `ξ̇` whose larger end is below this fraction of the magnitude of its
/// terms is rounding, not a turn (a 3-term dot product rounds to ~1e-16 of it).
const TURN_NOISE: f64 = 1e-12;

/// Stops a step may make inside its pieces per 2 ms of its length: located events and turns
/// of `ξ` (a nominal gait step makes a few dozen). More is pathological (chattering at a
/// threshold, a ring far faster than the scan interval, hysteresis radii far below the ring
/// amplitude): event detection is suspended for the rest of that step and the step reports
/// it. Each stop costs at most one bisection, so this bounds the work of a step by its
/// length.
pub(crate) const EVENTS_PER_2_MS: u32 = 20_000;

/// The event budget of a step of `h` seconds.
fn event_budget(h: f64) -> u32 {
    let periods = (h / 0.002).ceil().max(1.0) as u64;
    u32::try_from(periods.saturating_mul(u64::from(EVENTS_PER_2_MS))).unwrap_or(u32::MAX)
}

/// The play thresholds and the sliding direction the event loop watches, a function of
/// the hysteresis state alone.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Armed {
    up: f64,
    down: f64,
    direction: f64,
    /// `c0` of `u_h = W ξ + c0` (`Hysteresis::offset`).
    c0: f64,
    /// `Hysteresis::keep_interval`.
    keep: (f64, f64),
}

impl Armed {
    pub(crate) fn of(h: &Hysteresis) -> Armed {
        let (up, down) = h.next_thresholds();
        Armed { up, down, direction: Armed::direction(h), c0: h.offset(), keep: h.keep_interval() }
    }

    /// The sliding direction, 0 (of the sign of `ξ̇`) while nothing slides.
    fn direction(h: &Hysteresis) -> f64 {
        f64::from(h.direction) * f64::from(u8::from(h.sliding != 0))
    }

    /// After a change of `h.direction` alone (nothing slides, so only the sign of the zero
    /// changes): as `Armed::of(h)` would give.
    pub(crate) fn sync_direction(&mut self, h: &Hysteresis) {
        self.direction = Armed::direction(h);
    }

    pub(crate) fn c0(&self) -> f64 {
        self.c0
    }

    /// Whether `Hysteresis::sync` at `xi` would keep the memories and the slipping set, from
    /// the cached interval alone (`false` may still keep them).
    pub(crate) fn keeps(&self, xi: f64) -> bool {
        self.keep.0 < xi && xi < self.keep.1
    }
}

/// DAC volts as the plant holds them: clamped to the DAC's range, a non-finite value as 0 V.
pub(crate) fn held_volts(v: f64) -> f64 {
    if v.is_finite() {
        v.clamp(0.0, inchworm_board::DAC_FULL_SCALE)
    } else {
        0.0
    }
}

/// The direction of `ξ` from a value with the sign of `ξ̇`.
pub(crate) fn rate_sign(rate: f64) -> i8 {
    if rate > 0.0 {
        1
    } else if rate < 0.0 {
        -1
    } else {
        0
    }
}

/// What the event loop watches during one piece, frozen at its start.
pub(crate) struct Watch<'a> {
    pub(crate) vth: f64,
    pub(crate) earth_closed: bool,
    pub(crate) nonearth_closed: bool,
    /// The configuration's watched rows (`linear::xi_row`, `linear::drive_rate_row`).
    pub(crate) xi_row: &'a Vector,
    pub(crate) rate_row: &'a Vector,
    pub(crate) direction: f64,
    pub(crate) up: f64,
    pub(crate) down: f64,
}

impl Watch<'_> {
    #[inline(always)]
    pub(crate) fn brakes_changed(&self, e: &Chain, n: &Chain) -> bool {
        self.brakes_changed_at(e[2], n[2])
    }

    /// From the brake volts `V_E`, `V_N`.
    #[inline(always)]
    pub(crate) fn brakes_changed_at(&self, ve: f64, vn: f64) -> bool {
        (ve < self.vth) != self.earth_closed || (vn >= self.vth) != self.nonearth_closed
    }

    /// `ξ` as `xi_row.dot(z)` computes it, from the row's only non-zero entries (`Y3`, `VX`,
    /// `C0`, see `linear::xi_row`): nalgebra's dot adds the other products as ±0 terms in
    /// an order that leaves these three summed as `(p_Y3 + p_VX) + p_C0`, so the value is
    /// the same but for the sign of a zero, and the event loop only compares it (a ±0
    /// compares equal). The state it is taken on is finite, or the step is refused whatever
    /// the decisions (a non-finite state stays non-finite).
    #[inline(always)]
    pub(crate) fn xi(&self, z: &Vector) -> f64 {
        let r = self.xi_row;
        let v = (r[ix::Y3] * z[ix::Y3] + r[ix::VX] * z[ix::VX]) + r[ix::C0] * z[ix::C0];
        debug_assert!(v == r.dot(z) || !v.is_finite());
        v
    }

    /// `rate_row.dot(z)` from its only non-zero entries (`V3`, `BX1`, `VX`, see
    /// `linear::drive_rate_row`), as [`Self::xi`]: `(p_V3 + p_BX1) + p_VX`.
    #[inline(always)]
    pub(crate) fn rate(&self, z: &Vector) -> f64 {
        let r = self.rate_row;
        let v = (r[ix::V3] * z[ix::V3] + r[ix::BX1] * z[ix::BX1]) + r[ix::VX] * z[ix::VX];
        debug_assert!(v == r.dot(z) || !v.is_finite());
        v
    }

    #[inline(always)]
    pub(crate) fn play_event(&self, z: &Vector) -> bool {
        self.play_event_at(self.xi(z), self.rate(z))
    }

    /// `rate` has the sign of `ξ̇`.
    #[inline(always)]
    pub(crate) fn play_event_at(&self, xi: f64, rate: f64) -> bool {
        if self.direction != 0.0 {
            self.direction * rate <= 0.0
                || (self.direction > 0.0 && xi >= self.up)
                || (self.direction < 0.0 && xi <= self.down)
        } else {
            xi >= self.up || xi <= self.down
        }
    }

    /// Whether `ξ`, turning round between two points `dt` apart, may reach a threshold in
    /// between: its excursion beyond the end values is below `dt · max|ξ̇|`.
    #[inline(always)]
    pub(crate) fn extremum_may_cross(
        &self,
        xi0: f64,
        xi1: f64,
        rate0: f64,
        rate1: f64,
        dt: f64,
    ) -> bool {
        let reach = dt * (rate0.abs() + rate1.abs()) * self.xi_row[ix::VX];
        xi0.max(xi1) + reach >= self.up || xi0.min(xi1) - reach <= self.down
    }

    /// Whether a sign change of `ξ̇` between two states is a turn of `ξ` and not rounding:
    /// at rest `ξ̇` is a sum of terms that cancel, and its sign is noise. A turn at the
    /// rounding level has no excursion worth a stop.
    pub(crate) fn turns(&self, z0: &Vector, z1: &Vector, rate0: f64, rate1: f64) -> bool {
        let scale = |z: &Vector| {
            self.rate_row.iter().zip(z.iter()).map(|(r, x)| (r * x).abs()).sum::<f64>()
        };
        rate0.abs().max(rate1.abs()) > TURN_NOISE * scale(z0).max(scale(z1))
    }

    #[inline(always)]
    pub(crate) fn event(&self, z: &Vector, e: &Chain, n: &Chain) -> bool {
        self.brakes_changed(e, n) || self.play_event(z)
    }
}

impl Plant {
    /// Advances by `h` seconds with the DAC volts held (zero-order hold). Volts outside
    /// 0–10 V are clamped and a non-finite value counts as 0 V; the FMU layer refuses
    /// those before they get here.
    ///
    /// `h` must be in `(0, MAX_STEP]`: the work of one step is bounded by `h` (at most one
    /// top-level piece of 1.95 ms per 1.95 ms simulated, plus at most `EVENTS_PER_2_MS` located
    /// events per 2 ms). A step whose state would not be finite (parameters at the edge of
    /// their ranges can make a configuration's propagator overflow) is undone: the plant is
    /// left as it was before the call, and the error says when it happened.
    pub fn step(&mut self, dac: Dac, h: f64) -> Result<StepReport, StepError> {
        if !(h > 0.0 && h <= MAX_STEP) {
            return Err(StepError::StepSize { h });
        }
        if let Some(report) = self.quiet_step(dac, h) {
            return Ok(report);
        }
        let before = self.state.clone();
        let report = self.advance_held(dac, h);
        // Three plain loops: the chained iterator cost ~390 instructions a step.
        let finite = self.state.time.is_finite()
            && self.state.z.iter().all(|v| v.is_finite())
            && self.state.earth.iter().all(|v| v.is_finite())
            && self.state.nonearth.iter().all(|v| v.is_finite());
        if !finite {
            let time = before.time;
            self.state = before;
            return Err(StepError::NonFinite { time });
        }
        Ok(report)
    }

    fn advance_held(&mut self, dac: Dac, h: f64) -> StepReport {
        let mut report = StepReport::default();
        self.state.z[ix::UX] = held_volts(dac.extension);
        self.state.earth[3] = held_volts(dac.earth);
        self.state.nonearth[3] = held_volts(dac.nonearth);
        self.sync_hysteresis();

        let (mut left, rest) = ticks_of(h);
        let mut events = 0u32;
        // Stops inside a piece, events or turns of ξ: what the budget bounds. (`events`
        // alone decides the cached tail, as it always has, so results keep their bits.)
        let mut stops = 0u32;
        let budget = event_budget(h);
        let scan_level = self.solver.chain.scan_level;
        let fine = 1u64 << scan_level;
        let total = left;
        let t0 = self.state.time;
        // The step's first state: a step that stops nowhere ends at its whole-step
        // propagator times this (`whole`), the quiet step's one product.
        let first = (self.state.z, self.state.earth, self.state.nonearth);
        let mut stopless = true;
        while left > 0 {
            let (brakes_before, events_before) = (report.brake_events, events);
            let watching = stops < budget;
            if left >= fine {
                let points = ((left >> scan_level) as usize).min(self.solver.chain.scan_points);
                let clear = if watching { self.scan(points) } else { points };
                if clear > 0 {
                    let key = self.config();
                    let cfg = table(&self.solver.configs, key);
                    let ticks = (clear as u64) << scan_level;
                    self.state.z = cfg.advance(self.state.z, ticks, 0.0);
                    self.state.earth = self.solver.chain.advance(self.state.earth, ticks, 0.0);
                    self.state.nonearth =
                        self.solver.chain.advance(self.state.nonearth, ticks, 0.0);
                    left -= ticks;
                }
                if clear < points {
                    stopless = false;
                    let (consumed, event) = self.piece(scan_level, &mut report);
                    events += u32::from(event);
                    stops += u32::from(event || consumed < fine);
                    left -= consumed;
                }
            } else if events == 0 && self.remainder(left) {
                // The tail below one scan interval in one product, when nothing happens in it.
                // Only in steps without events so far: then the tail is the same for every
                // step of this size and its product is cached, not recomputed.
                left = 0;
            } else if watching && events > 0 {
                // The tail's dyadic pieces, in a step that has had an event (so the cached
                // tail is not tried before each): as many at once as run clear, up to the
                // first that stops.
                stopless = false;
                #[cfg(debug_assertions)]
                let reference = self.pieces_one_by_one(left, report);
                let (consumed, event, stopped) = self.pieces(left, &mut report);
                #[cfg(debug_assertions)]
                {
                    let (plant, r, outcome) = reference;
                    let (mut a, mut b) = (Vec::new(), Vec::new());
                    self.save_state(&mut a);
                    plant.save_state(&mut b);
                    assert!(
                        a == b && r == report && outcome == (consumed, event, stopped),
                        "the tail's pieces in one loop and one at a time differ"
                    );
                }
                events += u32::from(event);
                stops += u32::from(event || stopped);
                left -= consumed;
            } else {
                stopless = false;
                let level = 63 - left.leading_zeros() as usize;
                let (consumed, event) =
                    if watching { self.piece(level, &mut report) } else { self.blind(level) };
                events += u32::from(event);
                stops += u32::from(event || consumed < 1 << level);
                left -= consumed;
            }
            if report.brake_events > brakes_before && report.first_brake_event.is_none() {
                report.first_brake_event = Some(t0 + (total - left) as f64 * TICK);
            }
            if events > events_before && report.first_event.is_none() {
                report.first_event = Some(t0 + (total - left) as f64 * TICK);
            }
        }
        report.event_budget_exhausted = stops >= budget;
        self.solver.scan_stats.stops += u64::from(stops);
        if stopless && self.whole(first, h) {
            // The scans and the tail's test ran on the chain of products; the state is the
            // whole-step product's, as the quiet step's.
        } else if rest > 0.0 {
            let key = self.config();
            let cfg = table(&self.solver.configs, key);
            self.state.z = cfg.advance(self.state.z, 0, rest);
            self.state.earth = self.solver.chain.advance(self.state.earth, 0, rest);
            self.state.nonearth = self.solver.chain.advance(self.state.nonearth, 0, rest);
        }
        if self.state.mode == Mode::Drive {
            // The runner rides on node 3: remove the rounding drift of the two equal rows.
            self.state.z[ix::Y4] = self.state.z[ix::Y3] + self.state.drive_offset;
            self.state.z[ix::V4] = self.state.z[ix::V3];
        }
        self.state.time += h;
        self.sample_encoder();
        report
    }

    /// Advances over `ticks` (less than one scan interval) with one cached propagator if no
    /// event condition and no turn of `ξ` that could reach a threshold lies in it; returns
    /// false (and changes nothing) otherwise, leaving the interval to the dyadic pieces.
    fn remainder(&mut self, ticks: u64) -> bool {
        let key = self.config();
        let cfg = table(&self.solver.configs, key);
        let fresh = |c: &Option<Box<Remainder>>| c.as_ref().is_some_and(|r| r.ticks == ticks);
        if !fresh(&self.solver.remainders[key]) {
            self.solver.remainders[key] =
                Some(Box::new(Remainder { ticks, phi: product(&cfg.phi, ticks) }));
        }
        if self.solver.chain_remainder.as_ref().is_none_or(|r| r.ticks != ticks) {
            self.solver.chain_remainder =
                Some(ChainRemainder { ticks, phi: product(&self.solver.chain.phi, ticks) });
        }
        let phi = &self.solver.remainders[key].as_ref().expect("just filled").phi;
        let chain_phi = &self.solver.chain_remainder.as_ref().expect("just filled").phi;
        let (z1, e1, n1) = (
            mul_vec(phi, &self.state.z),
            mul_vec(chain_phi, &self.state.earth),
            mul_vec(chain_phi, &self.state.nonearth),
        );
        let watch = self.watch(cfg);
        if watch.event(&z1, &e1, &n1) {
            return false;
        }
        let (rate0, rate1) = (watch.rate(&self.state.z), watch.rate(&z1));
        if watch.direction == 0.0
            && rate0 * rate1 < 0.0
            && watch.turns(&self.state.z, &z1, rate0, rate1)
        {
            let (xi0, xi1) = (watch.xi(&self.state.z), watch.xi(&z1));
            if watch.extremum_may_cross(xi0, xi1, rate0, rate1, TICK * ticks as f64) {
                return false;
            }
        }
        (self.state.z, self.state.earth, self.state.nonearth) = (z1, e1, n1);
        true
    }

    /// Sets the state to a whole step of `h` from `first` (the step's first state, in the
    /// current configuration) by the whole-step propagators (`configs::whole_step`), caching
    /// them per configuration; `false` (and nothing changed) for a step they don't cover.
    fn whole(&mut self, first: (Vector, Chain, Chain), h: f64) -> bool {
        let key = self.config();
        let bits = h.to_bits();
        if self.solver.wholes[key].as_ref().is_none_or(|w| w.h != bits) {
            let w = Whole::new(table(&self.solver.configs, key), h);
            match &mut self.solver.wholes[key] {
                // Refilled in place: a master that changes its step allocates nothing.
                Some(b) => **b = w,
                slot => *slot = Some(Box::new(w)),
            }
        }
        if self.solver.chain_whole.as_ref().is_none_or(|w| w.h != bits) {
            self.solver.chain_whole = Some(Whole::new(&self.solver.chain, h));
        }
        let (Some(Some(phi)), Some(Some(chain_phi))) = (
            self.solver.wholes[key].as_ref().map(|w| w.phi.as_ref()),
            self.solver.chain_whole.as_ref().map(|w| w.phi.as_ref()),
        ) else {
            return false;
        };
        (self.state.z, self.state.earth, self.state.nonearth) =
            (mul_vec(phi, &first.0), mul_vec(chain_phi, &first.1), mul_vec(chain_phi, &first.2));
        true
    }

    /// Finest bisection level: event times are located to `rel_tol` seconds of simulated
    /// time (1 ns by default, docs/model.md §2.2 asks for 10 ns or better).
    pub(crate) fn resolution_level(&self) -> usize {
        let ticks = (self.params.rel_tol / TICK).max(1.0);
        (ticks.log2().floor() as usize).min(self.solver.chain.scan_level)
    }

    /// What to watch in the current configuration, whose table is `cfg`: its watched rows
    /// are `ξ` and the sign of `ξ̇` (built from the same parameters, so the same bits).
    pub(crate) fn watch<'a>(&self, cfg: &'a Propagators<{ linear::N }>) -> Watch<'a> {
        let Armed { up, down, direction, .. } = self.state.armed;
        #[cfg(debug_assertions)]
        {
            let fresh = Armed::of(&self.state.hysteresis);
            assert!(fresh.up.to_bits() == up.to_bits() && fresh.down.to_bits() == down.to_bits());
            assert!(fresh.direction.to_bits() == direction.to_bits());
            assert!(fresh.c0.to_bits() == self.state.armed.c0.to_bits());
        }
        debug_assert!(
            cfg.watched[0] == linear::xi_row(&self.params, self.state.hysteresis.sticking_weight())
                && cfg.watched[1] == linear::drive_rate_row(&self.params, self.state.mode)
        );
        debug_assert!((0..linear::N).all(|i| {
            ([ix::Y3, ix::VX, ix::C0].contains(&i) || cfg.watched[0][i] == 0.0)
                && ([ix::V3, ix::BX1, ix::VX].contains(&i) || cfg.watched[1][i] == 0.0)
        }));
        Watch {
            vth: self.params.v_th,
            earth_closed: self.state.earth_closed,
            nonearth_closed: self.state.nonearth_closed,
            xi_row: &cfg.watched[0],
            rate_row: &cfg.watched[1],
            direction,
            up,
            down,
        }
    }

    /// Applies the brake switches and the hysteresis changes found at the current state.
    pub(crate) fn handle_event(&mut self, report: &mut StepReport) {
        let vth = self.params.v_th;
        let earth_closed = self.state.earth[2] < vth;
        let nonearth_closed = self.state.nonearth[2] >= vth;
        report.brake_events += u32::from(earth_closed != self.state.earth_closed)
            + u32::from(nonearth_closed != self.state.nonearth_closed);
        self.state.earth_closed = earth_closed;
        self.state.nonearth_closed = nonearth_closed;
        let mode = Mode::from_brakes(earth_closed, nonearth_closed);
        if mode != self.state.mode {
            self.switch_mode(mode);
            if mode == Mode::Free {
                report.slips += 1;
            }
        }
        self.sync_hysteresis();
    }

    /// The jump conditions of docs/model.md §2.2.
    fn switch_mode(&mut self, mode: Mode) {
        let z = &mut self.state.z;
        match mode {
            Mode::Locked => {
                for i in [ix::V1, ix::V2, ix::V3, ix::V4] {
                    z[i] = 0.0;
                }
            }
            Mode::Drive => {
                let m3 = linear::masses(&self.params).m3;
                let m_r = self.params.m_r;
                self.state.drive_offset = z[ix::Y4] - z[ix::Y3];
                let v = (m3 * z[ix::V3] + m_r * z[ix::V4]) / (m3 + m_r);
                z[ix::V3] = v;
                z[ix::V4] = v;
            }
            Mode::Hold => z[ix::V4] = 0.0,
            Mode::Free => self.state.slip_events += 1,
        }
        self.state.mode = mode;
    }

    /// Brings the play memories and the sliding set up to the current `ξ` and its direction,
    /// and writes the resulting offset `c0` into the state.
    fn sync_hysteresis(&mut self) {
        // The rows of the current configuration, from its table if it has one (same bits).
        let (xi, rate) = match &self.solver.configs[self.config_key()] {
            // The sparse sums of `Watch`: the dense dot products but for the sign of a zero,
            // which neither `sync` nor the keep interval tells from the other.
            Some(cfg) => {
                let watch = self.watch(cfg);
                (watch.xi(&self.state.z), watch.rate(&self.state.z))
            }
            None => (
                linear::xi_row(&self.params, self.state.hysteresis.sticking_weight())
                    .dot(&self.state.z),
                linear::drive_rate_row(&self.params, self.state.mode).dot(&self.state.z),
            ),
        };
        if self.state.armed.keeps(xi) {
            // Inside the keep interval `sync` keeps every memory and slips nothing
            // (`Hysteresis::sync_keeps`); of what it derives only the direction changes,
            // and `Armed` weighs it only for slipping elements. The quiet step's shortcut,
            // taken at the start of every event-loop step and after most of its stops.
            debug_assert!(self.state.hysteresis.sync_keeps(xi, rate_sign(rate)));
            self.state.hysteresis.direction = rate_sign(rate);
            self.state.armed.sync_direction(&self.state.hysteresis);
            debug_assert!({
                let fresh = Armed::of(&self.state.hysteresis);
                fresh.up.to_bits() == self.state.armed.up.to_bits()
                    && fresh.down.to_bits() == self.state.armed.down.to_bits()
                    && fresh.c0.to_bits() == self.state.armed.c0.to_bits()
                    && fresh.direction.to_bits() == self.state.armed.direction.to_bits()
            });
        } else {
            self.state.hysteresis.sync(xi, rate_sign(rate));
            self.state.armed = Armed::of(&self.state.hysteresis);
        }
        self.state.z[ix::C0] = self.state.armed.c0;
    }

    pub(crate) fn sample_encoder(&mut self) {
        let mut x = self.state.z[ix::Y4];
        if self.params.encoder_noise > 0.0 {
            x += self.params.encoder_noise * gaussian(&mut self.state.rng);
        }
        // Half away from zero, as docs/model.md §2.6 asks.
        self.state.encoder_counts = inchworm_board::round_half_away(x / self.params.q_enc) as i64;
    }
}

#[cfg(test)]
mod tests;
