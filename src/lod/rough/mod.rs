//! The rough model (paper 4.3): every asset reduced to simple geometry that the ray
//! bundle is cast against and that level-1 assets are written with.
//!
//! * installations, openings (windows, doors) and other objects become their oriented
//!   bounding box ([`obb::Obb`], six quads);
//! * a *body* (a building's own LoD1/LoD2 solid or multi-surface, without thematic
//!   surfaces) is generalised to its planes keeping the holes
//!   ([`plane::generalize_keeping_holes`]), see below;
//! * shell surfaces (roof, wall, ground, closure, outer ceiling/floor) are generalised to
//!   their planes ([`plane::generalize`]): openings closed, reveals and frames absorbed;
//! * with [`RoughOptions::prefer_lod2`], an asset that also carries LoD2 geometry besides
//!   a higher LoD takes the LoD2 geometry as input (shell surfaces use it unchanged).
//!
//! # Whole-building assets
//!
//! A body's box covers ground that the building leaves open: the courtyard of a ring
//! block, the inner corner of an L or U. A POI standing there is then inside the rough
//! model, every ray hits the box, the body is written rough and the written model has no
//! sky. So a body's rough form is its own polygons united per plane (the grouping of
//! [`plane::generalize`]: normals within [`RoughOptions::angle_deg`], vertices within
//! [`RoughOptions::thickness_m`]) with every hole kept and nothing filled: it covers the
//! same surfaces as the full geometry, up to the projection onto each plane. A LoD1 block
//! stays itself (one polygon per face, a ring roof keeps its courtyard hole); a LoD2 body
//! loses only coplanar splits and thin detail; it never fills a courtyard. Its rough
//! polygons are written into the LoD property they came from ([`RoughGeometry::lod`]), as
//! a shell surface's are. `Other` objects keep their box (they are mostly small: street
//! furniture, vegetation, generic objects).
//!
//! As a safety net the selection promotes to level 2 any asset whose closed rough form
//! (its box) holds a POI that its full geometry does not
//! ([`crate::lod::select`]).

pub(crate) mod obb;
pub(crate) mod plane;
mod to_source;
pub use obb::{Obb, MIN_THICKNESS};
pub use plane::{generalize, generalize_keeping_holes};

pub use to_source::rough_to_source;

use crate::model::{Asset, AssetKind, CityModel, Polygon};
use rayon::prelude::*;
use std::borrow::Cow;

/// Options of the rough stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoughOptions {
    /// Largest angle (degrees) between the normals of polygons in one plane.
    pub angle_deg: f64,
    /// Largest distance (m) of a polygon from its plane to be merged or absorbed.
    pub thickness_m: f64,
    /// Use an asset's LoD2 geometry when it also has a higher LoD.
    pub prefer_lod2: bool,
}

impl Default for RoughOptions {
    fn default() -> Self {
        RoughOptions {
            angle_deg: 5.0,
            thickness_m: 0.3,
            prefer_lod2: true,
        }
    }
}

impl RoughOptions {
    /// Why these options cannot build a rough model, if they cannot: an angle outside 0 to
    /// 90 degrees, or a thickness that is negative or not a number. The reduce step checks
    /// the options a levels file names with it (the command line's flags are checked as
    /// they are parsed).
    ///
    /// ```
    /// use skylod::lod::rough::RoughOptions;
    /// assert_eq!(RoughOptions::default().check(), Ok(()));
    /// let wide = RoughOptions { angle_deg: 120.0, ..RoughOptions::default() };
    /// assert!(wide.check().unwrap_err().contains("angle"));
    /// ```
    pub fn check(&self) -> Result<(), String> {
        if !(0.0..=90.0).contains(&self.angle_deg) {
            return Err(format!(
                "angle {} degrees: must be between 0 and 90",
                self.angle_deg
            ));
        }
        if !(self.thickness_m >= 0.0 && self.thickness_m.is_finite()) {
            return Err(format!(
                "thickness {} m: must be 0 or more",
                self.thickness_m
            ));
        }
        Ok(())
    }
}

/// The rough geometry of one asset.
///
/// A boxed asset keeps its [`Obb`] only (the six faces are made where they are needed,
/// [`RoughGeometry::polygons()`](method@RoughGeometry::polygons)): a city holds hundreds
/// of thousands of boxes.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RoughGeometry {
    /// Polygons besides the box's faces, rings open: generalised planes (no id; no holes,
    /// except a body's, which keeps them),
    /// LoD2 polygons used unchanged (holes and ids kept), or geometry brought back to the
    /// source CRS. Empty for a box; read them all with
    /// [`RoughGeometry::polygons()`](method@RoughGeometry::polygons).
    pub polygons: Vec<Polygon>,
    /// The box, for assets replaced by their box (`None` for shell surfaces); its six faces
    /// ([`Obb::to_polygons`]) are the asset's rough polygons.
    pub obb: Option<Obb>,
    /// LoD of the geometry used as input (0 when the asset has no geometry); the writer
    /// puts the rough geometry into that LoD's property.
    pub lod: u8,
}

impl RoughGeometry {
    fn boxed(obb: Option<Obb>, lod: u8) -> Self {
        RoughGeometry {
            polygons: Vec::new(),
            obb,
            lod,
        }
    }

    /// The rough polygons: the box's six faces (made now) followed by
    /// [`RoughGeometry::polygons`](field@RoughGeometry::polygons), or those borrowed when
    /// there is no box.
    pub fn polygons(&self) -> Cow<'_, [Polygon]> {
        match &self.obb {
            Some(b) => {
                let mut faces = b.to_polygons();
                faces.extend(self.polygons.iter().cloned());
                Cow::Owned(faces)
            }
            None => Cow::Borrowed(&self.polygons),
        }
    }

    /// Number of rough polygons (`polygons().len()` without making them).
    pub fn polygon_count(&self) -> usize {
        self.polygons.len() + if self.obb.is_some() { 6 } else { 0 }
    }

    /// True when there is no rough polygon.
    pub fn is_empty(&self) -> bool {
        self.polygon_count() == 0
    }
}

/// The LoD whose geometry is the input of the rough stage for `asset`.
pub fn input_lod(asset: &Asset, opts: &RoughOptions) -> Option<u8> {
    let max = asset.max_lod()?;
    if opts.prefer_lod2 && max > 2 && asset.geometries.iter().any(|g| g.lod == 2) {
        Some(2)
    } else {
        Some(max)
    }
}

/// Rough geometry of one asset; see the module documentation.
///
/// # Example
/// ```rust
/// use glam::DVec3;
/// use skylod::model::{Asset, AssetKind, LodGeometry, Polygon};
/// use skylod::lod::rough::{rough_asset, RoughOptions};
/// let quad = |z: f64| Polygon::new(vec![
///     DVec3::new(0.0, 0.0, z), DVec3::new(1.0, 0.0, z), DVec3::new(1.0, 1.0, z), DVec3::new(0.0, 1.0, z),
/// ]);
/// let chimney = Asset {
///     kind: AssetKind::Installation, id: None, element: "BuildingInstallation".into(),
///     building: None, parent: None, span: 0..0, line: 1, function: None, file: 0,
///     geometries: vec![LodGeometry { lod: 3, property: "lod3Geometry".into(), span: 0..0, content: 0..0,
///         polygons: vec![quad(10.0), quad(12.0)] }],
/// };
/// let r = rough_asset(&chimney, &RoughOptions::default());
/// assert_eq!((r.polygon_count(), r.polygons().len(), r.lod), (6, 6, 3));
/// assert!((r.obb.unwrap().volume() - 2.0).abs() < 1e-9);
/// ```
pub fn rough_asset(asset: &Asset, opts: &RoughOptions) -> RoughGeometry {
    let Some(lod) = input_lod(asset, opts) else {
        return RoughGeometry::default();
    };
    if asset.kind.is_shell_surface() {
        let mut polygons: Vec<Polygon> = if lod == 2 && asset.max_lod().is_some_and(|m| m > 2) {
            // LoD2 alongside a higher LoD: already generalised.
            asset.polygons_at(lod).cloned().collect()
        } else {
            plane::generalize(asset.polygons_at(lod), opts.angle_deg, opts.thickness_m)
        };
        // a city's hundreds of thousands of rough surfaces: no room for polygons never added
        polygons.shrink_to_fit();
        RoughGeometry {
            polygons,
            obb: None,
            lod,
        }
    } else if asset.kind == AssetKind::Body {
        let mut polygons = plane::generalize_keeping_holes(
            asset.polygons_at(lod),
            opts.angle_deg,
            opts.thickness_m,
        );
        polygons.shrink_to_fit();
        RoughGeometry {
            polygons,
            obb: None,
            lod,
        }
    } else {
        let obb = Obb::of_points(asset.polygons_at(lod).flat_map(|p| p.points()));
        RoughGeometry::boxed(obb, lod)
    }
}

/// Rough geometry of every asset, in asset order (computed in parallel, deterministic).
pub fn rough_model(model: &CityModel, opts: &RoughOptions) -> Vec<RoughGeometry> {
    model
        .assets
        .par_iter()
        .map(|a| rough_asset(a, opts))
        .collect()
}

/// Every asset as the oriented box of its highest-LoD geometry (all properties of that
/// LoD), in asset order: the paper's "bounding box" model (Fig. 3(b)) used for comparisons.
pub fn all_boxes(model: &CityModel) -> Vec<RoughGeometry> {
    model
        .assets
        .par_iter()
        .map(|a| match a.max_lod() {
            Some(lod) => RoughGeometry::boxed(
                Obb::of_points(a.polygons_at(lod).flat_map(|p| p.points())),
                lod,
            ),
            None => RoughGeometry::default(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{AssetKind, LodGeometry};
    use glam::DVec3;
    use plane::tests::{lod3_wall, WallFrame};

    fn asset(kind: AssetKind, geoms: Vec<(u8, Vec<Polygon>)>) -> Asset {
        Asset {
            kind,
            id: Some(format!("{kind}").into()),
            element: "X".into(),
            building: Some(0),
            parent: None,
            span: 0..0,
            line: 1,
            function: None,
            geometries: geoms
                .into_iter()
                .map(|(lod, polygons)| LodGeometry {
                    lod,
                    property: format!("lod{lod}MultiSurface").into(),
                    span: 0..0,
                    content: 0..0,
                    polygons,
                })
                .collect(),
            file: 0,
        }
    }

    #[test]
    fn lod3_wall_asset_is_generalised() {
        let f = WallFrame::new(DVec3::new(691_000.0, 5_334_000.0, 370.0), 12.0);
        let wall = asset(AssetKind::Wall, vec![(3, lod3_wall(&f))]);
        let r = rough_asset(&wall, &RoughOptions::default());
        assert_eq!(r.lod, 3);
        assert!(r.obb.is_none());
        assert_eq!(r.polygons.len(), 1);
        assert!((r.polygons[0].area() - 300.0).abs() < 1e-6);
    }

    #[test]
    fn lod2_is_preferred_when_present() {
        let f = WallFrame::new(DVec3::new(0.0, 0.0, 0.0), 0.0);
        let mut lod2 = Polygon::new(f.quad(0.0, 20.0, 0.0, 15.0, 0.0));
        lod2.id = Some("lod2-poly".into());
        let wall = asset(
            AssetKind::Wall,
            vec![(3, lod3_wall(&f)), (2, vec![lod2.clone()])],
        );
        let r = rough_asset(&wall, &RoughOptions::default());
        assert_eq!((r.lod, r.polygons().to_vec()), (2, vec![lod2]));
        let opts = RoughOptions {
            prefer_lod2: false,
            ..RoughOptions::default()
        };
        let r = rough_asset(&wall, &opts);
        assert_eq!(r.lod, 3);
        assert_eq!(r.polygons.len(), 1);
        assert_eq!(r.polygons[0].id, None);
    }

    #[test]
    fn window_becomes_a_thin_box() {
        // Frame (4 strips) and pane of a 1.2 x 1.5 window, 0.08 m deep, on a rotated wall.
        let f = WallFrame::new(DVec3::new(691_000.0, 5_334_000.0, 370.0), 33.0);
        let polys = vec![
            Polygon::new(f.quad(0.0, 1.2, 0.0, 1.5, 0.0)),
            Polygon::new(f.quad(0.0, 1.2, 0.0, 1.5, -0.08)),
            Polygon::new(f.quad(0.1, 1.1, 0.1, 1.4, -0.04)),
        ];
        let win = asset(AssetKind::Window, vec![(3, polys.clone())]);
        let r = rough_asset(&win, &RoughOptions::default());
        let obb = r.obb.unwrap();
        assert_eq!(r.polygons().into_owned(), obb.to_polygons());
        assert!(r.polygons.is_empty());
        assert!((obb.volume() - 1.2 * 1.5 * 0.08).abs() < 1e-9);
        assert!((obb.half.y - 0.04).abs() < 1e-9);
        assert!(polys
            .iter()
            .flat_map(|p| p.points())
            .all(|p| obb.contains(*p, 1e-6)));
    }

    #[test]
    fn kinds_map_to_boxes_or_planes_and_model_order_is_kept() {
        let f = WallFrame::new(DVec3::new(10.0, 20.0, 0.0), 0.0);
        let roof = Polygon::new(vec![
            DVec3::new(0.0, 0.0, 5.0),
            DVec3::new(4.0, 0.0, 5.0),
            DVec3::new(4.0, 4.0, 5.0),
            DVec3::new(0.0, 4.0, 5.0),
        ]);
        let kinds = [
            AssetKind::Roof,
            AssetKind::Installation,
            AssetKind::Door,
            AssetKind::Body,
            AssetKind::Other,
            AssetKind::Ground,
        ];
        let mut model = CityModel::default();
        for k in kinds {
            model.assets.push(asset(k, vec![(2, vec![roof.clone()])]));
        }
        model
            .assets
            .push(asset(AssetKind::Wall, vec![(3, lod3_wall(&f))]));
        model.assets.push(asset(AssetKind::Other, vec![]));
        let rough = rough_model(&model, &RoughOptions::default());
        assert_eq!(rough.len(), model.assets.len());
        for (a, r) in model.assets.iter().zip(&rough) {
            assert_eq!(*r, rough_asset(a, &RoughOptions::default()));
            if a.geometries.is_empty() {
                assert!(r.is_empty() && r.obb.is_none());
            } else if a.kind.is_shell_surface() || a.kind == AssetKind::Body {
                assert!(r.obb.is_none());
                assert_eq!(r.polygons.len(), 1);
            } else {
                // A flat polygon becomes a thin box.
                let obb = r.obb.unwrap();
                assert_eq!(r.polygon_count(), 6);
                assert!((obb.volume() - 16.0 * obb::MIN_THICKNESS).abs() < 1e-9);
            }
        }
        let boxes = all_boxes(&model);
        assert_eq!(boxes.len(), model.assets.len());
        let wall_box = boxes[6].obb.unwrap();
        // The wall's box spans the reveals' 0.2 m depth.
        assert!((wall_box.volume() - 20.0 * 15.0 * 0.2).abs() < 1e-9);
        assert_eq!(boxes[6].lod, 3);
        assert!(boxes[7].obb.is_none());
    }
}
