//! Ray casting against a triangle scene through an `obvhs` BVH (pipeline stage "trace").
//!
//! A [`Scene`] owns the triangles of many polygons, each tagged with a `u32` chosen by
//! the caller (typically the asset index). [`SceneBuilder::build`] shifts everything
//! to a local origin (the centre of the scene's bounding box, kept as f64) and converts
//! to f32 before the BVH is built, because raw UTM coordinates (~5e6 m) in f32 lose
//! centimetres (see DESIGN.md, "Coordinates"). Ray origins are given in model
//! coordinates and shifted the same way, in f64, before rounding.
//!
//! Acceleration structure: obvhs' compressed wide BVH8 ([`BvhLayout::Cwbvh`], PLOC +
//! reinsertion, [`BuildQuality::Fast`] = `BvhBuildParams::fast_build`) is the default.
//! Measured with a CPU-time probe on the bench city (600K triangles, 10,000 hemisphere
//! rays from a street, 2-core machine under heavy load from other jobs):
//!
//! | layout, quality   | build  | 10K `first_hit` | 10K `occluded` |
//! |-------------------|--------|-----------------|----------------|
//! | Cwbvh, VeryFast   | 355 ms | 6.8 ms          | 4.2 ms         |
//! | Cwbvh, Fast       | 435 ms | 5.7 ms          | 3.6 ms         |
//! | Cwbvh, Medium     | 556 ms | 5.0 ms          | 3.1 ms         |
//! | Bvh2, Fastest     | 141 ms | 8.1 ms          | 4.9 ms         |
//! | Bvh2, Fast        | 343 ms | 6.3 ms          | 3.6 ms         |
//! | Bvh2, Medium      | 474 ms | 5.2 ms          | 3.2 ms         |
//!
//! At equal build effort the CWBVH traces 5-20 % faster, so it is the default; its
//! conversion from the binary tree makes it slower to build, and when building
//! dominates (many small scenes, few rays) `Bvh2` + [`BuildQuality::Fastest`] is the
//! better choice: [`SceneBuilder::for_rays`] is the one rule that picks it (`lod`'s
//! selection scene). obvhs is used without its `parallel` feature (single-thread build).
//!
//! Triangles are intersected with the *watertight* test of Woop, Benthin and Wald
//! (JCGT 2013) in f32, with an exact f64 fallback when an edge function is zero: a ray
//! through the shared edge or vertex of two triangles of one mesh hits at least one of
//! them. The distance of the closest hit is then refined in f64 against the plane of
//! the hit triangle.
//!
//! Results do not depend on the tree: [`Scene::first_hit`] returns the smallest f32
//! distance and, among triangles at exactly that distance (duplicated or coincident
//! faces, shared edges), the smallest triangle index; the node boxes are grown a little
//! (`node_pad`) so that obvhs' non-robust slab test never drops a triangle the triangle
//! test hits. So layout, build effort, thread count and how POIs are split into shards
//! never change an answer (`ties_resolve_to_smallest_triangle_index_whatever_the_tree`).
//!
//! All queries take `&self`; a [`Scene`] is `Send + Sync`, so callers parallelise over
//! rays with rayon. Results do not depend on the thread count.

mod polygons;
pub mod ray;

pub use polygons::scene_of;

use crate::model::triangulate;
use crate::model::{Bbox, Polygon};
use glam::{DVec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::leaf_collapser::collapse;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::bvh2::Bvh2;
use obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh;
use obvhs::cwbvh::CwBvh;
use obvhs::ploc::PlocBuilder;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use rayon::prelude::*;

/// Which obvhs acceleration structure a [`Scene`] uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BvhLayout {
    /// Compressed wide BVH8 (8-way, SIMD node tests). The faster one; the default.
    #[default]
    Cwbvh,
    /// Binary BVH with collapsed leaves.
    Bvh2,
}

/// Build effort of the BVH: less effort builds faster and traces a little slower.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BuildQuality {
    /// obvhs `fastest_build`: PLOC with the smallest search radius, no reinsertion.
    Fastest,
    /// obvhs `very_fast_build`: a little reinsertion.
    VeryFast,
    /// obvhs `fast_build`. The default.
    #[default]
    Fast,
    /// obvhs `medium_build`.
    Medium,
}

impl BuildQuality {
    fn params(self) -> BvhBuildParams {
        match self {
            BuildQuality::Fastest => BvhBuildParams::fastest_build(),
            BuildQuality::VeryFast => BvhBuildParams::very_fast_build(),
            BuildQuality::Fast => BvhBuildParams::fast_build(),
            BuildQuality::Medium => BvhBuildParams::medium_build(),
        }
    }
}

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

/// Collects tagged triangles in model coordinates; [`SceneBuilder::build`] makes a [`Scene`].
///
/// Non-finite triangles and zero-area triangles are skipped.
#[derive(Debug, Clone, Default)]
pub struct SceneBuilder {
    tris: Vec<[DVec3; 3]>,
    tags: Vec<u32>,
    layout: BvhLayout,
    quality: BuildQuality,
    scratch: Vec<[DVec3; 3]>,
}

impl SceneBuilder {
    /// An empty builder (CWBVH layout).
    pub fn new() -> Self {
        Self::default()
    }

    /// Choose the acceleration structure (default [`BvhLayout::Cwbvh`]).
    pub fn with_layout(mut self, layout: BvhLayout) -> Self {
        self.layout = layout;
        self
    }

    /// Choose the build effort (default [`BuildQuality::Fast`]).
    pub fn with_quality(mut self, quality: BuildQuality) -> Self {
        self.quality = quality;
        self
    }

    /// Choose layout and effort for a scene that will trace about `rays` rays (the one
    /// rule, used by `lod`'s selection scene): when they are fewer than half its
    /// triangles, building dominates and [`BvhLayout::Bvh2`] with [`BuildQuality::Fastest`]
    /// costs least overall; otherwise the default CWBVH with [`BuildQuality::Fast`].
    /// Measured (BENCHMARKS.md, "BVH: deterministic ties, quicker build"): the quick build
    /// saves 0.8-0.95 µs per triangle and costs 0.6-1.2 µs more per ray (paper district,
    /// 166K triangles, 60K rays: build + select ~295 → ~200 ms; 18x18 city, 1.33M
    /// triangles, 1M rays: a wash, so it keeps the CWBVH). Call it after the last triangle
    /// is added. Results do not depend on the choice ([`Scene::first_hit`] breaks ties by
    /// triangle index), so a shard that traces fewer rays may build another tree and
    /// still agree.
    pub fn for_rays(self, rays: usize) -> Self {
        if rays.saturating_mul(2) < self.tris.len() {
            self.with_layout(BvhLayout::Bvh2)
                .with_quality(BuildQuality::Fastest)
        } else {
            self.with_layout(BvhLayout::default())
                .with_quality(BuildQuality::default())
        }
    }

    /// Number of triangles collected so far.
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// True when no triangle was collected.
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// Triangulate a polygon (holes honoured) and add its triangles with `tag`.
    /// Returns the number of triangles added (0 for a degenerate polygon).
    pub fn add_polygon(&mut self, tag: u32, p: &Polygon) -> usize {
        let mut scratch = std::mem::take(&mut self.scratch);
        scratch.clear();
        triangulate(p, &mut scratch);
        let added = scratch
            .iter()
            .filter(|t| self.add_triangle(tag, **t))
            .count();
        self.scratch = scratch;
        added
    }

    /// Add one triangle with `tag`. Returns false (and adds nothing) when a vertex is
    /// not finite or the triangle has zero area.
    pub fn add_triangle(&mut self, tag: u32, tri: [DVec3; 3]) -> bool {
        if !tri.iter().all(|p| p.is_finite()) {
            return false;
        }
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        if n.length_squared() == 0.0 {
            return false;
        }
        self.tris.push(tri);
        self.tags.push(tag);
        true
    }

    /// Build the BVH. An empty builder gives an empty scene in which every ray is free.
    pub fn build(mut self) -> Scene {
        let bbox = Bbox::of_points(self.tris.iter().flatten());
        let origin = if bbox.is_empty() {
            DVec3::ZERO
        } else {
            bbox.center()
        };
        // The f64 triangles go before the BVH is built (its peak): a city's rough scene
        // holds millions.
        let world = std::mem::take(&mut self.tris);
        self.scratch = Vec::new();
        let local: Vec<Triangle> = world
            .par_iter()
            .map(|t| Triangle {
                v0: to_local(t[0], origin),
                v1: to_local(t[1], origin),
                v2: to_local(t[2], origin),
            })
            .collect();
        drop(world);
        if local.is_empty() {
            return Scene {
                origin,
                bbox,
                tris: Vec::new(),
                slot_triangle: Vec::new(),
                tags: self.tags,
                pad: 0.0,
                accel: Accel::Empty,
            };
        }
        let pad = node_pad(&local);
        let (accel, indices) = build_accel(&local, self.layout, self.quality.params(), pad);
        // Lay the triangles out in BVH leaf order so traversal reads them directly.
        let mut tris = Vec::with_capacity(indices.len());
        let mut slot_triangle = Vec::with_capacity(indices.len());
        for &i in &indices {
            if let Some(t) = local.get(i as usize) {
                tris.push(*t);
                slot_triangle.push(i);
            }
        }
        Scene {
            origin,
            bbox,
            tris,
            slot_triangle,
            tags: self.tags,
            pad,
            accel,
        }
    }
}

/// How far every BVH node box is grown on each side: 2^-15 of the largest local
/// coordinate (3 cm for a scene 2 km across; at least 2^-15 m).
///
/// obvhs' slab tests are not robust: a ray that hits a triangle exactly on the border of
/// its node's box (a shared edge or vertex, an axis-aligned face in a flat box) can miss
/// the box by rounding, and its neighbour across the edge, in another node, wins; which
/// one then depends on the tree. Grown boxes contain every point the f32 triangle test
/// can hit with a margin far above the rounding of both tests (tens of ulps of any
/// distance within a few scene extents), so whether a triangle is tested no longer
/// depends on the tree. Costs a few more node visits.
fn node_pad(local: &[Triangle]) -> f32 {
    let m = local
        .iter()
        .flat_map(|t| [t.v0, t.v1, t.v2])
        .fold(1.0f32, |m, v| m.max(v.abs().max_element()));
    m * (1.0 / 32768.0)
}

/// obvhs' `build_bvh2_from_tris` / `build_cwbvh_from_tris` (PLOC, reinsertion, then leaf
/// collapse or the wide conversion), with every node box grown by `pad`
/// ([`node_pad`]) before the tree is used. Returns the structure and its slot order.
fn build_accel(
    local: &[Triangle],
    layout: BvhLayout,
    params: BvhBuildParams,
    pad: f32,
) -> (Accel, Vec<u32>) {
    let mut bvh2 = PlocBuilder::with_capacity(local.len()).build(
        params.ploc_search_distance,
        local,
        (0..local.len() as u32).collect(),
        params.sort_precision,
        params.search_depth_threshold,
    );
    let mut reinsertion = ReinsertionOptimizer::default();
    reinsertion.run(&mut bvh2, params.reinsertion_batch_ratio, None);
    if layout == BvhLayout::Bvh2 {
        collapse(
            &mut bvh2,
            params.max_prims_per_leaf.clamp(1, 255),
            params.collapse_traversal_cost,
        );
        reinsertion.run(
            &mut bvh2,
            params.reinsertion_batch_ratio
                * params.post_collapse_reinsertion_batch_ratio_multiplier,
            None,
        );
    }
    let grow = Vec3A::splat(pad);
    for node in bvh2.nodes.iter_mut() {
        let a = *node.aabb();
        node.set_aabb(Aabb::new(a.min - grow, a.max + grow));
    }
    match layout {
        BvhLayout::Cwbvh => {
            let mut cw = bvh2_to_cwbvh(&bvh2, params.max_prims_per_leaf.clamp(1, 3), true, false);
            let idx = std::mem::take(&mut cw.primitive_indices);
            (Accel::Cw(cw), idx)
        }
        BvhLayout::Bvh2 => {
            let idx = std::mem::take(&mut bvh2.primitive_indices);
            (Accel::Bvh2(bvh2), idx)
        }
    }
}

fn to_local(p: DVec3, origin: DVec3) -> Vec3A {
    (p - origin).as_vec3().into()
}

#[derive(Clone)]
enum Accel {
    Empty,
    Cw(CwBvh),
    Bvh2(Bvh2),
}

impl std::fmt::Debug for Accel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Accel::Empty => f.write_str("Empty"),
            Accel::Cw(b) => write!(f, "Cwbvh({} nodes)", b.nodes.len()),
            Accel::Bvh2(b) => write!(f, "Bvh2({} nodes)", b.nodes.len()),
        }
    }
}

/// A BVH over tagged triangles, ready for ray queries. Build it with [`SceneBuilder`].
///
/// # Example
/// ```rust
/// use glam::DVec3;
/// use skylod::model::Polygon;
/// use skylod::trace::SceneBuilder;
/// let o = DVec3::new(430_000.0, 4_581_000.0, 0.0);
/// let roof = Polygon::new(vec![
///     o + DVec3::new(-5.0, 5.0, 8.0), o + DVec3::new(5.0, 5.0, 8.0),
///     o + DVec3::new(5.0, 20.0, 8.0), o + DVec3::new(-5.0, 20.0, 8.0),
/// ]);
/// let mut b = SceneBuilder::new();
/// assert_eq!(b.add_polygon(7, &roof), 2);
/// let scene = b.build();
/// let up_north = DVec3::new(0.0, 1.0, 1.0).normalize();
/// let hit = scene.first_hit(o, up_north, 0.0, f64::INFINITY).unwrap();
/// assert_eq!(hit.tag, 7);
/// assert!((hit.t - 8.0 * 2f64.sqrt()).abs() < 1e-6);
/// assert!(!scene.occluded(o, DVec3::Z, 0.0, f64::INFINITY));
/// ```
#[derive(Debug, Clone)]
pub struct Scene {
    origin: DVec3,
    bbox: Bbox,
    /// Local f32 triangles in BVH slot order.
    tris: Vec<Triangle>,
    /// Slot -> triangle index (insertion order).
    slot_triangle: Vec<u32>,
    /// Triangle index -> tag.
    tags: Vec<u32>,
    /// How far the node boxes were grown ([`node_pad`]).
    pad: f32,
    accel: Accel,
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

impl Scene {
    /// Number of triangles in the scene.
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// True for a scene without triangles.
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// Bounding box of the triangles in model coordinates (empty for an empty scene).
    pub fn bbox(&self) -> Bbox {
        self.bbox
    }

    /// The local origin (model coordinates) that was subtracted before conversion to f32.
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// Tag of triangle `triangle` (as in [`Hit::triangle`]).
    pub fn tag(&self, triangle: u32) -> Option<u32> {
        self.tags.get(triangle as usize).copied()
    }

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
    /// covered by that promise; callers start rays at [`crate::poi::POI_OFFSET`] or more.
    pub fn first_hit(&self, origin: DVec3, dir: DVec3, tmin: f64, tmax: f64) -> Option<Hit> {
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
        Some(Hit { tag, t, triangle })
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
mod tests {
    use super::*;
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

    fn random_scene(rng: &mut ChaCha8Rng, n: usize) -> Vec<[DVec3; 3]> {
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
    fn few_rays_choose_the_quick_build() {
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let mut b = SceneBuilder::new();
        for (i, t) in random_scene(&mut rng, 300).iter().enumerate() {
            b.add_triangle(i as u32, *t);
        }
        let few = b.clone().for_rays(100);
        assert_eq!(
            (few.layout, few.quality),
            (BvhLayout::Bvh2, BuildQuality::Fastest)
        );
        let many = b.for_rays(10_000);
        assert_eq!(
            (many.layout, many.quality),
            (BvhLayout::Cwbvh, BuildQuality::Fast)
        );
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
        s: &Scene,
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

    #[test]
    fn scene_is_send_and_sync() {
        fn assert_send_sync<T: Send + Sync>() {}
        assert_send_sync::<Scene>();
    }
}
