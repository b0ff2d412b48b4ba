//! POIs that see no sky: inside a closed building solid (a POI typed at the wrong height or
//! on the wrong side of a wall), or with every ray of the bundle blocked. Their SVF of 0 is
//! "correct" for the geometry and wrong for the user, so they are flagged: a warning naming
//! the POI and the building, and a flag per POI in the JSON outputs and the report.
//!
//! Inside a solid means that rays in every direction of the whole sphere (not only the
//! hemisphere the bundle covers) hit something; the building named is the one most of them
//! hit.
//!
//! # Example
//! ```
//! use glam::DVec3;
//! use skylod::poi::checks::{poi_flags, PoiFlag};
//! use skylod::poi::Poi;
//! use skylod::synth::boxes::{boxes_citygml, BoxBuilding};
//! let b = BoxBuilding { id: "B".into(), min: [0.0, 0.0], max: [10.0, 10.0], height: 10.0,
//!     installations: vec![] };
//! let xml = boxes_citygml(&[b], [0.0, 0.0, 0.0]);
//! let m = skylod::citygml::read::read_bytes(xml.as_bytes(), "b.gml").unwrap();
//! let scene = skylod::lod::scene::full_scene(&m);
//! let inside = Poi { id: "in".into(), position: DVec3::new(5.0, 5.0, 5.0), normal: None };
//! let flags = poi_flags(&scene, &m, &inside, None);
//! assert_eq!(flags, vec![PoiFlag::InsideBuilding { building: Some("B".into()) }]);
//! let outside = Poi { id: "out".into(), position: DVec3::new(-5.0, 5.0, 1.0), normal: None };
//! assert!(poi_flags(&scene, &m, &outside, Some(4000)).is_empty());
//! ```

use crate::model::CityModel;
use crate::model::Poi;
use crate::model::POI_OFFSET;
use crate::trace::Scene;
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
}

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

/// The flags of `poi` against `scene` (tagged with asset indices of `model`).
/// `sky_rays`: how many rays of its hemisphere bundle reached the sky, when known.
pub fn poi_flags(
    scene: &Scene,
    model: &CityModel,
    poi: &Poi,
    sky_rays: Option<usize>,
) -> Vec<PoiFlag> {
    let origin = poi.ray_origin();
    let mut counts: Vec<(Owner, usize)> = Vec::new();
    let mut enclosed = !scene.is_empty();
    for dir in fibonacci_sphere(PROBE_RAYS) {
        let Some(hit) = scene.first_hit(origin, dir, POI_OFFSET, f64::INFINITY) else {
            enclosed = false;
            break;
        };
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
    if enclosed {
        let building = counts
            .iter()
            .max_by_key(|(_, c)| *c)
            .and_then(|(o, _)| o.id(model));
        return vec![PoiFlag::InsideBuilding { building }];
    }
    if sky_rays == Some(0) {
        return vec![PoiFlag::NoSky];
    }
    Vec::new()
}
