//! Selection (paper 4.1, 4.2, 4.5): a level per asset from the sky bundle cast at each
//! point of interest against the rough model.
//!
//! * **level 0**: no ray of any POI hit the asset; it is omitted from the output;
//! * **level 2**: a *roof asset* whose rough outline lies on the silhouette (skyline) seen
//!   from a POI; it keeps its full detail;
//! * **level 1**: every other asset that was hit; it is written with its rough geometry.
//!
//! A *roof asset* is a `RoofSurface`, a building body (LoD1/2 solid without thematic
//! surfaces), or an installation or other object of a building whose lowest point is at or
//! above the lowest edge of the building's roofs minus [`SelectOptions::roof_tolerance_m`]
//! (a chimney, a water tank, an antenna, a stair tower).
//!
//! **Safety net**: an asset replaced by its box whose box holds a POI that the asset's full
//! geometry does not ([`rough_holds_poi_full_not`]) is at level 2 for that POI: the box
//! would hide sky that the full model has.
//!
//! **Silhouette test** (paper Fig. 4): the edges of the asset's rough outline (the four top
//! edges of an installation's box; every edge of a roof's generalised polygons) are
//! projected onto the unit sphere around the POI as great-circle arcs. The asset is on the
//! silhouette when a *sky ray* of that POI (one that hit nothing) lies within the angular
//! threshold of one of those arcs. The default threshold is 1.5 x the cell's angular size
//! `sqrt(2 pi / N)`.
//!
//! The bundle is Beckers' equal-solid-angle partition of the upper hemisphere (world
//! frame, azimuth from north), one jittered ray per cell from an RNG seeded from the POI
//! itself ([`Poi::ray_seed`]: its id with the seed). For a POI with
//! a normal only the rays in front of the surface (`dot(n, d) > 0`) are cast. Levels of
//! several POIs combine by maximum, hits add up. POIs are traced in parallel (rayon); the
//! result does not depend on the number of threads.
//!
//! # Example
//! ```
//! use glam::DVec3;
//! use skylod::model::{Asset, AssetKind, CityModel, LodGeometry, Polygon};
//! use skylod::lod::poi::Poi;
//! use skylod::lod::rough::{rough_model, RoughOptions};
//! use skylod::lod::{SelectOptions, select};
//! // One flat roof 10 m above the POI, 20 m x 20 m: it hides the zenith.
//! let roof = Polygon::new(vec![
//!     DVec3::new(-10.0, -10.0, 10.0), DVec3::new(10.0, -10.0, 10.0),
//!     DVec3::new(10.0, 10.0, 10.0), DVec3::new(-10.0, 10.0, 10.0),
//! ]);
//! let mut m = CityModel::default();
//! m.assets.push(Asset::new(AssetKind::Roof, Some("R"), "RoofSurface",
//!     vec![LodGeometry { lod: 2, polygons: vec![roof], ..Default::default() }],
//! ));
//! let rough = rough_model(&m, &RoughOptions::default());
//! let scene = skylod::lod::rough_scene(&rough);
//! let poi = Poi { id: "p".into(), position: DVec3::ZERO, normal: None };
//! let sel = select(&m, &rough, &scene, &[poi], &SelectOptions::default())?;
//! assert!(sel.hits[0] > 0);
//! assert_eq!(sel.levels[0], 2); // its edges are the skyline
//! # Ok::<(), skylod::lod::SelectError>(())
//! ```

use crate::lod::poi::{Poi, POI_OFFSET};
use crate::lod::rough::RoughGeometry;
use crate::model::{AssetKind, CityModel};
use crate::solar::sky::{SkyError, SkyPartition, SkyVariant};
use crate::solar::trace::TraceScene;
use foldhash::{HashMap, HashMapExt};
use glam::DVec3;
use rayon::prelude::*;
use std::time::Instant;

/// Options of the selection stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SelectOptions {
    /// Number of rays (cells of the hemisphere partition) per POI.
    pub rays: usize,
    /// Seed of the jitter.
    pub seed: u64,
    /// Angular threshold of the silhouette test in degrees; `None`: 1.5 x the cell size.
    pub threshold_deg: Option<f64>,
    /// Tolerance (m) below the lowest roof edge for an installation to count as standing
    /// on the roof.
    pub roof_tolerance_m: f64,
}

impl Default for SelectOptions {
    fn default() -> Self {
        SelectOptions {
            rays: 10_000,
            seed: 1,
            threshold_deg: None,
            roof_tolerance_m: 0.5,
        }
    }
}

/// Errors of the selection stage.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SelectError {
    /// The ray count is not usable.
    #[error("sky bundle: {0}")]
    Sky(#[from] SkyError),
    /// The rough model does not belong to the model.
    #[error("rough model has {rough} entries for {assets} assets")]
    RoughMismatch {
        /// Entries of the rough model.
        rough: usize,
        /// Assets of the model.
        assets: usize,
    },
    /// A threshold that is not a finite positive angle.
    #[error("silhouette threshold {0} deg is not a finite angle in (0, 90]")]
    Threshold(f64),
    /// A POI with a non-finite position or normal.
    #[error("POI {0}: position or normal is not finite")]
    Poi(String),
    /// The caller asked to stop ([`crate::model::runtime::progress::Progress::is_cancelled`]).
    #[error(transparent)]
    Cancelled(#[from] crate::model::runtime::progress::Cancelled),
}

/// What one POI saw.
#[derive(Debug, Clone, PartialEq)]
pub struct PoiSelection {
    /// The POI's id.
    pub id: String,
    /// Rays cast (in front of the surface).
    pub rays: usize,
    /// Rays that hit nothing.
    pub sky_rays: usize,
    /// Assets hit at least once.
    pub assets_hit: usize,
    /// Assets on this POI's silhouette (level 2 from this POI).
    pub silhouette_assets: usize,
    /// Wall-clock time of this POI (tracing + silhouette), seconds.
    pub seconds: f64,
    /// Polygons of this POI's own LoD model (its levels alone, as `lod` with only this POI
    /// would write them; [`crate::lod::level::polygon_count`]): what a region model is compared with.
    pub polygons: usize,
}

/// Result of [`select`].
#[derive(Debug, Clone, PartialEq)]
pub struct Selection {
    /// Level 0, 1 or 2 per asset (index = asset index).
    pub levels: Vec<u8>,
    /// Ray hits per asset, summed over the POIs.
    pub hits: Vec<u64>,
    /// Whether each asset counts as a roof asset.
    pub roof_asset: Vec<bool>,
    /// Per POI, in input order.
    pub pois: Vec<PoiSelection>,
    /// Threshold used, degrees.
    pub threshold_deg: f64,
    /// Rays per POI (cells of the partition).
    pub rays: usize,
}

impl Selection {
    /// Number of assets at each level `[level 0, level 1, level 2]`.
    pub fn level_counts(&self) -> [usize; 3] {
        let mut c = [0usize; 3];
        for &l in &self.levels {
            if let Some(x) = c.get_mut(usize::from(l)) {
                *x += 1;
            }
        }
        c
    }
}

/// Run the selection for `pois` against `scene`, the rough model of `model` built with
/// [`crate::lod::scene::selection_scene`] (or [`crate::lod::scene::rough_scene`]) from `rough`
/// (tags = asset indices).
///
/// # Errors
/// [`SelectError`] for an unusable ray count or threshold, a non-finite POI, or a rough
/// model of another length than the model's assets.
pub fn select(
    model: &CityModel,
    rough: &[RoughGeometry],
    scene: &TraceScene,
    pois: &[Poi],
    opts: &SelectOptions,
) -> Result<Selection, SelectError> {
    select_with(
        model,
        rough,
        scene,
        pois,
        opts,
        &crate::model::runtime::progress::Silent,
    )
}

/// [`select`] reporting each POI done to `progress` ([`Stage::Select`]) and stopping with
/// [`SelectError::Cancelled`] when it asks to.
///
/// # Errors
/// As [`select`], and [`SelectError::Cancelled`].
///
/// [`Stage::Select`]: crate::model::runtime::progress::Stage::Select
pub fn select_with(
    model: &CityModel,
    rough: &[RoughGeometry],
    scene: &TraceScene,
    pois: &[Poi],
    opts: &SelectOptions,
    progress: &dyn crate::model::runtime::progress::Progress,
) -> Result<Selection, SelectError> {
    select_facts(model, model, rough, scene, pois, opts, progress)
}

/// What the selection takes from the full polygons beyond the rough model and the assets a
/// POI's rough box holds: the lowest point of each asset (which installations are roof
/// assets) and its polygons at a level (each POI's own model). A [`CityModel`] answers from
/// its polygons, a [`crate::lod::hollow::Hollow`] from what its read made of them.
pub trait FullFacts: Sync {
    /// The lowest z of asset `i`'s polygons, all LoDs ([`crate::model::Asset::bbox`]).
    fn min_z(&self, i: usize) -> f64;
    /// [`crate::lod::level::polygon_count`] of asset `i` with `rough` at `level`.
    fn polygon_count(&self, i: usize, rough: Option<&RoughGeometry>, level: u8) -> usize;
    /// The polygons of asset `i` over all its geometry properties
    /// ([`crate::model::Asset::polygon_count`]).
    fn polygons(&self, i: usize) -> usize;
}

impl FullFacts for CityModel {
    fn min_z(&self, i: usize) -> f64 {
        self.assets.get(i).map_or(f64::INFINITY, |a| a.bbox().min.z)
    }

    fn polygon_count(&self, i: usize, rough: Option<&RoughGeometry>, level: u8) -> usize {
        let a = self.assets.get(i);
        a.map_or(0, |a| crate::lod::level::polygon_count(a, rough, level))
    }

    fn polygons(&self, i: usize) -> usize {
        self.assets
            .get(i)
            .map_or(0, crate::model::Asset::polygon_count)
    }
}

/// [`select_with`] taking the full geometry's facts from `facts` (a hollow read's,
/// [`crate::lod::hollow::Hollow`]); `model` needs the polygons only of the assets whose rough
/// box holds a POI ([`rough_holds_poi_full_not`]).
///
/// # Errors
/// As [`select_with`].
#[allow(clippy::too_many_arguments)]
pub fn select_facts(
    model: &CityModel,
    facts: &dyn FullFacts,
    rough: &[RoughGeometry],
    scene: &TraceScene,
    pois: &[Poi],
    opts: &SelectOptions,
    progress: &dyn crate::model::runtime::progress::Progress,
) -> Result<Selection, SelectError> {
    use crate::model::runtime::progress::{check, Stage};
    let n_assets = model.assets.len();
    if rough.len() != n_assets {
        return Err(SelectError::RoughMismatch {
            rough: rough.len(),
            assets: n_assets,
        });
    }
    let partition = SkyPartition::new(opts.rays, SkyVariant::EqualSolidAngle)?;
    let threshold = match opts.threshold_deg {
        Some(t) if t.is_finite() && t > 0.0 && t <= 90.0 => t.to_radians(),
        Some(t) => return Err(SelectError::Threshold(t)),
        None => 1.5 * partition.angular_size(),
    };
    for p in pois {
        if !p.position.is_finite() || p.normal.is_some_and(|n| !n.is_finite()) {
            return Err(SelectError::Poi(p.id.clone()));
        }
    }
    let roof_asset = roof_assets_with(model, facts, rough, opts.roof_tolerance_m);

    let per_poi: Vec<OnePoi> = pois
        .par_iter()
        .map(|poi| {
            check(progress, Stage::Select)?;
            let dirs = partition.sample(poi.ray_seed(opts.seed));
            let one = select_one(poi, &dirs, scene, rough, &roof_asset, threshold);
            progress.advance(Stage::Select, 1, 0, None);
            Ok(one)
        })
        .collect::<Result<_, crate::model::runtime::progress::Cancelled>>()?;

    let mut levels = vec![0u8; n_assets];
    let mut hits = vec![0u64; n_assets];
    let mut out_pois = Vec::with_capacity(per_poi.len());
    for (poi, (mut info, poi_hits, mut silhouette)) in pois.iter().zip(per_poi) {
        // Safety net: a closed rough form (a box) that holds the POI while the full
        // geometry does not hides sky the full model has; keep that asset in full.
        for &(a, _) in &poi_hits {
            let i = a as usize;
            if let (Some(asset), Some(r)) = (model.assets.get(i), rough.get(i)) {
                if rough_holds_poi_full_not(asset, r, poi.position) {
                    silhouette.push(a);
                }
            }
        }
        silhouette.sort_unstable();
        silhouette.dedup();
        info.polygons = own_polygons(model, facts, rough, &poi_hits, &silhouette);
        for (a, h) in poi_hits {
            let a = a as usize;
            if let (Some(x), Some(l)) = (hits.get_mut(a), levels.get_mut(a)) {
                *x += u64::from(h);
                *l = (*l).max(1);
            }
        }
        for a in silhouette {
            if let Some(l) = levels.get_mut(a as usize) {
                *l = 2;
            }
        }
        out_pois.push(info);
    }
    // An opening of a surface kept in full detail stays with it (the surface's polygons
    // have holes for it); openings of rough surfaces are closed by the rough plane.
    for (i, a) in model.assets.iter().enumerate() {
        if a.kind.is_opening() {
            if let Some(p) = a.parent {
                if levels.get(p) == Some(&2) {
                    if let Some(l) = levels.get_mut(i) {
                        *l = 2;
                    }
                }
            }
        }
    }
    Ok(Selection {
        levels,
        hits,
        roof_asset,
        pois: out_pois,
        threshold_deg: threshold.to_degrees(),
        rays: partition.len(),
    })
}

/// Polygons of one POI's own LoD model: hit assets at level 1, silhouette assets (and the
/// openings of silhouette surfaces) at level 2, as [`select`] combines them.
fn own_polygons(
    model: &CityModel,
    facts: &dyn FullFacts,
    rough: &[RoughGeometry],
    hits: &[(u32, u32)],
    silhouette: &[u32],
) -> usize {
    let mut levels: HashMap<usize, u8> = hits.iter().map(|&(a, _)| (a as usize, 1)).collect();
    for &a in silhouette {
        levels.insert(a as usize, 2);
    }
    if !silhouette.is_empty() {
        for (i, a) in model.assets.iter().enumerate() {
            if a.kind.is_opening() && a.parent.is_some_and(|p| levels.get(&p) == Some(&2)) {
                levels.insert(i, 2);
            }
        }
    }
    levels
        .iter()
        .filter(|&(&i, _)| i < model.assets.len())
        .map(|(&i, &l)| facts.polygon_count(i, rough.get(i), l))
        .sum()
}

/// What [`select_one`] finds: summary, hits per asset (sorted by asset), silhouette assets.
type OnePoi = (PoiSelection, Vec<(u32, u32)>, Vec<u32>);

/// Trace one POI.
fn select_one(
    poi: &Poi,
    dirs: &[DVec3],
    scene: &TraceScene,
    rough: &[RoughGeometry],
    roof_asset: &[bool],
    threshold: f64,
) -> OnePoi {
    let t0 = Instant::now();
    let origin = poi.ray_origin();
    let normal = poi.normal.and_then(|n| n.try_normalize());
    let cast: Vec<DVec3> = dirs
        .iter()
        .copied()
        .filter(|d| normal.is_none_or(|n| n.dot(*d) > 0.0))
        .collect();
    let tags: Vec<Option<u32>> = cast
        .par_iter()
        .with_min_len(256)
        .map(|&d| {
            scene
                .first_hit(origin, d, POI_OFFSET, f64::INFINITY)
                .map(|h| h.tag)
        })
        .collect();
    let mut counts: HashMap<u32, u32> = HashMap::new();
    let mut sky = Vec::new();
    for (d, t) in cast.iter().zip(&tags) {
        match t {
            Some(tag) => *counts.entry(*tag).or_insert(0) += 1,
            None => sky.push(*d),
        }
    }
    let mut hits: Vec<(u32, u32)> = counts.into_iter().collect();
    hits.sort_unstable();

    let index = SkyIndex::new(&sky, threshold);
    let silhouette: Vec<u32> = hits
        .iter()
        .map(|&(a, _)| a)
        .filter(|&a| roof_asset.get(a as usize).copied().unwrap_or(false))
        .filter(|&a| {
            rough
                .get(a as usize)
                .is_some_and(|r| outline_edges(r).any(|e| index.near_segment(origin, e)))
        })
        .collect();

    let info = PoiSelection {
        id: poi.id.clone(),
        rays: cast.len(),
        sky_rays: sky.len(),
        assets_hit: hits.len(),
        silhouette_assets: silhouette.len(),
        seconds: t0.elapsed().as_secs_f64(),
        polygons: 0,
    };
    (info, hits, silhouette)
}

/// Whether `p` lies inside the closed rough form of `asset` (its box) but not inside the
/// asset's full geometry (the polygons of the rough stage's LoD, by ray parity: inside
/// only when three rays in different directions each cross it an odd number of times).
pub fn rough_holds_poi_full_not(
    asset: &crate::model::Asset,
    rough: &RoughGeometry,
    p: DVec3,
) -> bool {
    let Some(b) = &rough.obb else { return false };
    if !b.contains(p, 0.0) {
        return false;
    }
    let mut tris = Vec::new();
    for poly in asset.polygons_at(rough.lod) {
        crate::model::triangulate(poly, &mut tris);
    }
    // generic directions: no ray along a triangulation diagonal of an axis-aligned face
    let dirs = [
        DVec3::new(0.012_3, 0.037_1, 1.0).normalize(),
        DVec3::new(0.577_1, 0.301_3, 0.759_2).normalize(),
        DVec3::new(-0.412_9, -0.703_7, -0.578_3).normalize(),
    ];
    !dirs
        .iter()
        .all(|&d| tris.iter().filter(|t| ray_crosses(p, d, t)).count() % 2 == 1)
}

/// Möller–Trumbore: whether the ray `o + t d` (t > 0) crosses triangle `t`.
fn ray_crosses(o: DVec3, d: DVec3, t: &[DVec3; 3]) -> bool {
    let [a, b, c] = *t;
    let e1 = b - a;
    let e2 = c - a;
    let h = d.cross(e2);
    let det = e1.dot(h);
    if det.abs() < 1e-12 {
        return false;
    }
    let s = o - a;
    let u = s.dot(h) / det;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    e2.dot(q) / det > 0.0
}

/// Which assets are roof assets (see the module docs).
pub fn roof_assets(model: &CityModel, rough: &[RoughGeometry], tolerance: f64) -> Vec<bool> {
    roof_assets_with(model, model, rough, tolerance)
}

/// [`roof_assets`] with the full geometry's facts from `facts`.
fn roof_assets_with(
    model: &CityModel,
    facts: &dyn FullFacts,
    rough: &[RoughGeometry],
    tolerance: f64,
) -> Vec<bool> {
    // Lowest roof edge per root building (over the building and its parts).
    let mut roof_min = vec![f64::INFINITY; model.buildings.len()];
    for (i, a) in model.assets.iter().enumerate() {
        if a.kind != AssetKind::Roof {
            continue;
        }
        let Some(b) = a.building else { continue };
        let root = model.root_building(b);
        let z = facts.min_z(i);
        if let Some(m) = roof_min.get_mut(root) {
            if z < *m {
                *m = z;
            }
        }
    }
    model
        .assets
        .iter()
        .enumerate()
        .map(|(i, a)| match a.kind {
            AssetKind::Roof | AssetKind::Body => true,
            AssetKind::Installation | AssetKind::Other => {
                let Some(b) = a.building else { return false };
                let Some(&m) = roof_min.get(model.root_building(b)) else {
                    return false;
                };
                let low = rough
                    .get(i)
                    .map(|r| {
                        r.polygons()
                            .iter()
                            .flat_map(|p| p.points())
                            .fold(f64::INFINITY, |z, p| z.min(p.z))
                    })
                    .unwrap_or(f64::INFINITY);
                m.is_finite() && low.is_finite() && low >= m - tolerance
            }
            _ => false,
        })
        .collect()
}

/// The edges whose projections form the asset's outline against the sky: the four top
/// edges of its box, or every exterior edge of its rough polygons.
fn outline_edges(r: &RoughGeometry) -> Box<dyn Iterator<Item = [DVec3; 2]> + '_> {
    match &r.obb {
        Some(b) => Box::new(b.top_edges().into_iter()),
        None => Box::new(r.polygons.iter().flat_map(|p| {
            let n = p.exterior().len();
            (0..n).filter_map(move |k| {
                let a = *p.exterior().get(k)?;
                let b = *p.exterior().get((k + 1) % n)?;
                Some([a, b])
            })
        })),
    }
}

/// Sky-ray directions hashed into a voxel grid on the unit sphere, for "is any sky ray
/// within `threshold` of this arc" queries.
struct SkyIndex {
    threshold: f64,
    cos_threshold: f64,
    voxel: f64,
    cells: HashMap<(i32, i32, i32), Vec<DVec3>>,
}

impl SkyIndex {
    fn new(sky: &[DVec3], threshold: f64) -> Self {
        // Arc samples are at most `threshold` apart, so a ray within `threshold` of the arc
        // is within 1.5 x threshold (chord: less) of a sample: one voxel of that size
        // around the sample's voxel covers it.
        let voxel = 1.5 * 2.0 * (threshold / 2.0).sin() + 1e-9;
        let mut cells: HashMap<(i32, i32, i32), Vec<DVec3>> = HashMap::new();
        for &d in sky {
            cells.entry(key(d, voxel)).or_default().push(d);
        }
        SkyIndex {
            threshold,
            cos_threshold: threshold.cos(),
            voxel,
            cells,
        }
    }

    /// Whether a sky ray lies within the threshold of the projection of segment `e` seen
    /// from `origin`.
    fn near_segment(&self, origin: DVec3, e: [DVec3; 2]) -> bool {
        if self.cells.is_empty() {
            return false;
        }
        let (Some(a), Some(b)) = (
            (e[0] - origin).try_normalize(),
            (e[1] - origin).try_normalize(),
        ) else {
            return false;
        };
        let angle = a.dot(b).clamp(-1.0, 1.0).acos();
        let steps = ((angle / self.threshold).ceil() as usize).clamp(1, 100_000);
        let axis = a.cross(b).try_normalize();
        for k in 0..=steps {
            let s = slerp(a, b, angle, k as f64 / steps as f64);
            let (i, j, l) = key(s, self.voxel);
            for di in -1..=1 {
                for dj in -1..=1 {
                    for dl in -1..=1 {
                        let Some(v) = self.cells.get(&(i + di, j + dj, l + dl)) else {
                            continue;
                        };
                        if v.iter().any(|&p| self.arc_near(p, a, b, axis)) {
                            return true;
                        }
                    }
                }
            }
        }
        false
    }

    /// Angular distance of `p` to the arc `a`-`b` (unit vectors, `axis` their normalised
    /// cross product, `None` for (anti)parallel ends) at most the threshold.
    fn arc_near(&self, p: DVec3, a: DVec3, b: DVec3, axis: Option<DVec3>) -> bool {
        if p.dot(a) >= self.cos_threshold || p.dot(b) >= self.cos_threshold {
            return true;
        }
        let Some(n) = axis else { return false };
        let off = p.dot(n);
        let q = p - off * n;
        // Inside the arc's wedge: the foot point lies between a and b.
        if a.cross(q).dot(n) >= 0.0 && q.cross(b).dot(n) >= 0.0 {
            off.abs().clamp(0.0, 1.0).asin() <= self.threshold
        } else {
            false
        }
    }
}

fn key(d: DVec3, voxel: f64) -> (i32, i32, i32) {
    (
        (d.x / voxel).floor() as i32,
        (d.y / voxel).floor() as i32,
        (d.z / voxel).floor() as i32,
    )
}

fn slerp(a: DVec3, b: DVec3, angle: f64, t: f64) -> DVec3 {
    if angle < 1e-9 {
        return a;
    }
    let s = angle.sin();
    if s.abs() < 1e-12 {
        // Antipodal ends: the arc is not defined; stay on the straight chord.
        return (a * (1.0 - t) + b * t).try_normalize().unwrap_or(a);
    }
    (a * ((1.0 - t) * angle).sin() + b * (t * angle).sin()) / s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lod::rough::{rough_model, RoughOptions};
    use crate::model::{Asset, LodGeometry, Polygon};

    /// The box's faces: top first, then bottom and the four sides.
    fn boxed(x0: f64, y0: f64, z0: f64, x1: f64, y1: f64, z1: f64) -> Vec<Polygon> {
        crate::model::synth::boxes::box_faces([x0, y0, z0, x1, y1, z1])
            .into_iter()
            .map(|r| Polygon::new(r.into_iter().map(DVec3::from_array).collect()))
            .collect()
    }

    fn asset(kind: AssetKind, id: &str, building: Option<usize>, polys: Vec<Polygon>) -> Asset {
        Asset {
            building,
            ..Asset::new(
                kind,
                Some(id),
                kind.as_str(),
                vec![LodGeometry {
                    lod: 3,
                    polygons: polys,
                    ..Default::default()
                }],
            )
        }
    }

    fn building() -> crate::model::Building {
        crate::model::Building {
            id: Some("B".into()),
            is_part: false,
            parent: None,
            span: 0..0,
            line: 1,
            assets: vec![],
            geometries: vec![],
            file: 0,
        }
    }

    /// A building 20 m east of the POI: walls up to 10 m, flat roof at 10 m, a chimney on
    /// the roof at the far side (hidden) and one at the near edge (skyline).
    fn scene_model() -> CityModel {
        let mut m = CityModel::default();
        m.buildings.push(building());
        let all = boxed(20.0, -20.0, 0.0, 40.0, 20.0, 10.0);
        // Faces: top (the roof), bottom (dropped), four walls.
        let (roof, walls) = (all[..1].to_vec(), all[2..].to_vec());
        m.assets.push(asset(AssetKind::Roof, "roof", Some(0), roof));
        m.assets
            .push(asset(AssetKind::Wall, "walls", Some(0), walls));
        // Far chimney: 1 m tall at the back edge, hidden below the sight line over the
        // near roof edge (slope 10/20 = 0.5 -> at x = 39 the line is at 19.5 m).
        m.assets.push(asset(
            AssetKind::Installation,
            "far_chimney",
            Some(0),
            boxed(38.0, -0.5, 10.0, 39.0, 0.5, 11.0),
        ));
        // Near chimney: 3 m tall, right at the near edge: against the sky.
        m.assets.push(asset(
            AssetKind::Installation,
            "near_chimney",
            Some(0),
            boxed(20.5, -1.0, 10.0, 22.5, 1.0, 13.0),
        ));
        m
    }

    /// A POI `id` at 1.5 m above the street at the origin of the test scenes.
    fn street_poi(id: &str, normal: Option<DVec3>) -> Poi {
        Poi {
            id: id.into(),
            position: DVec3::new(0.0, 0.0, 1.5),
            normal,
        }
    }

    fn run(m: &CityModel, poi: Poi, rays: usize) -> Selection {
        let rough = rough_model(m, &RoughOptions::default());
        let scene = crate::lod::scene::rough_scene(&rough);
        select(
            m,
            &rough,
            &scene,
            &[poi],
            &SelectOptions {
                rays,
                ..Default::default()
            },
        )
        .unwrap()
    }

    #[test]
    fn levels_from_the_street() {
        let m = scene_model();
        let poi = street_poi("p", None);
        let s = run(&m, poi, 20_000);
        assert_eq!(
            s.levels[0], 0,
            "a flat roof is edge-on from below: never hit"
        );
        assert_eq!(
            s.levels[1], 1,
            "walls are hit; their top edge is the skyline"
        );
        assert_eq!(s.levels[2], 0, "far chimney is hidden behind the roof edge");
        assert_eq!(s.levels[3], 2, "near chimney stands against the sky");
        assert!(s.roof_asset[2] && s.roof_asset[3] && !s.roof_asset[1]);
        assert_eq!(s.level_counts(), [2, 1, 1]);
    }

    #[test]
    fn pitched_roof_ridge_is_the_skyline() {
        // Gable roof: eaves at 10 m (x = 20 and 40), ridge at 16 m (x = 30), along y.
        let p = |x, y, z| DVec3::new(x, y, z);
        let mut m = CityModel::default();
        m.buildings.push(building());
        let near = Polygon::new(vec![
            p(20.0, -20.0, 10.0),
            p(20.0, 20.0, 10.0),
            p(30.0, 20.0, 16.0),
            p(30.0, -20.0, 16.0),
        ]);
        let far = Polygon::new(vec![
            p(30.0, -20.0, 16.0),
            p(30.0, 20.0, 16.0),
            p(40.0, 20.0, 10.0),
            p(40.0, -20.0, 10.0),
        ]);
        m.assets
            .push(asset(AssetKind::Roof, "near", Some(0), vec![near]));
        m.assets
            .push(asset(AssetKind::Roof, "far", Some(0), vec![far]));
        let walls = boxed(20.0, -20.0, 0.0, 40.0, 20.0, 10.0)[2..].to_vec();
        m.assets
            .push(asset(AssetKind::Wall, "walls", Some(0), walls));
        let poi = street_poi("street", None);
        let s = run(&m, poi, 20_000);
        assert!(s.hits[0] > 0);
        assert_eq!(s.levels[0], 2, "the near slope's ridge is the skyline");
        assert_eq!(s.levels[1], 0, "the far slope is behind the ridge");
        assert_eq!(s.levels[2], 1);
    }

    #[test]
    fn normal_restricts_the_bundle() {
        let m = scene_model();
        // Facing west, away from the building: nothing is hit.
        let poi = street_poi("w", Some(DVec3::NEG_X));
        let s = run(&m, poi, 5_000);
        assert_eq!(s.levels, vec![0, 0, 0, 0]);
        assert!(s.pois[0].rays > 2_000 && s.pois[0].rays < 3_000);
        assert_eq!(s.pois[0].sky_rays, s.pois[0].rays);
    }

    #[test]
    fn thread_count_does_not_change_levels() {
        let m = scene_model();
        let poi = street_poi("p", None);
        let a = run(&m, poi.clone(), 10_000);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let b = pool.install(|| run(&m, poi, 10_000));
        assert_eq!(a.levels, b.levels);
        assert_eq!(a.hits, b.hits);
    }

    #[test]
    fn bad_options_are_errors() {
        let m = scene_model();
        let rough = rough_model(&m, &RoughOptions::default());
        let scene = crate::lod::scene::rough_scene(&rough);
        let poi = Poi {
            id: "p".into(),
            position: DVec3::new(0.0, 0.0, f64::NAN),
            normal: None,
        };
        let o = SelectOptions::default();
        assert!(matches!(
            select(&m, &rough, &scene, &[poi], &o),
            Err(SelectError::Poi(_))
        ));
        let o = SelectOptions {
            threshold_deg: Some(-1.0),
            ..Default::default()
        };
        assert!(matches!(
            select(&m, &rough, &scene, &[], &o),
            Err(SelectError::Threshold(_))
        ));
        assert!(matches!(
            select(&m, &rough[..1], &scene, &[], &SelectOptions::default()),
            Err(SelectError::RoughMismatch { .. })
        ));
    }

    #[test]
    fn arc_distance() {
        let idx = SkyIndex::new(&[DVec3::new(0.0, 0.02, 1.0).normalize()], 0.03);
        let o = DVec3::ZERO;
        // Segment along x at z = 1: the sky ray is 0.02 rad off its middle.
        assert!(idx.near_segment(o, [DVec3::new(-1.0, 0.0, 1.0), DVec3::new(1.0, 0.0, 1.0)]));
        // Far from the segment's ends and off its arc.
        assert!(!idx.near_segment(o, [DVec3::new(0.5, 0.0, 1.0), DVec3::new(1.0, 0.0, 1.0)]));
        let idx = SkyIndex::new(&[DVec3::new(0.0, 0.05, 1.0).normalize()], 0.03);
        assert!(!idx.near_segment(o, [DVec3::new(-1.0, 0.0, 1.0), DVec3::new(1.0, 0.0, 1.0)]));
    }

    /// The rough model's safety net: a POI between the two walls of a gate-like object lies inside
    /// the object's box but outside its geometry: the object goes to level 2. A POI inside
    /// a closed box-shaped object (both its box and its geometry hold it) does not promote it.
    #[test]
    fn poi_inside_the_box_but_outside_the_geometry_promotes_to_level_2() {
        let wall = |x: f64| {
            Polygon::new(vec![
                DVec3::new(x, -5.0, 0.0),
                DVec3::new(x, 5.0, 0.0),
                DVec3::new(x, 5.0, 10.0),
                DVec3::new(x, -5.0, 10.0),
            ])
        };
        let mut m = CityModel::default();
        m.assets.push(asset(
            AssetKind::Other,
            "gate",
            None,
            vec![wall(-5.0), wall(5.0)],
        ));
        let poi = street_poi("between", None);
        let rough = rough_model(&m, &RoughOptions::default());
        assert!(rough[0].obb.is_some_and(|b| b.contains(poi.position, 0.0)));
        assert!(rough_holds_poi_full_not(
            &m.assets[0],
            &rough[0],
            poi.position
        ));
        let sel = run(&m, poi.clone(), 2_000);
        assert!(sel.hits[0] > 0);
        assert!(!sel.roof_asset[0]);
        assert_eq!(sel.levels, vec![2]);

        // The same object closed into a box: the POI is inside both; level 1.
        let mut closed = CityModel::default();
        closed.assets.push(asset(
            AssetKind::Other,
            "cube",
            None,
            boxed(-5.0, -5.0, 0.0, 5.0, 5.0, 10.0),
        ));
        let rough = rough_model(&closed, &RoughOptions::default());
        assert!(!rough_holds_poi_full_not(
            &closed.assets[0],
            &rough[0],
            poi.position
        ));
        assert_eq!(run(&closed, poi, 2_000).levels, vec![1]);
    }
}
