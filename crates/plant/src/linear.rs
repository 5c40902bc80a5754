//! The plant as a piecewise linear system, and its exact propagation.
//!
//! Between events (a brake threshold crossing, a play starting to slide, `ξ` reversing
//! while plays slide) every mode with a fixed sliding set is linear time-invariant with
//! the DAC inputs held, so the exact solution over a duration `τ` is `z(τ) = e^{Aτ} z(0)`
//! for the state augmented with its constant inputs. Durations are counted in ticks of
//! 2⁻³⁰ s (0.93 ns); the propagators `e^{A 2^l tick}` are tabulated per configuration,
//! so any duration is a product of at most a few dozen table entries, and bisection for
//! an event walks down the same table, locating it to one tick.

use nalgebra::{SMatrix, SVector};

use crate::analog::chain_rows;
use crate::params::PlantParams;
use crate::Mode;

/// Seconds per tick: 2⁻⁴⁰ s (0.91 ps), fine enough for any event tolerance asked for.
pub const TICK: f64 = 1.0 / (1u64 << 40) as f64;
/// Table levels: level `l` propagates `2^l` ticks; the top level is 2⁻⁹ s = 1.95 ms.
pub const LEVELS: usize = 32;
/// The scan interval at the default tolerance: 2²⁴ ticks = 15.3 µs, a 16th of the period of
/// the fastest mode that moves node 3 appreciably (the ~4 kHz stack-on-flexure mode in
/// HOLD), so `ξ̇` changes sign at most once between two scan points.
pub const DEFAULT_SCAN_LEVEL: usize = 24;

/// Scan level for an event tolerance: each decade below 1 ns halves the scan interval (down
/// to 1.9 µs), so a tighter run also resolves faster turns of `ξ`.
pub fn scan_level(rel_tol: f64) -> usize {
    let decades = (1e-9 / rel_tol).log10().round().max(0.0) as usize;
    DEFAULT_SCAN_LEVEL - decades.min(3)
}

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
    /// Hysteresis offset `c0` in `u_h = W_s ξ + c0`.
    pub const C0: usize = 13;
}

/// Earth and non-earth channels: `[b1, b2, V, u]`, independent of the mechanics.
pub type Chain = SVector<f64, 4>;
pub type ChainMatrix = SMatrix<f64, 4, 4>;

/// `e^{A 2^l tick}` for every level, and the watched functionals `c` seen through the
/// propagator at every scan point, `cᵀ e^{A k Δ}`: scanning a whole top-level piece for
/// events then costs one dot product per functional and point instead of a full
/// propagation per point.
#[derive(Clone, Debug)]
pub struct Propagators<const D: usize> {
    pub a: SMatrix<f64, D, D>,
    pub phi: [SMatrix<f64, D, D>; LEVELS],
    pub watched: Vec<SVector<f64, D>>,
    /// The scan interval Δ is `2^scan_level` ticks; a top-level piece has `scan_points` of them.
    pub scan_level: usize,
    pub scan_points: usize,
    /// `scan[k * watched.len() + o]` = `watched[o]ᵀ e^{A (k+1) Δ}`.
    pub scan: Vec<SVector<f64, D>>,
}

impl<const D: usize> Propagators<D> {
    /// `exp` is the matrix exponential (nalgebra's Padé scaling-and-squaring for the concrete size).
    pub fn new(
        a: SMatrix<f64, D, D>,
        watched: Vec<SVector<f64, D>>,
        scan_level: usize,
        exp: impl Fn(SMatrix<f64, D, D>) -> SMatrix<f64, D, D>,
    ) -> Self {
        // Every level from its own exponential: squaring the finest one 31 times would
        // double its rounding error at each level.
        let phi: [SMatrix<f64, D, D>; LEVELS] = std::array::from_fn(|l| exp(a * (TICK * (1u64 << l) as f64)));
        let step = phi[scan_level];
        let scan_points = 1 << (LEVELS - 1 - scan_level);
        let mut scan = Vec::with_capacity(scan_points * watched.len());
        let mut rows: Vec<SVector<f64, D>> = watched.clone();
        for _ in 0..scan_points {
            for r in rows.iter_mut() {
                *r = step.transpose() * *r;
                scan.push(*r);
            }
        }
        Propagators { a, phi, watched, scan_level, scan_points, scan }
    }

    /// Exact propagation over `ticks`, plus the sub-tick remainder `rest` seconds (< 1 tick)
    /// by a second-order Taylor step, whose error there is below 1e-20 of the state.
    pub fn advance(&self, mut z: SVector<f64, D>, mut ticks: u64, rest: f64) -> SVector<f64, D> {
        let top = 1u64 << (LEVELS - 1);
        while ticks >= 2 * top {
            z = self.phi[LEVELS - 1] * z;
            ticks -= top;
        }
        for l in 0..LEVELS {
            if ticks & (1 << l) != 0 {
                z = self.phi[l] * z;
            }
        }
        if rest > 0.0 {
            let az = self.a * z;
            z += az * rest + self.a * az * (0.5 * rest * rest);
        }
        z
    }

    /// Watched functional `o` at scan point `k` (1-based) from the state `z` at scan point 0.
    #[inline]
    pub fn scanned(&self, k: usize, o: usize, z: &SVector<f64, D>) -> f64 {
        self.scan[(k - 1) * self.watched.len() + o].dot(z)
    }
}

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

/// Masses of the lumped model (SPEC 2.3).
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

/// Rate matrix of the mechanics plus the extension channel in `mode`, with sliding plays
/// of total weight `w_s` (SPEC 2.3, 2.4, 2.5).
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
    // F_p = T_em (ξ − κδ) with ξ = (V_X + κδ − c0)/(1 + W_s): sliding plays soften the stack.
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

/// Row giving `ξ` from the state, for a configuration with sliding weight `w_s`.
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
