//! What an asset contributes to the mixed-LoD model at level 0, 1 or 2: the one definition
//! that the writer ([`crate::lod::mixed`]), the report, the traced LoD scene
//! ([`crate::lod::scene::mixed_scene`]) and `evaluate` all call, so that the polygons counted are
//! the polygons written and the polygons traced are those a reader of the written file sees.
//!
//! * **level 0**: nothing;
//! * **level 2**: every LoD property verbatim;
//! * **level 1**: per LoD property, either the rough polygons ([`PropertyOut::rough`]) or the
//!   property's own polygons kept verbatim. A property is replaced when it is at or above the
//!   rough geometry's LoD, can hold world-coordinate polygons (not an implicit geometry, a
//!   curve or a terrain intersection), is not the very geometry the rough model took unchanged
//!   (a shell surface's LoD2 beside its LoD3), and holds at least as many polygons as the rough
//!   geometry (a flat window quad is not replaced by its six-face box). Without rough geometry
//!   (or with an empty one) everything stays verbatim.
//!
//! The traced geometry ([`traced`]) is the first written property at the highest LoD, which
//! is what [`crate::model::Asset::detail_polygons`] gives for the asset read back from the
//! written file. Which assets the *selection* traces is [`selection_traced`].
//!
//! Not modelled here: the writer's pruning of `xlink:href` references *between* assets
//! (a level-2 asset whose geometry references a polygon of a dropped one loses that member);
//! the writer's own summary counts such a loss.
//!
//! # Example
//! ```
//! use skylod::lod::{polygon_count, traced};
//! use skylod::model::{Asset, AssetKind, LodGeometry, Polygon};
//! use skylod::lod::rough::RoughGeometry;
//! let wall = Asset::new(AssetKind::Wall, None, "WallSurface",
//!     vec![LodGeometry { lod: 3, property: "lod3MultiSurface".into(),
//!         polygons: vec![Polygon::default(); 40], ..Default::default() }]);
//! let rough = RoughGeometry { polygons: vec![Polygon::default(); 2], obb: None, lod: 3 };
//! assert_eq!(polygon_count(&wall, Some(&rough), 2), 40);
//! assert_eq!(polygon_count(&wall, Some(&rough), 1), 2);
//! assert_eq!(traced(&wall, Some(&rough), 1).len(), 2);
//! assert_eq!(polygon_count(&wall, Some(&rough), 0), 0);
//! ```

use crate::lod::rough::RoughGeometry;
use crate::model::{Asset, CityModel, LodGeometry, Polygon};
use std::borrow::Cow;

/// One LoD property of an asset as written at some level.
#[derive(Debug, Clone, PartialEq)]
pub struct PropertyOut<'a> {
    /// The property as read.
    pub geometry: &'a LodGeometry,
    /// Whether its content is replaced by the rough geometry.
    pub rough: bool,
    /// The polygons written in it (a box's faces are made for it).
    pub polygons: Cow<'a, [Polygon]>,
}

/// Whether a LoD property (by local name) can hold world-coordinate polygons written by
/// skylod; implicit geometries (a shared prototype), curves and terrain intersections cannot.
pub fn holds_polygons(property: &str) -> bool {
    !(property.contains("Implicit")
        || property.contains("Curve")
        || property.contains("TerrainIntersection"))
        && (property.ends_with("Solid")
            || property.ends_with("MultiSurface")
            || property.ends_with("Geometry")
            || property == "lod0FootPrint"
            || property == "lod0RoofEdge"
            || (property.starts_with("lod") && property.ends_with("Surface")))
}

/// Whether the rough geometry of `asset` is its own geometry at the rough LoD (a shell
/// surface whose LoD2 is used unchanged beside its LoD3): those properties stay verbatim.
fn rough_is_own_geometry(asset: &Asset, r: &RoughGeometry, polygons: &[Polygon]) -> bool {
    let same: Vec<&Polygon> = asset.polygons_at(r.lod).collect();
    same.len() == polygons.len() && same.iter().zip(polygons).all(|(x, y)| *x == y)
}

/// Whether property `g`, of `count` polygons, is written as the rough geometry `r` (of
/// `rough_count` polygons) at level 1; `unchanged`: the rough geometry is the asset's own
/// ([`rough_is_own`]).
fn replaced(
    g: &LodGeometry,
    count: usize,
    r: &RoughGeometry,
    rough_count: usize,
    unchanged: bool,
) -> bool {
    !(g.lod < r.lod
        || (g.lod == r.lod && unchanged)
        || !holds_polygons(&g.property)
        || rough_count > count)
}

/// Whether the rough geometry `r` of `asset` is its own geometry at the rough LoD (those
/// properties stay verbatim at level 1): what [`polygon_count_of`] needs of the full polygons.
pub fn rough_is_own(asset: &Asset, r: &RoughGeometry) -> bool {
    rough_is_own_geometry(asset, r, &r.polygons())
}

/// [`polygon_count`] from what a hollow read ([`crate::lod::hollow`]) keeps of an asset whose
/// polygons are gone: `counts[k]`, the polygons of `asset.geometries[k]` in the full model, and
/// `unchanged`, [`rough_is_own`] of the full asset.
pub fn polygon_count_of(
    asset: &Asset,
    counts: &[u32],
    rough: Option<&RoughGeometry>,
    level: u8,
    unchanged: bool,
) -> usize {
    let each = asset
        .geometries
        .iter()
        .zip(counts.iter().map(|&n| n as usize));
    match (level, rough) {
        (0, _) => 0,
        (1, Some(r)) if !r.is_empty() => {
            let n = r.polygon_count();
            each.map(|(g, c)| {
                if replaced(g, c, r, n, unchanged) {
                    n
                } else {
                    c
                }
            })
            .sum()
        }
        _ => each.map(|(_, c)| c).sum(),
    }
}

/// The asset's LoD properties as written at `level` (none at level 0), in document order.
pub fn properties<'a>(
    asset: &'a Asset,
    rough: Option<&'a RoughGeometry>,
    level: u8,
) -> Vec<PropertyOut<'a>> {
    let verbatim = |g: &'a LodGeometry| PropertyOut {
        geometry: g,
        rough: false,
        polygons: Cow::Borrowed(&g.polygons),
    };
    match (level, rough) {
        (0, _) => Vec::new(),
        (1, Some(r)) if !r.is_empty() => {
            let polygons = r.polygons();
            let unchanged = rough_is_own_geometry(asset, r, &polygons);
            asset
                .geometries
                .iter()
                .map(|g| {
                    if replaced(g, g.polygons.len(), r, polygons.len(), unchanged) {
                        PropertyOut {
                            geometry: g,
                            rough: true,
                            polygons: polygons.clone(),
                        }
                    } else {
                        verbatim(g)
                    }
                })
                .collect()
        }
        _ => asset.geometries.iter().map(verbatim).collect(),
    }
}

/// Polygons the asset has in the output at `level` (all properties, all LoDs).
pub fn polygon_count(asset: &Asset, rough: Option<&RoughGeometry>, level: u8) -> usize {
    properties(asset, rough, level)
        .iter()
        .map(|p| p.polygons.len())
        .sum()
}

/// Polygons the asset contributes to the traced LoD model at `level`: the first written
/// property at the highest LoD (as [`Asset::detail_polygons`] of the asset read back).
pub fn traced<'a>(
    asset: &'a Asset,
    rough: Option<&'a RoughGeometry>,
    level: u8,
) -> Cow<'a, [Polygon]> {
    let props = properties(asset, rough, level);
    let Some(top) = props.iter().map(|p| p.geometry.lod).max() else {
        return Cow::Borrowed(&[]);
    };
    props
        .into_iter()
        .find(|p| p.geometry.lod == top)
        .map_or(Cow::Borrowed(&[]), |p| p.polygons)
}

/// Polygons of the whole model at the given levels (`rough[i]`, `levels[i]` per asset;
/// missing levels count as 0).
pub fn model_polygon_count(model: &CityModel, rough: &[RoughGeometry], levels: &[u8]) -> usize {
    model
        .assets
        .iter()
        .enumerate()
        .map(|(i, a)| polygon_count(a, rough.get(i), levels.get(i).copied().unwrap_or(0)))
        .sum()
}

/// Whether each asset takes part in the *selection* scene: every asset except openings
/// (windows, doors) of a shell surface, whose holes the surface's rough plane closes
/// (paper 4.3), so that they neither hide their wall nor cost triangles.
pub fn selection_traced(model: &CityModel) -> Vec<bool> {
    model
        .assets
        .iter()
        .map(|a| {
            !(a.kind.is_opening()
                && a.parent
                    .and_then(|p| model.assets.get(p))
                    .is_some_and(|p| p.kind.is_shell_surface()))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::AssetKind;

    fn asset(geoms: Vec<(u8, &str, usize)>) -> Asset {
        Asset::new(
            AssetKind::Installation,
            None,
            "BuildingInstallation",
            geoms
                .into_iter()
                .map(|(lod, p, n)| LodGeometry {
                    lod,
                    property: p.into(),
                    polygons: (0..n)
                        .map(|k| Polygon::default().with_id(Some(format!("{p}{k}").into())))
                        .collect(),
                    ..Default::default()
                })
                .collect(),
        )
    }

    fn boxed(lod: u8) -> RoughGeometry {
        RoughGeometry {
            polygons: vec![Polygon::default(); 6],
            obb: None,
            lod,
        }
    }

    #[test]
    fn few_polygons_stay_verbatim_and_are_traced_as_written() {
        // 3 polygons, box of 6: the writer keeps the 3; the traced model must too.
        let a = asset(vec![(3, "lod3Geometry", 3)]);
        let r = boxed(3);
        assert_eq!(polygon_count(&a, Some(&r), 1), 3);
        let t = traced(&a, Some(&r), 1);
        assert_eq!(t.len(), 3);
        assert_eq!(t[0].id.as_deref(), Some("lod3Geometry0"));
    }

    #[test]
    fn lower_lods_and_implicit_stay_higher_are_replaced() {
        let a = asset(vec![
            (2, "lod2Geometry", 8),
            (3, "lod3ImplicitRepresentation", 10),
            (3, "lod3MultiSurface", 20),
        ]);
        let r = boxed(3);
        let p = properties(&a, Some(&r), 1);
        assert_eq!(
            p.iter().map(|p| p.rough).collect::<Vec<_>>(),
            [false, false, true]
        );
        assert_eq!(polygon_count(&a, Some(&r), 1), 8 + 10 + 6);
        // traced: the first property at the highest LoD as written (the implicit one)
        assert_eq!(traced(&a, Some(&r), 1).len(), 10);
        assert_eq!(traced(&a, Some(&r), 2).len(), 10);
        assert_eq!(polygon_count(&a, Some(&r), 2), 38);
        assert_eq!(polygon_count(&a, None, 1), 38);
        assert!(traced(&a, Some(&r), 0).is_empty());
    }

    #[test]
    fn own_lod2_beside_lod3_is_kept() {
        let mut a = asset(vec![
            (2, "lod2MultiSurface", 1),
            (3, "lod3MultiSurface", 30),
        ]);
        a.kind = AssetKind::Wall;
        let r = RoughGeometry {
            polygons: a.geometries[0].polygons.clone(),
            obb: None,
            lod: 2,
        };
        let p = properties(&a, Some(&r), 1);
        assert!(!p[0].rough && p[1].rough);
        assert_eq!(polygon_count(&a, Some(&r), 1), 2);
    }

    #[test]
    fn property_kinds() {
        for p in [
            "lod3MultiSurface",
            "lod2Solid",
            "lod3Geometry",
            "lod0FootPrint",
            "lod2Surface",
        ] {
            assert!(holds_polygons(p), "{p}");
        }
        for p in [
            "lod3ImplicitRepresentation",
            "lod2MultiCurve",
            "lod2TerrainIntersection",
            "tin",
        ] {
            assert!(!holds_polygons(p), "{p}");
        }
    }
}
