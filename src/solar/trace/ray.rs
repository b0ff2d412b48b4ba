//! Exact-ish f64 ray tests: Möller–Trumbore ray–triangle and slab ray–AABB.
//!
//! These are the slow, simple reference implementations that the BVH tracer in
//! [`crate::solar::trace`] is checked against. They work on raw model coordinates (UTM-sized
//! values are fine in f64): the triangle is translated to the ray origin before any
//! product is formed, so the large common offset cancels exactly where it matters.

use glam::DVec3;

/// A ray–triangle intersection: distance along the ray and barycentric coordinates.
///
/// The hit point is `origin + t * dir` = `(1 - u - v) * a + u * b + v * c`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayTriangleHit {
    /// Ray parameter (a distance when `dir` is a unit vector).
    pub t: f64,
    /// Barycentric weight of the second vertex.
    pub u: f64,
    /// Barycentric weight of the third vertex.
    pub v: f64,
}

impl RayTriangleHit {
    /// Smallest barycentric coordinate (`min(1-u-v, u, v)`): how far inside the
    /// triangle the hit lies, 0 on an edge.
    pub fn margin(&self) -> f64 {
        (1.0 - self.u - self.v).min(self.u).min(self.v)
    }
}

/// Möller–Trumbore ray–triangle test in f64, both faces, with `tmin <= t <= tmax`.
///
/// Points on an edge or vertex count as hits (barycentrics compared with `>= 0`).
/// Degenerate (zero-area) triangles, rays parallel to the plane and non-finite input
/// return `None`.
///
/// # Example
/// ```rust
/// use glam::DVec3;
/// use skylod::solar::trace::ray_triangle;
/// let tri = [
///     DVec3::new(430_000.0, 4_581_000.0, 10.0),
///     DVec3::new(430_010.0, 4_581_000.0, 10.0),
///     DVec3::new(430_000.0, 4_581_010.0, 10.0),
/// ];
/// let o = DVec3::new(430_001.0, 4_581_001.0, 0.0);
/// let hit = ray_triangle(o, DVec3::Z, &tri, 0.0, f64::INFINITY).unwrap();
/// assert!((hit.t - 10.0).abs() < 1e-9);
/// assert!(ray_triangle(o, -DVec3::Z, &tri, 0.0, f64::INFINITY).is_none());
/// ```
pub fn ray_triangle(
    origin: DVec3,
    dir: DVec3,
    tri: &[DVec3; 3],
    tmin: f64,
    tmax: f64,
) -> Option<RayTriangleHit> {
    // Translate to the ray origin first: keeps UTM offsets out of the products.
    let a = tri[0] - origin;
    let b = tri[1] - origin;
    let c = tri[2] - origin;
    let e1 = b - a;
    let e2 = c - a;
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = -a; // origin - a, with origin at zero
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = dir.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    if t.is_finite() && t >= tmin && t <= tmax {
        Some(RayTriangleHit { t, u, v })
    } else {
        None
    }
}

/// Slab test of a ray against an axis-aligned box `[min, max]`.
///
/// Returns the parameter interval `(t_enter, t_exit)` clipped to `[tmin, tmax]`, or
/// `None` when the ray misses. Zero direction components are handled (the ray is then
/// inside or outside that slab for every `t`); the exit bound is widened by a few ulps
/// (Ize 2013) so that a ray grazing a face is not lost to rounding.
///
/// # Example
/// ```rust
/// use glam::DVec3;
/// use skylod::solar::trace::ray_aabb;
/// let (t0, t1) = ray_aabb(
///     DVec3::new(-5.0, 0.5, 0.5), DVec3::X,
///     DVec3::ZERO, DVec3::ONE, 0.0, f64::INFINITY,
/// ).unwrap();
/// assert!((t0 - 5.0).abs() < 1e-12 && (t1 - 6.0).abs() < 1e-9);
/// assert!(ray_aabb(DVec3::new(-5.0, 2.0, 0.5), DVec3::X, DVec3::ZERO, DVec3::ONE, 0.0, 1e9).is_none());
/// ```
pub fn ray_aabb(
    origin: DVec3,
    dir: DVec3,
    min: DVec3,
    max: DVec3,
    tmin: f64,
    tmax: f64,
) -> Option<(f64, f64)> {
    const WIDEN: f64 = 1.0 + 2.0 * 3.0 * f64::EPSILON;
    let mut t0 = tmin;
    let mut t1 = tmax;
    for axis in 0..3 {
        let (o, d, lo, hi) = (origin[axis], dir[axis], min[axis], max[axis]);
        if d == 0.0 {
            if o < lo || o > hi {
                return None;
            }
            continue;
        }
        let inv = 1.0 / d;
        let mut near = (lo - o) * inv;
        let mut far = (hi - o) * inv;
        if near > far {
            std::mem::swap(&mut near, &mut far);
        }
        far *= WIDEN;
        // NaN-safe: comparisons with NaN leave the bounds untouched.
        if near > t0 {
            t0 = near;
        }
        if far < t1 {
            t1 = far;
        }
        if t0 > t1 {
            return None;
        }
    }
    Some((t0, t1))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> [[DVec3; 3]; 2] {
        let p = [
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(0.0, 1.0, 1.0),
        ];
        [[p[0], p[1], p[2]], [p[0], p[2], p[3]]]
    }

    #[test]
    fn hits_centre_and_misses_outside() {
        let [t1, _] = quad();
        let h = ray_triangle(DVec3::new(0.7, 0.2, 0.0), DVec3::Z, &t1, 0.0, 10.0).unwrap();
        assert!((h.t - 1.0).abs() < 1e-12);
        assert!(h.margin() > 0.0);
        assert!(ray_triangle(DVec3::new(0.2, 0.7, 0.0), DVec3::Z, &t1, 0.0, 10.0).is_none());
        // Behind the origin / beyond tmax.
        assert!(ray_triangle(DVec3::new(0.7, 0.2, 2.0), DVec3::Z, &t1, 0.0, 10.0).is_none());
        assert!(ray_triangle(DVec3::new(0.7, 0.2, 0.0), DVec3::Z, &t1, 0.0, 0.5).is_none());
    }

    #[test]
    fn shared_diagonal_is_hit_by_one_of_the_two() {
        let q = quad();
        for i in 1..100 {
            let s = i as f64 / 100.0;
            let o = DVec3::new(s, s, 0.0);
            let hits = q
                .iter()
                .filter(|t| ray_triangle(o, DVec3::Z, t, 0.0, 10.0).is_some())
                .count();
            assert!(hits >= 1, "slipped through at {s}");
        }
    }

    #[test]
    fn degenerate_and_parallel() {
        let line = [DVec3::ZERO, DVec3::X, DVec3::X * 2.0];
        assert!(ray_triangle(DVec3::new(0.5, 0.0, -1.0), DVec3::Z, &line, 0.0, 9.0).is_none());
        let [t1, _] = quad();
        assert!(ray_triangle(DVec3::new(-1.0, 0.1, 1.0), DVec3::X, &t1, 0.0, 9.0).is_none());
        let nan = DVec3::new(f64::NAN, 0.0, 0.0);
        assert!(ray_triangle(nan, DVec3::Z, &t1, 0.0, 9.0).is_none());
    }

    #[test]
    fn utm_offsets() {
        let off = DVec3::new(430_000.0, 4_581_000.0, 50.0);
        let [t1, _] = quad();
        let t = t1.map(|p| p * 20.0 + off);
        let o = off + DVec3::new(15.0, 3.0, -100.0);
        let h = ray_triangle(o, DVec3::Z, &t, 0.0, 1e9).unwrap();
        assert!((h.t - 120.0).abs() < 1e-9);
    }

    #[test]
    fn aabb_axis_parallel_and_inside() {
        let (min, max) = (DVec3::ZERO, DVec3::ONE);
        // Starting inside: enter at tmin.
        let (a, b) = ray_aabb(DVec3::splat(0.5), DVec3::X, min, max, 0.0, 1e9).unwrap();
        assert_eq!(a, 0.0);
        assert!((b - 0.5).abs() < 1e-12);
        // Parallel to a slab, outside of it.
        assert!(ray_aabb(DVec3::new(0.5, 2.0, 0.5), DVec3::X, min, max, 0.0, 1e9).is_none());
        // Box behind the ray.
        assert!(ray_aabb(DVec3::new(2.0, 0.5, 0.5), DVec3::X, min, max, 0.0, 1e9).is_none());
        // Diagonal through a corner region.
        let d = DVec3::ONE.normalize();
        assert!(ray_aabb(DVec3::splat(-1.0), d, min, max, 0.0, 1e9).is_some());
        assert!(ray_aabb(DVec3::new(-1.0, -1.0, 3.0), d, min, max, 0.0, 1e9).is_none());
    }
}
