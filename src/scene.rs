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

use crate::model::{Asset, CityModel, Polygon};
use crate::poi::Poi;
use crate::rough::RoughGeometry;
use crate::trace::{Scene, SceneBuilder};
use glam::DVec3;

/// Distance (m) a ray origin is moved along the POI's normal, and the `tmin` used, so that
/// rays do not hit the surface the POI lies on.
pub const POI_OFFSET: f64 = 0.01;

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
    scene_of(
        rough
            .iter()
            .enumerate()
            .flat_map(|(i, r)| r.polygons.iter().map(move |p| (i as u32, p))),
    )
}

/// The scene the selection traces: the rough model without the openings that their
/// surface's rough plane closes ([`crate::select::traced`]).
pub fn selection_scene(model: &CityModel, rough: &[RoughGeometry]) -> Scene {
    let traced = crate::select::traced(model);
    scene_of(
        rough
            .iter()
            .zip(traced)
            .enumerate()
            .filter(|(_, (_, t))| *t)
            .flat_map(|(i, (r, _))| r.polygons.iter().map(move |p| (i as u32, p))),
    )
}

/// The mixed-LoD model: level 2 full detail, level 1 rough, level 0 absent.
pub fn mixed_scene(model: &CityModel, rough: &[RoughGeometry], levels: &[u8]) -> Scene {
    scene_of(model.assets.iter().enumerate().flat_map(|(i, a)| {
        let level = levels.get(i).copied().unwrap_or(0);
        level_polygons(a, rough.get(i), level)
            .iter()
            .map(move |p| (i as u32, p))
    }))
}

/// What an asset contributes to the mixed-LoD model at `level`: its full detail (highest LoD)
/// at level 2 (and above), its rough geometry at level 1, nothing at level 0. The traced LoD
/// scene ([`mixed_scene`]) and the OBJ export ([`crate::export::obj`]) both take it from here.
pub fn level_polygons<'a>(
    asset: &'a Asset,
    rough: Option<&'a RoughGeometry>,
    level: u8,
) -> &'a [Polygon] {
    match level {
        0 => &[],
        1 => rough.map(|r| r.polygons.as_slice()).unwrap_or(&[]),
        _ => asset.detail_polygons(),
    }
}

/// Ray origin for a POI: moved [`POI_OFFSET`] along its normal when it has one.
pub fn ray_origin(poi: &Poi) -> DVec3 {
    match poi.normal {
        Some(n) => poi.position + n * POI_OFFSET,
        None => poi.position,
    }
}
