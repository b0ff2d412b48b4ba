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
//! reinsertion, `BvhBuildParams::fast_build`) is the default. On the bench
//! (`benches/trace.rs`, ~300K triangles of a synthetic city, 2-core machine) it
//! traced hemisphere rays faster than the binary BVH ([`BvhLayout::Bvh2`]) at a
//! similar build time, so the binary BVH is kept only as an option for comparison.
//!
//! Triangles are intersected with the *watertight* test of Woop, Benthin and Wald
//! (JCGT 2013) in f32, with an exact f64 fallback when an edge function is zero: a ray
//! through the shared edge or vertex of two triangles of one mesh hits at least one of
//! them. The distance of the closest hit is then refined in f64 against the plane of
//! the hit triangle.
//!
//! All queries take `&self`; a [`Scene`] is `Send + Sync`, so callers parallelise over
//! rays with rayon. Results do not depend on the thread count.

use crate::geom::triangulate;
use crate::model::{Bbox, Polygon};
use glam::{DVec3, Vec3A};
use obvhs::bvh2::builder::build_bvh2_from_tris;
use obvhs::bvh2::Bvh2;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use std::time::Duration;

/// Which obvhs acceleration structure a [`Scene`] uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BvhLayout {
    /// Compressed wide BVH8 (8-way, SIMD node tests). The faster one; the default.
    #[default]
    Cwbvh,
    /// Binary BVH with collapsed leaves.
    Bvh2,
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
    pub fn build(self) -> Scene {
        let bbox = Bbox::of_points(self.tris.iter().flatten());
        let origin = if bbox.is_empty() {
            DVec3::ZERO
        } else {
            bbox.center()
        };
        let local: Vec<Triangle> = self
            .tris
            .iter()
            .map(|t| Triangle {
                v0: to_local(t[0], origin),
                v1: to_local(t[1], origin),
                v2: to_local(t[2], origin),
            })
            .collect();
        if local.is_empty() {
            return Scene {
                origin,
                bbox,
                tris: Vec::new(),
                slot_triangle: Vec::new(),
                tags: self.tags,
                accel: Accel::Empty,
            };
        }
        let mut dur = Duration::default();
        let (accel, indices) = match self.layout {
            BvhLayout::Cwbvh => {
                let mut bvh = build_cwbvh_from_tris(&local, build_params(), &mut dur);
                let idx = std::mem::take(&mut bvh.primitive_indices);
                (Accel::Cw(bvh), idx)
            }
            BvhLayout::Bvh2 => {
                let mut bvh = build_bvh2_from_tris(&local, build_params(), &mut dur);
                let idx = std::mem::take(&mut bvh.primitive_indices);
                (Accel::Bvh2(bvh), idx)
            }
        };
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
            accel,
        }
    }
}

fn build_params() -> BvhBuildParams {
    BvhBuildParams::fast_build()
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
///     o + DVec3::new(-5.0, 10.0, 8.0), o + DVec3::new(5.0, 10.0, 8.0),
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
        let (o, d) = (Vec3A::from(o), Vec3A::from(d));
        Some((Ray::new(o, d, tmin, tmax), Watertight::new(o, d)))
    }

    /// True when a triangle is hit with `tmin <= t <= tmax` (any-hit traversal, stops at
    /// the first hit found). Invalid rays (zero or non-finite direction or origin) and
    /// empty scenes are never occluded.
    pub fn occluded(&self, origin: DVec3, dir: DVec3, tmin: f64, tmax: f64) -> bool {
        let Some((ray, wt)) = self.local_ray(origin, dir, tmin, tmax) else {
            return false;
        };
        let tris = &self.tris;
        let mut isect = |r: &Ray, id: usize| match tris.get(id) {
            Some(t) => wt.intersect(t, r.tmin, r.tmax),
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
    pub fn first_hit(&self, origin: DVec3, dir: DVec3, tmin: f64, tmax: f64) -> Option<Hit> {
        let (ray, wt) = self.local_ray(origin, dir, tmin, tmax)?;
        let tris = &self.tris;
        let mut isect = |r: &Ray, id: usize| match tris.get(id) {
            Some(t) => wt.intersect(t, r.tmin, r.tmax),
            None => f32::INFINITY,
        };
        let mut hit = RayHit::none();
        let found = match &self.accel {
            Accel::Empty => false,
            Accel::Cw(bvh) => bvh.ray_traverse(ray, &mut hit, &mut isect),
            Accel::Bvh2(bvh) => bvh.ray_traverse(ray, &mut hit, &mut isect),
        };
        if !found {
            return None;
        }
        let slot = hit.primitive_id as usize;
        let tri = self.tris.get(slot)?;
        let triangle = *self.slot_triangle.get(slot)?;
        let tag = *self.tags.get(triangle as usize)?;
        let t = refine_t(tri, origin - self.origin, dir, hit.t as f64);
        Some(Hit { tag, t, triangle })
    }
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
