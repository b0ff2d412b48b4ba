//! A scene straight from polygons: each polygon triangulated and tagged as the caller says.
//! The scenes of a model at a level of detail are [`crate::lod::scene`]'s; this one knows no
//! levels (regions use it for the surfaces that hold their POIs).

use super::{SceneBuilder, TraceScene};
use crate::model::Polygon;

/// A scene of the given polygons, each tagged with its asset index.
///
/// ```
/// use glam::DVec3;
/// use skylod::model::Polygon;
/// let quad = Polygon::new(vec![
///     DVec3::new(-1.0, -1.0, 5.0), DVec3::new(1.0, -1.0, 5.0),
///     DVec3::new(1.0, 1.0, 5.0), DVec3::new(-1.0, 1.0, 5.0),
/// ]);
/// let scene = skylod::solar::trace::scene_of([(7, &quad)]);
/// let hit = scene.first_hit(DVec3::ZERO, DVec3::Z, 0.0, f64::INFINITY).unwrap();
/// assert_eq!((hit.tag, (hit.t - 5.0).abs() < 1e-6), (7, true));
/// ```
pub fn scene_of<'a>(polys: impl IntoIterator<Item = (u32, &'a Polygon)>) -> TraceScene {
    let mut b = SceneBuilder::new();
    for (tag, p) in polys {
        b.add_polygon(tag, p);
    }
    b.build()
}
