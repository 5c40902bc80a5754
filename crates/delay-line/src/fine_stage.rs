//! The fine stage (docs/delay-line.md §3): a PZT stack in its own closed loop, range and
//! bandwidth as parameters, driven by the fringe tracker's estimate through an integrator
//! (type 1) or a double integrator (type 2).
//!
//! The stack follows its command `c` as a first-order lag of bandwidth `f_b`, sampled
//! exactly: `p ← p + (1 − e^{−2π f_b T})(c − p)`; the command is clamped to the range.
//! Type 1 adds `g₁ x̂` to the command each sample: a ramp of rate `r` leaves the residual
//! `r/K_v`, `K_v = g₁/T`. Type 2 also integrates `x̂` into a rate term `g₂ Σ x̂`: a ramp
//! leaves no residual (Franklin, Powell & Workman 1998, §8.4).

use inchworm_declare::{Declare, Declared};

/// Which loop drives the stage.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LoopType {
    /// One integrator: a constant rate leaves `r/K_v`.
    Type1,
    /// Two integrators: a constant rate leaves nothing.
    Type2,
}

/// The stage and its loop, each declared once on its field.
#[derive(Clone, Copy, Debug, PartialEq, Declare)]
pub struct FineStageParams {
    /// A fine PZT stage between the fringe tracker and the inchworm (off: the inchworm alone)
    #[var(name = "fine_stage", start = true)]
    pub enabled: bool,
    /// Full range of the fine stage in optical path
    #[var(name = "fine_range", unit = "m", start = 20e-6, min = 1e-9, max = 1e-2)]
    pub range: f64,
    /// Bandwidth of the fine stage's own position loop
    #[var(name = "fine_bandwidth", unit = "Hz", start = 200.0, min = 1e-3, max = 1e5)]
    pub bandwidth: f64,
    /// Integrator gain a sample of the fine stage's loop on the fringe tracker
    #[var(name = "fine_gain", start = 0.3, min = 1e-6, max = 0.99)]
    pub gain: f64,
    /// Rate-integrator gain a sample (type 2 only; below fine_gain)
    #[var(name = "fine_rate_gain", start = 0.02, min = 0.0, max = 0.99)]
    pub rate_gain: f64,
    /// Loop type: 1 one integrator (a ramp leaves rate/Kv), 2 two (a ramp leaves nothing)
    #[var(name = "fine_loop_type", start = 2, min = 1, max = 2)]
    pub loop_type: u32,
}

impl Default for FineStageParams {
    fn default() -> Self {
        FineStageParams::declared()
    }
}

impl FineStageParams {
    pub fn loop_type(&self) -> LoopType {
        if self.loop_type == 1 {
            LoopType::Type1
        } else {
            LoopType::Type2
        }
    }
}

/// A stage refused its parameters.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FineStageError {
    /// A parameter outside its declared range.
    #[error("fine stage: {name}: {why}")]
    Range { name: &'static str, why: String },
    #[error("fine stage: fine_loop_type {0}: it is 1 (one integrator) or 2 (two)")]
    LoopType(u32),
    #[error("fine stage: fine_rate_gain {rate_gain} must be below fine_gain {gain}")]
    RateGain { rate_gain: f64, gain: f64 },
}

/// The fine stage's state.
#[derive(Clone, Debug)]
pub struct FineStage {
    p: FineStageParams,
    /// Lag factor a sample.
    alpha: f64,
    command: f64,
    rate: f64,
    position: f64,
    saturated: u32,
}

impl FineStage {
    /// A stage at mid-range, sampled every `period` s.
    pub fn new(p: FineStageParams, period: f64) -> Result<FineStage, FineStageError> {
        if let Some((name, why)) = inchworm_declare::out_of_range(&p) {
            return Err(FineStageError::Range { name, why });
        }
        if !(1..=2).contains(&p.loop_type) {
            return Err(FineStageError::LoopType(p.loop_type));
        }
        if p.rate_gain >= p.gain {
            return Err(FineStageError::RateGain { rate_gain: p.rate_gain, gain: p.gain });
        }
        let alpha = 1.0 - (-2.0 * std::f64::consts::PI * p.bandwidth * period).exp();
        Ok(FineStage { p, alpha, command: 0.0, rate: 0.0, position: 0.0, saturated: 0 })
    }

    /// The stage's optical path now (m).
    pub fn position(&self) -> f64 {
        self.position
    }

    /// Samples at which the command hit the range.
    pub fn saturated(&self) -> u32 {
        self.saturated
    }

    /// One sample: the tracker's estimate `x̂` of the residual (None: no fringes, hold),
    /// then the stack moves over the sample toward the new command.
    pub fn step(&mut self, estimate: Option<f64>) {
        if let Some(x) = estimate {
            if self.p.loop_type() == LoopType::Type2 {
                self.rate += self.p.rate_gain * x;
            }
            let half = self.p.range / 2.0;
            let c = self.command + self.p.gain * x + self.rate;
            if c.abs() > half {
                self.saturated += 1;
                // Hold the rate where the range stops it: no wind-up.
                self.rate = 0.0;
            }
            self.command = c.clamp(-half, half);
        }
        self.position += self.alpha * (self.command - self.position);
    }

    pub(crate) fn save_state(&self, w: &mut inchworm_state_bytes::Writer) {
        [self.command, self.rate, self.position].iter().for_each(|v| w.f64(*v));
        w.u64(u64::from(self.saturated));
    }

    pub(crate) fn load_state(
        &mut self,
        r: &mut inchworm_state_bytes::Reader,
    ) -> Result<(), String> {
        for v in [&mut self.command, &mut self.rate, &mut self.position] {
            *v = crate::optics::finite(r.f64()?)?;
        }
        self.saturated = u32::try_from(r.u64()?).map_err(|_| "delay line state: saturations")?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: f64 = 2e-3;

    /// The residual of a ramp of `rate` m/s tracked by the stage alone, after it settles.
    fn ramp_residual(p: FineStageParams, rate: f64) -> f64 {
        let mut s = FineStage::new(p, T).unwrap();
        let mut residual = 0.0;
        for k in 0..20_000 {
            let target = rate * k as f64 * T;
            residual = target - s.position();
            s.step(Some(residual));
        }
        residual
    }

    #[test]
    fn type_1_leaves_rate_over_kv() {
        let rate = 1e-6; // 1 µm/s
        let p = FineStageParams { loop_type: 1, range: 1e-2, ..Default::default() };
        let kv = p.gain / T;
        let e = ramp_residual(p, rate);
        assert!((e - rate / kv).abs() / (rate / kv) < 0.02, "{e:e} vs {:e}", rate / kv);
    }

    #[test]
    fn type_2_leaves_no_residual_on_a_ramp() {
        let rate = 1e-6;
        let p = FineStageParams { range: 1e-2, ..Default::default() };
        let type1 = rate * T / p.gain;
        let e = ramp_residual(p, rate);
        assert!(e.abs() < 0.02 * type1, "{e:e} against type 1's {type1:e}");
    }

    #[test]
    fn the_range_stops_the_stage() {
        let p = FineStageParams { range: 2e-6, ..Default::default() };
        let mut s = FineStage::new(p, T).unwrap();
        for _ in 0..1000 {
            s.step(Some(5e-6));
        }
        assert!((s.position() - 1e-6).abs() < 1e-12);
        assert!(s.saturated() > 0);
        assert!(FineStage::new(FineStageParams { gain: 1.5, ..p }, T).is_err());
    }
}
