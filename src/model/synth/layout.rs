//! Eixample block layout: each block is a square with chamfered corners (an octagon); its
//! perimeter ring, between the outer octagon and the same octagon offset inward by the
//! building depth, is cut into lots. Each of the 4 chamfers is one corner lot; each straight
//! side is cut into 5 or 6 lots of varied width. Every lot is a trapezoid whose street and
//! courtyard edges are parallel, so flat and gabled roofs over it are planar.
//!
//! Lots are listed starting with the last lot of the west side, then the south-west chamfer,
//! then counter-clockwise around the block, so the first few lots form a street corner.
//!
//! # Example
//!
//! ```rust
//! use skylod::model::synth::{LotEdge, block_lots};
//!
//! let mut lots = Vec::new();
//! block_lots(7, 0, 0, &mut lots);
//! assert!(lots.len() >= 24);
//! assert_eq!(lots[1].edge, LotEdge::Chamfer(0));
//! // the lots tile the perimeter ring: their areas add up to octagon minus courtyard
//! let area: f64 = lots.iter().map(|l| l.area()).sum();
//! assert!(area > 5000.0 && area < 7000.0);
//! ```

use glam::DVec2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Easting of the district's south-west street corner (EPSG:25831, metres).
pub const ORIGIN_X: f64 = 430_000.0;
/// Northing of the district's south-west street corner (EPSG:25831, metres).
pub const ORIGIN_Y: f64 = 4_581_000.0;
/// Ground height (flat terrain), metres.
pub const GROUND_Z: f64 = 12.0;
/// Distance between block centres, metres.
pub const PITCH: f64 = 133.3;
/// Street width between facades, metres.
pub const STREET: f64 = 20.0;
/// Chamfer leg (the corner cut is a 45 degree face of `CHAMFER * sqrt(2)` metres).
pub const CHAMFER: f64 = 15.0;

/// Which edge of the block octagon a lot fronts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LotEdge {
    /// A chamfered corner: 0 = south-west, 1 = south-east, 2 = north-east, 3 = north-west.
    Chamfer(u8),
    /// A straight side: 0 = south, 1 = east, 2 = north, 3 = west; with the lot's position
    /// along it and the side's lot count.
    Side(u8, u8, u8),
}

/// One building lot: trapezoid `o0 -> o1 -> i1 -> i0` (counter-clockwise from above);
/// `o0 -> o1` is the street facade, `i1 -> i0` the courtyard facade.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lot {
    /// Block column.
    pub bx: u32,
    /// Block row.
    pub by: u32,
    /// Index of the lot in its block (listing order).
    pub index: u32,
    /// Street edge start.
    pub o0: DVec2,
    /// Street edge end.
    pub o1: DVec2,
    /// Courtyard edge end (opposite `o1`).
    pub i1: DVec2,
    /// Courtyard edge start (opposite `o0`).
    pub i0: DVec2,
    /// Building depth (distance between street and courtyard edges).
    pub depth: f64,
    /// The block edge the lot fronts.
    pub edge: LotEdge,
}

impl Lot {
    /// Footprint corners, counter-clockwise seen from above.
    pub fn footprint(&self) -> [DVec2; 4] {
        [self.o0, self.o1, self.i1, self.i0]
    }

    /// Footprint area (m^2).
    pub fn area(&self) -> f64 {
        let f = self.footprint().map(|p| p - self.o0);
        let mut a = 0.0;
        for k in 0..4 {
            let (p, q) = (f[k], f[(k + 1) % 4]);
            a += p.x * q.y - q.x * p.y;
        }
        a * 0.5
    }
}

/// Mix seed and integers into one 64-bit seed (SplitMix64 finaliser).
pub fn mix(seed: u64, parts: &[u64]) -> u64 {
    let mut h = seed ^ 0x9E37_79B9_7F4A_7C15;
    for &p in parts {
        h = h.wrapping_add(p).wrapping_add(0x9E37_79B9_7F4A_7C15);
        h = (h ^ (h >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h = (h ^ (h >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        h ^= h >> 31;
    }
    h
}

/// Outer octagon of block (`bx`, `by`), counter-clockwise, vertex k starting edge k
/// (edge 0 = south-west chamfer, 1 = south side, 2 = south-east chamfer, ...).
pub fn block_octagon(bx: u32, by: u32) -> [DVec2; 8] {
    let x0 = ORIGIN_X + STREET * 0.5 + bx as f64 * PITCH;
    let y0 = ORIGIN_Y + STREET * 0.5 + by as f64 * PITCH;
    let s = PITCH - STREET;
    let c = CHAMFER;
    [
        DVec2::new(x0, y0 + c),
        DVec2::new(x0 + c, y0),
        DVec2::new(x0 + s - c, y0),
        DVec2::new(x0 + s, y0 + c),
        DVec2::new(x0 + s, y0 + s - c),
        DVec2::new(x0 + s - c, y0 + s),
        DVec2::new(x0 + c, y0 + s),
        DVec2::new(x0, y0 + s - c),
    ]
}

/// Inward unit normal of a counter-clockwise edge direction.
fn inward(d: DVec2) -> DVec2 {
    DVec2::new(-d.y, d.x)
}

/// Write the lots of block (`bx`, `by`) into `out` (cleared first).
pub fn block_lots(seed: u64, bx: u32, by: u32, out: &mut Vec<Lot>) {
    out.clear();
    let mut rng = ChaCha8Rng::seed_from_u64(mix(seed, &[1, bx as u64, by as u64]));
    let depth = rng.random_range(14.0..17.0);
    let a = block_octagon(bx, by);
    // inner octagon: offset every edge inward by `depth`
    let mut b = [DVec2::ZERO; 8];
    for k in 0..8 {
        let prev = (a[k] - a[(k + 7) % 8]).normalize();
        let next = (a[(k + 1) % 8] - a[k]).normalize();
        let (n1, n2) = (inward(prev), inward(next));
        b[k] = a[k] + (n1 + n2) * (depth / (1.0 + n1.dot(n2)));
    }
    let mut raw: Vec<Lot> = Vec::with_capacity(32);
    for e in 0..8usize {
        let (p, q) = (a[e], a[(e + 1) % 8]);
        let len = (q - p).length();
        let d = (q - p) / len;
        let nin = inward(d);
        if e % 2 == 0 {
            raw.push(Lot {
                bx,
                by,
                index: 0,
                o0: p,
                o1: q,
                i1: b[(e + 1) % 8],
                i0: b[e],
                depth,
                edge: LotEdge::Chamfer((e / 2) as u8),
            });
            continue;
        }
        let n: usize = rng.random_range(5..=6);
        let mut w = [0.0f64; 6];
        for (j, wj) in w.iter_mut().enumerate().take(n) {
            let end = if j == 0 || j + 1 == n { 1.4 } else { 1.0 };
            *wj = end * rng.random_range(0.75..1.25);
        }
        let total: f64 = w.iter().take(n).sum();
        let mut t = 0.0;
        for (j, wj) in w.iter().enumerate().take(n) {
            let t1 = if j + 1 == n {
                len
            } else {
                t + wj / total * len
            };
            let o0 = p + d * t;
            let o1 = p + d * t1;
            let i0 = if j == 0 { b[e] } else { o0 + nin * depth };
            let i1 = if j + 1 == n {
                b[(e + 1) % 8]
            } else {
                o1 + nin * depth
            };
            raw.push(Lot {
                bx,
                by,
                index: 0,
                o0,
                o1,
                i1,
                i0,
                depth,
                edge: LotEdge::Side((e / 2) as u8, j as u8, n as u8),
            });
            t = t1;
        }
    }
    // start with the last lot of the west side so the first lots form the SW street corner
    if let Some(last) = raw.pop() {
        out.push(last);
    }
    out.extend(raw);
    for (i, l) in out.iter_mut().enumerate() {
        l.index = i as u32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lots_are_convex_ccw_trapezoids_with_parallel_edges() {
        let mut lots = Vec::new();
        for s in 0..20 {
            block_lots(s, 3, 2, &mut lots);
            let chamfers = lots
                .iter()
                .filter(|l| matches!(l.edge, LotEdge::Chamfer(_)))
                .count();
            assert_eq!(chamfers, 4);
            for l in &lots {
                let f = l.footprint();
                for k in 0..4 {
                    let e1 = f[(k + 1) % 4] - f[k];
                    let e2 = f[(k + 2) % 4] - f[(k + 1) % 4];
                    assert!(e1.perp_dot(e2) > 0.0, "convex ccw {l:?}");
                    assert!(e1.length() > 1.0, "edge too short {l:?}");
                }
                let so = (l.o1 - l.o0).normalize();
                let si = (l.i0 - l.i1).normalize();
                assert!((so.perp_dot(si)).abs() < 1e-9);
                // courtyard edge is `depth` behind the street edge
                let dist = so.perp_dot(l.i0 - l.o0);
                assert!((dist - l.depth).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn lots_tile_the_ring() {
        let mut lots = Vec::new();
        block_lots(3, 0, 0, &mut lots);
        let oct = block_octagon(0, 0);
        let poly_area = |p: &[DVec2]| {
            let mut a = 0.0;
            for k in 0..p.len() {
                let (u, v) = (p[k] - p[0], p[(k + 1) % p.len()] - p[0]);
                a += u.perp_dot(v);
            }
            a * 0.5
        };
        let d = lots[0].depth;
        let s = PITCH - STREET;
        let outer = poly_area(&oct);
        assert!((outer - (s * s - 2.0 * CHAMFER * CHAMFER)).abs() < 1e-6);
        let sum: f64 = lots.iter().map(Lot::area).sum();
        // inner octagon area via offset formula: A - P d + 8 tan(22.5) d^2
        let perim: f64 = (0..8).map(|k| (oct[(k + 1) % 8] - oct[k]).length()).sum();
        let inner = outer - perim * d + 8.0 * (std::f64::consts::PI / 8.0).tan() * d * d;
        assert!(
            (sum - (outer - inner)).abs() < 1e-6,
            "{sum} vs {}",
            outer - inner
        );
    }

    #[test]
    fn layout_depends_on_seed_only_through_rng() {
        let (mut a, mut b) = (Vec::new(), Vec::new());
        block_lots(1, 0, 0, &mut a);
        block_lots(1, 0, 0, &mut b);
        assert_eq!(a, b);
        block_lots(2, 0, 0, &mut b);
        assert_ne!(a, b);
    }
}
