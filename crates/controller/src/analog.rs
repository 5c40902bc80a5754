//! Analog mode near the target (docs/model.md §4.2, docs/controller-design.md "Analog
//! mode"): the runner is held in DRIVE (earth open, non-earth closed) and the extension
//! DAC is driven every sample by a loop of its own, instead of stepping.
//!
//! # The loop
//! In DRIVE the runner rides on node 3, so the extension voltage moves it directly: a
//! static gain `g` (m per DAC volt; small-signal ≈ 1.7 µm/V on `fia20`, 2.5 µm/V while the
//! hysteresis elements slip) behind the analog chain (300 Hz Bessel, 475 Hz amplifier) and
//! the lightly damped 2.1 kHz DRIVE mode, which the chain attenuates by about 43 dB. The
//! controller is an integrator on the encoder error,
//!
//! ```text
//! u_k = u_{k−1} + (k_I / g) (r_{k−2} − y_k) + (r_k − r_{k−1}) / g,
//! ```
//!
//! with the reference increment fed forward at once and the feedback comparing the
//! position with the reference of two ticks before (the loop's delay: tick j's volts are
//! held during interval j + 1 and read back at tick j + 2). Seen from the sampler
//! `L(jω) ≈ k_I e^{−jωT} H_b(jω) H_a(jω) / (jωT)` (chain at unity DC gain): an integrator
//! with crossover near `k_I/(2πT)`, one sample of delay and the chain's phase (see
//! [`margins`]: 23.8 Hz, 63.8°, 11.0 dB at the default `k_I` = 0.3).
//!
//! # Sequences
//! Every brake change passes through LOCKED, one channel at a time, each held
//! [`PHASE_SAMPLES`] samples (the 50 V crossing lags the DAC edge by 0.98 ms and the chain
//! is within 0.01 % after 2.98 ms):
//!
//! * **entry** (from parked HOLD): extension to `mid + offset` in HOLD (the stack moves, the
//!   runner is held), non-earth closes (LOCKED), the extension drops to `mid` still in
//!   LOCKED, then the earth opens (DRIVE): the stack force of the drop `offset` is there
//!   when the brake disturbance arrives and cancels it. The error left at the entry is fed
//!   forward in DRIVE, through the chain, not released with the brake (a force step would
//!   ring the 2.1 kHz mode);
//! * **re-centring** (the next command would leave `[band, 10 V − band]`): the last volts
//!   held, earth closes (LOCKED), non-earth opens (HOLD), then entry as above;
//! * **exit** (an error beyond twice `analog_range`): earth closes, non-earth opens, the
//!   extension returns to 0 in HOLD: parked, and stepping resumes.
//!
//! `offset` starts at the stepping estimator's disturbance over `g` and is re-measured
//! after every entry that the reference did not disturb (the volts the loop settled at
//! against the volts it entered with).

use inchworm_declare::{Declare, Declared};

/// Samples each brake phase of a sequence is held (6 ms).
pub const PHASE_SAMPLES: u32 = 3;
/// Samples the extension is given to move in HOLD before the brakes change (10 ms).
pub const MOVE_SAMPLES: u32 = 5;
/// Samples after an entry at which the entry offset is re-measured (60 ms).
pub const LEARN_SAMPLES: u32 = 30;
/// Middle of the extension DAC range (V).
pub const MID: f64 = 5.0;

/// Parameters of analog mode, each declared once (the controller FMU's parameters;
/// [`crate::Params`] flattens them).
#[derive(Clone, Copy, Debug, PartialEq, Declare)]
pub struct AnalogParams {
    /// Analog mode: enter at an iteration with |reference - position| below this, leave above twice it (0 < 2 x range < (5 V - analog_recentre_band) x analog_gain)
    #[var(name = "analog_range", unit = "m", start = 2.5e-6, min = 0.0, max = 2e-5)]
    pub range: f64,
    /// Analog mode: DRIVE gain of the extension the loop is designed on, m per DAC volt (> 0)
    #[var(name = "analog_gain", unit = "m/V", start = 1.7e-6, min = 1e-8, max = 1e-4)]
    pub gain: f64,
    /// Analog mode: integrator gain k_I per sample, u += (k_I / analog_gain) e (0 < k_I < 1)
    #[var(name = "analog_loop_gain", start = 0.3, min = 0.0, max = 1.0)]
    pub loop_gain: f64,
    /// Analog mode: re-centre the extension when its command leaves [band, 10 V - band] (0.5 <= band < 4 V)
    #[var(name = "analog_recentre_band", unit = "V", start = 1.5, min = 0.5, max = 4.0)]
    pub recentre_band: f64,
}

impl Default for AnalogParams {
    fn default() -> Self {
        AnalogParams::declared()
    }
}

impl AnalogParams {
    pub fn validate(&self) -> Result<(), String> {
        if !(self.gain.is_finite() && self.gain > 0.0) {
            return Err(format!("{} must be > 0, got {}", Self::GAIN.name(), self.gain));
        }
        if !(self.loop_gain > 0.0 && self.loop_gain < 1.0) {
            return Err(format!(
                "{} must be in (0, 1), got {}",
                Self::LOOP_GAIN.name(),
                self.loop_gain
            ));
        }
        if !(self.recentre_band >= 0.5 && self.recentre_band < 4.0) {
            return Err(format!(
                "{} must be in [0.5, 4) V, got {}",
                Self::RECENTRE_BAND.name(),
                self.recentre_band
            ));
        }
        let reach = (MID - self.recentre_band) * self.gain;
        if !(self.range > 0.0 && 2.0 * self.range < reach) {
            return Err(format!(
                "{range} must be > 0 and twice it (the exit threshold) below what the extension reaches from mid-range, (5 V − {band}) × {gain} = {reach:e} m, got {}",
                self.range,
                range = Self::RANGE.name(),
                band = Self::RECENTRE_BAND.name(),
                gain = Self::GAIN.name(),
            ));
        }
        Ok(())
    }
}

/// Where the analog mode is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Phase {
    /// Stepping (the gait runs).
    Off,
    /// Entry, sub-phase 0 (extension to `mid + offset` in HOLD) or 1 (non-earth closed,
    /// LOCKED), with the samples left in it.
    Entry(u8, u32),
    /// The next tick sets the extension for DRIVE, still LOCKED: the drop that cancels
    /// the brake disturbance, and the error to take up.
    Enter,
    /// LOCKED with the entry extension, samples left; then the earth opens (DRIVE).
    Drop(u32),
    /// DRIVE, the extension under the loop.
    Hold,
    /// Leaving DRIVE: sub-phase 0 (earth closed, LOCKED) or 1 (non-earth opened, HOLD),
    /// samples left, and whether an entry follows (re-centring) or parking (exit).
    Release(u8, u32, bool),
    /// Extension back to 0 in HOLD, then stepping resumes.
    Park(u32),
}

/// The analog loop's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Analog {
    pub phase: Phase,
    /// Extension command (DAC V).
    pub u: f64,
    /// Extension drop at the entry into DRIVE that cancels the brake disturbance (V).
    pub offset: f64,
    /// The reference at the previous two ticks (m).
    r1: f64,
    r2: f64,
    /// `hold_x + e/g` of the last entry: `offset` is re-measured as this minus the volts
    /// the loop settled at, `LEARN_SAMPLES` after it (0 = nothing to learn).
    entered_with: f64,
    learn: u32,
    /// Hold ticks left before the integrator runs after an entry (the entry's move is
    /// still in flight).
    wait: u32,
    /// Re-centrings and entries so far.
    pub recentres: u32,
    pub entries: u32,
}

impl Analog {
    pub fn new(offset: f64) -> Analog {
        Analog {
            phase: Phase::Off,
            u: 0.0,
            offset,
            r1: 0.0,
            r2: 0.0,
            entered_with: 0.0,
            learn: 0,
            wait: 0,
            recentres: 0,
            entries: 0,
        }
    }

    /// The reference the loop last tracked (m): where the runner was held.
    pub fn tracked(&self) -> f64 {
        self.r1
    }

    pub fn active(&self) -> bool {
        self.phase != Phase::Off
    }

    /// Starts the entry from parked.
    pub fn enter(&mut self) {
        self.phase = Phase::Entry(0, MOVE_SAMPLES);
    }

    fn hold_x(&self) -> f64 {
        MID + self.offset
    }

    /// One tick: encoder position `y`, reference `r` (m); returns the DAC volts for the
    /// next interval. Once the phase is back at `Off` (after the exit's parked samples),
    /// the controller resumes stepping.
    pub fn tick(&mut self, p: &AnalogParams, y: f64, r: f64) -> [f64; 3] {
        match self.phase {
            Phase::Hold => {
                if (r - y).abs() > 2.0 * p.range {
                    self.learn = 0;
                    self.phase = Phase::Release(0, PHASE_SAMPLES, false);
                } else {
                    if r != self.r1 && self.learn < LEARN_SAMPLES {
                        // The reference moved after the entry: nothing clean to learn.
                        self.learn = 0;
                    }
                    if self.learn == LEARN_SAMPLES {
                        // The error at the entry, fed forward now, counts as part of the
                        // volts the loop will settle at.
                        self.entered_with += (r - self.r1) / p.gain;
                    }
                    let integral = if self.wait > 0 {
                        self.wait -= 1;
                        0.0
                    } else {
                        p.loop_gain / p.gain * (self.r2 - y)
                    };
                    let u = self.u + (r - self.r1) / p.gain + integral;
                    if u >= p.recentre_band && u <= 10.0 - p.recentre_band {
                        self.u = u;
                        self.r2 = self.r1;
                        self.r1 = r;
                        if self.learn > 0 {
                            self.learn -= 1;
                            if self.learn == 0 {
                                self.offset = self.entered_with - self.u;
                            }
                        }
                        return [10.0, 10.0, self.u];
                    }
                    // The extension would leave its band: re-centre from where the runner
                    // is, holding the last volts (nothing in flight is frozen half-way);
                    // the re-entry takes up the error, the new reference included.
                    self.recentres += 1;
                    self.learn = 0;
                    self.phase = Phase::Release(0, PHASE_SAMPLES, true);
                }
            }
            Phase::Enter => {
                // Still LOCKED (nothing moves): the extension drops by `offset`, so that the
                // stack force that cancels the brake disturbance is already there when the
                // earth opens. The error left is not taken up here: a move released with
                // the brake would be a force step, ringing the 2.1 kHz DRIVE mode; it is
                // fed forward through the analog chain once in DRIVE.
                self.entered_with = self.hold_x();
                self.u = MID;
                self.phase = Phase::Drop(PHASE_SAMPLES - 1);
                return [0.0, 10.0, self.u];
            }
            Phase::Drop(left) => {
                if left > 1 {
                    self.phase = Phase::Drop(left - 1);
                    return [0.0, 10.0, self.u];
                }
                // The earth opens: DRIVE. The runner is where it was held, so the loop
                // starts from that as its reference: the next tick feeds the error
                // forward. The integrator waits until the entry has arrived.
                self.learn = LEARN_SAMPLES;
                self.wait = 2;
                self.entries += 1;
                self.r1 = y;
                self.r2 = y;
                self.phase = Phase::Hold;
                return [10.0, 10.0, self.u];
            }
            _ => {}
        }
        let (volts, left) = match &mut self.phase {
            Phase::Off | Phase::Hold | Phase::Enter | Phase::Drop(_) => return [0.0; 3],
            Phase::Entry(0, left) => ([0.0, 0.0, MID + self.offset], left),
            Phase::Entry(_, left) => ([0.0, 10.0, MID + self.offset], left),
            Phase::Release(0, left, _) => ([0.0, 10.0, self.u], left),
            Phase::Release(_, left, _) => ([0.0, 0.0, self.u], left),
            Phase::Park(left) => ([0.0; 3], left),
        };
        *left = left.saturating_sub(1);
        if *left == 0 {
            self.phase = match self.phase {
                Phase::Entry(0, _) => Phase::Entry(1, PHASE_SAMPLES),
                Phase::Entry(..) => Phase::Enter,
                Phase::Release(0, _, recentre) => Phase::Release(1, PHASE_SAMPLES, recentre),
                Phase::Release(_, _, true) => Phase::Entry(0, MOVE_SAMPLES),
                Phase::Release(_, _, false) => Phase::Park(MOVE_SAMPLES),
                _ => Phase::Off,
            };
        }
        if self.phase == Phase::Off {
            self.u = 0.0;
        }
        volts
    }

    pub(crate) fn save(&self, w: &mut inchworm_state_bytes::Writer) {
        let (tag, sub, left, flag) = match self.phase {
            Phase::Off => (0, 0, 0, false),
            Phase::Entry(s, l) => (1, s, l, false),
            Phase::Enter => (2, 0, 0, false),
            Phase::Hold => (3, 0, 0, false),
            Phase::Release(s, l, f) => (4, s, l, f),
            Phase::Park(l) => (5, 0, l, false),
            Phase::Drop(l) => (6, 0, l, false),
        };
        w.u8(tag);
        w.u8(sub);
        w.u64(u64::from(left));
        w.u8(u8::from(flag));
        for v in [self.u, self.offset, self.r1, self.r2, self.entered_with] {
            w.f64(v);
        }
        for v in [self.learn, self.wait, self.recentres, self.entries] {
            w.u64(u64::from(v));
        }
    }

    pub(crate) fn load(r: &mut inchworm_state_bytes::Reader) -> Result<Analog, String> {
        let (tag, sub) = (r.u8()?, r.u8()?);
        let left = u32::try_from(r.u64()?).map_err(|_| "controller state: analog count")?;
        let flag = r.bool()?;
        let phase = match tag {
            0 => Phase::Off,
            1 => Phase::Entry(sub, left),
            2 => Phase::Enter,
            3 => Phase::Hold,
            4 => Phase::Release(sub, left, flag),
            5 => Phase::Park(left),
            6 => Phase::Drop(left),
            t => return Err(format!("controller state: invalid analog phase {t}")),
        };
        let mut f = [0.0; 5];
        for v in f.iter_mut() {
            *v = r.f64()?;
        }
        let mut n = [0u32; 4];
        for v in n.iter_mut() {
            *v = u32::try_from(r.u64()?).map_err(|_| "controller state: analog count")?;
        }
        Ok(Analog {
            phase,
            u: f[0],
            offset: f[1],
            r1: f[2],
            r2: f[3],
            entered_with: f[4],
            learn: n[0],
            wait: n[1],
            recentres: n[2],
            entries: n[3],
        })
    }
}

/// Margins of the analog loop (docs/controller-design.md, "Analog mode").
#[derive(Clone, Copy, Debug)]
pub struct Margins {
    pub crossover_hz: f64,
    pub phase_margin_deg: f64,
    /// At the first phase crossover (−180°).
    pub gain_margin_db: f64,
    pub phase_crossover_hz: f64,
}

/// −3 dB frequency of the driver board's Bessel filter and the amplifier's pole (Hz),
/// docs/model.md §2.1: the chain the loop is designed on.
pub const F_BESSEL: f64 = 300.0;
pub const F_AMP: f64 = 475.0;

/// `L(jω) = k e^{−jωT} H_b(jω) H_a(jω) / (jωT)` (chain at unity DC gain) as (magnitude,
/// phase in degrees, unwrapped) at `f` Hz: the integrator `k/(1 − e^{−jωT})` times the
/// DAC's zero-order hold `(1 − e^{−jωT})/(jωT)` and one sample of computation delay
/// `e^{−jωT}`; the static DRIVE gain is folded into `k` (aliasing ignored, valid well
/// below Nyquist, where the margins lie).
pub fn loop_gain(k: f64, f: f64) -> (f64, f64) {
    use std::f64::consts::PI;
    let t = crate::SAMPLE_PERIOD;
    let w = 2.0 * PI * f;
    let wb = 2.0 * PI * F_BESSEL / 1.36165;
    // Bessel 3 wb² / (s² + 3 wb s + 3 wb²) at s = jw.
    let (re, im) = (3.0 * wb * wb - w * w, 3.0 * wb * w);
    let mag_b = 3.0 * wb * wb / re.hypot(im);
    let ph_b = -im.atan2(re);
    let wa = 2.0 * PI * F_AMP;
    let mag_a = 1.0 / (1.0 + (w / wa).powi(2)).sqrt();
    let ph_a = -(w / wa).atan();
    let mag = k / (w * t) * mag_b * mag_a;
    let phase = -90.0 + (-w * t + ph_b + ph_a).to_degrees();
    (mag, phase)
}

/// Crossover, phase margin and gain margin of [`loop_gain`] with loop gain `k`.
pub fn margins(k: f64) -> Margins {
    let bisect = |g: &dyn Fn(f64) -> f64, mut a: f64, mut b: f64| {
        for _ in 0..200 {
            let m = 0.5 * (a + b);
            if (g(a) > 0.0) == (g(m) > 0.0) {
                a = m;
            } else {
                b = m;
            }
        }
        0.5 * (a + b)
    };
    let mag = |f: f64| loop_gain(k, f).0 - 1.0;
    let ph = |f: f64| loop_gain(k, f).1 + 180.0;
    let fc = bisect(&mag, 1e-3, 250.0);
    let fp = bisect(&ph, 1e-3, 250.0);
    Margins {
        crossover_hz: fc,
        phase_margin_deg: 180.0 + loop_gain(k, fc).1,
        gain_margin_db: -20.0 * loop_gain(k, fp).0.log10(),
        phase_crossover_hz: fp,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn margins_of_the_default_analog_loop() {
        let d = AnalogParams::default();
        let m = margins(d.loop_gain);
        eprintln!("analog loop k = {}: {m:?}", d.loop_gain);
        // Crossover k/(2πT) lowered a little by the chain; the phase lags by the delay.
        assert!((20.0..25.0).contains(&m.crossover_hz), "{m:?}");
        assert!(m.phase_margin_deg > 60.0 && m.gain_margin_db > 8.0, "{m:?}");
        // The hysteresis raises the DRIVE gain by up to 1.5x (all elements slipping):
        // still stable with margin.
        let slipping = margins(1.5 * d.loop_gain);
        eprintln!("with the slipping gain: {slipping:?}");
        assert!(slipping.phase_margin_deg > 50.0 && slipping.gain_margin_db > 4.0);
    }

    #[test]
    fn validate_names_the_field() {
        assert_eq!(AnalogParams::default().validate(), Ok(()));
        let bad = AnalogParams { range: 0.0, ..AnalogParams::default() };
        assert!(bad.validate().unwrap_err().starts_with("analog_range"));
    }
}
