//! Geometry helpers shared by the pipeline stages: polygon triangulation and
//! exact (f64) ray intersection tests used as the brute-force reference for
//! [`crate::trace`].

pub mod ray;
pub mod triangulate;

pub use ray::{ray_aabb, ray_triangle, RayTriangleHit};
pub use triangulate::triangulate;
