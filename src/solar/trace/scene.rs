//! The scene and its BVH: tagged triangles collected in model coordinates, shifted to a
//! local origin, converted to f32 and built into an obvhs BVH (see the module docs of
//! [`crate::solar::trace`]).

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
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use rayon::prelude::*;

/// Which obvhs acceleration structure a [`TraceScene`] uses.
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

/// Collects tagged triangles in model coordinates; [`SceneBuilder::build`] makes a [`TraceScene`].
///
/// Non-finite triangles and zero-area triangles are skipped.
#[derive(Debug, Clone, Default)]
pub struct SceneBuilder {
    pub(super) tris: Vec<[DVec3; 3]>,
    tags: Vec<u32>,
    layout: BvhLayout,
    quality: BuildQuality,
    scratch: Vec<[DVec3; 3]>,
    frame: Option<Bbox>,
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
    /// costs least overall; otherwise the default CWBVH with [`BuildQuality::Fast`]. The
    /// quick build saves about as much per triangle as it costs more per ray, hence the
    /// threshold: the paper district's selection scene (166K triangles, 60K rays) gains, the
    /// 1 GB city's (1.33M triangles, 1M rays) would not, so it keeps the CWBVH. Call it after
    /// the last triangle is added. Results do not depend on the choice ([`TraceScene::first_hit`] breaks ties by
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

    /// Build in the frame of `bbox` (the box of a larger scene holding these triangles):
    /// the local origin is its centre and the node boxes are grown as for it, so every
    /// triangle gets the same f32 coordinates, and every ray the same f32 distances, as in
    /// that scene. A scene made of part of another's triangles, added in the same order,
    /// then answers [`TraceScene::first_hit`] exactly as the whole would for every ray whose
    /// answer there is one of its triangles and that no left-out triangle hits as close.
    /// Ignored when `bbox` is empty.
    pub fn with_frame(mut self, bbox: Bbox) -> Self {
        self.frame = (!bbox.is_empty()).then_some(bbox);
        self
    }

    /// Whether [`SceneBuilder::add_triangle`] keeps `tri` (finite, non-zero area).
    pub fn accepts(tri: &[DVec3; 3]) -> bool {
        tri.iter().all(|p| p.is_finite())
            && (tri[1] - tri[0]).cross(tri[2] - tri[0]).length_squared() != 0.0
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
        if !Self::accepts(&tri) {
            return false;
        }
        self.tris.push(tri);
        self.tags.push(tag);
        true
    }

    /// Build the BVH. An empty builder gives an empty scene in which every ray is free.
    pub fn build(mut self) -> TraceScene {
        // min and max are exact in any order: the box is the serial one
        let bbox = (self.tris.par_iter())
            .fold(
                || Bbox::EMPTY,
                |mut b, t| {
                    t.iter().for_each(|p| b.add(*p));
                    b
                },
            )
            .reduce(
                || Bbox::EMPTY,
                |mut a, b| {
                    a.union(&b);
                    a
                },
            );
        let origin = match self.frame {
            Some(f) => f.center(),
            None if bbox.is_empty() => DVec3::ZERO,
            None => bbox.center(),
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
            return TraceScene {
                origin,
                bbox,
                tris: Vec::new(),
                slot_triangle: Vec::new(),
                tags: self.tags,
                pad: 0.0,
                accel: Accel::Empty,
            };
        }
        let mut pad = node_pad(&local);
        if let Some(f) = self.frame {
            // the pad of the frame's scene: its largest local coordinate is a corner's
            let corners = [to_local(f.min, origin), to_local(f.max, origin)];
            pad = pad.max(node_pad(&[Triangle {
                v0: corners[0],
                v1: corners[1],
                v2: corners[1],
            }]));
        }
        let (accel, indices) = build_accel(&local, self.layout, self.quality.params(), pad);
        // Lay the triangles out in BVH leaf order so traversal reads them directly.
        let (tris, slot_triangle): (Vec<Triangle>, Vec<u32>) = (indices.par_iter())
            .filter_map(|&i| Some((*local.get(i as usize)?, i)))
            .unzip();
        TraceScene {
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
    // max is exact in any order
    let m = (local.par_iter())
        .map(|t| {
            [t.v0, t.v1, t.v2]
                .iter()
                .fold(1.0f32, |m, v| m.max(v.abs().max_element()))
        })
        .reduce(|| 1.0f32, f32::max);
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
pub(super) enum Accel {
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
/// use skylod::solar::trace::SceneBuilder;
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
pub struct TraceScene {
    pub(super) origin: DVec3,
    pub(super) bbox: Bbox,
    /// Local f32 triangles in BVH slot order.
    pub(super) tris: Vec<Triangle>,
    /// Slot -> triangle index (insertion order).
    pub(super) slot_triangle: Vec<u32>,
    /// Triangle index -> tag.
    pub(super) tags: Vec<u32>,
    /// How far the node boxes were grown ([`node_pad`]).
    pub(super) pad: f32,
    pub(super) accel: Accel,
}

impl TraceScene {
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

    /// Tag of triangle `triangle` (as in [`Hit::triangle`](super::Hit::triangle)).
    pub fn tag(&self, triangle: u32) -> Option<u32> {
        self.tags.get(triangle as usize).copied()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solar::trace::query::tests::random_scene;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

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
    fn scene_is_send_and_sync() {
        fn assert_send_sync<T: Send + Sync>() {}
        assert_send_sync::<TraceScene>();
    }
}
