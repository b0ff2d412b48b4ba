//! Polygon arena used by the district generator: one flat buffer of points, ring ends and
//! polygon ends, reused from building to building so that generation allocates nothing in
//! steady state. Every polygon is oriented on insertion from the outward normal it should
//! have, so callers may list vertices in either cyclic order.
//!
//! # Example
//!
//! ```rust
//! use glam::DVec3;
//! use skylod::model::synth::Mesh;
//!
//! let mut m = Mesh::default();
//! // a unit cube: 6 faces, every normal pointing away from the centre
//! m.cuboid(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z);
//! assert_eq!(m.poly_count(), 6);
//! for p in 0..m.poly_count() {
//!     let ring = m.ring(m.rings_of(p).start);
//!     let c = ring.iter().copied().sum::<DVec3>() / ring.len() as f64;
//!     let n = skylod::model::newell(ring);
//!     assert!(n.dot(c - DVec3::splat(0.5)) > 0.0);
//! }
//! ```

use glam::DVec3;
use std::ops::Range;

/// Flat polygon storage: rings are open (the closing point is implicit).
#[derive(Debug, Default, Clone)]
pub struct Mesh {
    /// All ring vertices.
    pub pts: Vec<DVec3>,
    /// End offset (exclusive) of each ring into `pts`.
    pub ring_end: Vec<u32>,
    /// End offset (exclusive) of each polygon into `ring_end`; the first ring is the exterior.
    pub poly_end: Vec<u32>,
}

impl Mesh {
    /// Forget all polygons, keep the capacity.
    pub fn clear(&mut self) {
        self.pts.clear();
        self.ring_end.clear();
        self.poly_end.clear();
    }

    /// Number of polygons.
    pub fn poly_count(&self) -> u32 {
        self.poly_end.len() as u32
    }

    /// Ring indices of polygon `p` (first = exterior).
    pub fn rings_of(&self, p: u32) -> Range<u32> {
        let p = p as usize;
        let start = if p == 0 {
            0
        } else {
            self.poly_end.get(p - 1).copied().unwrap_or(0)
        };
        let end = self.poly_end.get(p).copied().unwrap_or(start);
        start..end
    }

    /// Vertices of ring `r` (open ring).
    pub fn ring(&self, r: u32) -> &[DVec3] {
        let r = r as usize;
        let start = if r == 0 {
            0
        } else {
            self.ring_end.get(r - 1).copied().unwrap_or(0) as usize
        };
        let end = self.ring_end.get(r).copied().unwrap_or(0) as usize;
        self.pts.get(start..end).unwrap_or(&[])
    }

    /// Append a ring, reversed if needed so that its Newell normal points along `normal`
    /// (exterior) or against it (`hole`).
    fn push_ring(&mut self, pts: &[DVec3], normal: DVec3, hole: bool) {
        let n = crate::model::newell(pts);
        let flip = (n.dot(normal) < 0.0) != hole;
        if flip {
            self.pts.extend(pts.iter().rev());
        } else {
            self.pts.extend_from_slice(pts);
        }
        self.ring_end.push(self.pts.len() as u32);
    }

    /// Start a polygon with exterior ring `pts`, oriented counter-clockwise seen from the side
    /// `normal` points to. Add holes with [`Mesh::hole`], then it is complete (polygons end
    /// where the next begins).
    pub fn poly(&mut self, pts: &[DVec3], normal: DVec3) -> u32 {
        self.push_ring(pts, normal, false);
        self.poly_end.push(self.ring_end.len() as u32);
        self.poly_end.len() as u32 - 1
    }

    /// Add an interior ring to the last polygon (clockwise seen from `normal`); returns the
    /// ring index.
    pub fn hole(&mut self, pts: &[DVec3], normal: DVec3) -> u32 {
        self.push_ring(pts, normal, true);
        if let Some(last) = self.poly_end.last_mut() {
            *last = self.ring_end.len() as u32;
        }
        self.ring_end.len() as u32 - 1
    }

    /// Parallelepiped spanned by `a`, `b`, `c` from `o` (6 faces, outward normals).
    pub fn cuboid(&mut self, o: DVec3, a: DVec3, b: DVec3, c: DVec3) {
        let centre = o + (a + b + c) * 0.5;
        let faces = [
            [o, o + a, o + a + b, o + b],
            [o + c, o + a + c, o + a + b + c, o + b + c],
            [o, o + a, o + a + c, o + c],
            [o + b, o + a + b, o + a + b + c, o + b + c],
            [o, o + b, o + b + c, o + c],
            [o + a, o + a + b, o + a + b + c, o + a + c],
        ];
        for f in faces {
            let fc = (f[0] + f[1] + f[2] + f[3]) * 0.25;
            let n = (f[1] - f[0]).cross(f[3] - f[0]);
            let n = if n.dot(fc - centre) < 0.0 { -n } else { n };
            self.poly(&f, n);
        }
    }

    /// Vertical prism over a convex horizontal base of at most 32 vertices (any orientation) from `base[..].z` up by
    /// `height`: sides, top and bottom, outward normals.
    pub fn prism(&mut self, base: &[DVec3], height: f64) {
        let up = DVec3::Z * height;
        let k = base.len();
        let centre = base.iter().copied().sum::<DVec3>() / k.max(1) as f64;
        for i in 0..k {
            let (Some(&p), Some(&q)) = (base.get(i), base.get((i + 1) % k)) else {
                continue;
            };
            let mid = (p + q) * 0.5;
            let out = DVec3::new(mid.x - centre.x, mid.y - centre.y, 0.0);
            self.poly(&[p, q, q + up, p + up], out);
        }
        self.poly(base, -DVec3::Z);
        let mut top = [DVec3::ZERO; 32];
        let k = k.min(top.len());
        for (t, p) in top.iter_mut().zip(base) {
            *t = *p + up;
        }
        let top = top.get(..k).unwrap_or(&[]);
        self.poly(top, DVec3::Z);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hole_is_opposite_to_exterior() {
        let mut m = Mesh::default();
        let sq = |s: f64| {
            [
                DVec3::new(-s, 0.0, -s),
                DVec3::new(s, 0.0, -s),
                DVec3::new(s, 0.0, s),
                DVec3::new(-s, 0.0, s),
            ]
        };
        let n = -DVec3::Y;
        let p = m.poly(&sq(2.0), n);
        let h = m.hole(&sq(1.0), n);
        assert_eq!(m.rings_of(p), 0..2);
        assert!(crate::model::newell(m.ring(0)).dot(n) > 0.0);
        assert!(crate::model::newell(m.ring(h)).dot(n) < 0.0);
        m.poly(&sq(3.0), -n);
        assert_eq!(m.rings_of(1), 2..3);
        assert!(crate::model::newell(m.ring(2)).dot(n) < 0.0);
    }

    #[test]
    fn prism_is_closed_and_outward() {
        let mut m = Mesh::default();
        let base: Vec<DVec3> = (0..12)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 12.0;
                DVec3::new(a.cos(), a.sin(), 5.0)
            })
            .collect();
        m.prism(&base, 2.0);
        assert_eq!(m.poly_count(), 14);
        let mut sum = DVec3::ZERO;
        for p in 0..m.poly_count() {
            sum += crate::model::newell(m.ring(m.rings_of(p).start));
        }
        // a closed surface has zero total vector area
        assert!(sum.length() < 1e-9);
        let top = m.ring(13);
        assert!(top.iter().all(|p| (p.z - 7.0).abs() < 1e-12));
        assert!(crate::model::newell(top).z > 0.0);
    }
}
