//! Regions of interest (DESIGN.md "Regions and error bounds"): many POIs from one surface or
//! one area, so that one mixed-LoD model serves a whole facade or street.
//!
//! * [`facade_pois`]: a wall or roof surface (by `gml:id`), or a building / building part
//!   (all its walls), sampled on a grid of `spacing` metres in the plane of each of its main
//!   polygons (cell centres inside the polygon, outside its holes, i.e. not in window
//!   openings), moved `offset` metres out along the outward normal. Small polygons (less than a
//!   quarter cell) and polygons turned more than 30° away from the surface's area-weighted
//!   normal (window reveals, sills) are not sampled.
//! * [`grid_pois`]: a horizontal grid of `spacing` metres at height `z` over a polygon given
//!   as WKT (`POLYGON((x y, ...), (hole ...))`), for a street or a square; free points (no
//!   normal).
//!
//! Facade points that fall inside a closed solid (the neighbour behind a party wall) are
//! dropped: a 128-direction sphere probe ([`crate::lod::poi::checks::poi_flags`]) against the buildings
//! near the facade. A facade with no point left is an error.
//!
//! # Example
//! ```
//! use glam::DVec3;
//! use skylod::model::{Asset, AssetKind, CityModel, LodGeometry, Polygon};
//! use skylod::lod::poi::{facade_pois, grid_pois};
//! let mut m = CityModel::default();
//! // a 4 m x 3 m wall in the plane y = 0, facing -y (counter-clockwise seen from outside)
//! let wall = Polygon::new(vec![
//!     DVec3::new(0.0, 0.0, 0.0), DVec3::new(4.0, 0.0, 0.0),
//!     DVec3::new(4.0, 0.0, 3.0), DVec3::new(0.0, 0.0, 3.0),
//! ]);
//! m.assets.push(Asset {
//!     kind: AssetKind::Wall, id: Some("w".into()), element: "WallSurface".into(),
//!     building: None, parent: None, span: 0..0, line: 1, function: None, file: 0,
//!     geometries: vec![LodGeometry { lod: 2, polygons: vec![wall], ..Default::default() }],
//! });
//! let pois = facade_pois(&m, "w", 1.0, 0.05).unwrap();
//! assert_eq!(pois.len(), 12);
//! assert!(pois.iter().all(|p| (p.position.y + 0.05).abs() < 1e-9));
//! assert_eq!(pois[0].normal, Some(DVec3::new(0.0, -1.0, 0.0)));
//! let street = grid_pois("POLYGON((0 0, 10 0, 10 2, 0 2, 0 0))", 1.5, 1.0).unwrap();
//! assert_eq!(street.len(), 20);
//! ```

use crate::lod::poi::checks::{poi_flags, PoiFlag};
use crate::model::Poi;
use crate::model::{AssetKind, Bbox, CityModel, Polygon};
use crate::solar::trace::scene_of;
use glam::{DVec2, DVec3};
use rayon::prelude::*;
use std::collections::HashSet;

/// Errors of the region samplers.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum RegionError {
    /// No surface or building has this id.
    #[error("no wall, roof or building with gml:id {0:?}")]
    UnknownId(String),
    /// The spacing is not a positive number.
    #[error("spacing must be a positive number of metres, got {0}")]
    Spacing(f64),
    /// The WKT text is not a POLYGON this reader understands.
    #[error("WKT: {0}")]
    Wkt(String),
    /// Nothing to sample (the surface or polygon is smaller than one cell).
    #[error("{0}: no point falls inside at this spacing")]
    Empty(String),
    /// The model has no roof or wall of the classes asked for, or none large enough for a
    /// point of the grid.
    #[error("the model has no {} surface with a point at this spacing", .0.iter().map(|c| c.as_str()).collect::<Vec<_>>().join(" or "))]
    NoSurfaces(Vec<crate::lod::poi::SurfaceClass>),
    /// Two POIs of a run share an id (a region POI and a listed one).
    #[error("POI id {0:?} is given twice (a region POI and a listed one?)")]
    DuplicateId(String),
}

/// Distance (m) facade POIs are moved out along the surface normal ([`RegionSpec`]).
pub const FACADE_OFFSET: f64 = 0.05;

/// The region POIs of a run (`--facade`, `--region`/`--height`, `--surfaces`, `--spacing`):
/// sampled on the
/// model as read, after the listed POIs.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RegionSpec {
    /// Surfaces or buildings (gml:ids) whose walls are sampled ([`facade_pois`]).
    pub facades: Vec<String>,
    /// A WKT polygon and the height of its grid ([`grid_pois`]).
    pub area: Option<(String, f64)>,
    /// Every roof and/or wall of the model ([`crate::lod::poi::cadastre_surfaces`]).
    pub surfaces: Vec<crate::lod::poi::SurfaceClass>,
    /// Grid spacing (m) of all three.
    pub spacing: f64,
}

impl RegionSpec {
    /// Whether any region is given.
    pub fn is_active(&self) -> bool {
        !self.facades.is_empty() || self.area.is_some() || !self.surfaces.is_empty()
    }

    /// `pois` followed by the facades' POIs (`FACADE_OFFSET` out) and the area's, sampled
    /// on `model`; every id once.
    ///
    /// # Errors
    /// As [`facade_pois`] and [`grid_pois`]; [`RegionError::DuplicateId`].
    pub fn extend(&self, mut pois: Vec<Poi>, model: &CityModel) -> Result<Vec<Poi>, RegionError> {
        for id in &self.facades {
            pois.extend(facade_pois(model, id, self.spacing, FACADE_OFFSET)?);
        }
        if let Some((wkt, z)) = &self.area {
            pois.extend(grid_pois(wkt, *z, self.spacing)?);
        }
        if !self.surfaces.is_empty() {
            let sampled = crate::lod::poi::surfaces::surface_pois_of(
                model,
                &self.surfaces,
                self.spacing,
                FACADE_OFFSET,
            )?;
            if sampled.is_empty() {
                return Err(RegionError::NoSurfaces(self.surfaces.clone()));
            }
            pois.extend(sampled);
        }
        let mut seen = HashSet::new();
        if let Some(p) = pois.iter().find(|p| !seen.insert(p.id.as_str())) {
            return Err(RegionError::DuplicateId(p.id.clone()));
        }
        Ok(pois)
    }
}

/// Even-odd point-in-ring test in 2D.
fn inside(ring: &[DVec2], p: DVec2) -> bool {
    let mut c = false;
    let n = ring.len();
    for i in 0..n {
        let (a, b) = (ring[i], ring[(i + 1) % n]);
        if (a.y > p.y) != (b.y > p.y) && p.x < a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x) {
            c = !c;
        }
    }
    c
}

/// Cell centres of a `spacing` grid inside `outer` and outside every hole.
fn grid_in(outer: &[DVec2], holes: &[Vec<DVec2>], spacing: f64) -> Vec<DVec2> {
    let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    for p in outer {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return Vec::new();
    }
    // cells of `spacing` over the box (at least one), their centres centred on the box
    let nx = ((hi.x - lo.x) / spacing).floor().max(1.0) as usize;
    let ny = ((hi.y - lo.y) / spacing).floor().max(1.0) as usize;
    // centre the grid on the box so that the margins are equal
    let ox = lo.x + 0.5 * ((hi.x - lo.x) - (nx as f64 - 1.0) * spacing);
    let oy = lo.y + 0.5 * ((hi.y - lo.y) - (ny as f64 - 1.0) * spacing);
    let mut out = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let p = DVec2::new(ox + i as f64 * spacing, oy + j as f64 * spacing);
            if inside(outer, p) && !holes.iter().any(|h| inside(h, p)) {
                out.push(p);
            }
        }
    }
    out
}

/// Points of one polygon at `spacing` in its plane, with its unit normal.
pub(crate) fn sample_polygon(p: &Polygon, n: DVec3, spacing: f64) -> Vec<DVec3> {
    let Some(&o) = p.exterior().first() else {
        return Vec::new();
    };
    // in-plane basis: u horizontal when the plane is not horizontal
    let u = n.cross(DVec3::Z).try_normalize().unwrap_or(DVec3::X);
    let v = n.cross(u);
    let to2 = |q: &DVec3| DVec2::new((*q - o).dot(u), (*q - o).dot(v));
    let outer: Vec<DVec2> = p.exterior().iter().map(to2).collect();
    let holes: Vec<Vec<DVec2>> = p.interiors().map(|h| h.iter().map(to2).collect()).collect();
    grid_in(&outer, &holes, spacing)
        .into_iter()
        .map(|q| o + u * q.x + v * q.y)
        .collect()
}

/// POIs on the surface or building `id` (see the module docs), named `<id>:<k>`.
///
/// # Errors
/// [`RegionError`] for an unknown id, a bad spacing, or a surface with no point inside.
pub fn facade_pois(
    model: &CityModel,
    id: &str,
    spacing: f64,
    offset: f64,
) -> Result<Vec<Poi>, RegionError> {
    if spacing.is_nan() || spacing <= 0.0 || !spacing.is_finite() {
        return Err(RegionError::Spacing(spacing));
    }
    let surfaces: Vec<usize> = match model
        .assets
        .iter()
        .position(|a| a.id.as_deref() == Some(id))
    {
        Some(i) => vec![i],
        None => {
            let b = model
                .buildings
                .iter()
                .position(|b| b.id.as_deref() == Some(id))
                .ok_or_else(|| RegionError::UnknownId(id.to_string()))?;
            // walls of the building and of its parts
            let under = |mut x: usize| loop {
                if x == b {
                    return true;
                }
                match model.buildings.get(x).and_then(|bb| bb.parent) {
                    Some(p) => x = p,
                    None => return false,
                }
            };
            model
                .assets
                .iter()
                .enumerate()
                .filter(|(_, a)| a.kind == AssetKind::Wall && a.building.is_some_and(under))
                .map(|(i, _)| i)
                .collect()
        }
    };
    let mut out = Vec::new();
    for i in surfaces {
        let polys = model.assets[i].detail_polygons();
        let main = polys
            .iter()
            .fold(DVec3::ZERO, |s, p| s + p.newell_normal())
            .try_normalize();
        for p in polys {
            let Some(n) = p.newell_normal().try_normalize() else {
                continue;
            };
            if p.area() < 0.25 * spacing * spacing || main.is_some_and(|m| m.dot(n) < 0.866) {
                continue;
            }
            for q in sample_polygon(p, n, spacing) {
                out.push(Poi {
                    id: format!("{id}:{}", out.len()),
                    position: q + n * offset,
                    normal: Some(n),
                });
            }
        }
    }
    let mut out = outside_solids(model, out);
    if out.is_empty() {
        return Err(RegionError::Empty(id.to_string()));
    }
    for (k, p) in out.iter_mut().enumerate() {
        p.id = format!("{id}:{k}");
    }
    Ok(out)
}

/// `pois` without those inside a closed solid of the buildings near them: a square of
/// [`SOLIDS_SQUARE`] at a time, every building with an asset within [`SOLIDS_MARGIN`] of the
/// box of the square's points, whole; the square's points tested in parallel.
pub(crate) fn outside_solids(model: &CityModel, pois: Vec<Poi>) -> Vec<Poi> {
    let bb = Bbox::of_points(pois.iter().map(|p| &p.position));
    if bb.is_empty() {
        return pois;
    }
    let boxes: Vec<Bbox> = model.assets.par_iter().map(|a| a.bbox()).collect();
    let root = |a: &crate::model::Asset| a.building.map(|b| model.root_building(b));
    let points: Vec<DVec3> = pois.iter().map(|p| p.position).collect();
    let mut keep = vec![true; pois.len()];
    // a neighbourhood at a time: one scene of the buildings near its points
    for (_, members) in crate::model::squares(&points, bb.min, SOLIDS_SQUARE) {
        let mut near_box = Bbox::of_points(members.iter().map(|&i| &points[i]));
        near_box.min -= DVec3::splat(SOLIDS_MARGIN);
        near_box.max += DVec3::splat(SOLIDS_MARGIN);
        let overlaps = |a: &Bbox| {
            !a.is_empty() && a.min.cmple(near_box.max).all() && a.max.cmpge(near_box.min).all()
        };
        let near: HashSet<usize> = (model.assets.iter().zip(&boxes))
            .filter(|(_, b)| overlaps(b))
            .filter_map(|(a, _)| root(a))
            .collect();
        let scene = scene_of(
            model
                .assets
                .iter()
                .enumerate()
                .filter(|(_, a)| root(a).is_some_and(|b| near.contains(&b)))
                .flat_map(|(i, a)| a.detail_polygons().iter().map(move |p| (i as u32, p))),
        );
        let inside: Vec<bool> = members
            .par_iter()
            .map(|&i| {
                poi_flags(&scene, model, &pois[i], None)
                    .iter()
                    .any(|f| matches!(f, PoiFlag::InsideBuilding { .. }))
            })
            .collect();
        for (&i, inside) in members.iter().zip(inside) {
            keep[i] = !inside;
        }
    }
    pois.into_iter()
        .zip(keep)
        .filter_map(|(p, k)| k.then_some(p))
        .collect()
}

/// Side (m) of the squares [`outside_solids`] tests at a time.
const SOLIDS_SQUARE: f64 = 250.0;

/// Reach (m) of the buildings that enclose a point in [`outside_solids`]: a point is inside
/// when every probe ray meets something, and a gap between buildings may be closed far off.
const SOLIDS_MARGIN: f64 = 100.0;

/// Parse `POLYGON((x y, ...), (x y, ...))` (extra coordinates ignored): exterior and holes.
fn parse_wkt_polygon(wkt: &str) -> Result<(Vec<DVec2>, Vec<Vec<DVec2>>), RegionError> {
    let t = wkt.trim();
    let bad = |m: &str| RegionError::Wkt(format!("{m} in {t:?} (expected POLYGON((x y, ...)))"));
    let rest = t
        .get(..7)
        .filter(|h| h.eq_ignore_ascii_case("POLYGON"))
        .map(|_| t[7..].trim())
        .ok_or_else(|| bad("no POLYGON keyword"))?;
    if t.matches('(').count() != t.matches(')').count() {
        return Err(bad("unbalanced parentheses"));
    }
    let inner = rest
        .strip_prefix('(')
        .and_then(|r| r.strip_suffix(')'))
        .ok_or_else(|| bad("unbalanced parentheses"))?;
    let mut rings = Vec::new();
    for part in inner.split(')') {
        let part = part.trim().trim_start_matches(',').trim();
        if part.is_empty() {
            continue;
        }
        let body = part
            .strip_prefix('(')
            .ok_or_else(|| bad("a ring without '('"))?;
        let mut ring = Vec::new();
        for pt in body.split(',') {
            let nums: Vec<f64> = pt
                .split_whitespace()
                .map(|x| x.parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| bad(&format!("{:?} is not a point", pt.trim())))?;
            match nums.as_slice() {
                [x, y, ..] if x.is_finite() && y.is_finite() => ring.push(DVec2::new(*x, *y)),
                _ => return Err(bad(&format!("{:?} is not a point", pt.trim()))),
            }
        }
        if ring.len() > 1 && ring.first() == ring.last() {
            ring.pop();
        }
        if ring.len() < 3 {
            return Err(bad("a ring with fewer than 3 points"));
        }
        rings.push(ring);
    }
    let mut it = rings.into_iter();
    let outer = it.next().ok_or_else(|| bad("no ring"))?;
    Ok((outer, it.collect()))
}

/// POIs on a horizontal `spacing` grid at height `z` inside a WKT polygon (model CRS),
/// named `region:<k>`, without a normal.
///
/// # Errors
/// [`RegionError`] for bad WKT, a bad spacing, or a polygon smaller than one cell.
pub fn grid_pois(wkt: &str, z: f64, spacing: f64) -> Result<Vec<Poi>, RegionError> {
    if spacing.is_nan() || spacing <= 0.0 || !spacing.is_finite() {
        return Err(RegionError::Spacing(spacing));
    }
    let (outer, holes) = parse_wkt_polygon(wkt)?;
    let pts = grid_in(&outer, &holes, spacing);
    if pts.is_empty() {
        return Err(RegionError::Empty("the region".into()));
    }
    Ok(pts
        .into_iter()
        .enumerate()
        .map(|(k, p)| Poi {
            id: format!("region:{k}"),
            position: DVec3::new(p.x, p.y, z),
            normal: None,
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Asset, Building, LodGeometry};

    #[test]
    fn a_region_spec_adds_its_pois_after_the_listed_ones_each_id_once() {
        let m = model();
        let street = "POLYGON((0 0, 4 0, 4 2, 0 2, 0 0))";
        let mut spec = RegionSpec {
            spacing: 1.0,
            ..RegionSpec::default()
        };
        assert!(!spec.is_active());
        let listed = vec![Poi::at("p", [1.0, 1.0, 1.0])];
        assert_eq!(spec.extend(listed.clone(), &m).unwrap(), listed);
        spec.area = Some((street.into(), 1.5));
        spec.facades.push("B".into());
        assert!(spec.is_active());
        let all = spec.extend(listed.clone(), &m).unwrap();
        let walls = facade_pois(&m, "B", 1.0, FACADE_OFFSET).unwrap();
        let grid = grid_pois(street, 1.5, 1.0).unwrap();
        assert_eq!(all.len(), 1 + walls.len() + grid.len());
        assert_eq!(all[0], listed[0]);
        assert_eq!(all[1..=walls.len()], walls[..]);
        assert_eq!(all[1 + walls.len()..], grid[..]);
        // A listed POI named as a region POI: refused, naming the id.
        let clash = vec![Poi::at(grid[0].id.clone(), [0.0, 0.0, 0.0])];
        let e = spec.extend(clash, &m).unwrap_err();
        assert_eq!(e, RegionError::DuplicateId(grid[0].id.clone()));
        spec.facades = vec!["nope".into()];
        let e = spec.extend(listed, &m).unwrap_err();
        assert_eq!(e, RegionError::UnknownId("nope".into()));
    }

    fn wall_with_window() -> Polygon {
        // 10 m x 5 m wall facing +x, a 2 m x 2 m window hole in the middle
        let mut p = Polygon::new(vec![
            DVec3::new(0.0, 10.0, 0.0),
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, 5.0),
            DVec3::new(0.0, 10.0, 5.0),
        ]);
        p.exterior_mut().reverse();
        p.push_interior(&[
            DVec3::new(0.0, 4.0, 1.0),
            DVec3::new(0.0, 6.0, 1.0),
            DVec3::new(0.0, 6.0, 3.0),
            DVec3::new(0.0, 4.0, 3.0),
        ]);
        p
    }

    fn model() -> CityModel {
        let mut m = CityModel::default();
        m.buildings.push(Building::new(Some("B"), vec![0]));
        let reveal = Polygon::new(vec![
            DVec3::new(0.0, 4.0, 1.5),
            DVec3::new(-0.3, 4.0, 1.5),
            DVec3::new(-0.3, 6.0, 1.5),
            DVec3::new(0.0, 6.0, 1.5),
        ]);
        m.assets.push(Asset {
            building: Some(0),
            ..Asset::new(
                AssetKind::Wall,
                Some("W"),
                "WallSurface",
                vec![LodGeometry {
                    lod: 3,
                    polygons: vec![wall_with_window(), reveal],
                    ..Default::default()
                }],
            )
        });
        m
    }

    #[test]
    fn facade_skips_the_window_and_the_reveal() {
        let m = model();
        let n = wall_with_window().newell_normal().normalize();
        assert!(n.x < -0.99 || n.x > 0.99);
        let pois = facade_pois(&m, "W", 1.0, 0.05).unwrap();
        // 10 x 5 cells minus the 2 x 2 window
        assert_eq!(pois.len(), 46);
        for p in &pois {
            assert_eq!(p.normal, Some(n));
            assert!((p.position.x - 0.05 * n.x).abs() < 1e-9);
            let in_window =
                (4.0..6.0).contains(&p.position.y) && (1.0..3.0).contains(&p.position.z);
            assert!(!in_window, "{:?}", p.position);
        }
        // the building gives its walls
        assert_eq!(facade_pois(&m, "B", 1.0, 0.05).unwrap().len(), 46);
        assert!(matches!(
            facade_pois(&m, "nope", 1.0, 0.05),
            Err(RegionError::UnknownId(_))
        ));
        assert!(facade_pois(&m, "W", 0.0, 0.05).is_err());
        assert!(facade_pois(&m, "W", 100.0, 0.05).is_err());
        // ids are unique
        let ids: std::collections::HashSet<_> = pois.iter().map(|p| &p.id).collect();
        assert_eq!(ids.len(), pois.len());
    }

    #[test]
    fn wkt_grid_with_hole_and_errors() {
        let pois = grid_pois(
            "POLYGON ((0 0, 4 0, 4 4, 0 4, 0 0), (1 1, 3 1, 3 3, 1 3, 1 1))",
            2.0,
            1.0,
        )
        .unwrap();
        assert_eq!(pois.len(), 12);
        assert!(pois
            .iter()
            .all(|p| p.position.z == 2.0 && p.normal.is_none()));
        for bad in [
            "POINT (1 2)",
            "POLYGON ((0 0, 1 0))",
            "POLYGON ((0 0, a 0, 1 1, 0 0))",
            "POLYGON ((0 0, 1 0, 1 1, 0 0)",
            "",
        ] {
            assert!(grid_pois(bad, 0.0, 1.0).is_err(), "{bad}");
        }
        assert!(grid_pois("POLYGON((0 0, 1 0, 1 1, 0 0))", 0.0, -1.0).is_err());
    }
}
