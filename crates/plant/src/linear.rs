//! The plant as a piecewise linear system: its state vector and the rate matrices of each
//! mode (docs/model.md §2); their exact propagation is `numerics::propagators`.
//!
//! Between events (a brake threshold crossing, a hysteresis element starting to slip, `ξ`
//! reversing while elements slip) every mode with a fixed slipping set is linear time-invariant with
//! the DAC inputs held, so the exact solution over a duration `τ` is `z(τ) = e^{Aτ} z(0)`
//! for the state augmented with its constant inputs.

use nalgebra::{SMatrix, SVector};

use crate::analog::chain_rows;
use crate::params::PlantParams;
use crate::Mode;

pub const N: usize = 14;
pub type Vector = SVector<f64, N>;
pub type Matrix = SMatrix<f64, N, N>;

/// Indices into the mechanical state vector. Positions are deviations from rest:
/// `y_i = x_i − i L_p/3` for the stack nodes and `y4 = x4 − L_r` for the runner.
pub mod ix {
    pub const Y1: usize = 0;
    pub const V1: usize = 1;
    pub const Y2: usize = 2;
    pub const V2: usize = 3;
    pub const Y3: usize = 4;
    pub const V3: usize = 5;
    pub const Y4: usize = 6;
    pub const V4: usize = 7;
    /// Extension channel: Bessel output, its rate, amplifier output `V_X`.
    pub const BX1: usize = 8;
    pub const BX2: usize = 9;
    pub const VX: usize = 10;
    /// Constant inputs carried as states with zero derivative.
    pub const ONE: usize = 11;
    pub const UX: usize = 12;
    /// Hysteresis offset `c0` in `u_h = W ξ + c0`.
    pub const C0: usize = 13;
}

/// Earth and non-earth channels: `[b1, b2, V, u]`, independent of the mechanics.
pub type Chain = SVector<f64, 4>;
pub type ChainMatrix = SMatrix<f64, 4, 4>;

/// Rate matrix of one analog channel.
pub fn chain_matrix(p: &PlantParams) -> ChainMatrix {
    let rows = chain_rows(p);
    let mut m = ChainMatrix::zeros();
    for (r, row) in rows.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            m[(r, c)] = *v;
        }
    }
    m
}

/// Masses of the lumped model (docs/model.md §2.3).
pub struct Masses {
    pub m1: f64,
    pub m3: f64,
}

pub fn masses(p: &PlantParams) -> Masses {
    Masses { m1: p.m_p / 3.0, m3: p.m_p / 6.0 + p.m_b }
}

/// `κ = T_em / C`: volts of `ξ` per metre of stack elongation.
pub fn kappa(p: &PlantParams) -> f64 {
    p.t_em / p.c
}

/// Rate matrix of the mechanics plus the extension channel in `mode`, with sticking
/// hysteresis elements of total weight `w_s` (docs/model.md §2.3, §2.4, §2.5).
pub fn system_matrix(p: &PlantParams, mode: Mode, w_s: f64) -> Matrix {
    use ix::*;
    let mut a = Matrix::zeros();
    let rows = chain_rows(p);
    for (r, row) in rows.iter().enumerate() {
        a[(BX1 + r, BX1)] = row[0];
        a[(BX1 + r, BX2)] = row[1];
        a[(BX1 + r, VX)] = row[2];
        a[(BX1 + r, UX)] = row[3];
    }
    if mode == Mode::Locked {
        return a;
    }
    let k = 3.0 * p.k_p;
    let c = 3.0 * p.c_p;
    let Masses { m1, m3 } = masses(p);
    let kap = kappa(p);
    // Forces as rows over the state: tension positive, deviations from rest cancel `l`.
    let row = |pairs: &[(usize, f64)]| {
        let mut r = SVector::<f64, N>::zeros();
        for &(i, v) in pairs {
            r[i] += v;
        }
        r
    };
    let f1 = row(&[(Y1, k), (V1, c)]);
    let f2 = row(&[(Y2, k), (Y1, -k), (V2, c), (V1, -c)]);
    let f3 = row(&[(Y3, k), (Y2, -k), (V3, c), (V2, -c)]);
    let f_f = row(&[(Y3, p.k_f), (V3, p.c_f)]);
    let g = p.t_em / (1.0 + w_s);
    // F_p = T_em (ξ − κδ) with ξ = (V_X + κδ − c0)/(1 + W): sticking elements stiffen the stack.
    let f_p = row(&[(VX, g), (C0, -g), (Y3, -g * w_s * kap)]);
    let f_e = row(&[(Y4, p.k_e), (V4, p.c_e)]);
    let f_d = row(&[(ONE, p.f_d0), (Y4, -p.gamma * p.k_e)]);
    let set_row = |a: &mut Matrix, i: usize, r: &SVector<f64, N>| {
        for j in 0..N {
            a[(i, j)] = r[j];
        }
    };
    a[(Y1, V1)] = 1.0;
    a[(Y2, V2)] = 1.0;
    a[(Y3, V3)] = 1.0;
    set_row(&mut a, V1, &((f2 - f1) / m1));
    set_row(&mut a, V2, &((f3 - f2) / m1));
    match mode {
        Mode::Hold | Mode::Free => {
            set_row(&mut a, V3, &((f_p - f3 - f_f) / m3));
            if mode == Mode::Free {
                a[(Y4, V4)] = 1.0;
                set_row(&mut a, V4, &(-f_e / p.m_r));
            }
        }
        Mode::Drive => {
            let a3 = (f_p + f_d - f3 - f_f - f_e) / (m3 + p.m_r);
            set_row(&mut a, V3, &a3);
            a[(Y4, V4)] = 1.0;
            set_row(&mut a, V4, &a3);
        }
        Mode::Locked => unreachable!(),
    }
    a
}

/// Row giving `ξ` from the state, for a configuration with sticking weight `w_s`.
pub fn xi_row(p: &PlantParams, w_s: f64) -> Vector {
    let mut r = Vector::zeros();
    let s = 1.0 / (1.0 + w_s);
    r[ix::VX] = s;
    r[ix::Y3] = s * kappa(p);
    r[ix::C0] = -s;
    r
}

/// Row whose sign is the sign of `ξ̇` in every configuration: `V̇_X + κ v3`.
pub fn drive_rate_row(p: &PlantParams, mode: Mode) -> Vector {
    let rows = chain_rows(p);
    let mut r = Vector::zeros();
    r[ix::BX1] = rows[2][0];
    r[ix::VX] = rows[2][2];
    if mode != Mode::Locked {
        r[ix::V3] = kappa(p);
    }
    r
}
