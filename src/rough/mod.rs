//! The rough model (paper 4.3): every asset reduced to simple geometry that the ray
//! bundle is cast against and that level-1 assets are written with.
//!
//! * installations, openings (windows, doors), bodies and other objects become their
//!   oriented bounding box ([`obb::Obb`], six quads);
//! * shell surfaces (roof, wall, ground, closure, outer ceiling/floor) are generalised to
//!   their planes ([`plane::generalize`]): openings closed, reveals and frames absorbed;
//! * with [`RoughOptions::prefer_lod2`], an asset that also carries LoD2 geometry besides
//!   a higher LoD takes the LoD2 geometry as input (shell surfaces use it unchanged).

pub mod obb;
pub mod plane;

use crate::model::{Asset, CityModel, Polygon};
use obb::Obb;
use rayon::prelude::*;

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

/// The rough geometry of one asset.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RoughGeometry {
    /// Polygons (open rings, no holes). Generated polygons have no id; LoD2 polygons used
    /// unchanged keep theirs.
    pub polygons: Vec<Polygon>,
    /// The box, for assets replaced by their box (`None` for shell surfaces).
    pub obb: Option<Obb>,
    /// LoD of the geometry used as input (0 when the asset has no geometry); the writer
    /// puts the rough geometry into that LoD's property.
    pub lod: u8,
}

impl RoughGeometry {
    fn boxed(obb: Option<Obb>, lod: u8) -> Self {
        RoughGeometry {
            polygons: obb.map(|b| b.to_polygons()).unwrap_or_default(),
            obb,
            lod,
        }
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
/// use skylod::rough::{rough_asset, RoughOptions};
/// let quad = |z: f64| Polygon::new(vec![
///     DVec3::new(0.0, 0.0, z), DVec3::new(1.0, 0.0, z), DVec3::new(1.0, 1.0, z), DVec3::new(0.0, 1.0, z),
/// ]);
/// let chimney = Asset {
///     kind: AssetKind::Installation, id: None, element: "BuildingInstallation".into(),
///     building: None, parent: None, span: 0..0, line: 1, function: None, file: 0,
///     geometries: vec![LodGeometry { lod: 3, property: "lod3Geometry".into(), span: 0..0,
///         polygons: vec![quad(10.0), quad(12.0)] }],
/// };
/// let r = rough_asset(&chimney, &RoughOptions::default());
/// assert_eq!((r.polygons.len(), r.lod), (6, 3));
/// assert!((r.obb.unwrap().volume() - 2.0).abs() < 1e-9);
/// ```
pub fn rough_asset(asset: &Asset, opts: &RoughOptions) -> RoughGeometry {
    let Some(lod) = input_lod(asset, opts) else {
        return RoughGeometry::default();
    };
    if asset.kind.is_shell_surface() {
        let input: Vec<Polygon> = asset.polygons_at(lod).cloned().collect();
        let polygons = if lod == 2 && asset.max_lod().is_some_and(|m| m > 2) {
            input // LoD2 alongside a higher LoD: already generalised
        } else {
            plane::generalize(&input, opts.angle_deg, opts.thickness_m)
        };
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

/// Every asset as the oriented box of its highest-LoD geometry, in asset order: the
/// paper's "bounding box" model (Fig. 3(b)) used for comparisons.
pub fn all_boxes(model: &CityModel) -> Vec<RoughGeometry> {
    model
        .assets
        .par_iter()
        .map(|a| match a.max_lod() {
            Some(lod) => RoughGeometry::boxed(Obb::of_polygons(a.detail_polygons()), lod),
            None => RoughGeometry::default(),
        })
        .collect()
}
