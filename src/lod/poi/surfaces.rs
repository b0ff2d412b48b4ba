//! Every roof and wall of a model as sample points, for a solar cadastre.
//!
//! [`cadastre_surfaces`] lists the surfaces: each `RoofSurface` and `WallSurface` (CityGML's
//! thematic surfaces, CityJSON's semantic surfaces), and, for a building with no thematic
//! surfaces (an LoD1 or LoD2 body), its body split by the normals of its polygons into a
//! roof-like face (tilt under 75°, `n.z > 0.25`) and a wall-like one (`|n.z| <= 0.25`); faces
//! turned downwards are neither. A surface is named as skylod names an asset elsewhere
//! ([`CityModel::asset_name`]: its `gml:id`, else its building's id and its index among
//! the building's assets; a name met before, such as a building in two tiles, gets the
//! merge's `__<k>` with k its input), a body's faces `<name>:roof` and `<name>:wall`. Its area is the
//! sum of its polygons' areas, holes (openings) taken out.
//!
//! [`surface_pois`] samples them: a grid of `spacing` metres in the plane of each polygon
//! (cell centres inside the polygon, outside its holes, so never in a window or door
//! opening), moved `offset` out along the polygon's outward normal; polygons smaller than a
//! quarter cell are not sampled. A point that falls inside a closed solid (a party wall's
//! neighbour) is dropped. The points of surface `s` are named `<s>:<k>`. Areas and spacings
//! are in metres: give these functions the model in a metric frame, or use
//! [`surface_pois_of`], which samples in the model's local frame.
//!
//! # Example
//! ```
//! use glam::DVec3;
//! use skylod::model::{Asset, AssetKind, CityModel, LodGeometry, Polygon};
//! use skylod::lod::poi::{cadastre_surfaces, surface_pois, SurfaceClass};
//! let mut m = CityModel::default();
//! // a 4 m x 3 m wall in the plane y = 0, facing -y
//! let wall = Polygon::new(vec![
//!     DVec3::new(0.0, 0.0, 0.0), DVec3::new(4.0, 0.0, 0.0),
//!     DVec3::new(4.0, 0.0, 3.0), DVec3::new(0.0, 0.0, 3.0),
//! ]);
//! m.assets.push(Asset {
//!     kind: AssetKind::Wall, id: Some("w".into()), element: "WallSurface".into(),
//!     building: None, parent: None, span: 0..0, line: 1, function: None, file: 0,
//!     geometries: vec![LodGeometry { lod: 2, polygons: vec![wall], ..Default::default() }],
//! });
//! let s = cadastre_surfaces(&m, &[SurfaceClass::Wall]);
//! assert_eq!((s[0].name.as_str(), s[0].area_m2), ("w", 12.0));
//! let pois = surface_pois(&m, &s, 1.0, 0.05).unwrap();
//! assert_eq!(pois.len(), 12);
//! assert_eq!(pois[0].id, "w:0");
//! ```

use super::region::{outside_solids, sample_polygon, RegionError};
use crate::model::crs::{model_crs, LocalFrame};
use crate::model::{AssetKind, CityModel, Poi};
use std::ops::Range;

/// Largest `|n.z|` of a wall-like face of a body; above it, a face turned up is roof-like.
pub const WALL_MAX_NZ: f64 = 0.25;

/// Whether a cadastre surface is a roof or a wall.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum SurfaceClass {
    /// A `RoofSurface`, or the faces of a body turned up.
    Roof,
    /// A `WallSurface`, or the near-vertical faces of a body.
    Wall,
}

impl SurfaceClass {
    /// `roof` or `wall`.
    pub fn as_str(self) -> &'static str {
        match self {
            SurfaceClass::Roof => "roof",
            SurfaceClass::Wall => "wall",
        }
    }

    /// The class of a body's face with unit normal `n`; `None` for one turned down.
    pub fn of_normal(n: glam::DVec3) -> Option<SurfaceClass> {
        if n.z > WALL_MAX_NZ {
            Some(SurfaceClass::Roof)
        } else if n.z >= -WALL_MAX_NZ {
            Some(SurfaceClass::Wall)
        } else {
            None
        }
    }
}

/// One surface of a cadastre (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct CadastreSurface {
    /// Its name: the asset's name, with `:roof` / `:wall` for a body's face.
    pub name: String,
    /// The asset (index into the model's assets).
    pub asset: usize,
    /// Roof or wall.
    pub class: SurfaceClass,
    /// The `gml:id` of its building (the outermost one, not a part), if any.
    pub building: Option<String>,
    /// The polygons of the asset's most detailed geometry that belong to it.
    pub polygons: Vec<usize>,
    /// Their area (m²), holes taken out.
    pub area_m2: f64,
}

/// The roofs and walls of `model` of the classes `classes` (see the module docs), in asset
/// order.
pub fn cadastre_surfaces(model: &CityModel, classes: &[SurfaceClass]) -> Vec<CadastreSurface> {
    let mut out = Vec::new();
    let mut seen: std::collections::HashSet<String> = Default::default();
    for (i, a) in model.assets.iter().enumerate() {
        // a name given before (the same building in two tiles) is the merge's `<name>__<k>`,
        // k the asset's input
        let mut name = model.asset_name(i, i);
        if !seen.insert(name.clone()) {
            name = format!("{name}__{}", a.file);
            seen.insert(name.clone());
        }
        let building = a
            .building
            .map(|b| model.root_building(b))
            .and_then(|b| model.buildings.get(b))
            .and_then(|b| b.id.as_deref().map(str::to_string));
        let polys = a.detail_polygons();
        let of_class = |c: SurfaceClass| -> Vec<usize> {
            (0..polys.len())
                .filter(|&k| match a.kind {
                    AssetKind::Body => {
                        polys[k]
                            .newell_normal()
                            .try_normalize()
                            .and_then(SurfaceClass::of_normal)
                            == Some(c)
                    }
                    _ => true,
                })
                .collect()
        };
        let mut push = |class: SurfaceClass, name: String, polygons: Vec<usize>| {
            if polygons.is_empty() || !classes.contains(&class) {
                return;
            }
            let area_m2 = polygons.iter().map(|&k| polys[k].area()).sum();
            out.push(CadastreSurface {
                name,
                asset: i,
                class,
                building: building.clone(),
                polygons,
                area_m2,
            });
        };
        match a.kind {
            AssetKind::Roof => push(SurfaceClass::Roof, name, of_class(SurfaceClass::Roof)),
            AssetKind::Wall => push(SurfaceClass::Wall, name, of_class(SurfaceClass::Wall)),
            AssetKind::Body => {
                for c in [SurfaceClass::Roof, SurfaceClass::Wall] {
                    push(c, format!("{name}:{}", c.as_str()), of_class(c));
                }
            }
            _ => {}
        }
    }
    out
}

/// Sample points on `surfaces` of `model` (see the module docs), named `<surface>:<k>`.
///
/// # Errors
/// [`RegionError::Spacing`] for a spacing that is not a positive number.
pub fn surface_pois(
    model: &CityModel,
    surfaces: &[CadastreSurface],
    spacing: f64,
    offset: f64,
) -> Result<Vec<Poi>, RegionError> {
    if spacing.is_nan() || spacing <= 0.0 || !spacing.is_finite() {
        return Err(RegionError::Spacing(spacing));
    }
    let mut out = Vec::new();
    for s in surfaces {
        let Some(a) = model.assets.get(s.asset) else {
            continue;
        };
        let polys = a.detail_polygons();
        let mut k = 0usize;
        for &p in &s.polygons {
            let Some(poly) = polys.get(p) else { continue };
            let Some(n) = poly.newell_normal().try_normalize() else {
                continue;
            };
            if poly.area() < 0.25 * spacing * spacing {
                continue;
            }
            for q in sample_polygon(poly, n, spacing) {
                out.push(Poi {
                    id: format!("{}:{k}", s.name),
                    position: q + n * offset,
                    normal: Some(n),
                });
                k += 1;
            }
        }
    }
    Ok(outside_solids(model, out))
}

/// [`surface_pois`] of the surfaces of `classes` of `model`, sampled in its local metric
/// frame (so a spacing is in metres whatever the CRS: a model in latitude and longitude too)
/// and returned in the model's CRS.
///
/// # Errors
/// As [`surface_pois`].
pub fn surface_pois_of(
    model: &CityModel,
    classes: &[SurfaceClass],
    spacing: f64,
    offset: f64,
) -> Result<Vec<Poi>, RegionError> {
    let crs = model_crs(model, None);
    let (frame, _) = LocalFrame::new(&crs, &model.bbox());
    let local = frame.model_to_local(model);
    let surfaces = cadastre_surfaces(&local, classes);
    let pois = surface_pois(&local, &surfaces, spacing, offset)?;
    if frame.is_identity() {
        return Ok(pois);
    }
    Ok(pois
        .into_iter()
        .map(|p| Poi {
            position: frame.to_source(p.position),
            normal: p.normal.map(|n| frame.normal_to_source(n)),
            id: p.id,
        })
        .collect())
}

/// The surfaces part `index` of `count` of an array job works on: `count` contiguous runs of
/// `surfaces`, cut only where the building changes (so a building's roof total is whole in
/// one part), each cut at the building boundary nearest to an even share of the total area.
/// The parts in order hold every surface once; the result depends only on the surfaces.
pub fn shard_range(surfaces: &[CadastreSurface], index: usize, count: usize) -> Range<usize> {
    let n = surfaces.len();
    let count = count.max(1);
    // the positions a cut may take: 0, n, and every change of building
    let mut bounds = vec![0];
    for k in 1..n {
        let same =
            surfaces[k].building.is_some() && surfaces[k].building == surfaces[k - 1].building;
        if !same {
            bounds.push(k);
        }
    }
    bounds.push(n);
    let mut area = vec![0.0; n + 1];
    for (k, s) in surfaces.iter().enumerate() {
        area[k + 1] = area[k] + s.area_m2.max(0.0);
    }
    let total = area[n];
    let cut = |k: usize| -> usize {
        if k == 0 {
            return 0;
        }
        if k >= count {
            return n;
        }
        let want = total * k as f64 / count as f64;
        (bounds.iter().copied())
            .min_by(|&a, &b| (area[a] - want).abs().total_cmp(&(area[b] - want).abs()))
            .unwrap_or(n)
    };
    let (lo, hi) = (cut(index.min(count)), cut(index.min(count) + 1));
    lo..hi.max(lo)
}

/// The name of the surface of a point [`surface_pois`] made.
pub fn surface_of_poi(id: &str) -> &str {
    id.rsplit_once(':').map_or(id, |(s, _)| s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Asset, Building, LodGeometry, Polygon};
    use glam::DVec3;

    /// A 10 × 6 × 4 m box as one body (no thematic surfaces), faces outward.
    fn body() -> CityModel {
        let (x, y, z) = (10.0, 6.0, 4.0);
        let p = |v: [[f64; 3]; 4]| Polygon::new(v.iter().map(|a| DVec3::from(*a)).collect());
        let faces = vec![
            p([[0., 0., z], [x, 0., z], [x, y, z], [0., y, z]]),
            p([[0., 0., 0.], [0., y, 0.], [x, y, 0.], [x, 0., 0.]]),
            p([[0., 0., 0.], [x, 0., 0.], [x, 0., z], [0., 0., z]]),
            p([[x, 0., 0.], [x, y, 0.], [x, y, z], [x, 0., z]]),
            p([[x, y, 0.], [0., y, 0.], [0., y, z], [x, y, z]]),
            p([[0., y, 0.], [0., 0., 0.], [0., 0., z], [0., y, z]]),
        ];
        let mut m = CityModel::default();
        m.buildings.push(Building {
            id: Some("B".into()),
            is_part: false,
            parent: None,
            span: 0..0,
            line: 1,
            assets: vec![0],
            geometries: Vec::new(),
            file: 0,
        });
        // as the readers take a body out of its building: with the building's id
        m.assets.push(Asset {
            kind: AssetKind::Body,
            id: Some("B".into()),
            element: "Building".into(),
            building: Some(0),
            parent: None,
            span: 0..0,
            line: 1,
            function: None,
            file: 0,
            geometries: vec![LodGeometry {
                lod: 1,
                polygons: faces,
                ..Default::default()
            }],
        });
        m
    }

    #[test]
    fn shards_cut_between_buildings_and_cover_every_surface_once() {
        let s = |name: &str, b: Option<&str>, area: f64| CadastreSurface {
            name: name.into(),
            asset: 0,
            class: SurfaceClass::Roof,
            building: b.map(str::to_string),
            polygons: vec![0],
            area_m2: area,
        };
        let list = vec![
            s("a1", Some("A"), 10.0),
            s("a2", Some("A"), 10.0),
            s("b1", Some("B"), 5.0),
            s("x", None, 1.0),
            s("c1", Some("C"), 20.0),
            s("c2", Some("C"), 1.0),
        ];
        for count in 1..=8 {
            let parts: Vec<Range<usize>> =
                (0..count).map(|i| shard_range(&list, i, count)).collect();
            assert_eq!(parts[0].start, 0);
            assert_eq!(parts[count - 1].end, list.len());
            for w in parts.windows(2) {
                assert_eq!(w[0].end, w[1].start, "{count}: {parts:?}");
            }
            for p in &parts {
                // never inside a building
                assert!(p.start == 0 || p.start == list.len() || ![1, 5].contains(&p.start));
            }
        }
        assert_eq!(shard_range(&list, 0, 2), 0..3);
        assert_eq!(shard_range(&list, 1, 2), 3..6);
    }

    #[test]
    fn a_body_splits_into_roof_and_walls() {
        let m = body();
        let s = cadastre_surfaces(&m, &[SurfaceClass::Roof, SurfaceClass::Wall]);
        let got: Vec<(&str, SurfaceClass, f64)> = s
            .iter()
            .map(|s| (s.name.as_str(), s.class, s.area_m2))
            .collect();
        assert_eq!(
            got,
            vec![
                ("B:roof", SurfaceClass::Roof, 60.0),
                ("B:wall", SurfaceClass::Wall, 128.0)
            ]
        );
        assert_eq!(s[0].building.as_deref(), Some("B"));
        let pois = surface_pois(&m, &s[..1], 1.0, 0.05).unwrap();
        assert_eq!(pois.len(), 60);
        assert!(pois.iter().all(|p| (p.position.z - 4.05).abs() < 1e-9));
        assert_eq!(surface_of_poi(&pois[7].id), "B:roof");
        let walls = surface_pois(&m, &s[1..], 2.0, 0.05).unwrap();
        assert_eq!(walls.len(), 2 * (5 * 2 + 3 * 2));
        assert!(cadastre_surfaces(&m, &[SurfaceClass::Wall]).len() == 1);
        assert!(surface_pois(&m, &s, 0.0, 0.05).is_err());
    }
}
