//! The hexagonal segmented mirror: segment centres in the order of hcipy's
//! `make_hexagonal_segmented_aperture` (the order `python/inchworm_segments` numbers the
//! segments `seg0`, `seg1`, …), and the edges neighbouring segments share.

use crate::{check, PhasingError};

/// The most rings: 16 with the centre are 817 segments, an ELT-class primary (ELT has 798).
pub const MAX_RINGS: u32 = 16;

/// A hexagonal mirror of `rings` rings around the centre segment (or the hole where it
/// would be), segments `flat_to_flat` wide across their flats with `gap` between them:
/// the lattice's pitch, centre to centre, is `flat_to_flat + gap`.
#[derive(Clone, Debug, PartialEq)]
pub struct Mirror {
    pub rings: u32,
    pub centre: bool,
    pub flat_to_flat: f64,
    pub gap: f64,
    centres: Vec<[f64; 2]>,
    axial: Vec<(i32, i32)>,
}

/// The edge segments `a < b` share: its midpoint, its direction (unit, along the edge),
/// its normal (unit, from `a` toward `b`) and half its length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Edge {
    pub a: usize,
    pub b: usize,
    pub midpoint: [f64; 2],
    pub along: [f64; 2],
    pub normal: [f64; 2],
    pub half_length: f64,
}

/// The six neighbours of a hexagon in axial coordinates.
const NEIGHBOURS: [(i32, i32); 6] = [(1, 0), (-1, 0), (0, 1), (0, -1), (1, -1), (-1, 1)];

impl Mirror {
    /// Checks the geometry: at least one ring, at most [`MAX_RINGS`]; a positive segment
    /// width below 20 m; a gap from 0 to below the width.
    pub fn new(
        rings: u32,
        centre: bool,
        flat_to_flat: f64,
        gap: f64,
    ) -> Result<Mirror, PhasingError> {
        if !(1..=MAX_RINGS).contains(&rings) {
            return Err(PhasingError::Geometry(format!(
                "rings = {rings}: a segmented mirror has 1 to {MAX_RINGS} rings around its centre (16 with the centre: 817 segments, ELT-class)"
            )));
        }
        check("flat_to_flat", flat_to_flat, 1e-3, 20.0, "m")?;
        let gap = check("gap", gap, 0.0, 1.0, "m")?;
        if gap >= flat_to_flat {
            return Err(PhasingError::Parameter {
                name: "gap",
                value: gap,
                unit: "m",
                why: format!("must be below flat_to_flat, {flat_to_flat} m"),
            });
        }
        let pitch = flat_to_flat + gap;
        let axial: Vec<(i32, i32)> =
            hcipy_order(rings as i32).into_iter().skip(if centre { 0 } else { 1 }).collect();
        let centres = axial
            .iter()
            .map(|&(q, r)| {
                [f64::from(q + r) * pitch * 3f64.sqrt() / 2.0, f64::from(r - q) * pitch / 2.0]
            })
            .collect();
        Ok(Mirror { rings, centre, flat_to_flat, gap, centres, axial })
    }

    /// Segment centres `(x, y)` (m), in hcipy's order.
    pub fn centres(&self) -> &[[f64; 2]] {
        &self.centres
    }

    pub fn segments(&self) -> usize {
        self.centres.len()
    }

    /// Centre to centre of neighbours (m).
    pub fn pitch(&self) -> f64 {
        self.flat_to_flat + self.gap
    }

    /// The RMS over a segment of the distance from its centre along x (or y): a regular
    /// hexagon's `sqrt(5/72)` times its flat-to-flat width. A tip or tilt θ moves the
    /// segment's surface by `θ × lever()` RMS.
    pub fn lever(&self) -> f64 {
        (5.0f64 / 72.0).sqrt() * self.flat_to_flat
    }

    /// Every shared edge, once, `a < b`, ordered by `a` then by `b`.
    pub fn edges(&self) -> Vec<Edge> {
        let index: std::collections::HashMap<(i32, i32), usize> =
            self.axial.iter().enumerate().map(|(i, &qr)| (qr, i)).collect();
        let half_length = self.flat_to_flat / (2.0 * 3f64.sqrt());
        let mut edges = Vec::new();
        for (a, &(q, r)) in self.axial.iter().enumerate() {
            let mut bs: Vec<usize> = NEIGHBOURS
                .iter()
                .filter_map(|(dq, dr)| index.get(&(q + dq, r + dr)).copied())
                .filter(|&b| b > a)
                .collect();
            bs.sort_unstable();
            for b in bs {
                let (ca, cb) = (self.centres[a], self.centres[b]);
                let d = [cb[0] - ca[0], cb[1] - ca[1]];
                let len = d[0].hypot(d[1]);
                let normal = [d[0] / len, d[1] / len];
                edges.push(Edge {
                    a,
                    b,
                    midpoint: [(ca[0] + cb[0]) / 2.0, (ca[1] + cb[1]) / 2.0],
                    along: [-normal[1], normal[0]],
                    normal,
                    half_length,
                });
            }
        }
        edges
    }
}

/// hcipy's `make_hexagonal_grid` order of the axial coordinates `(q, r)`: the centre, then
/// each ring from its top, round the six sides.
fn hcipy_order(rings: i32) -> Vec<(i32, i32)> {
    let mut out = vec![(0, 0)];
    for n in 1..=rings {
        out.extend((1..=n).rev().zip(0..n));
        out.extend((0..n).map(|i| (-i, n)));
        out.extend((1..=n).rev().map(|i| (-n, i)));
        out.extend((-n..0).zip((0..n).map(|i| -i)));
        out.extend((0..n).map(|i| (i, -n)));
        out.extend((-n..0).map(|i| (n, i)));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ring_counts_and_edges() {
        for (rings, n, edges) in [(1, 7, 12), (2, 19, 42), (3, 37, 90), (5, 91, 240)] {
            let m = Mirror::new(rings, true, 1.0, 0.0).unwrap();
            assert_eq!((m.segments(), m.edges().len()), (n, edges), "{rings} rings");
        }
        let jwst = Mirror::new(2, false, 1.32, 0.007).unwrap();
        assert_eq!((jwst.segments(), jwst.edges().len()), (18, 36));
    }

    #[test]
    fn neighbours_are_one_pitch_apart_and_the_order_is_hcipys() {
        let m = Mirror::new(3, true, 1.0, 0.1).unwrap();
        for e in m.edges() {
            let (a, b) = (m.centres()[e.a], m.centres()[e.b]);
            assert!(((b[0] - a[0]).hypot(b[1] - a[1]) - 1.1).abs() < 1e-12);
        }
        // hcipy 0.7.1's segment centres of make_hexagonal_segmented_aperture(2, 1.0, 0.0)
        // (its make_hexagonal_grid(1.0, 2, pointy_top=False)), in its order.
        let h = 3f64.sqrt() / 2.0;
        let hcipy = [
            [0.0, 0.0],
            [h, -0.5],
            [h, 0.5],
            [0.0, 1.0],
            [-h, 0.5],
            [-h, -0.5],
            [0.0, -1.0],
            [2.0 * h, -1.0],
            [2.0 * h, 0.0],
            [2.0 * h, 1.0],
            [h, 1.5],
            [0.0, 2.0],
            [-h, 1.5],
            [-2.0 * h, 1.0],
            [-2.0 * h, 0.0],
            [-2.0 * h, -1.0],
            [-h, -1.5],
            [0.0, -2.0],
            [h, -1.5],
        ];
        let c = Mirror::new(2, true, 1.0, 0.0).unwrap();
        for (k, (ours, theirs)) in c.centres().iter().zip(&hcipy).enumerate() {
            assert!(
                (ours[0] - theirs[0]).abs() < 1e-15 && (ours[1] - theirs[1]).abs() < 1e-15,
                "segment {k}: {ours:?}"
            );
        }
        // Without the centre, the same segments from 1 on (hcipy's starting_ring = 1).
        let hole = Mirror::new(2, false, 1.0, 0.0).unwrap();
        assert_eq!(hole.centres(), &c.centres()[1..]);
    }

    #[test]
    fn bad_geometry_is_refused_by_name() {
        let err = |r, f, g| Mirror::new(r, true, f, g).unwrap_err().to_string();
        assert!(err(0, 1.0, 0.0).starts_with("rings = 0: "));
        assert!(err(17, 1.0, 0.0).starts_with("rings = 17: "));
        assert_eq!(err(1, f64::NAN, 0.0), "flat_to_flat = NaN m: must be finite, 0.001 to 20 m");
        assert_eq!(err(1, 0.5, 0.9), "gap = 0.9 m: must be below flat_to_flat, 0.5 m");
    }
}
