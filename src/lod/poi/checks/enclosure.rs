//! POIs that see no sky: inside a closed building solid (a POI typed at the wrong height or
//! on the wrong side of a wall), or with every ray of the bundle blocked. Their SVF of 0 is
//! "correct" for the geometry and wrong for the user, so they are flagged: a warning naming
//! the POI and the building, and a flag per POI in the JSON outputs and the report.
//!
//! [`poi_flags_around`] adds two flags that need the POI's surroundings
//! ([`Surroundings`]): far below every building around it ([`PoiFlag::FarBelow`]) and a
//! normal into the surface it lies on ([`PoiFlag::NormalIntoSurface`]).
//!
//! Inside a solid means that rays in every direction of the whole sphere (not only the
//! hemisphere the bundle covers) hit something; the building named is the one most of them
//! hit.
//!
//! # Example
//! ```
//! use glam::DVec3;
//! use skylod::lod::poi::{PoiFlag, poi_flags};
//! use skylod::lod::poi::Poi;
//! use skylod::model::synth::{BoxBuilding, boxes_citygml};
//! let b = BoxBuilding { id: "B".into(), min: [0.0, 0.0], max: [10.0, 10.0], height: 10.0,
//!     installations: vec![] };
//! let xml = boxes_citygml(&[b], [0.0, 0.0, 0.0]);
//! let m = skylod::io::citygml::read_bytes(xml.as_bytes(), "b.gml").unwrap();
//! let scene = skylod::lod::full_scene(&m);
//! let inside = Poi { id: "in".into(), position: DVec3::new(5.0, 5.0, 5.0), normal: None };
//! let flags = poi_flags(&scene, &m, &inside, None);
//! assert_eq!(flags, vec![PoiFlag::InsideBuilding { building: Some("B".into()) }]);
//! let outside = Poi { id: "out".into(), position: DVec3::new(-5.0, 5.0, 1.0), normal: None };
//! assert!(poi_flags(&scene, &m, &outside, Some(4000)).is_empty());
//! ```

use super::surroundings::Surroundings;
use crate::model::CityModel;
use crate::model::Poi;
use crate::model::POI_OFFSET;
use crate::solar::trace::TraceScene;
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// Directions of the sphere probe (a Fibonacci lattice: near-uniform, deterministic).
const PROBE_RAYS: usize = 128;

/// Something that makes a POI's results suspect.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(tag = "flag", rename_all = "snake_case")]
pub enum PoiFlag {
    /// Every direction of the sphere is blocked: the POI is inside a closed solid.
    InsideBuilding {
        /// gml:id of the building (or of the asset, when it has no building) hit most.
        building: Option<String>,
    },
    /// Every ray of the hemisphere bundle is blocked: SVF and sun hours are 0.
    NoSky,
    /// The POI lies more than `FAR_BELOW_MARGIN` below the lowest point of every building
    /// (or other object) within `FAR_BELOW_RADIUS` horizontally: a height above ground, or
    /// in another vertical datum, given where the model wants its own heights.
    FarBelow {
        /// Metres below that lowest point (rounded down).
        below_m: u32,
    },
    /// The POI lies within `ON_SURFACE` of a polygon and its normal points to the
    /// polygon's inner side: its bundle looks into the building.
    NormalIntoSurface {
        /// gml:id of the surface (asset) the POI lies on, when it has one.
        surface: Option<String>,
        /// How the polygon's outer side was decided.
        outward_from: OutwardRule,
    },
}

/// How [`PoiFlag::NormalIntoSurface`] decides which side of a polygon is outside, in this
/// order (CityGML's rule, exterior rings counter-clockwise seen from outside, is often
/// broken, so the ring's orientation is the last resort).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum OutwardRule {
    /// The polygon belongs to a closed solid: of two points 5 cm either side of it, one is
    /// enclosed (every probe ray blocked) and the other not; outside is the open side.
    Solid,
    /// Open geometry, the POI off the plane by more than 5 mm: outside is the POI's side.
    PoiSide,
    /// Open geometry, the POI on the plane: the exterior ring's orientation (Newell normal).
    RingOrientation,
}

/// Horizontal radius (m) within which [`PoiFlag::FarBelow`] looks for buildings.
pub const FAR_BELOW_RADIUS: f64 = 100.0;
/// How far (m) below the lowest building around a POI may lie before [`PoiFlag::FarBelow`]:
/// more than a sunken yard or a ramp, less than the height of a city above its datum (a
/// height above ground given instead of an absolute one is off by tens to hundreds of metres).
pub const FAR_BELOW_MARGIN: f64 = 5.0;
/// Distance (m) to a polygon within which a POI lies on it ([`PoiFlag::NormalIntoSurface`]):
/// POIs made from surfaces sit 5 cm out.
pub const ON_SURFACE: f64 = 0.1;

impl PoiFlag {
    /// A warning line for `poi`.
    pub fn message(&self, poi: &Poi) -> String {
        match self {
            PoiFlag::InsideBuilding { building } => format!(
                "POI {} lies inside a closed solid{}: every direction is blocked, its results \
                 are 0 (check its height and the side of the wall it is on)",
                poi.id,
                building
                    .as_deref()
                    .map(|b| format!(" of building {b}"))
                    .unwrap_or_default()
            ),
            PoiFlag::NoSky => format!(
                "POI {}: every ray of the sky bundle is blocked, so its SVF and sun hours are 0",
                poi.id
            ),
            PoiFlag::FarBelow { below_m } => format!(
                "POI {} lies {below_m} m below the lowest point of every building within \
                 {FAR_BELOW_RADIUS} m: is its height above ground or in another datum? POI \
                 heights are in the model's vertical CRS",
                poi.id
            ),
            PoiFlag::NormalIntoSurface {
                surface,
                outward_from,
            } => format!(
                "POI {}: its normal points into the surface{} it lies on (outer side from {}), \
                 so its sky is the inside of the building: reverse the normal (nx, ny, nz)",
                poi.id,
                surface
                    .as_deref()
                    .map(|b| format!(" {b}"))
                    .unwrap_or_default(),
                match outward_from {
                    OutwardRule::Solid => "the closed solid",
                    OutwardRule::PoiSide => "the side the POI is on",
                    OutwardRule::RingOrientation => "the ring's orientation",
                }
            ),
        }
    }
}

fn fibonacci_sphere(n: usize) -> impl Iterator<Item = DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n).map(move |i| {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let a = golden * i as f64;
        DVec3::new(r * a.cos(), r * a.sin(), z)
    })
}

/// Who a hit belongs to: a building (or part), or an asset outside any building.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Owner {
    Building(usize),
    Asset(usize),
}

impl Owner {
    /// gml:id of the whole building (not the part), or of the asset.
    fn id(self, model: &CityModel) -> Option<String> {
        match self {
            Owner::Asset(i) => model.assets.get(i)?.id.as_deref().map(str::to_owned),
            Owner::Building(i) => {
                let mut b = model.buildings.get(i)?;
                let mut steps = 0;
                while let Some(p) = b.parent.and_then(|p| model.buildings.get(p)) {
                    b = p;
                    steps += 1;
                    if steps > model.buildings.len() {
                        break;
                    }
                }
                b.id.clone()
            }
        }
    }
}

/// Who most probe rays from `origin` hit when every direction is blocked (`None` when one
/// reaches the sky or the scene is empty).
fn enclosed(scene: &TraceScene, model: &CityModel, origin: DVec3) -> Option<Option<String>> {
    if scene.is_empty() {
        return None;
    }
    let mut counts: Vec<(Owner, usize)> = Vec::new();
    for dir in fibonacci_sphere(PROBE_RAYS) {
        let hit = scene.first_hit(origin, dir, POI_OFFSET, f64::INFINITY)?;
        let tag = hit.tag as usize;
        let owner = match model.assets.get(tag).and_then(|a| a.building) {
            Some(b) => Owner::Building(b),
            None => Owner::Asset(tag),
        };
        match counts.iter_mut().find(|(o, _)| *o == owner) {
            Some((_, c)) => *c += 1,
            None => counts.push((owner, 1)),
        }
    }
    Some(
        counts
            .iter()
            .max_by_key(|(_, c)| *c)
            .and_then(|(o, _)| o.id(model)),
    )
}

/// The inside-building and no-sky flags of `poi` against `scene` (tagged with asset indices
/// of `model`). `sky_rays`: how many rays of its hemisphere bundle reached the sky, when
/// known. The commands call `poi_flags_around`, which adds the flags that need the
/// surroundings.
pub fn poi_flags(
    scene: &TraceScene,
    model: &CityModel,
    poi: &Poi,
    sky_rays: Option<usize>,
) -> Vec<PoiFlag> {
    flags_with(scene, model, poi, sky_rays, |_| {})
}

/// The flags of `poi` in their order: inside a building (then no other), what `between`
/// adds, no sky.
fn flags_with(
    scene: &TraceScene,
    model: &CityModel,
    poi: &Poi,
    sky_rays: Option<usize>,
    between: impl FnOnce(&mut Vec<PoiFlag>),
) -> Vec<PoiFlag> {
    if let Some(building) = enclosed(scene, model, poi.ray_origin()) {
        return vec![PoiFlag::InsideBuilding { building }];
    }
    let mut flags = Vec::new();
    between(&mut flags);
    if sky_rays == Some(0) {
        flags.push(PoiFlag::NoSky);
    }
    flags
}

/// Every flag of `poi`: inside a building (judged on `scene`, which must hold the full
/// geometry around the POI: the full scene, or [`Surroundings::scene_holding`]), far below
/// the buildings around it, its normal into the surface it lies on, no sky.
pub fn poi_flags_around(
    scene: &TraceScene,
    model: &CityModel,
    around: &Surroundings,
    poi: &Poi,
    sky_rays: Option<usize>,
) -> Vec<PoiFlag> {
    flags_with(scene, model, poi, sky_rays, |flags| {
        let p = poi.position;
        if let Some(low) = around.lowest_near(p, FAR_BELOW_RADIUS) {
            if p.z < low - FAR_BELOW_MARGIN {
                flags.push(PoiFlag::FarBelow {
                    below_m: (low - p.z).floor().min(u32::MAX as f64) as u32,
                });
            }
        }
        flags.extend(normal_into_surface(scene, model, around, poi));
    })
}

/// Whether `q` (on the plane of `t` with unit normal `n`) lies in the triangle `t`.
fn in_triangle(q: DVec3, t: &[DVec3; 3], n: DVec3) -> bool {
    let eps = -1e-9;
    (0..3).all(|k| {
        let (a, b) = (t[k], t[(k + 1) % 3]);
        (b - a).cross(q - a).dot(n) >= eps * (b - a).length_squared().max(1.0)
    })
}

/// [`PoiFlag::NormalIntoSurface`] for `poi` when it has a normal and lies within
/// [`ON_SURFACE`] of a full-detail polygon (the nearest counts).
fn normal_into_surface(
    scene: &TraceScene,
    model: &CityModel,
    around: &Surroundings,
    poi: &Poi,
) -> Option<PoiFlag> {
    let n = poi.normal?.normalize_or_zero();
    if n == DVec3::ZERO {
        return None;
    }
    let p = poi.position;
    // (distance, asset, ring normal, foot, signed distance along the ring normal)
    let mut best: Option<(f64, u32, DVec3, DVec3, f64)> = None;
    let mut tris = Vec::new();
    for (i, poly) in around.polygons_at(model, p, ON_SURFACE) {
        let m = poly.newell_normal().normalize_or_zero();
        if m == DVec3::ZERO {
            continue;
        }
        tris.clear();
        crate::model::triangulate(poly, &mut tris);
        for t in &tris {
            let tn = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
            if tn == DVec3::ZERO {
                continue;
            }
            let d = (p - t[0]).dot(tn);
            let foot = p - tn * d;
            if d.abs() > ON_SURFACE || !in_triangle(foot, t, tn) {
                continue;
            }
            if best.is_none_or(|b| d.abs() < b.0) {
                best = Some((d.abs(), i, m, foot, (p - t[0]).dot(m)));
            }
        }
    }
    let (_, asset, m, foot, dm) = best?;
    let front = enclosed(scene, model, foot + m * 0.05).is_some();
    let back = enclosed(scene, model, foot - m * 0.05).is_some();
    let (outward, rule) = match (front, back) {
        (false, true) => (m, OutwardRule::Solid),
        (true, false) => (-m, OutwardRule::Solid),
        _ if dm.abs() > 0.005 => (m * dm.signum(), OutwardRule::PoiSide),
        _ => (m, OutwardRule::RingOrientation),
    };
    (n.dot(outward) < 0.0).then(|| PoiFlag::NormalIntoSurface {
        surface: model
            .assets
            .get(asset as usize)
            .and_then(|a| a.id.as_deref().map(str::to_owned)),
        outward_from: rule,
    })
}
