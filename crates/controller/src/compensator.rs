//! The asynchronous loop's compensator `C(z) = K (z − a)/(z − 1)` on the move increment,
//! the loop that joins it to the [`crate::prefilter`] and the [`crate::feedforward`], and
//! the discrete loop analysis that chose the gains.
//!
//! One iteration per move: the plant seen by the loop is the integrator `1/(z − 1)` from
//! move distance to position, so the loop gain is `L(z) = K (z − a)/(z − 1)²`: two
//! integrators (zero steady-state error to a constant per-step disturbance) and a lead
//! zero at `a` for phase margin.

use inchworm_declare::{Declare, Declared};

use crate::feedforward::Feedforward;
use crate::prefilter::Prefilter;

/// Coefficients of the compensator and the prefilter, each declared once (the controller
/// FMU's parameters; [`crate::Params`] flattens them).
#[derive(Clone, Copy, Debug, PartialEq, Declare)]
pub struct Gains {
    /// K of C(z) = K (z - a)/(z - 1)
    #[var(name = "compensator_gain", start = 0.36)]
    pub k: f64,
    /// a of C(z) = K (z - a)/(z - 1)
    #[var(name = "compensator_zero", start = 0.8)]
    pub a: f64,
    /// Prefilter r_f <- p r_f + (1 - p) r
    ///
    /// At `p = a` it cancels the closed-loop zero, the source of the loop's overshoot to a
    /// reference step.
    #[var(start = 0.8)]
    pub prefilter_pole: f64,
}

impl Default for Gains {
    fn default() -> Self {
        Gains::declared()
    }
}

/// The compensator's difference equation, `D_k = D_{k−1} + K (e_k − a e_{k−1})`: the
/// z-transform of `C(z) = K (z − a)/(z − 1)` from the error to the move distance.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Compensator {
    previous_error: f64,
    output: f64,
}

impl Compensator {
    pub fn step(&mut self, g: &Gains, error: f64) -> f64 {
        self.output += g.k * (error - g.a * self.previous_error);
        self.previous_error = error;
        self.output
    }
}

/// Loop state between iterations: prefilter, feedforward and compensator.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Loop {
    started: bool,
    prefilter: Prefilter,
    feedforward: Feedforward,
    compensator: Compensator,
}

/// The compensator a loop iteration runs on the error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Law {
    /// `C(z) = K (z − a)/(z − 1)` with the [`Gains`]' `k` and `a`: with the plant's own
    /// integrator, two in the loop.
    Lead,
    /// The single-integrator compensator `C(z) = k` (the plant's own integrator is the
    /// loop's only one, `L(z) = k/(z − 1)`): for use with the disturbance map, whose
    /// prediction removes the per-step disturbance the second integrator was there for. The
    /// lead compensator's state is not touched.
    Proportional(f64),
}

impl Loop {
    /// One control iteration with measured position `y` and reference `r` (m); returns the
    /// move distance. `deadband`: no move while `|r − y|` is below it (integrators frozen,
    /// so leaving the band resumes from where the loop was, without a windup kick).
    #[allow(clippy::too_many_arguments)]
    pub fn iterate(
        &mut self,
        law: Law,
        g: &Gains,
        r: f64,
        y: f64,
        prefilter: bool,
        feedforward: bool,
        deadband: f64,
    ) -> f64 {
        if !self.started {
            self.started = true;
            self.prefilter.start(y);
            self.feedforward.start(y);
        }
        let r = if prefilter { self.prefilter.filter(g.prefilter_pole, r) } else { r };
        if (r - y).abs() < deadband {
            self.feedforward.hold(r);
            return 0.0;
        }
        let (error, ff) = self.feedforward.split(r, y, feedforward);
        match law {
            Law::Lead => self.compensator.step(g, error) + ff,
            Law::Proportional(k) => k * error + ff,
        }
    }

    /// No move: the target is held another way (analog mode). The integrators hold, and
    /// the prefilter and the feedforward take `r` as reached, so stepping resumes from it.
    pub fn hold(&mut self, r: f64, y: f64) {
        if !self.started {
            self.started = true;
            self.feedforward.start(y);
        }
        self.prefilter.start(r);
        self.feedforward.hold(r);
    }

    pub(crate) fn save(&self, w: &mut inchworm_state_bytes::Writer) {
        w.u8(u8::from(self.started));
        for v in [
            self.prefilter.state(),
            self.feedforward.previous_reference(),
            self.compensator.previous_error,
            self.compensator.output,
        ] {
            w.f64(v);
        }
    }

    pub(crate) fn load(r: &mut inchworm_state_bytes::Reader) -> Result<Loop, String> {
        Ok(Loop {
            started: r.bool()?,
            prefilter: Prefilter::with_state(r.f64()?),
            feedforward: Feedforward::with_previous(r.f64()?),
            compensator: Compensator { previous_error: r.f64()?, output: r.f64()? },
        })
    }
}

/// Margins of `L(z) = K (z − a)/(z − 1)²` at iteration rate `fs` (Hz).
#[derive(Clone, Copy, Debug)]
pub struct Margins {
    pub crossover_hz: f64,
    pub phase_margin_deg: f64,
    /// At the phase crossover after the gain crossover; for this loop that is Nyquist,
    /// where `L(−1) = −K (1 + a)/4` is real and negative.
    pub gain_margin_db: f64,
    /// −3 dB bandwidth of the closed loop `L/(1 + L)`.
    pub closed_loop_bandwidth_hz: f64,
}

/// `L(e^{jw})` as (re, im).
fn loop_gain(g: &Gains, w: f64) -> (f64, f64) {
    let (c, s) = (w.cos(), w.sin());
    let num = (g.k * (c - g.a), g.k * s);
    let zm1 = (c - 1.0, s);
    let den = (zm1.0 * zm1.0 - zm1.1 * zm1.1, 2.0 * zm1.0 * zm1.1);
    let d2 = den.0 * den.0 + den.1 * den.1;
    ((num.0 * den.0 + num.1 * den.1) / d2, (num.1 * den.0 - num.0 * den.1) / d2)
}

fn magnitude(g: &Gains, w: f64) -> f64 {
    let (re, im) = loop_gain(g, w);
    re.hypot(im)
}

/// Phase in (−360°, 0]: the two integrators start the loop at −180°.
fn phase_deg(g: &Gains, w: f64) -> f64 {
    let (re, im) = loop_gain(g, w);
    let p = im.atan2(re).to_degrees();
    if p > 0.0 {
        p - 360.0
    } else {
        p
    }
}

fn closed_loop_magnitude(g: &Gains, w: f64) -> f64 {
    let (re, im) = loop_gain(g, w);
    re.hypot(im) / (1.0 + re).hypot(im)
}

/// First `w` in (`from`, π] where `f` falls through `level`: a grid to find the bracket
/// (the curves are smooth), then bisection to machine precision, so the margins do not
/// depend on the grid.
fn first_fall_through(f: impl Fn(f64) -> f64, level: f64, from: f64) -> Option<f64> {
    let n = 20_000;
    let w_at = |i: usize| from + (std::f64::consts::PI - from) * i as f64 / n as f64;
    let i = (1..n).find(|&i| f(w_at(i)) >= level && f(w_at(i + 1)) < level)?;
    let (mut lo, mut hi) = (w_at(i), w_at(i + 1));
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if f(mid) >= level {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

pub fn margins(g: &Gains, fs: f64) -> Margins {
    let to_hz = |w: f64| w * fs / (2.0 * std::f64::consts::PI);
    let wc = first_fall_through(|w| magnitude(g, w), 1.0, 0.0);
    let phase_margin_deg = wc.map_or(f64::NAN, |w| 180.0 + phase_deg(g, w));
    // For 0 ≤ a < 1 the phase is −180° + (angle of e^{jw} seen from a) − w > −180° on
    // (0, π): it returns to −180° only at Nyquist. Search anyway, for other coefficients.
    let w180 = wc
        .and_then(|w0| first_fall_through(|w| phase_deg(g, w), -180.0, w0))
        .unwrap_or(std::f64::consts::PI);
    Margins {
        crossover_hz: wc.map_or(f64::NAN, to_hz),
        phase_margin_deg,
        gain_margin_db: -20.0 * magnitude(g, w180).log10(),
        closed_loop_bandwidth_hz: first_fall_through(
            |w| closed_loop_magnitude(g, w),
            std::f64::consts::FRAC_1_SQRT_2,
            0.0,
        )
        .map_or(f64::NAN, to_hz),
    }
}

/// Margins of the single-integrator loop `L(z) = k/(z − 1)` at iteration rate `fs`, in
/// closed form: `|L| = k / (2 sin(w/2))`, `arg L = −90° − w/2`, `L(−1) = −k/2`.
pub fn single_integrator_margins(k: f64, fs: f64) -> Margins {
    let wc = 2.0 * (k / 2.0).asin();
    let to_hz = |w: f64| w * fs / (2.0 * std::f64::consts::PI);
    // Closed loop k/(z − 1 + k): |T|² = k² / (k² + 2(1 − k)(1 − cos w)) = 1/2.
    let c = 1.0 - k * k / (2.0 * (1.0 - k));
    Margins {
        crossover_hz: to_hz(wc),
        phase_margin_deg: 90.0 - (wc / 2.0).to_degrees(),
        gain_margin_db: -20.0 * (k / 2.0).log10(),
        closed_loop_bandwidth_hz: if k < 1.0 && c.abs() <= 1.0 {
            to_hz(c.acos())
        } else {
            fs / 2.0
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_integrator_margins_in_closed_form() {
        let k = 0.6;
        let m = single_integrator_margins(k, 5.0);
        let w = m.crossover_hz * 2.0 * std::f64::consts::PI / 5.0;
        // |k/(e^{jw} − 1)| = 1 and arg = −90° − w/2 at the crossover.
        let (re, im) = (w.cos() - 1.0, w.sin());
        assert!((k / re.hypot(im) - 1.0).abs() < 1e-12);
        let phase = (-im).atan2(re).to_degrees(); // arg(1/(e^{jw} − 1))
        assert!((180.0 + phase - m.phase_margin_deg).abs() < 1e-9, "{phase} {m:?}");
        assert!(
            (m.gain_margin_db - 10.4576).abs() < 1e-4 && (m.phase_margin_deg - 72.54).abs() < 0.01
        );
        assert!((m.crossover_hz - 0.4849).abs() < 1e-4);
    }

    #[test]
    fn margins_of_the_implemented_gains_meet_spec_4() {
        let g = Gains::default();
        let m = margins(&g, 5.0);
        eprintln!("K = {}, a = {}: {m:?}", g.k, g.a);
        // docs/model.md §4 targets; the prototype (same K, a) gave 0.30 Hz, 49°, 15.8 dB, 0.49 Hz.
        assert!(
            (m.crossover_hz - 0.30).abs() < 0.01,
            "crossover {} Hz, expected 0.30 ± 0.01",
            m.crossover_hz
        );
        assert!(m.phase_margin_deg >= 35.0, "phase margin {}°, expected ≥ 35°", m.phase_margin_deg);
        assert!(
            (m.phase_margin_deg - 49.0).abs() < 0.5,
            "phase margin {}°, expected 49 ± 0.5°",
            m.phase_margin_deg
        );
        assert!(
            (m.gain_margin_db - 15.8).abs() < 0.1,
            "gain margin {} dB, expected 15.8 ± 0.1",
            m.gain_margin_db
        );
        assert!(
            (m.closed_loop_bandwidth_hz - 0.49).abs() < 0.01,
            "closed-loop bandwidth {} Hz, expected 0.49 ± 0.01",
            m.closed_loop_bandwidth_hz
        );

        // The same numbers from the closed forms of L(e^{jw}) = K (e^{jw} − a)/(e^{jw} − 1)²:
        // |L| = K √(1 − 2a cos w + a²)/(2 − 2 cos w), arg L + 180° = ∠(e^{jw} − a) − w.
        let wc = m.crossover_hz * 2.0 * std::f64::consts::PI / 5.0;
        let mag = g.k * (1.0 - 2.0 * g.a * wc.cos() + g.a * g.a).sqrt() / (2.0 - 2.0 * wc.cos());
        assert!((mag - 1.0).abs() < 1e-9, "|L| at the crossover: {mag}");
        let pm = (wc.sin().atan2(wc.cos() - g.a) - wc).to_degrees();
        assert!(
            (pm - m.phase_margin_deg).abs() < 1e-9,
            "phase margin {pm}° vs {}°",
            m.phase_margin_deg
        );
        let gm = -20.0 * (g.k * (1.0 + g.a) / 4.0).log10();
        assert!(
            (gm - m.gain_margin_db).abs() < 1e-9,
            "gain margin {gm} dB vs {} dB",
            m.gain_margin_db
        );
        // Closed-loop poles: z² + (K − 2) z + (1 − K a) = 0, complex here, radius √(1 − K a).
        let disc = (g.k - 2.0).powi(2) - 4.0 * (1.0 - g.k * g.a);
        assert!(
            disc < 0.0 && (1.0 - g.k * g.a).sqrt() < 1.0,
            "closed-loop poles must be a stable complex pair"
        );
    }

    /// Crossover and bandwidth are two targets for two coefficients, so they pin K and a;
    /// this shows the neighbours (docs/controller-design.md, "The loop and its analysis").
    #[test]
    fn neighbouring_gains_trade_bandwidth_against_margin() {
        let at = |k: f64, a: f64| margins(&Gains { k, a, prefilter_pole: a }, 5.0);
        for (k, a) in [
            (0.25, 0.8),
            (0.36, 0.8),
            (0.5, 0.8),
            (0.36, 0.7),
            (0.36, 0.9),
            (0.2, 0.7),
            (0.55, 0.85),
        ] {
            let m = at(k, a);
            eprintln!(
                "| {k:.2} | {a:.2} | {:.3} Hz | {:.1}° | {:.1} dB | {:.3} Hz |",
                m.crossover_hz, m.phase_margin_deg, m.gain_margin_db, m.closed_loop_bandwidth_hz
            );
        }
        let (lo, mid, hi) = (at(0.25, 0.8), at(0.36, 0.8), at(0.5, 0.8));
        assert!(
            lo.crossover_hz < mid.crossover_hz && mid.crossover_hz < hi.crossover_hz,
            "crossover rises with K"
        );
        assert!(
            lo.gain_margin_db > mid.gain_margin_db && mid.gain_margin_db > hi.gain_margin_db,
            "gain margin falls with K"
        );
        // A zero nearer 1 puts its lead further below the crossover: more phase margin, but
        // crossover and bandwidth drop below target at the same K; a zero further away
        // costs phase margin towards the 35° floor.
        assert!(at(0.36, 0.9).phase_margin_deg > mid.phase_margin_deg, "phase margin rises with a");
        assert!(at(0.36, 0.7).phase_margin_deg < 40.0, "a = 0.7 leaves under 40° at K = 0.36");
    }

    #[test]
    fn difference_equation_and_the_two_integrators() {
        let g = Gains::default();
        let mut l = Loop::default();
        // y constant, r steps: first move = K e (no feedforward, no prefilter).
        assert!((l.iterate(Law::Lead, &g, 10.0, 0.0, false, false, 0.0) - 3.6).abs() < 1e-12);
        // Second, same error: D = D_prev + K (e − a e_prev) = 3.6 + 0.36·(10 − 8).
        assert!((l.iterate(Law::Lead, &g, 10.0, 0.0, false, false, 0.0) - 4.32).abs() < 1e-12);
        // Against a constant per-move disturbance the loop converges with zero error.
        let (mut l, mut y) = (Loop::default(), 0.0);
        for _ in 0..200 {
            let d = l.iterate(Law::Lead, &g, 100.0, y, false, false, 0.0);
            y += d + 4.5;
        }
        assert!((y - 100.0).abs() < 1e-6, "final position {y}");
    }

    #[test]
    fn feedforward_moves_the_reference_step_at_once() {
        let g = Gains::default();
        let mut l = Loop::default();
        // Starting at y = 0 with r = 100: the whole step is fed forward, no feedback yet.
        assert!((l.iterate(Law::Lead, &g, 100.0, 0.0, false, true, 0.0) - 100.0).abs() < 1e-12);
        // Next iteration at y = 100: no error, no move.
        assert!(l.iterate(Law::Lead, &g, 100.0, 100.0, false, true, 0.0).abs() < 1e-12);
    }

    #[test]
    fn prefilter_smooths_and_deadband_stops() {
        let g = Gains::default();
        let mut l = Loop::default();
        let d = l.iterate(Law::Lead, &g, 100.0, 0.0, true, true, 0.0);
        assert!((d - 20.0).abs() < 1e-12, "prefiltered step: 20 % at the first iteration, got {d}");
        let mut l = Loop::default();
        assert_eq!(l.iterate(Law::Lead, &g, 0.5, 0.0, false, false, 1.0), 0.0);
    }
}
