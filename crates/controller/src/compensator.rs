//! The asynchronous loop's compensator `C(z) = K (z − a)/(z − 1)` on the move increment,
//! the prefilter, the feedforward with its one-iteration delay, and the discrete loop
//! analysis that chose the gains.
//!
//! One iteration per move: the plant seen by the loop is the integrator `1/(z − 1)` from
//! move distance to position, so the loop gain is `L(z) = K (z − a)/(z − 1)²`: two
//! integrators (zero steady-state error to a constant per-step disturbance) and a lead
//! zero at `a` for phase margin.

/// Gains and flags of the loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gains {
    pub k: f64,
    pub a: f64,
    /// Prefilter pole: `r_f ← p r_f + (1 − p) r`. At `p = a` it cancels the closed-loop
    /// zero, the source of the loop's overshoot to a reference step.
    pub prefilter_pole: f64,
}

impl Default for Gains {
    fn default() -> Self {
        Gains { k: 0.36, a: 0.8, prefilter_pole: 0.8 }
    }
}

/// Loop state between iterations.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Loop {
    started: bool,
    prefiltered: f64,
    previous_reference: f64,
    previous_error: f64,
    feedback: f64,
}

impl Loop {
    /// One control iteration with measured position `y` and reference `r` (m); returns the
    /// move distance. `deadband`: no move while `|r − y|` is below it (integrators frozen).
    pub fn iterate(&mut self, g: &Gains, r: f64, y: f64, prefilter: bool, feedforward: bool, deadband: f64) -> f64 {
        if !self.started {
            // A reference already far away at the start is fed forward, not left to the
            // integrators: start every memory at the measured position.
            self.started = true;
            self.prefiltered = y;
            self.previous_reference = y;
        }
        let r = if prefilter {
            self.prefiltered = g.prefilter_pole * self.prefiltered + (1.0 - g.prefilter_pole) * r;
            self.prefiltered
        } else {
            r
        };
        if (r - y).abs() < deadband {
            self.previous_reference = r;
            return 0.0;
        }
        // With feedforward the reference increment is moved at once and the feedback sees
        // the new reference one iteration later, after that move.
        let (error, ff) = if feedforward { (self.previous_reference - y, r - self.previous_reference) } else { (r - y, 0.0) };
        self.feedback += g.k * (error - g.a * self.previous_error);
        self.previous_error = error;
        self.previous_reference = r;
        self.feedback + ff
    }
}

impl Loop {
    pub(crate) fn save(&self, w: &mut inchworm_state_bytes::Writer) {
        w.u8(u8::from(self.started));
        for v in [self.prefiltered, self.previous_reference, self.previous_error, self.feedback] {
            w.f64(v);
        }
    }

    pub(crate) fn load(r: &mut inchworm_state_bytes::Reader) -> Result<Loop, String> {
        Ok(Loop { started: r.bool()?, prefiltered: r.f64()?, previous_reference: r.f64()?, previous_error: r.f64()?, feedback: r.f64()? })
    }
}

/// Margins of `L(z) = K (z − a)/(z − 1)²` at iteration rate `fs` (Hz).
#[derive(Clone, Copy, Debug)]
pub struct Margins {
    pub crossover_hz: f64,
    pub phase_margin_deg: f64,
    pub gain_margin_db: f64,
    /// −3 dB bandwidth of the closed loop `L/(1 + L)`.
    pub closed_loop_bandwidth_hz: f64,
}

fn loop_gain(g: &Gains, w: f64) -> (f64, f64) {
    // z = e^{jw}; L = K (z − a)/(z − 1)², as (re, im).
    let (c, s) = (w.cos(), w.sin());
    let num = (g.k * (c - g.a), g.k * s);
    let zm1 = (c - 1.0, s);
    let den = (zm1.0 * zm1.0 - zm1.1 * zm1.1, 2.0 * zm1.0 * zm1.1);
    let d2 = den.0 * den.0 + den.1 * den.1;
    ((num.0 * den.0 + num.1 * den.1) / d2, (num.1 * den.0 - num.0 * den.1) / d2)
}

pub fn margins(g: &Gains, fs: f64) -> Margins {
    let n = 200_000;
    let mut crossover = None;
    let mut phase_cross = None;
    let mut bandwidth = None;
    let mut prev: Option<(f64, f64, f64)> = None;
    for i in 1..n {
        let w = std::f64::consts::PI * i as f64 / n as f64;
        let (re, im) = loop_gain(g, w);
        let mag = (re * re + im * im).sqrt();
        // Phase unwrapped into (−360°, 0]: two integrators start at −180°.
        let mut phase = im.atan2(re).to_degrees();
        if phase > 0.0 {
            phase -= 360.0;
        }
        let t_mag = {
            let (tr, ti) = (1.0 + re, im);
            mag / (tr * tr + ti * ti).sqrt()
        };
        if let Some((pm, pp, pt)) = prev {
            if crossover.is_none() && pm >= 1.0 && mag < 1.0 {
                crossover = Some((w, phase));
            }
            if phase_cross.is_none() && pp > -180.0 && phase <= -180.0 && crossover.is_some() {
                phase_cross = Some((w, mag));
            }
            if bandwidth.is_none() && pt >= std::f64::consts::FRAC_1_SQRT_2 && t_mag < std::f64::consts::FRAC_1_SQRT_2 {
                bandwidth = Some(w);
            }
        }
        prev = Some((mag, phase, t_mag));
    }
    if phase_cross.is_none() {
        // L(−1) = −K (1 + a)/4 is real and negative: the phase reaches −180° at Nyquist.
        let (re, im) = loop_gain(g, std::f64::consts::PI);
        phase_cross = Some((std::f64::consts::PI, (re * re + im * im).sqrt()));
    }
    let to_hz = |w: f64| w * fs / (2.0 * std::f64::consts::PI);
    let (wc, pc) = crossover.unwrap_or((f64::NAN, f64::NAN));
    Margins {
        crossover_hz: to_hz(wc),
        phase_margin_deg: 180.0 + pc,
        gain_margin_db: phase_cross.map_or(f64::INFINITY, |(_, m)| -20.0 * m.log10()),
        closed_loop_bandwidth_hz: bandwidth.map_or(f64::NAN, to_hz),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn margins_of_the_implemented_gains_meet_spec_4() {
        let m = margins(&Gains::default(), 5.0);
        eprintln!("{m:?}");
        assert!((m.crossover_hz - 0.30).abs() < 0.02, "crossover {} Hz", m.crossover_hz);
        assert!(m.phase_margin_deg >= 35.0, "phase margin {}°", m.phase_margin_deg);
        assert!((m.phase_margin_deg - 49.0).abs() < 1.5, "phase margin {}° (prototype 49°)", m.phase_margin_deg);
        assert!((m.gain_margin_db - 15.8).abs() < 0.5, "gain margin {} dB (prototype 15.8 dB)", m.gain_margin_db);
        assert!((m.closed_loop_bandwidth_hz - 0.49).abs() < 0.03, "closed-loop bandwidth {} Hz", m.closed_loop_bandwidth_hz);
    }

    #[test]
    fn difference_equation_and_the_two_integrators() {
        let g = Gains::default();
        let mut l = Loop::default();
        // y constant, r steps: first move = K e (no feedforward, no prefilter).
        assert!((l.iterate(&g, 10.0, 0.0, false, false, 0.0) - 3.6).abs() < 1e-12);
        // Second, same error: D = D_prev + K (e − a e_prev) = 3.6 + 0.36·(10 − 8).
        assert!((l.iterate(&g, 10.0, 0.0, false, false, 0.0) - 4.32).abs() < 1e-12);
        // Against a constant per-move disturbance the loop converges with zero error.
        let (mut l, mut y) = (Loop::default(), 0.0);
        for _ in 0..200 {
            let d = l.iterate(&g, 100.0, y, false, false, 0.0);
            y += d + 4.5;
        }
        assert!((y - 100.0).abs() < 1e-6, "final position {y}");
    }

    #[test]
    fn feedforward_moves_the_reference_step_at_once() {
        let g = Gains::default();
        let mut l = Loop::default();
        // Starting at y = 0 with r = 100: the whole step is fed forward, no feedback yet.
        assert!((l.iterate(&g, 100.0, 0.0, false, true, 0.0) - 100.0).abs() < 1e-12);
        // Next iteration at y = 100: no error, no move.
        assert!(l.iterate(&g, 100.0, 100.0, false, true, 0.0).abs() < 1e-12);
    }

    #[test]
    fn prefilter_smooths_and_deadband_stops() {
        let g = Gains::default();
        let mut l = Loop::default();
        let d = l.iterate(&g, 100.0, 0.0, true, true, 0.0);
        assert!((d - 20.0).abs() < 1e-12, "prefiltered step: 20 % at the first iteration, got {d}");
        let mut l = Loop::default();
        assert_eq!(l.iterate(&g, 0.5, 0.0, false, false, 1.0), 0.0);
    }
}
