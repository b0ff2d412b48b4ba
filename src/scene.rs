//! Building ray-tracing scenes from a model: the full-detail model, the rough model, or a
//! mixed-LoD model given a level per asset. Triangles are tagged with the asset index.
//!
//! # Example
//! ```
//! use glam::DVec3;
//! use skylod::model::{Asset, AssetKind, CityModel, LodGeometry, Polygon};
//! let mut m = CityModel::default();
//! let quad = Polygon::new(vec![
//!     DVec3::new(-1.0, -1.0, 5.0), DVec3::new(1.0, -1.0, 5.0),
//!     DVec3::new(1.0, 1.0, 5.0), DVec3::new(-1.0, 1.0, 5.0),
//! ]);
//! m.assets.push(Asset {
//!     kind: AssetKind::Roof, id: None, element: "RoofSurface".into(), building: None,
//!     parent: None, span: 0..0, line: 1, function: None, file: 0,
//!     geometries: vec![LodGeometry { lod: 2, polygons: vec![quad], ..Default::default() }],
//! });
//! let scene = skylod::scene::full_scene(&m);
//! let hit = scene.first_hit(DVec3::ZERO, DVec3::Z, 0.0, f64::INFINITY).unwrap();
//! assert_eq!(hit.tag, 0);
//! assert!((hit.t - 5.0).abs() < 1e-6);
//! ```

use crate::model::{CityModel, Polygon};
use crate::rough::RoughGeometry;
use crate::trace::{Scene, SceneBuilder};

/// A scene of the given polygons, each tagged with its asset index.
pub fn scene_of<'a>(polys: impl IntoIterator<Item = (u32, &'a Polygon)>) -> Scene {
    let mut b = SceneBuilder::new();
    for (tag, p) in polys {
        b.add_polygon(tag, p);
    }
    b.build()
}

/// Every asset at full detail (its highest LoD).
pub fn full_scene(model: &CityModel) -> Scene {
    scene_of(
        model
            .assets
            .iter()
            .enumerate()
            .flat_map(|(i, a)| a.detail_polygons().iter().map(move |p| (i as u32, p))),
    )
}

/// Every asset as its rough geometry (`rough[i]` belongs to asset `i`).
pub fn rough_scene(rough: &[RoughGeometry]) -> Scene {
    let mut b = SceneBuilder::new();
    for (i, r) in rough.iter().enumerate() {
        for p in r.polygons().iter() {
            b.add_polygon(i as u32, p);
        }
    }
    b.build()
}

/// The scene the selection traces: the rough model without the openings that their
/// surface's rough plane closes ([`crate::level::selection_traced`]).
pub fn selection_scene(model: &CityModel, rough: &[RoughGeometry]) -> Scene {
    let traced = crate::level::selection_traced(model);
    let mut b = SceneBuilder::new();
    for (i, (r, _)) in rough
        .iter()
        .zip(traced)
        .enumerate()
        .filter(|(_, (_, t))| *t)
    {
        for p in r.polygons().iter() {
            b.add_polygon(i as u32, p);
        }
    }
    b.build()
}

/// The mixed-LoD model as `lod` writes it: each asset's [`crate::level::traced`] polygons
/// at its level (level 0 absent).
pub fn mixed_scene(model: &CityModel, rough: &[RoughGeometry], levels: &[u8]) -> Scene {
    let mut b = SceneBuilder::new();
    for (i, a) in model.assets.iter().enumerate() {
        let level = levels.get(i).copied().unwrap_or(0);
        for p in crate::level::traced(a, rough.get(i), level).iter() {
            b.add_polygon(i as u32, p);
        }
    }
    b.build()
}
