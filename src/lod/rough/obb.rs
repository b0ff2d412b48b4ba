//! Oriented bounding box of a point set (paper 4.3, "bounding box" of an asset).
//!
//! The box is the minimum-area rectangle of the plan (x, y) convex hull, extruded over the
//! z range of the points: boxes stay upright (their third axis is +z), which is what the
//! paper's procedural models produce and what keeps a chimney on a rotated building tight.
//! The minimum-area rectangle has one side collinear with a hull edge, so every hull edge
//! direction is tried (the axis-aligned box is tried first and kept on ties). Degenerate
//! plans (collinear points, a single point) and flat point sets give a thin box whose sides
//! are at least [`MIN_THICKNESS`] thick, so that it still blocks rays.
//!
//! Coordinates are shifted to a local origin (the centre of the points' axis-aligned box)
//! before any computation, so UTM-sized coordinates (~5e6 m) keep sub-micrometre precision.

use crate::model::Polygon;
use geo::{ConvexHull, MultiPoint};
use glam::{DVec2, DVec3};

/// Smallest full thickness of a box side in metres (a degenerate box still blocks rays).
pub const MIN_THICKNESS: f64 = 0.01;

/// An upright oriented box: `center + s0*half.x*axes[0] + s1*half.y*axes[1] + s2*half.z*axes[2]`
/// for `s0, s1, s2` in `[-1, 1]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Obb {
    /// Centre of the box.
    pub center: DVec3,
    /// Unit axes, right-handed: `axes[0]` and `axes[1]` horizontal, `axes[2]` = +z.
    /// `axes[0]` is the direction of the longer plan side.
    pub axes: [DVec3; 3],
    /// Half extents along the axes (each at least `MIN_THICKNESS / 2`).
    pub half: DVec3,
}

impl Obb {
    /// The box of a set of points, or `None` when there is no finite point.
    ///
    /// Non-finite points are ignored.
    ///
    /// # Example
    /// ```rust
    /// use glam::DVec3;
    /// use skylod::lod::rough::Obb;
    /// // A 4 x 2 x 3 box rotated by 30 degrees in plan.
    /// let (s, c) = 30f64.to_radians().sin_cos();
    /// let mut pts = Vec::new();
    /// for &(x, y) in &[(0.0, 0.0), (4.0, 0.0), (4.0, 2.0), (0.0, 2.0)] {
    ///     for z in [10.0, 13.0] {
    ///         pts.push(DVec3::new(c * x - s * y, s * x + c * y, z));
    ///     }
    /// }
    /// let obb = Obb::of_points(&pts).unwrap();
    /// assert!((obb.volume() - 24.0).abs() < 1e-9);
    /// assert!(pts.iter().all(|p| obb.contains(*p, 1e-9)));
    /// ```
    pub fn of_points<'a>(points: impl IntoIterator<Item = &'a DVec3>) -> Option<Obb> {
        let pts: Vec<DVec3> = points
            .into_iter()
            .copied()
            .filter(|p| p.is_finite())
            .collect();
        let first = *pts.first()?;
        let (mut lo, mut hi) = (first, first);
        for p in &pts {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let origin = (lo + hi) * 0.5;
        let plan: Vec<(f64, f64)> = pts
            .iter()
            .map(|p| (p.x - origin.x, p.y - origin.y))
            .collect();
        let hull = MultiPoint::from(plan).convex_hull();
        let hull: Vec<DVec2> = hull
            .exterior()
            .coords()
            .map(|c| DVec2::new(c.x, c.y))
            .collect();
        let (dir, rect) = min_area_rect(&hull, lo - origin, hi - origin);
        let perp = dir.perp();
        let min_half = MIN_THICKNESS * 0.5;
        let mut half = DVec3::new(
            ((rect[1] - rect[0]) * 0.5).max(min_half),
            ((rect[3] - rect[2]) * 0.5).max(min_half),
            ((hi.z - lo.z) * 0.5).max(min_half),
        );
        let c2 = dir * ((rect[0] + rect[1]) * 0.5) + perp * ((rect[2] + rect[3]) * 0.5);
        let mut a0 = DVec3::new(dir.x, dir.y, 0.0);
        let mut a1 = DVec3::new(perp.x, perp.y, 0.0);
        if half.y > half.x {
            // Longer side first; rotating the frame by 90 degrees keeps it right-handed.
            (a0, a1) = (a1, -a0);
            (half.x, half.y) = (half.y, half.x);
        }
        Some(Obb {
            center: DVec3::new(origin.x + c2.x, origin.y + c2.y, (lo.z + hi.z) * 0.5),
            axes: [a0, a1, DVec3::Z],
            half,
        })
    }

    /// The box of every point of a set of polygons (all rings), or `None` when there is none.
    pub fn of_polygons(polygons: &[Polygon]) -> Option<Obb> {
        Obb::of_points(polygons.iter().flat_map(|p| p.points()))
    }

    /// Volume of the box.
    pub fn volume(&self) -> f64 {
        8.0 * self.half.x * self.half.y * self.half.z
    }

    /// Corner with signs `s` (each component -1 or +1).
    pub fn corner(&self, s: DVec3) -> DVec3 {
        self.center
            + self.axes[0] * (s.x * self.half.x)
            + self.axes[1] * (s.y * self.half.y)
            + self.axes[2] * (s.z * self.half.z)
    }

    /// True when `p` lies inside the box grown by `tol` on every side.
    pub fn contains(&self, p: DVec3, tol: f64) -> bool {
        let d = p - self.center;
        (0..3).all(|k| d.dot(self.axes[k]).abs() <= self.half[k] + tol)
    }

    /// The six faces as quads, rings open and counter-clockwise seen from outside
    /// (their Newell normals point outward).
    ///
    /// # Example
    /// ```rust
    /// use glam::DVec3;
    /// use skylod::lod::rough::Obb;
    /// let obb = Obb::of_points(&[DVec3::ZERO, DVec3::new(2.0, 1.0, 1.0)]).unwrap();
    /// let faces = obb.to_polygons();
    /// assert_eq!(faces.len(), 6);
    /// // Every face normal points away from the centre.
    /// for f in &faces {
    ///     let c = f.exterior().iter().sum::<DVec3>() / 4.0;
    ///     assert!(f.newell_normal().dot(c - obb.center) > 0.0);
    /// }
    /// ```
    pub fn to_polygons(&self) -> Vec<Polygon> {
        const SQUARE: [(f64, f64); 4] = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
        let mut out = Vec::with_capacity(6);
        for k in 0..3 {
            for s in [1.0, -1.0] {
                // (i, j) with axes[i] x axes[j] = s * axes[k].
                let (mut i, mut j) = ((k + 1) % 3, (k + 2) % 3);
                if s < 0.0 {
                    std::mem::swap(&mut i, &mut j);
                }
                let ring = SQUARE
                    .iter()
                    .map(|&(a, b)| {
                        let mut sg = DVec3::ZERO;
                        sg[k] = s;
                        sg[i] = a;
                        sg[j] = b;
                        self.corner(sg)
                    })
                    .collect();
                out.push(Polygon::new(ring));
            }
        }
        out
    }

    /// The four edges of the top face (counter-clockwise seen from above), for the
    /// silhouette test.
    pub fn top_edges(&self) -> [[DVec3; 2]; 4] {
        let c = [
            self.corner(DVec3::new(-1.0, -1.0, 1.0)),
            self.corner(DVec3::new(1.0, -1.0, 1.0)),
            self.corner(DVec3::new(1.0, 1.0, 1.0)),
            self.corner(DVec3::new(-1.0, 1.0, 1.0)),
        ];
        [[c[0], c[1]], [c[1], c[2]], [c[2], c[3]], [c[3], c[0]]]
    }
}

/// Minimum-area rectangle of a plan convex hull (local coordinates).
///
/// Returns the unit direction of the rectangle's first side and its extent
/// `[min_u, max_u, min_v, max_v]` along that direction `u` and `v = u.perp()`.
/// The axis-aligned rectangle (from `lo`, `hi`) is the starting candidate and is only
/// replaced by a strictly smaller one.
fn min_area_rect(hull: &[DVec2], lo: DVec3, hi: DVec3) -> (DVec2, [f64; 4]) {
    let mut best_dir = DVec2::X;
    let mut best = [lo.x, hi.x, lo.y, hi.y];
    // Degenerate (collinear) plans have zero area for several directions: compare the
    // area of the rectangle padded to the minimum thickness, so that the thin box along
    // the line wins over a thin axis-aligned one only when it is really smaller.
    let padded = |r: &[f64; 4]| (r[1] - r[0]).max(MIN_THICKNESS) * (r[3] - r[2]).max(MIN_THICKNESS);
    let mut best_area = padded(&best);
    for w in hull.windows(2) {
        let e = w[1] - w[0];
        let len = e.length();
        if len <= 1e-12 || !len.is_finite() {
            continue;
        }
        let u = e / len;
        let v = u.perp();
        let mut r = [
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        for p in hull {
            let a = p.dot(u);
            let b = p.dot(v);
            r[0] = r[0].min(a);
            r[1] = r[1].max(a);
            r[2] = r[2].min(b);
            r[3] = r[3].max(b);
        }
        let area = padded(&r);
        if area < best_area * (1.0 - 1e-12) {
            best_area = area;
            best = r;
            best_dir = u;
        }
    }
    (best_dir, best)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn rotated_box(size: DVec3, angle_deg: f64, offset: DVec3) -> Vec<DVec3> {
        let (s, c) = angle_deg.to_radians().sin_cos();
        let mut pts = Vec::new();
        for x in [0.0, size.x] {
            for y in [0.0, size.y] {
                for z in [0.0, size.z] {
                    pts.push(offset + DVec3::new(c * x - s * y, s * x + c * y, z));
                }
            }
        }
        pts
    }

    #[test]
    fn rotated_box_is_recovered() {
        let size = DVec3::new(7.0, 3.0, 5.0);
        let pts = rotated_box(size, 30.0, DVec3::new(690_000.0, 5_400_000.0, 370.0));
        let obb = Obb::of_points(&pts).unwrap();
        let v = size.x * size.y * size.z;
        assert!((obb.volume() - v).abs() / v < 1e-9, "{}", obb.volume());
        assert!(pts.iter().all(|p| obb.contains(*p, 1e-6)));
        // Longer side first, along the 30-degree direction (up to sign).
        let d = DVec3::new(30f64.to_radians().cos(), 30f64.to_radians().sin(), 0.0);
        assert!((obb.axes[0].dot(d).abs() - 1.0).abs() < 1e-9);
        assert!((obb.half - size * 0.5).abs().max_element() < 1e-6);
        assert_eq!(obb.axes[2], DVec3::Z);
        assert!((obb.axes[0].cross(obb.axes[1]) - DVec3::Z).length() < 1e-12);
    }

    #[test]
    fn axis_aligned_box_stays_axis_aligned() {
        let pts = rotated_box(DVec3::new(2.0, 5.0, 1.0), 0.0, DVec3::new(1.0, 2.0, 3.0));
        let obb = Obb::of_points(&pts).unwrap();
        assert!((obb.axes[0].y.abs() - 1.0).abs() < 1e-15);
        assert!((obb.volume() - 10.0).abs() < 1e-12);
        assert!((obb.center - DVec3::new(2.0, 4.5, 3.5)).length() < 1e-12);
    }

    #[test]
    fn antenna_mast_at_45_degrees_is_tight() {
        // A thin mast 0.1 x 3 m in plan, 6 m tall, rotated 45 degrees, with a point cloud
        // along it (e.g. rungs).
        let mut pts = rotated_box(DVec3::new(3.0, 0.1, 6.0), 45.0, DVec3::new(5e5, 5e6, 400.0));
        let (s, c) = 45f64.to_radians().sin_cos();
        for i in 0..=30 {
            let x = 0.1 * i as f64;
            pts.push(DVec3::new(
                5e5 + c * x - s * 0.05,
                5e6 + s * x + c * 0.05,
                403.0,
            ));
        }
        let obb = Obb::of_points(&pts).unwrap();
        let tight = 3.0 * 0.1 * 6.0;
        assert!(
            (obb.volume() - tight).abs() / tight < 1e-6,
            "{}",
            obb.volume()
        );
        // The axis-aligned box would be ~ 2.19 x 2.19 x 6 = 28.8 m^3.
        let aabb = crate::model::Bbox::of_points(&pts);
        let e = aabb.max - aabb.min;
        assert!(e.x * e.y * e.z > 15.0 * obb.volume());
        assert!(pts.iter().all(|p| obb.contains(*p, 1e-6)));
    }

    #[test]
    fn collinear_points_give_a_thin_oriented_box() {
        let pts: Vec<DVec3> = (0..5)
            .map(|i| DVec3::new(100.0 + i as f64, 200.0 + i as f64, 10.0 + 0.5 * i as f64))
            .collect();
        let obb = Obb::of_points(&pts).unwrap();
        assert!(pts.iter().all(|p| obb.contains(*p, 1e-9)));
        assert!((obb.half.x - 2.0 * 2f64.sqrt()).abs() < 1e-9);
        assert!((obb.half.y - MIN_THICKNESS * 0.5).abs() < 1e-12);
        assert!((obb.half.z - 1.0).abs() < 1e-12);
        assert!(obb.volume() > 0.0);
        // Vertical line: plan is a single point.
        let pts = [DVec3::new(3.0, 4.0, 0.0), DVec3::new(3.0, 4.0, 8.0)];
        let obb = Obb::of_points(&pts).unwrap();
        assert!((obb.volume() - MIN_THICKNESS * MIN_THICKNESS * 8.0).abs() < 1e-12);
        assert!(pts.iter().all(|p| obb.contains(*p, 1e-12)));
    }

    #[test]
    fn single_point_and_empty_input() {
        let p = DVec3::new(4e5, 5.5e6, 12.0);
        let obb = Obb::of_points(&[p]).unwrap();
        assert!(obb.contains(p, 0.0));
        assert!((obb.half - DVec3::splat(MIN_THICKNESS * 0.5)).length() < 1e-12);
        assert!(Obb::of_points(&[]).is_none());
        assert!(Obb::of_points(&[DVec3::new(f64::NAN, 0.0, 0.0)]).is_none());
    }

    #[test]
    fn faces_are_outward_quads_and_top_edges_on_top() {
        let pts = rotated_box(
            DVec3::new(4.0, 2.0, 3.0),
            17.0,
            DVec3::new(10.0, 20.0, 30.0),
        );
        let obb = Obb::of_points(&pts).unwrap();
        let faces = obb.to_polygons();
        assert_eq!(faces.len(), 6);
        let mut total = 0.0;
        for f in &faces {
            assert_eq!(f.exterior().len(), 4);
            let c = f.exterior().iter().sum::<DVec3>() / 4.0;
            let n = f.newell_normal();
            assert!(n.normalize().dot((c - obb.center).normalize()) > 1.0 - 1e-9);
            total += f.area();
        }
        assert!((total - 2.0 * (8.0 + 12.0 + 6.0)).abs() < 1e-9);
        for [a, b] in obb.top_edges() {
            assert!((a.z - 33.0).abs() < 1e-9 && (b.z - 33.0).abs() < 1e-9);
        }
        let perimeter: f64 = obb.top_edges().iter().map(|[a, b]| a.distance(*b)).sum();
        assert!((perimeter - 12.0).abs() < 1e-9);
    }

    proptest! {
        #[test]
        fn obb_contains_points_and_beats_aabb(
            sx in 0.1f64..60.0, sy in 0.1f64..60.0, sz in 0.1f64..40.0,
            angle in 0.0f64..360.0,
            ox in 3e5f64..8e5, oy in 5.0e6f64..6.0e6, oz in 0.0f64..500.0,
        ) {
            let pts = rotated_box(DVec3::new(sx, sy, sz), angle, DVec3::new(ox, oy, oz));
            let obb = Obb::of_points(&pts).unwrap();
            for p in &pts {
                prop_assert!(obb.contains(*p, 1e-6));
            }
            let b = crate::model::Bbox::of_points(&pts);
            let e = b.max - b.min;
            prop_assert!(obb.volume() <= e.x * e.y * e.z + 1e-6);
            // And it is the rotated box itself.
            let v = sx * sy * sz;
            prop_assert!((obb.volume() - v).abs() <= 1e-6 * v.max(1.0));
        }
    }
}
