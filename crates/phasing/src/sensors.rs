//! Edge sensors: two per shared edge near its ends, each reading the height of segment
//! `a`'s surface minus segment `b`'s at its location, plus a dihedral term (docs/phasing.md).
//!
//! With segment `k`'s surface `z_k(x, y) = p_k + tip_k (y − y_k) + tilt_k (x − x_k)`, a
//! sensor at `s` on the edge of `a` and `b`, normal `n` from `a` toward `b`, reads
//!
//! `z_a(s) − z_b(s) + h (∇z_a − ∇z_b)·n`,   `∇z_k = (tilt_k, tip_k)`,
//!
//! `h` the dihedral gain (m): the height above the surfaces at which a capacitive sensor's
//! plates sit, which turns the two segments' relative slope across the edge (the dihedral
//! angle, which opens or closes the gap at that height) into a reading. The readings are
//! linear in the poses: the interaction matrix [`EdgeSensors::interaction`].

use nalgebra::{DMatrix, DVector};

use crate::geometry::Mirror;
use crate::{check, PhasingError};

/// One sensor: the segments it joins (`a < b`), where it sits and the edge's normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensor {
    pub a: usize,
    pub b: usize,
    pub at: [f64; 2],
    pub normal: [f64; 2],
}

/// A mirror's edge sensors and how they read.
#[derive(Clone, Debug, PartialEq)]
pub struct EdgeSensors {
    pub sensors: Vec<Sensor>,
    /// Dihedral gain `h` (m).
    pub dihedral: f64,
    /// The segment's RMS lever arm ([`Mirror::lever`]): the scale of the tip and tilt
    /// coordinates, so every coordinate of a pose vector is in metres of surface RMS.
    pub lever: f64,
    pub segments: usize,
}

/// Where a sensor sits: this fraction of the edge's length in from each end (0.15: at
/// ±0.35 of the length from the midpoint).
pub const INSET: f64 = 0.15;

impl EdgeSensors {
    /// Two sensors per shared edge, [`INSET`] in from its ends, edge by edge in the
    /// mirror's order (docs/phasing.md); `dihedral` 0 to 0.1 m.
    pub fn new(mirror: &Mirror, dihedral: f64) -> Result<EdgeSensors, PhasingError> {
        let dihedral = check("dihedral", dihedral, 0.0, 0.1, "m")?;
        let mut sensors = Vec::new();
        for e in mirror.edges() {
            for side in [-1.0, 1.0] {
                let t = side * (1.0 - 2.0 * INSET) * e.half_length;
                let at = [e.midpoint[0] + t * e.along[0], e.midpoint[1] + t * e.along[1]];
                sensors.push(Sensor { a: e.a, b: e.b, at, normal: e.normal });
            }
        }
        Ok(EdgeSensors { sensors, dihedral, lever: mirror.lever(), segments: mirror.segments() })
    }

    /// Checks a sensor list given from outside: every sensor on an edge its two segments
    /// share, within the edge's length.
    pub fn check_layout(mirror: &Mirror, sensors: &[Sensor]) -> Result<(), PhasingError> {
        let edges = mirror.edges();
        for (i, s) in sensors.iter().enumerate() {
            let Some(e) = edges.iter().find(|e| (e.a, e.b) == (s.a, s.b)) else {
                return Err(PhasingError::Geometry(format!(
                    "sensor {i} joins segments {} and {}, which share no edge",
                    s.a, s.b
                )));
            };
            let d = [s.at[0] - e.midpoint[0], s.at[1] - e.midpoint[1]];
            let along = d[0] * e.along[0] + d[1] * e.along[1];
            let off = d[0] * e.normal[0] + d[1] * e.normal[1];
            if !(along.abs() <= e.half_length && off.abs() <= 1e-9 * mirror.pitch()) {
                return Err(PhasingError::Geometry(format!(
                    "sensor {i} at ({}, {}) m is not on the edge of segments {} and {}",
                    s.at[0], s.at[1], s.a, s.b
                )));
            }
        }
        Ok(())
    }

    pub fn len(&self) -> usize {
        self.sensors.len()
    }

    pub fn is_empty(&self) -> bool {
        self.sensors.is_empty()
    }

    /// The interaction matrix: rows the sensors, columns per segment `k` its piston
    /// (`3k`), tip × lever (`3k + 1`) and tilt × lever (`3k + 2`), `centres` the mirror's.
    pub fn interaction(&self, centres: &[[f64; 2]]) -> DMatrix<f64> {
        self.sparse(centres).dense()
    }

    /// The same as its rows' six nonzero entries each: what an ELT-class mirror's loop and
    /// reconstructor use (4 800 sensors by 2 451 columns is 94 MB dense, 0.25 % nonzero).
    pub fn sparse(&self, centres: &[[f64; 2]]) -> Interaction {
        let rows = self
            .sensors
            .iter()
            .map(|s| {
                let mut row = [(0, 0.0); 6];
                for (half, (k, sign)) in [(s.a, 1.0), (s.b, -1.0)].into_iter().enumerate() {
                    let c = centres[k];
                    // ∂reading/∂tip = sign (y_s − y_k + h n_y), ∂/∂tilt = sign (x_s − x_k + h n_x).
                    row[3 * half] = (3 * k, sign);
                    row[3 * half + 1] = (
                        3 * k + 1,
                        sign * (s.at[1] - c[1] + self.dihedral * s.normal[1]) / self.lever,
                    );
                    row[3 * half + 2] = (
                        3 * k + 2,
                        sign * (s.at[0] - c[0] + self.dihedral * s.normal[0]) / self.lever,
                    );
                }
                row
            })
            .collect();
        Interaction { rows, columns: 3 * self.segments }
    }

    /// The pose vector of the interaction matrix's columns from poses `[piston, tip, tilt]`.
    pub fn coordinates(&self, poses: &[[f64; 3]]) -> Vec<f64> {
        poses.iter().flat_map(|p| [p[0], p[1] * self.lever, p[2] * self.lever]).collect()
    }

    /// Poses `[piston, tip, tilt]` from a pose vector.
    pub fn poses(&self, u: &[f64]) -> Vec<[f64; 3]> {
        u.chunks_exact(3).map(|c| [c[0], c[1] / self.lever, c[2] / self.lever]).collect()
    }
}

/// An interaction matrix by its rows' nonzero entries `(column, value)`: every sensor reads
/// two segments' three coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct Interaction {
    pub rows: Vec<[(usize, f64); 6]>,
    pub columns: usize,
}

impl Interaction {
    /// The readings of pose vector `u`.
    pub fn apply(&self, u: &DVector<f64>) -> DVector<f64> {
        DVector::from_iterator(
            self.rows.len(),
            self.rows.iter().map(|row| row.iter().map(|&(j, a)| a * u[j]).sum::<f64>()),
        )
    }

    /// `Aᵀ y`.
    pub fn transpose_apply(&self, y: &[f64]) -> DVector<f64> {
        let mut x = DVector::zeros(self.columns);
        for (row, &v) in self.rows.iter().zip(y) {
            for &(j, a) in row {
                x[j] += a * v;
            }
        }
        x
    }

    /// `Aᵀ A`, summed row by row.
    pub fn normal(&self) -> DMatrix<f64> {
        let mut m = DMatrix::zeros(self.columns, self.columns);
        for row in &self.rows {
            for &(i, a) in row {
                for &(j, b) in row {
                    m[(i, j)] += a * b;
                }
            }
        }
        m
    }

    pub fn dense(&self) -> DMatrix<f64> {
        let mut a = DMatrix::zeros(self.rows.len(), self.columns);
        for (r, row) in self.rows.iter().enumerate() {
            for &(j, v) in row {
                a[(r, j)] += v;
            }
        }
        a
    }
}
