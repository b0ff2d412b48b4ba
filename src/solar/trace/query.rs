//! The ray queries of a [`TraceScene`]: the watertight triangle test, [`TraceScene::first_hit`] and
//! [`TraceScene::occluded`] (see the module docs of [`crate::solar::trace`]).

use super::scene::{Accel, TraceScene};
use glam::{DVec3, Vec3A};
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;

/// The closest hit of a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Tag of the polygon or triangle hit (given to the builder).
    pub tag: u32,
    /// Ray parameter of the hit (a distance in metres for a unit direction).
    pub t: f64,
    /// Index of the triangle hit, in the order the scene stored them (0..len()).
    pub triangle: u32,
}

/// Per-ray constants of the watertight test (Woop et al. 2013) as three rows, so the
/// shear/permutation of a vertex is three dot products with exact 0/1 entries.
struct Watertight {
    rx: Vec3A,
    ry: Vec3A,
    rz: Vec3A,
    org: Vec3A,
}

impl Watertight {
    fn new(org: Vec3A, dir: Vec3A) -> Self {
        let a = dir.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let (sx, sy, sz) = (dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]);
        let mut rx = Vec3A::ZERO;
        let mut ry = Vec3A::ZERO;
        let mut rz = Vec3A::ZERO;
        rx[kx] = 1.0;
        rx[kz] = -sx;
        ry[ky] = 1.0;
        ry[kz] = -sy;
        rz[kz] = sz;
        Watertight { rx, ry, rz, org }
    }

    #[inline(always)]
    fn xform(&self, v: Vec3A) -> Vec3A {
        let p = v - self.org;
        Vec3A::new(p.dot(self.rx), p.dot(self.ry), p.dot(self.rz))
    }

    /// Ray parameter of the hit, or infinity.
    #[inline(always)]
    fn intersect(&self, t: &Triangle, tmin: f32, tmax: f32) -> f32 {
        let a = self.xform(t.v0);
        let b = self.xform(t.v1);
        let c = self.xform(t.v2);
        let mut u = c.x * b.y - c.y * b.x;
        let mut v = a.x * c.y - a.y * c.x;
        let mut w = b.x * a.y - b.y * a.x;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            // Exact in f64: products of two f32 are representable.
            let (ax, ay, bx, by, cx, cy) = (
                a.x as f64, a.y as f64, b.x as f64, b.y as f64, c.x as f64, c.y as f64,
            );
            u = (cx * by - cy * bx) as f32;
            v = (ax * cy - ay * cx) as f32;
            w = (bx * ay - by * ax) as f32;
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return f32::INFINITY;
        }
        let det = u + v + w;
        if det == 0.0 {
            return f32::INFINITY;
        }
        let tt = (u * a.z + v * b.z + w * c.z) / det;
        if tt >= tmin && tt <= tmax {
            tt
        } else {
            f32::INFINITY
        }
    }
}

impl TraceScene {
    /// The f32 ray in local coordinates and its watertight constants, or `None` for a
    /// non-finite or zero direction, a non-finite origin or an empty interval.
    fn local_ray(
        &self,
        origin: DVec3,
        dir: DVec3,
        tmin: f64,
        tmax: f64,
    ) -> Option<(Ray, Watertight)> {
        let o = (origin - self.origin).as_vec3();
        let d = dir.as_vec3();
        if !o.is_finite() || !d.is_finite() || d.length_squared() == 0.0 {
            return None;
        }
        let tmin = if tmin.is_nan() { 0.0 } else { tmin.max(0.0) } as f32;
        let tmax = if tmax.is_nan() { f64::INFINITY } else { tmax } as f32;
        if tmin > tmax {
            return None;
        }
        // `-0.0 + 0.0 == +0.0`: obvhs' CWBVH node test takes the octant from `d < 0` but
        // the inverse from the sign bit, so a negative zero would lose whole subtrees.
        let (o, d) = (Vec3A::from(o), Vec3A::from(d) + Vec3A::ZERO);
        Some((Ray::new(o, d, tmin, tmax), Watertight::new(o, d)))
    }

    /// True when a triangle is hit with `tmin <= t <= tmax` (any-hit traversal, stops at
    /// the first hit found). Invalid rays (zero or non-finite direction or origin) and
    /// empty scenes are never occluded.
    pub fn occluded(&self, origin: DVec3, dir: DVec3, tmin: f64, tmax: f64) -> bool {
        let Some((ray, wt)) = self.local_ray(origin, dir, tmin, tmax) else {
            return false;
        };
        let (t0, t1) = (ray.tmin, ray.tmax);
        // Nodes entered at exactly `tmax` are still visited (see `prune_bound`).
        let ray = Ray {
            tmax: prune_bound(t1, self.pad),
            ..ray
        };
        let tris = &self.tris;
        let mut isect = |_: &Ray, id: usize| match tris.get(id) {
            Some(t) => wt.intersect(t, t0, t1),
            None => f32::INFINITY,
        };
        match &self.accel {
            Accel::Empty => false,
            Accel::Cw(bvh) => !bvh.ray_traverse_miss(ray, &mut isect),
            Accel::Bvh2(bvh) => !bvh.ray_traverse_miss(ray, &mut isect),
        }
    }

    /// The closest hit with `tmin <= t <= tmax`, if any. `tmin` lets a caller skip the
    /// surface its point lies on. Invalid rays and empty scenes hit nothing.
    ///
    /// Deterministic: the hit is the triangle with the smallest f32 distance and, among
    /// triangles at exactly that distance (duplicated or coincident faces, shared edges),
    /// the one with the smallest triangle index (insertion order), whatever the layout,
    /// build quality or tree. Hits closer than 1e-4 (obvhs' CWBVH node epsilon) are not
    /// covered by that promise; callers start rays at [`crate::model::POI_OFFSET`] or more.
    pub fn first_hit(&self, origin: DVec3, dir: DVec3, tmin: f64, tmax: f64) -> Option<Hit> {
        self.first_hit_f32(origin, dir, tmin, tmax).map(|(h, _)| h)
    }

    /// [`TraceScene::first_hit`] and the f32 distance by which it won (hits are ordered by it,
    /// then by triangle index): for callers that merge the answers of several scenes built
    /// in one frame ([`SceneBuilder::with_frame`](super::SceneBuilder::with_frame)) from
    /// disjoint parts of one triangle list, where the smallest (f32 distance, position in
    /// that list) is the whole list's answer.
    #[inline]
    pub(crate) fn first_hit_f32(
        &self,
        origin: DVec3,
        dir: DVec3,
        tmin: f64,
        tmax: f64,
    ) -> Option<(Hit, f32)> {
        let (ray, wt) = self.local_ray(origin, dir, tmin, tmax)?;
        let (t0, t1) = (ray.tmin, ray.tmax);
        let ray = Ray {
            tmax: prune_bound(t1, self.pad),
            ..ray
        };
        let (tris, slot_triangle, pad) = (&self.tris, &self.slot_triangle, self.pad);
        // The authoritative best (t, triangle, slot) lives here, not in obvhs' `RayHit`:
        // obvhs keeps the first of equal candidates it meets (`t < tmax`), which depends
        // on the tree. It is told `prune_bound(best)` instead, so that every node that
        // may hold a triangle at exactly `best` is still visited.
        let mut best = (f32::INFINITY, u32::MAX, usize::MAX);
        let mut isect = |_: &Ray, slot: usize| {
            let (Some(tri), Some(&index)) = (tris.get(slot), slot_triangle.get(slot)) else {
                return f32::INFINITY;
            };
            let t = wt.intersect(tri, t0, t1);
            if t < f32::INFINITY && (t < best.0 || (t == best.0 && index < best.1)) {
                best = (t, index, slot);
                prune_bound(t, pad)
            } else {
                f32::INFINITY
            }
        };
        let mut hit = RayHit::none();
        // Their own verdict (`hit`) is not used: `best` is.
        let _ = match &self.accel {
            Accel::Empty => false,
            Accel::Cw(bvh) => bvh.ray_traverse(ray, &mut hit, &mut isect),
            Accel::Bvh2(bvh) => bvh.ray_traverse(ray, &mut hit, &mut isect),
        };
        let (t32, triangle, slot) = best;
        let tri = self.tris.get(slot)?;
        let tag = *self.tags.get(triangle as usize)?;
        let t = refine_t(tri, origin - self.origin, dir, t32 as f64);
        Some((Hit { tag, t, triangle }, t32))
    }
}

/// The `tmax` obvhs prunes with when the closest hit so far is at `t`: a little beyond
/// `t` (2^-12 relative, plus the node growth `pad`), so that a node that may hold a
/// triangle at exactly `t` is still visited even when the triangle's f32 distance is
/// off (grazing rays): obvhs' Bvh2 visits a node only when its entry is `< tmax`. Costs
/// a few node visits per ray.
#[inline(always)]
fn prune_bound(t: f32, pad: f32) -> f32 {
    t + t.abs() * (1.0 / 4096.0) + pad
}

/// Distance to the plane of `tri` in f64 (from the unrounded local origin); falls back
/// to the f32 estimate for grazing rays or when the refinement disagrees wildly.
fn refine_t(tri: &Triangle, o: DVec3, d: DVec3, t32: f64) -> f64 {
    let a = tri.v0.as_dvec3();
    let n = (tri.v1.as_dvec3() - a).cross(tri.v2.as_dvec3() - a);
    let dn = n.dot(d);
    let scale = n.length() * d.length();
    if dn.abs() <= 1e-6 * scale {
        return t32;
    }
    let t = n.dot(a - o) / dn;
    if t.is_finite() && (t - t32).abs() <= 1e-3 * (1.0 + t32.abs()) {
        t
    } else {
        t32
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::model::Polygon;
    use crate::solar::trace::{BuildQuality, BvhLayout, SceneBuilder};
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    const UTM: DVec3 = DVec3::new(430_000.0, 4_581_000.0, 0.0);

    /// Möller–Trumbore without the barycentric bounds: (t, margin) where margin is the
    /// smallest barycentric coordinate (negative outside).
    fn mt_unbounded(o: DVec3, d: DVec3, tri: &[DVec3; 3]) -> Option<(f64, f64)> {
        let (a, b, c) = (tri[0] - o, tri[1] - o, tri[2] - o);
        let (e1, e2) = (b - a, c - a);
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det == 0.0 {
            return None;
        }
        let s = -a;
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        let t = e2.dot(q) / det;
        Some((t, (1.0 - u - v).min(u).min(v)))
    }

    struct Brute {
        /// Closest certain hit (t, index).
        sure: Option<(f64, usize)>,
        /// Closest possible hit t (within tolerance of an edge or of tmin/tmax).
        possible: f64,
        /// Number of distinct possible hits within 1e-3 of the closest certain one.
        near_sure: usize,
    }

    const BARY_EPS: f64 = 1e-4;
    const T_EPS: f64 = 1e-3;

    fn brute(tris: &[[DVec3; 3]], o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> Brute {
        let mut sure: Option<(f64, usize)> = None;
        let mut possible = f64::INFINITY;
        let mut all = Vec::new();
        for (i, tri) in tris.iter().enumerate() {
            let Some((t, m)) = mt_unbounded(o, d, tri) else {
                continue;
            };
            if m >= -BARY_EPS && t >= tmin - T_EPS && t <= tmax + T_EPS {
                possible = possible.min(t);
                all.push(t);
                if m >= BARY_EPS
                    && t >= tmin + T_EPS
                    && t <= tmax - T_EPS
                    && sure.is_none_or(|(s, _)| t < s)
                {
                    sure = Some((t, i));
                }
            }
        }
        let near_sure = sure.map_or(0, |(s, _)| {
            all.iter().filter(|t| (*t - s).abs() <= T_EPS).count()
        });
        Brute {
            sure,
            possible,
            near_sure,
        }
    }

    pub(crate) fn random_scene(rng: &mut ChaCha8Rng, n: usize) -> Vec<[DVec3; 3]> {
        (0..n)
            .map(|_| {
                let c = UTM
                    + DVec3::new(
                        rng.random_range(-100.0..100.0),
                        rng.random_range(-100.0..100.0),
                        rng.random_range(0.0..50.0),
                    );
                let mut v = || {
                    c + DVec3::new(
                        rng.random_range(-10.0..10.0),
                        rng.random_range(-10.0..10.0),
                        rng.random_range(-10.0..10.0),
                    )
                };
                [v(), v(), v()]
            })
            .collect()
    }

    fn random_dir(rng: &mut ChaCha8Rng) -> DVec3 {
        loop {
            let v = DVec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }

    /// Check `n_rays` random rays against brute force; returns the number of hits seen.
    fn check_against_brute(seed: u64, n_tris: usize, n_rays: usize, layout: BvhLayout) -> usize {
        check_against_brute_with(seed, n_tris, n_rays, layout, BuildQuality::default())
    }

    fn check_against_brute_with(
        seed: u64,
        n_tris: usize,
        n_rays: usize,
        layout: BvhLayout,
        quality: BuildQuality,
    ) -> usize {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let tris = random_scene(&mut rng, n_tris);
        let mut b = SceneBuilder::new()
            .with_layout(layout)
            .with_quality(quality);
        for (i, t) in tris.iter().enumerate() {
            assert!(b.add_triangle(1000 + i as u32, *t));
        }
        let scene = b.build();
        assert_eq!(scene.len(), tris.len());
        let mut hits = 0;
        for _ in 0..n_rays {
            let o = UTM
                + DVec3::new(
                    rng.random_range(-150.0..150.0),
                    rng.random_range(-150.0..150.0),
                    rng.random_range(-10.0..70.0),
                );
            // Some axis-aligned rays, with the negative zeros that `-DVec3::Z` carries.
            let axes = [
                DVec3::X,
                -DVec3::X,
                DVec3::Y,
                -DVec3::Y,
                DVec3::Z,
                -DVec3::Z,
            ];
            let d = if rng.random_bool(0.2) {
                axes[rng.random_range(0..axes.len())]
            } else {
                random_dir(&mut rng)
            };
            let tmin = if rng.random_bool(0.5) {
                0.0
            } else {
                rng.random_range(0.0..20.0)
            };
            let tmax = if rng.random_bool(0.5) {
                f64::INFINITY
            } else {
                rng.random_range(20.0..300.0)
            };
            let bf = brute(&tris, o, d, tmin, tmax);
            let occ = scene.occluded(o, d, tmin, tmax);
            let fh = scene.first_hit(o, d, tmin, tmax);
            assert_eq!(occ, fh.is_some(), "occluded and first_hit disagree");
            if bf.sure.is_some() {
                assert!(occ, "missed a certain hit {o:?} {d:?}");
            }
            if bf.possible.is_infinite() {
                assert!(!occ, "hit where nothing can be hit");
            }
            if let Some(h) = fh {
                hits += 1;
                let sure_t = bf.sure.map_or(f64::INFINITY, |s| s.0);
                assert!(
                    h.t >= bf.possible - T_EPS && h.t <= sure_t + T_EPS,
                    "t {} not in [{}, {}]",
                    h.t,
                    bf.possible,
                    sure_t
                );
                // The reported triangle is really hit there.
                let tri = &tris[h.triangle as usize];
                let (t, m) = mt_unbounded(o, d, tri).unwrap();
                assert!((t - h.t).abs() <= T_EPS && m >= -BARY_EPS);
                assert_eq!(h.tag, 1000 + h.triangle);
                if let Some((s, i)) = bf.sure {
                    if bf.near_sure == 1 && (h.t - s).abs() <= T_EPS {
                        assert_eq!(h.tag, 1000 + i as u32);
                    }
                    if bf.near_sure == 1 && bf.possible >= s - T_EPS {
                        assert_eq!(h.tag, 1000 + i as u32, "wrong closest triangle");
                    }
                }
            }
        }
        hits
    }

    #[test]
    fn random_scene_matches_brute_force_cwbvh() {
        let hits = check_against_brute(1, 400, 2000, BvhLayout::Cwbvh);
        assert!(hits > 100, "too few hits to mean anything: {hits}");
    }

    #[test]
    fn random_scene_matches_brute_force_bvh2() {
        let hits = check_against_brute(2, 300, 1000, BvhLayout::Bvh2);
        assert!(hits > 40, "too few hits to mean anything: {hits}");
    }

    #[test]
    fn fastest_bvh2_matches_brute_force() {
        let hits = check_against_brute_with(3, 400, 2000, BvhLayout::Bvh2, BuildQuality::Fastest);
        assert!(hits > 100, "too few hits to mean anything: {hits}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(12))]
        #[test]
        fn prop_random_scenes(seed in any::<u64>(), n in 1usize..200) {
            check_against_brute(seed, n, 200, BvhLayout::Cwbvh);
        }
    }

    /// The 12 triangles of an axis-aligned box, tagged per face (0..6: -x +x -y +y -z +z).
    fn add_box(b: &mut SceneBuilder, min: DVec3, max: DVec3, tag0: u32) {
        let c = |i: usize| {
            DVec3::new(
                if i & 1 == 0 { min.x } else { max.x },
                if i & 2 == 0 { min.y } else { max.y },
                if i & 4 == 0 { min.z } else { max.z },
            )
        };
        let faces = [
            [0, 4, 6, 2],
            [1, 3, 7, 5],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 2, 3, 1],
            [4, 5, 7, 6],
        ];
        for (f, q) in faces.iter().enumerate() {
            let p = Polygon::new(q.iter().map(|&i| c(i)).collect());
            assert_eq!(b.add_polygon(tag0 + f as u32, &p), 2);
        }
    }

    #[test]
    fn unit_box_in_front_of_origin() {
        let o = UTM + DVec3::new(0.0, 0.0, 10.0);
        let mut b = SceneBuilder::new();
        add_box(
            &mut b,
            o + DVec3::new(2.0, -0.5, -0.5),
            o + DVec3::new(3.0, 0.5, 0.5),
            0,
        );
        let s = b.build();
        assert_eq!(s.len(), 12);
        let bb = s.bbox();
        assert!((bb.min - (o + DVec3::new(2.0, -0.5, -0.5))).length() < 1e-9);
        assert!((s.origin() - (o + DVec3::new(2.5, 0.0, 0.0))).length() < 1e-9);
        let h = s.first_hit(o, DVec3::X, 0.0, f64::INFINITY).unwrap();
        assert_eq!(h.tag, 0);
        assert!((h.t - 2.0).abs() < 1e-6, "{}", h.t);
        assert_eq!(s.tag(h.triangle), Some(0));
        // Skip the front face with tmin: the back face (+x) is next.
        let h = s.first_hit(o, DVec3::X, 2.5, f64::INFINITY).unwrap();
        assert_eq!(h.tag, 1);
        assert!((h.t - 3.0).abs() < 1e-6);
        assert!(s.first_hit(o, -DVec3::X, 0.0, f64::INFINITY).is_none());
        assert!(!s.occluded(o, DVec3::X, 0.0, 1.5));
        assert!(s.occluded(o, DVec3::X, 0.0, 2.5));
        assert!(!s.occluded(o, DVec3::Z, 0.0, f64::INFINITY));
        assert!(!s.occluded(o, DVec3::X, 3.5, f64::INFINITY));
        // From above: the top face.
        let h = s
            .first_hit(o + DVec3::new(2.5, 0.0, 5.0), -DVec3::Z, 0.0, 100.0)
            .unwrap();
        assert_eq!(h.tag, 5);
        assert!((h.t - 4.5).abs() < 1e-6);
        // Oblique ray through the box.
        let d = DVec3::new(2.5, 0.2, 0.1).normalize();
        let h = s.first_hit(o, d, 0.0, f64::INFINITY).unwrap();
        assert_eq!(h.tag, 0);
        assert!((h.t - 2.0 / d.x).abs() < 1e-6);
    }

    #[test]
    fn empty_scene_and_invalid_rays() {
        let s = SceneBuilder::new().build();
        assert!(s.is_empty());
        assert!(s.bbox().is_empty());
        assert!(!s.occluded(UTM, DVec3::Z, 0.0, f64::INFINITY));
        assert!(s.first_hit(UTM, DVec3::Z, 0.0, f64::INFINITY).is_none());
        // Only degenerate input: still empty.
        let mut b = SceneBuilder::new();
        assert!(!b.add_triangle(0, [DVec3::ZERO, DVec3::X, DVec3::X * 2.0]));
        assert!(!b.add_triangle(0, [DVec3::ZERO, DVec3::X, DVec3::splat(f64::NAN)]));
        assert_eq!(
            b.add_polygon(0, &Polygon::new(vec![DVec3::ZERO, DVec3::X])),
            0
        );
        assert!(b.build().is_empty());
        // Invalid rays on a real scene.
        let mut b = SceneBuilder::new();
        add_box(&mut b, UTM, UTM + DVec3::ONE, 0);
        let s = b.build();
        let o = UTM - DVec3::X;
        assert!(s.occluded(
            o + DVec3::splat(0.5) * DVec3::new(0.0, 1.0, 1.0),
            DVec3::X,
            0.0,
            f64::INFINITY
        ));
        assert!(!s.occluded(o, DVec3::ZERO, 0.0, f64::INFINITY));
        assert!(!s.occluded(o, DVec3::splat(f64::NAN), 0.0, f64::INFINITY));
        assert!(s
            .first_hit(DVec3::splat(f64::INFINITY), DVec3::X, 0.0, 1.0)
            .is_none());
        assert!(!s.occluded(o, DVec3::X, 5.0, 1.0));
    }

    #[test]
    fn rays_through_shared_edges_and_vertices_do_not_slip() {
        // A quad split along its diagonal, at UTM coordinates, plus a closed box.
        let q = [
            UTM + DVec3::new(10.0, 20.0, 30.0),
            UTM + DVec3::new(17.3, 20.0, 30.0),
            UTM + DVec3::new(17.3, 29.1, 30.0),
            UTM + DVec3::new(10.0, 29.1, 30.0),
        ];
        let mut b = SceneBuilder::new();
        assert_eq!(b.add_polygon(1, &Polygon::new(q.to_vec())), 2);
        let s = b.build();
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        for i in 0..=1000 {
            let f = i as f64 / 1000.0;
            // Points on the diagonal, on the inner vertex pair and the centre.
            let targets = [q[0].lerp(q[2], f), q[1].lerp(q[3], f)];
            for target in targets {
                let o = UTM
                    + DVec3::new(
                        rng.random_range(-50.0..50.0),
                        rng.random_range(-50.0..50.0),
                        rng.random_range(-20.0..20.0),
                    );
                let d = (target - o).normalize();
                let dist = (target - o).length();
                let inside_edge = f > 0.0 && f < 1.0;
                if inside_edge {
                    assert!(
                        s.occluded(o, d, 0.0, dist + 1.0),
                        "slipped through at f={f}"
                    );
                    let h = s.first_hit(o, d, 0.0, f64::INFINITY).unwrap();
                    assert!((h.t - dist).abs() < 1e-3);
                }
            }
        }
        // Closed box: every ray from inside hits, including rays aimed at its vertices
        // and edges, where four or six triangles meet.
        let (lo, hi) = (
            UTM + DVec3::new(-3.0, -4.0, 0.0),
            UTM + DVec3::new(5.0, 6.5, 12.0),
        );
        let mut b = SceneBuilder::new();
        add_box(&mut b, lo, hi, 0);
        let s = b.build();
        let inside = UTM + DVec3::new(0.3, 0.7, 4.1);
        let mut aims = Vec::new();
        for i in 0..8 {
            let corner = DVec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            );
            aims.push(corner);
            aims.push((corner + inside) * 0.5);
            aims.push(DVec3::new(corner.x, corner.y, (lo.z + hi.z) * 0.5));
        }
        for a in aims {
            let d = (a - inside).normalize();
            assert!(
                s.occluded(inside, d, 0.0, f64::INFINITY),
                "escaped towards {a:?}"
            );
        }
        for _ in 0..20_000 {
            let d = random_dir(&mut rng);
            assert!(
                s.first_hit(inside, d, 0.0, f64::INFINITY).is_some(),
                "escaped along {d:?}"
            );
        }
    }

    const LAYOUTS: [BvhLayout; 2] = [BvhLayout::Cwbvh, BvhLayout::Bvh2];
    const QUALITIES: [BuildQuality; 4] = [
        BuildQuality::Fastest,
        BuildQuality::VeryFast,
        BuildQuality::Fast,
        BuildQuality::Medium,
    ];

    /// What `first_hit` promises, by brute force over every triangle with the same f32
    /// test: the smallest (t, triangle index). Returns (t, triangle, number of
    /// triangles at exactly that t).
    fn brute_closest(
        s: &TraceScene,
        o: DVec3,
        d: DVec3,
        tmin: f64,
        tmax: f64,
    ) -> Option<(f32, u32, usize)> {
        let (ray, wt) = s.local_ray(o, d, tmin, tmax)?;
        let mut best: Option<(f32, u32, usize)> = None;
        for (slot, tri) in s.tris.iter().enumerate() {
            let t = wt.intersect(tri, ray.tmin, ray.tmax);
            if !t.is_finite() {
                continue;
            }
            let index = s.slot_triangle[slot];
            best = match best {
                Some((bt, bi, n)) if t == bt => Some((t, bi.min(index), n + 1)),
                Some(b) if b.0 < t => Some(b),
                _ => Some((t, index, 1)),
            };
        }
        best
    }

    /// Triangles with exact ties: a ground grid (shared edges and vertices), boxes
    /// whose every triangle is there twice, and overlapping coplanar quads on a wall
    /// and on a tilted roof. Also the points rays are aimed at.
    fn tie_scene(rng: &mut ChaCha8Rng) -> (Vec<[DVec3; 3]>, Vec<DVec3>) {
        let mut tris = Vec::new();
        let mut aims = Vec::new();
        let g = UTM + DVec3::new(-50.0, -50.0, 0.0);
        let at = |i: usize, j: usize| g + DVec3::new(i as f64 * 5.0, j as f64 * 5.0, 0.0);
        for j in 0..20 {
            for i in 0..20 {
                let (a, b, c, e) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                tris.push([a, b, c]);
                tris.push([a, c, e]);
                aims.push(a);
                aims.push(a.lerp(c, rng.random_range(0.0..1.0)));
                aims.push(a.lerp(b, rng.random_range(0.0..1.0)));
            }
        }
        for k in 0..30 {
            let lo = g + DVec3::new(
                rng.random_range(0.0..90.0),
                rng.random_range(0.0..90.0),
                0.0,
            );
            let hi = lo
                + DVec3::new(
                    rng.random_range(2.0..8.0),
                    rng.random_range(2.0..8.0),
                    rng.random_range(3.0..20.0),
                );
            let mut b = SceneBuilder::new();
            add_box(&mut b, lo, hi, 0);
            let copies = if k % 3 == 0 { 3 } else { 2 };
            for _ in 0..copies {
                tris.extend_from_slice(&b.tris);
            }
            for t in &b.tris {
                aims.push((t[0] + t[1] + t[2]) / 3.0);
                aims.push(t[0].lerp(t[2], rng.random_range(0.0..1.0)));
            }
        }
        let x = g.x + 101.0;
        let wall = |y0: f64, y1: f64, z0: f64, z1: f64| {
            Polygon::new(vec![
                DVec3::new(x, y0, z0),
                DVec3::new(x, y1, z0),
                DVec3::new(x, y1, z1),
                DVec3::new(x, y0, z1),
            ])
        };
        let (o, u, v) = (
            g + DVec3::new(20.0, 110.0, 10.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 0.8, 0.6),
        );
        let roof = |a0: f64, a1: f64, b0: f64, b1: f64| {
            Polygon::new(vec![
                o + u * a0 + v * b0,
                o + u * a1 + v * b0,
                o + u * a1 + v * b1,
                o + u * a0 + v * b1,
            ])
        };
        for _ in 0..20 {
            let (y0, z0) = (rng.random_range(0.0..60.0), rng.random_range(0.0..20.0));
            let p = wall(g.y + y0, g.y + y0 + 30.0, z0, z0 + 10.0);
            let (a0, b0) = (rng.random_range(0.0..40.0), rng.random_range(0.0..20.0));
            let q = roof(a0, a0 + 20.0, b0, b0 + 10.0);
            for poly in [p, q] {
                let mut b = SceneBuilder::new();
                b.add_polygon(0, &poly);
                tris.extend_from_slice(&b.tris);
                aims.push(b.tris[0][0].lerp(b.tris[0][2], rng.random_range(0.0..1.0)));
                aims.push(b.tris[1][0].lerp(b.tris[1][1], 0.5));
            }
        }
        (tris, aims)
    }

    #[test]
    fn ties_resolve_to_smallest_triangle_index_whatever_the_tree() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let (tris, aims) = tie_scene(&mut rng);
        let mut rays = Vec::new();
        for k in 0..3000 {
            let o = UTM
                + DVec3::new(
                    rng.random_range(-80.0..80.0),
                    rng.random_range(-80.0..80.0),
                    rng.random_range(1.0..60.0),
                );
            let d = if k % 10 == 9 {
                random_dir(&mut rng)
            } else {
                (aims[rng.random_range(0..aims.len())] - o).normalize()
            };
            rays.push((o, d));
        }
        let mut ties = 0;
        let mut winners_by_order = Vec::new();
        for order in 0..3 {
            // Original index as tag; the insertion order is shuffled after the first.
            let mut tagged: Vec<(u32, [DVec3; 3])> = tris
                .iter()
                .enumerate()
                .map(|(i, t)| (i as u32, *t))
                .collect();
            if order > 0 {
                for i in (1..tagged.len()).rev() {
                    tagged.swap(i, rng.random_range(0..=i));
                }
            }
            let mut reference: Option<Vec<Option<Hit>>> = None;
            for layout in LAYOUTS {
                for quality in QUALITIES {
                    let mut b = SceneBuilder::new()
                        .with_layout(layout)
                        .with_quality(quality);
                    for (tag, t) in &tagged {
                        assert!(b.add_triangle(*tag, *t));
                    }
                    let s = b.build();
                    let hits: Vec<Option<Hit>> = rays
                        .iter()
                        .map(|&(o, d)| s.first_hit(o, d, 0.01, f64::INFINITY))
                        .collect();
                    if reference.is_none() {
                        for (&(o, d), h) in rays.iter().zip(&hits) {
                            let want = brute_closest(&s, o, d, 0.01, f64::INFINITY);
                            assert_eq!(h.map(|h| h.triangle), want.map(|w| w.1), "{o:?} {d:?}");
                            if let (Some(h), Some(w)) = (h, want) {
                                assert_eq!(Some(h.tag), s.tag(w.1));
                                assert_eq!(h.tag, tagged[w.1 as usize].0);
                                if w.2 > 1 {
                                    ties += 1;
                                }
                            }
                        }
                        reference = Some(hits);
                    } else {
                        // Bit-identical to the first tree's answers (t included).
                        for (i, (a, b)) in reference.iter().flatten().zip(&hits).enumerate() {
                            assert_eq!(
                                a.map(|h| (h.tag, h.triangle, h.t.to_bits())),
                                b.map(|h| (h.tag, h.triangle, h.t.to_bits())),
                                "ray {i}, {layout:?} {quality:?}, order {order}"
                            );
                        }
                    }
                }
            }
            winners_by_order.push(reference.unwrap_or_default());
        }
        assert!(ties > 1000, "too few exact ties to mean anything: {ties}");
        // Duplicates: the shuffled orders pick other copies (other tags) at the same t.
        let changed = winners_by_order[0]
            .iter()
            .zip(&winners_by_order[1])
            .filter(|(a, b)| match (a, b) {
                (Some(a), Some(b)) => a.tag != b.tag && a.t == b.t,
                _ => false,
            })
            .count();
        assert!(
            changed > 100,
            "insertion order never decided a tie: {changed}"
        );
    }

    #[test]
    fn occluded_sees_a_face_at_exactly_tmax() {
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        let (tris, aims) = tie_scene(&mut rng);
        for layout in LAYOUTS {
            for quality in QUALITIES {
                let mut b = SceneBuilder::new()
                    .with_layout(layout)
                    .with_quality(quality);
                for (i, t) in tris.iter().enumerate() {
                    b.add_triangle(i as u32, *t);
                }
                let s = b.build();
                let mut checked = 0;
                for a in aims.iter().step_by(7) {
                    let o = UTM + DVec3::new(3.0, -7.0, 70.0);
                    let d = (*a - o).normalize();
                    let Some(h) = s.first_hit(o, d, 0.01, f64::INFINITY) else {
                        continue;
                    };
                    let (ray, _) = s.local_ray(o, d, 0.01, f64::INFINITY).unwrap();
                    let (_, wt) = s.local_ray(o, d, 0.0, 0.0).unwrap();
                    let slot = s
                        .slot_triangle
                        .iter()
                        .position(|&x| x == h.triangle)
                        .unwrap();
                    let t32 = wt.intersect(&s.tris[slot], ray.tmin, ray.tmax);
                    assert!(s.occluded(o, d, 0.01, t32 as f64), "{layout:?} {quality:?}");
                    let hit = s.first_hit(o, d, 0.01, t32 as f64).unwrap();
                    assert_eq!(hit.triangle, h.triangle);
                    checked += 1;
                }
                assert!(checked > 100, "{checked}");
            }
        }
    }
}
