//! Triangulation of 3D polygons with holes (ear clipping with `earcutr`).
//!
//! The polygon is projected on the plane of the Newell normal of its exterior ring
//! (a proper orthonormal 2D basis, so non-planar rings and vertical walls work), the
//! 2D rings are ear-clipped, and the triangles are emitted with the *original* 3D
//! vertices, so that neighbouring polygons sharing vertices stay watertight.
//!
//! Input hygiene: non-finite points are skipped, consecutive duplicates (and a closing
//! point equal to the first) are removed; a ring left with fewer than 3 points, or
//! whose points are all collinear (zero area), contributes nothing: a degenerate
//! exterior yields 0 triangles, a degenerate hole is ignored. Nothing panics.

use crate::model::{newell, Polygon};
use glam::{DVec2, DVec3};

/// Relative tolerance (times the squared ring extent) below which an area is zero.
const AREA_EPS: f64 = 1e-12;

/// Triangulate `p` (exterior minus holes) and append the triangles to `out`.
///
/// Returns the number of triangles added. Triangles are oriented like the exterior
/// ring (counter-clockwise around its Newell normal).
///
/// # Example
/// ```rust
/// use glam::DVec3;
/// use skylod::model::triangulate;
/// use skylod::model::Polygon;
/// let sq = |s: f64, o: f64| vec![
///     DVec3::new(o, o, 3.0), DVec3::new(o + s, o, 3.0),
///     DVec3::new(o + s, o + s, 3.0), DVec3::new(o, o + s, 3.0),
/// ];
/// let mut p = Polygon::new(sq(4.0, 0.0));
/// p.push_interior(&sq(1.0, 1.0));
/// let mut tris = Vec::new();
/// let n = triangulate(&p, &mut tris);
/// assert_eq!(n, tris.len());
/// let area: f64 = tris.iter().map(|t| (t[1] - t[0]).cross(t[2] - t[0]).length() / 2.0).sum();
/// assert!((area - 15.0).abs() < 1e-9);
/// ```
pub fn triangulate(p: &Polygon, out: &mut Vec<[DVec3; 3]>) -> usize {
    let exterior = clean_ring(p.exterior());
    if exterior.len() < 3 {
        return 0;
    }
    // Work relative to the first point: UTM offsets cancel before any product.
    let origin = exterior[0];
    let local: Vec<DVec3> = exterior.iter().map(|q| *q - origin).collect();
    let extent = ring_extent(&local);
    let normal = newell(&local);
    let nlen = normal.length();
    if !(nlen.is_finite() && nlen > AREA_EPS * extent * extent) {
        return 0;
    }
    let n = normal / nlen;
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    let project = |q: DVec3| {
        let d = q - origin;
        DVec2::new(d.dot(u), d.dot(v))
    };

    let mut pts3: Vec<DVec3> = exterior.clone();
    let mut coords: Vec<f64> = Vec::with_capacity(2 * exterior.len());
    for q in &exterior {
        let c = project(*q);
        coords.extend([c.x, c.y]);
    }
    let mut holes: Vec<usize> = Vec::new();
    for ring in p.interiors() {
        let ring = clean_ring(ring);
        if ring.len() < 3 {
            continue;
        }
        let flat: Vec<DVec2> = ring.iter().map(|q| project(*q)).collect();
        if shoelace(&flat).abs() <= AREA_EPS * extent * extent {
            continue;
        }
        holes.push(pts3.len());
        pts3.extend_from_slice(&ring);
        for c in &flat {
            coords.extend([c.x, c.y]);
        }
    }

    let Ok(indices) = earcutr::earcut(&coords, &holes, 2) else {
        return 0;
    };
    let before = out.len();
    let min_area2 = AREA_EPS * extent * extent;
    for t in indices.chunks_exact(3) {
        let (Some(a), Some(b), Some(c)) = (pts3.get(t[0]), pts3.get(t[1]), pts3.get(t[2])) else {
            continue;
        };
        let (pa, pb, pc) = (project(*a), project(*b), project(*c));
        let area2 = (pb - pa).perp_dot(pc - pa);
        if area2.abs() <= min_area2 {
            continue;
        }
        // Keep the exterior's orientation (earcut's output order is not specified).
        if area2 > 0.0 {
            out.push([*a, *b, *c]);
        } else {
            out.push([*a, *c, *b]);
        }
    }
    out.len() - before
}

/// Finite points, no consecutive duplicates, no closing point.
fn clean_ring(ring: &[DVec3]) -> Vec<DVec3> {
    let mut r: Vec<DVec3> = Vec::with_capacity(ring.len());
    for q in ring.iter().filter(|q| q.is_finite()) {
        if r.last() != Some(q) {
            r.push(*q);
        }
    }
    while r.len() > 1 && r.first() == r.last() {
        r.pop();
    }
    r
}

/// Largest side of the ring's bounding box.
fn ring_extent(ring: &[DVec3]) -> f64 {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for q in ring {
        lo = lo.min(*q);
        hi = hi.max(*q);
    }
    (hi - lo).max_element()
}

/// Twice the signed area of a 2D ring.
fn shoelace(ring: &[DVec2]) -> f64 {
    let n = ring.len();
    (0..n)
        .map(|i| ring[i].perp_dot(ring[(i + 1) % n]))
        .sum::<f64>()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;
    use proptest::prelude::*;

    fn area(tris: &[[DVec3; 3]]) -> f64 {
        tris.iter()
            .map(|t| (t[1] - t[0]).cross(t[2] - t[0]).length() * 0.5)
            .sum()
    }

    fn sq(s: f64, o: f64) -> Vec<DVec3> {
        vec![
            DVec3::new(o, o, 0.0),
            DVec3::new(o + s, o, 0.0),
            DVec3::new(o + s, o + s, 0.0),
            DVec3::new(o, o + s, 0.0),
        ]
    }

    #[test]
    fn square_with_two_holes() {
        let mut p = Polygon::new(sq(10.0, 0.0));
        p.push_interior(&sq(2.0, 1.0));
        p.push_interior(&sq(3.0, 5.0));
        let mut out = Vec::new();
        let n = triangulate(&p, &mut out);
        assert!(n >= 8, "{n}");
        assert!((area(&out) - (100.0 - 4.0 - 9.0)).abs() < 1e-9);
        // Orientation follows the exterior (counter-clockwise seen from +z).
        for t in &out {
            assert!((t[1] - t[0]).cross(t[2] - t[0]).z > 0.0);
        }
    }

    #[test]
    fn duplicates_closing_point_and_nan_are_skipped() {
        let mut ring = sq(2.0, 0.0);
        ring.insert(1, ring[0]);
        ring.insert(3, DVec3::new(f64::NAN, 1.0, 0.0));
        ring.push(ring[0]);
        ring.push(DVec3::new(f64::INFINITY, 0.0, 0.0));
        let mut out = Vec::new();
        assert_eq!(triangulate(&Polygon::new(ring), &mut out), 2);
        assert!((area(&out) - 4.0).abs() < 1e-12);
    }

    #[test]
    fn degenerate_rings_give_nothing() {
        let mut out = Vec::new();
        let line = vec![DVec3::ZERO, DVec3::X, DVec3::X * 2.0, DVec3::X * 3.0];
        assert_eq!(triangulate(&Polygon::new(line), &mut out), 0);
        let two = vec![DVec3::ZERO, DVec3::X, DVec3::X, DVec3::ZERO];
        assert_eq!(triangulate(&Polygon::new(two), &mut out), 0);
        assert_eq!(triangulate(&Polygon::new(Vec::new()), &mut out), 0);
        let nans = vec![DVec3::splat(f64::NAN); 5];
        assert_eq!(triangulate(&Polygon::new(nans), &mut out), 0);
        assert!(out.is_empty());
        // A degenerate hole is ignored, the exterior still counts.
        let mut p = Polygon::new(sq(2.0, 0.0));
        p.push_interior(&[DVec3::splat(0.5), DVec3::splat(0.5), DVec3::ONE]);
        assert_eq!(triangulate(&p, &mut out), 2);
    }

    /// Rings of (x, y, z) and their triangle count and area (within a tolerance): a vertical
    /// wall far from the origin, a concave L, a quad warped by lifting one corner 1 cm.
    #[test]
    fn walls_concave_and_non_planar_rings() {
        let (x, y) = (430_000.0, 4_581_000.0);
        let wall = [
            [x, y, 0.0],
            [x + 10.0, y, 0.0],
            [x + 10.0, y, 6.0],
            [x, y, 6.0],
        ];
        let l =
            [(0, 0), (4, 0), (4, 1), (1, 1), (1, 4), (0, 4)].map(|(x, y)| [x, y, 0].map(f64::from));
        let warped = [
            [0.0, 0.0, 0.0],
            [5.0, 0.0, 0.0],
            [5.0, 5.0, 0.01],
            [0.0, 5.0, 0.0],
        ];
        let cases: [(&[[f64; 3]], usize, f64, f64); 3] = [
            (&wall, 2, 60.0, 1e-9),
            (&l, 4, 7.0, 1e-12),
            (&warped, 2, 25.0, 1e-3),
        ];
        for (ring, triangles, want, tol) in cases {
            let ring: Vec<DVec3> = ring.iter().map(|&p| DVec3::from_array(p)).collect();
            let mut out = Vec::new();
            assert_eq!(
                triangulate(&Polygon::new(ring.clone()), &mut out),
                triangles
            );
            assert!((area(&out) - want).abs() < tol, "{ring:?}");
            // Output keeps the original vertices.
            assert!(ring.iter().all(|p| out.iter().flatten().any(|q| q == p)));
        }
    }

    /// Star-shaped ring around `c` (in the xy plane), angles jittered by at most
    /// 0.2 of the even spacing, radii from `radii`.
    fn star(c: DVec3, radii: &[f64], jitter: &[f64]) -> Vec<DVec3> {
        let n = radii.len();
        let step = std::f64::consts::TAU / n as f64;
        (0..n)
            .map(|i| {
                let a = step * (i as f64 + 0.2 * jitter[i % jitter.len()]);
                c + DVec3::new(a.cos(), a.sin(), 0.0) * radii[i]
            })
            .collect()
    }

    /// Holes: one per quadrant at most, rectangles or small stars, all within radius
    /// 2.3 of the centre. An exterior star with n >= 5 evenly spaced (±20 %) points
    /// and radii >= 5 contains the disc of radius 5 cos(0.7 * 2pi/5) > 3.
    fn holes(spec: &[(bool, f64, f64, f64, f64)]) -> Vec<Vec<DVec3>> {
        let quadrants = [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)];
        spec.iter()
            .zip(quadrants)
            .map(|(&(is_rect, jx, jy, w, h), (qx, qy))| {
                let c = DVec3::new(qx + 0.2 * jx, qy + 0.2 * jy, 0.0);
                if is_rect {
                    let (w, h) = (0.4 * w, 0.4 * h);
                    // Clockwise, as holes usually are (orientation must not matter).
                    vec![
                        c + DVec3::new(-w, -h, 0.0),
                        c + DVec3::new(-w, h, 0.0),
                        c + DVec3::new(w, h, 0.0),
                        c + DVec3::new(w, -h, 0.0),
                    ]
                } else {
                    let r: Vec<f64> = (0..7)
                        .map(|i| if i % 2 == 0 { 0.4 * w } else { 0.4 * h * 0.5 })
                        .collect();
                    star(c, &r, &[0.0])
                }
            })
            .collect()
    }

    fn hole_spec() -> impl Strategy<Value = (bool, f64, f64, f64, f64)> {
        (
            any::<bool>(),
            -1.0..1.0f64,
            -1.0..1.0f64,
            0.2..1.0f64,
            0.2..1.0f64,
        )
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]
        #[test]
        fn area_is_preserved(
            radii in prop::collection::vec(5.0..15.0f64, 5..40),
            jitter in prop::collection::vec(-1.0..1.0f64, 1..40),
            spec in prop::collection::vec(hole_spec(), 0..=4),
            axis in (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64),
            angle in 0.0..std::f64::consts::TAU,
            shift in (0.0..1000.0f64, 0.0..1000.0f64, 0.0..100.0f64),
        ) {
            let p = Polygon::from_rings(None, &star(DVec3::ZERO, &radii, &jitter), &holes(&spec));
            let expected = p.area();
            prop_assert!(expected > 0.0);
            let mut out = Vec::new();
            let n = triangulate(&p, &mut out);
            prop_assert_eq!(n, out.len());
            let a = area(&out);
            prop_assert!((a - expected).abs() <= 1e-6 * expected, "{} vs {}", a, expected);

            // Same polygon rotated in 3D and moved to UTM-sized coordinates.
            let axis = DVec3::new(axis.0, axis.1, axis.2).try_normalize().unwrap_or(DVec3::Z);
            let rot = DQuat::from_axis_angle(axis, angle);
            let off = DVec3::new(430_000.0 + shift.0, 4_581_000.0 + shift.1, shift.2);
            let tf = |r: &[DVec3]| r.iter().map(|q| rot * *q + off).collect::<Vec<_>>();
            let hs: Vec<Vec<DVec3>> = p.interiors().map(tf).collect();
            let q = Polygon::from_rings(None, &tf(p.exterior()), &hs);
            prop_assert!((q.area() - expected).abs() <= 1e-6 * expected);
            out.clear();
            triangulate(&q, &mut out);
            let a = area(&out);
            prop_assert!((a - expected).abs() <= 1e-6 * expected, "{} vs {}", a, expected);
        }
    }
}
