//! Ray casting against a triangle scene through an `obvhs` BVH (pipeline stage "trace").
//!
//! A [`TraceScene`] owns the triangles of many polygons, each tagged with a `u32` chosen by
//! the caller (typically the asset index). [`SceneBuilder::build`] shifts everything
//! to a local origin (the centre of the scene's bounding box, kept as f64) and converts
//! to f32 before the BVH is built, because raw UTM coordinates (~5e6 m) in f32 lose
//! centimetres (see DESIGN.md, "Coordinates"). Ray origins are given in model
//! coordinates and shifted the same way, in f64, before rounding.
//!
//! Acceleration structure: obvhs' compressed wide BVH8 ([`BvhLayout::Cwbvh`], PLOC +
//! reinsertion, [`BuildQuality::Fast`] = `BvhBuildParams::fast_build`) is the default: at
//! equal build effort it traces faster (8-way nodes tested with SIMD). Its
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
//! Results do not depend on the tree: [`TraceScene::first_hit`] returns the smallest f32
//! distance and, among triangles at exactly that distance (duplicated or coincident
//! faces, shared edges), the smallest triangle index; the node boxes are grown a little
//! (`node_pad`) so that obvhs' non-robust slab test never drops a triangle the triangle
//! test hits. So layout, build effort, thread count and how POIs are split into shards
//! never change an answer (`ties_resolve_to_smallest_triangle_index_whatever_the_tree`).
//!
//! All queries take `&self`; a [`TraceScene`] is `Send + Sync`, so callers parallelise over
//! rays with rayon. Results do not depend on the thread count.

mod boxes;
mod polygons;
mod query;
pub(crate) mod ray;
mod scene;
pub use ray::{ray_aabb, ray_triangle};

pub use boxes::BoxIndex;
pub use polygons::scene_of;
pub use query::Hit;
pub use scene::{BuildQuality, BvhLayout, SceneBuilder, TraceScene};
