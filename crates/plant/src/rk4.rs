//! A plain fixed-step classical Runge–Kutta integration of the same plant, written from
//! docs/model.md §2 independently of the exact solver: absolute positions, the charge
//! solved from the monotone equation with the play memories held over each step and
//! updated at its end, brake switches located by re-integrating the step to 1 ns.
//!
//! It exists as the benchmark's baseline and as an independent cross-check of the exact
//! solver; it is not used by the FMU.

use crate::analog::chain_rows;
use crate::hysteresis::{play, Hysteresis};
use crate::{Dac, Mode, PlantParams, N_PLAYS};

#[derive(Clone, Copy, Debug, Default)]
struct State {
    x: [f64; 4],
    v: [f64; 4],
    /// Earth, non-earth, extension channels: Bessel output, its rate, amplifier output.
    chain: [[f64; 3]; 3],
}

impl State {
    fn axpy(&self, k: &State, a: f64) -> State {
        let mut s = *self;
        for i in 0..4 {
            s.x[i] += a * k.x[i];
            s.v[i] += a * k.v[i];
        }
        for c in 0..3 {
            for j in 0..3 {
                s.chain[c][j] += a * k.chain[c][j];
            }
        }
        s
    }
}

/// The RK4 plant: same parameters, inputs and outputs as [`crate::Plant`].
#[derive(Clone, Debug)]
pub struct Rk4Plant {
    p: PlantParams,
    h: f64,
    s: State,
    mode: Mode,
    hysteresis: Hysteresis,
    drive_offset: f64,
    time: f64,
}

impl Rk4Plant {
    /// A plant at rest integrated with steps of at most `h` seconds.
    pub fn new(p: PlantParams, h: f64) -> Self {
        let mut s = State::default();
        for i in 0..3 {
            s.x[i] = (i + 1) as f64 * p.l_p / 3.0;
        }
        s.x[3] = p.l_r;
        let hysteresis = Hysteresis::new(p.play_radius, p.play_weight);
        Rk4Plant { p, h, s, mode: Mode::Hold, hysteresis, drive_offset: 0.0, time: 0.0 }
    }

    fn xi(&self, s: &State) -> f64 {
        let kappa = self.p.t_em / self.p.c;
        self.hysteresis.solve_xi(s.chain[2][2] + kappa * (s.x[2] - self.p.l_p))
    }

    fn rates(&self, s: &State, dac: &Dac) -> State {
        let p = &self.p;
        let rows = chain_rows(p);
        let mut d = State::default();
        for (c, u) in [dac.earth, dac.nonearth, dac.extension].into_iter().enumerate() {
            let z = s.chain[c];
            for (j, row) in rows.iter().enumerate() {
                d.chain[c][j] = row[0] * z[0] + row[1] * z[1] + row[2] * z[2] + row[3] * u;
            }
        }
        if self.mode == Mode::Locked {
            return d;
        }
        let (k, c, l) = (3.0 * p.k_p, 3.0 * p.c_p, p.l_p / 3.0);
        let (m1, m3) = (p.m_p / 3.0, p.m_p / 6.0 + p.m_b);
        let (x, v) = (s.x, s.v);
        let f1 = k * (x[0] - l) + c * v[0];
        let f2 = k * (x[1] - x[0] - l) + c * (v[1] - v[0]);
        let f3 = k * (x[2] - x[1] - l) + c * (v[2] - v[1]);
        let f_f = p.k_f * (x[2] - p.l_p) + p.c_f * v[2];
        let f_e = p.k_e * (x[3] - p.l_r) + p.c_e * v[3];
        let kappa = p.t_em / p.c;
        let f_p = p.t_em * (self.xi(s) - kappa * (x[2] - p.l_p));
        d.x = v;
        d.v[0] = (f2 - f1) / m1;
        d.v[1] = (f3 - f2) / m1;
        match self.mode {
            Mode::Hold => {
                d.v[2] = (f_p - f3 - f_f) / m3;
                d.x[3] = 0.0;
            }
            Mode::Free => {
                d.v[2] = (f_p - f3 - f_f) / m3;
                d.v[3] = -f_e / p.m_r;
            }
            Mode::Drive => {
                let f_d = p.f_d0 - p.gamma * p.k_e * (x[3] - p.l_r);
                d.v[2] = (f_p + f_d - f3 - f_f - f_e) / (m3 + p.m_r);
                d.v[3] = d.v[2];
            }
            Mode::Locked => unreachable!(),
        }
        d
    }

    fn rk4(&self, s: &State, dac: &Dac, h: f64) -> State {
        let k1 = self.rates(s, dac);
        let k2 = self.rates(&s.axpy(&k1, h / 2.0), dac);
        let k3 = self.rates(&s.axpy(&k2, h / 2.0), dac);
        let k4 = self.rates(&s.axpy(&k3, h), dac);
        let mut out = s.axpy(&k1, h / 6.0).axpy(&k2, h / 3.0).axpy(&k3, h / 3.0).axpy(&k4, h / 6.0);
        if self.mode == Mode::Drive {
            out.x[3] = out.x[2] + self.drive_offset;
            out.v[3] = out.v[2];
        }
        out
    }

    fn brakes(&self, s: &State) -> Mode {
        Mode::from_brakes(s.chain[0][2] < self.p.v_th, s.chain[1][2] >= self.p.v_th)
    }

    /// Advances by `h` with the DAC volts held.
    pub fn step(&mut self, dac: Dac, h: f64) {
        let end = self.time + h;
        while end - self.time > 1e-15 {
            let dt = self.h.min(end - self.time);
            let next = self.rk4(&self.s, &dac, dt);
            if self.brakes(&next) == self.mode {
                self.accept(next, dt);
                continue;
            }
            // Bisect the step length for the first switch, then take the step just past it.
            let (mut lo, mut hi) = (0.0, dt);
            while hi - lo > 1e-9 {
                let mid = 0.5 * (lo + hi);
                if self.brakes(&self.rk4(&self.s, &dac, mid)) == self.mode {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            let at = self.rk4(&self.s, &dac, hi);
            self.accept(at, hi);
            self.switch(self.brakes(&at));
        }
        self.time = end;
    }

    fn accept(&mut self, s: State, dt: f64) {
        self.s = s;
        self.time += dt;
        let xi = self.xi(&s);
        for i in 0..N_PLAYS {
            self.hysteresis.memory[i] =
                play(self.hysteresis.memory[i], xi, self.hysteresis.radius[i]);
        }
    }

    fn switch(&mut self, mode: Mode) {
        let s = &mut self.s;
        match mode {
            Mode::Locked => s.v = [0.0; 4],
            Mode::Drive => {
                let m3 = self.p.m_p / 6.0 + self.p.m_b;
                self.drive_offset = s.x[3] - s.x[2];
                let v = (m3 * s.v[2] + self.p.m_r * s.v[3]) / (m3 + self.p.m_r);
                s.v[2] = v;
                s.v[3] = v;
            }
            Mode::Hold => s.v[3] = 0.0,
            Mode::Free => {}
        }
        self.mode = mode;
    }

    pub fn encoder_counts(&self) -> i64 {
        ((self.s.x[3] - self.p.l_r) / self.p.q_enc).round() as i64
    }

    pub fn runner_position(&self) -> f64 {
        self.s.x[3] - self.p.l_r
    }

    pub fn mode(&self) -> Mode {
        self.mode
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reference trace through the RK4 plant at 5 µs: an independent integration of
    /// the same equations must agree with it as the exact solver does.
    #[test]
    fn rk4_at_5_us_reproduces_the_reference_trace() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/plant-check-trace-fia20-passive.csv"
        );
        let text = std::fs::read_to_string(path).unwrap();
        let mut plant = Rk4Plant::new(PlantParams::fia20(), 5e-6);
        let mut worst = (0, 0.0);
        for line in text.lines().skip(1) {
            let f: Vec<&str> = line.split(',').collect();
            let v = |i: usize| f[i].parse::<f64>().unwrap();
            plant.step(Dac { earth: v(1), nonearth: v(2), extension: v(3) }, 0.002);
            let d = (plant.encoder_counts() - f[4].parse::<i64>().unwrap()).abs();
            if d > worst.0 {
                worst = (d, v(0));
            }
            assert_eq!(plant.mode() as u8, f[5].parse::<u8>().unwrap(), "mode at t = {}", v(0));
        }
        assert!(
            worst.0 <= 2,
            "RK4 differs from the reference by {} counts at t = {} s",
            worst.0,
            worst.1
        );
    }
}
