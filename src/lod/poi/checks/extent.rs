//! POIs far outside the scene: almost always coordinates in another CRS (latitude and
//! longitude against a projected model) or swapped axes. Tracing them gives SVF 1 and an
//! empty model with exit 0, so they are refused with a hint.
//!
//! # Example
//! ```
//! use glam::DVec3;
//! use skylod::lod::poi::check_pois_near;
//! use skylod::model::Bbox;
//! use skylod::lod::poi::Poi;
//! let scene = Bbox::of_points(&[DVec3::new(430000.0, 4581000.0, 0.0), DVec3::new(430500.0, 4581500.0, 30.0)]);
//! let near = Poi { id: "a".into(), position: DVec3::new(430100.0, 4581100.0, 2.0), normal: None };
//! assert!(check_pois_near(&scene, &[near], 1000.0).is_ok());
//! let latlon = Poi { id: "b".into(), position: DVec3::new(41.38, 2.16, 2.0), normal: None };
//! let e = check_pois_near(&scene, &[latlon], 1000.0).unwrap_err();
//! let skylod::lod::poi::TrustError::PoiOutside(far) = e else { panic!("{e}") };
//! assert_eq!(far.pois[0].id, "b");
//! assert_eq!(far.pois[0].hint, Some(skylod::lod::poi::OutsideHint::Degrees));
//! ```

use super::TrustError;
use crate::model::Bbox;
use crate::model::Poi;
use glam::DVec3;
use std::fmt::Write as _;

/// Default margin (m) around the scene's bounding box within which a POI is accepted: a
/// kilometre, far more than any street or square around a modelled block, far less than the
/// error of a wrong CRS or swapped axes (tens of kilometres and more).
pub const DEFAULT_POI_MARGIN: f64 = 1000.0;

/// Distance from `p` to the box (0 inside).
pub fn distance_to_box(b: &Bbox, p: DVec3) -> f64 {
    distance(b, p)
}

fn distance(b: &Bbox, p: DVec3) -> f64 {
    let d = (b.min - p).max(p - b.max).max(DVec3::ZERO);
    d.length()
}

/// Refuse POIs farther than `margin` from the scene's box, naming each (up to five) with its
/// distance and a hint: swapped axes when swapping x and y brings it inside, `--poi-crs
/// EPSG:4326` when it looks like degrees. An empty scene accepts everything (nothing to trace).
/// For a scene and POIs in a metric CRS; see `check_pois_near_in_frame` otherwise.
pub fn check_pois_near(scene: &Bbox, pois: &[Poi], margin: f64) -> Result<(), TrustError> {
    check_pois_near_in_frame(scene, pois, scene, pois, margin)
}

/// [`check_pois_near`] for a scene traced in a local metric frame: distances from `local`
/// POIs to the `scene` box (both in the frame, metres), while the message shows the POIs and
/// the box as the user gave them (`shown`, `shown_scene`: the model's CRS, e.g. degrees).
pub fn check_pois_near_in_frame(
    scene: &Bbox,
    local: &[Poi],
    shown_scene: &Bbox,
    shown: &[Poi],
    margin: f64,
) -> Result<(), TrustError> {
    if scene.is_empty() {
        return Ok(());
    }
    let far: Vec<(&Poi, &Poi, f64)> = local
        .iter()
        .zip(shown)
        .map(|(l, s)| (l, s, distance(scene, l.position)))
        .filter(|(_, _, d)| *d > margin)
        .collect();
    if far.is_empty() {
        return Ok(());
    }
    let pois = far
        .iter()
        .map(|(l, p, d)| {
            let l = l.position;
            let q = p.position;
            let hint = if distance(scene, DVec3::new(l.y, l.x, l.z)) <= margin {
                Some(OutsideHint::SwappedAxes)
            } else if q.x.abs() <= 180.0 && q.y.abs() <= 180.0 {
                Some(OutsideHint::Degrees)
            } else {
                None
            };
            FarPoi {
                id: p.id.clone(),
                position: q,
                distance_m: *d,
                hint,
            }
        })
        .collect();
    Err(TrustError::PoiOutside(Box::new(PoisOutside {
        pois,
        total: local.len(),
        margin,
        scene: *shown_scene,
    })))
}

/// Why a POI far outside the scene probably is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum OutsideHint {
    /// Swapping x and y brings it within the margin.
    SwappedAxes,
    /// Its x and y look like degrees (both within ±180).
    Degrees,
}

/// One POI farther than the margin outside the scene.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct FarPoi {
    /// The POI's id.
    pub id: String,
    /// Its position as given (the model's CRS).
    pub position: DVec3,
    /// Its distance (m, in the tracing frame) to the scene's bounding box.
    pub distance_m: f64,
    /// What it looks like.
    pub hint: Option<OutsideHint>,
}

/// The refusal of [`check_pois_near_in_frame`], as data: which POIs, how far, the scene.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct PoisOutside {
    /// Every POI outside, in POI order.
    pub pois: Vec<FarPoi>,
    /// POIs checked.
    pub total: usize,
    /// The margin (m).
    pub margin: f64,
    /// The scene's bounding box as the user sees it (the model's CRS).
    pub scene: Bbox,
}

impl PoisOutside {
    /// The explanation, up to five POIs named with their distance and hint, ending in
    /// `crs_hint` (what to give for POIs in latitude/longitude).
    pub fn message(&self, crs_hint: &str) -> String {
        let b = &self.scene;
        let mut message = format!(
            "{} of {} POI(s) lie more than {} m outside the scene (x {:.1}..{:.1}, y {:.1}..{:.1}, z {:.1}..{:.1}):",
            self.pois.len(),
            self.total,
            self.margin,
            b.min.x,
            b.max.x,
            b.min.y,
            b.max.y,
            b.min.z,
            b.max.z
        );
        for p in self.pois.iter().take(5) {
            let q = p.position;
            let _ = write!(
                message,
                " {} at ({}, {}, {}) is {:.0} m away",
                p.id, q.x, q.y, q.z, p.distance_m
            );
            message.push_str(match p.hint {
                Some(OutsideHint::SwappedAxes) => " (x and y look swapped);",
                Some(OutsideHint::Degrees) => " (looks like degrees);",
                None => ";",
            });
        }
        if self.pois.len() > 5 {
            let _ = write!(message, " and {} more;", self.pois.len() - 5);
        }
        let _ = write!(
            message,
            " POIs are in the model's CRS and axis order: check the CRS ({crs_hint} for \
             latitude/longitude) and the order of x and y"
        );
        message
    }
}

impl std::fmt::Display for PoisOutside {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message("POIs given in EPSG:4326"))
    }
}

/// Refuse POIs given in a latitude-first geographic CRS (`--poi-crs EPSG:4326`, named
/// `crs`) whose first two coordinates look exchanged: `near(p)` (the point `p` in `crs`
/// converted lies within the margin of the scene) is false as given and true with the first
/// two coordinates swapped. `shown_scene` is the scene's box in the model's CRS, for the
/// message.
///
/// ```
/// use glam::DVec3;
/// use skylod::model::Bbox;
/// use skylod::lod::poi::check_lat_lon_order;
/// use skylod::lod::poi::Poi;
/// let scene = Bbox::of_points(&[DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 1.0, 1.0)]);
/// // a "scene" near latitude 48.77, longitude 11.42
/// let near = |p: DVec3| (p.x - 48.77).abs() < 0.01 && (p.y - 11.42).abs() < 0.01;
/// let good = Poi { id: "a".into(), position: DVec3::new(48.77, 11.42, 380.0), normal: None };
/// assert!(check_lat_lon_order("EPSG:4326", &[good], &scene, near).is_ok());
/// let swapped = Poi { id: "b".into(), position: DVec3::new(11.42, 48.77, 380.0), normal: None };
/// let e = check_lat_lon_order("EPSG:4326", &[swapped], &scene, near).unwrap_err().to_string();
/// assert!(e.contains("latitude, longitude"), "{e}");
/// ```
pub fn check_lat_lon_order(
    crs: &str,
    pois: &[Poi],
    shown_scene: &Bbox,
    near: impl Fn(DVec3) -> bool,
) -> Result<(), TrustError> {
    let swapped: Vec<&Poi> = pois
        .iter()
        .filter(|p| {
            let q = p.position;
            !near(q) && near(DVec3::new(q.y, q.x, q.z))
        })
        .collect();
    if swapped.is_empty() {
        return Ok(());
    }
    let b = shown_scene;
    let mut message = format!(
        "{} of {} POI(s) given in {crs} lie outside the model (x {:.1}..{:.1}, y {:.1}..{:.1}) \
         as latitude, longitude but inside it with the two exchanged:",
        swapped.len(),
        pois.len(),
        b.min.x,
        b.max.x,
        b.min.y,
        b.max.y,
    );
    for p in swapped.iter().take(5) {
        let q = p.position;
        let _ = write!(
            message,
            " {} (latitude {}, longitude {}: try {}, {});",
            p.id, q.x, q.y, q.y, q.x
        );
    }
    if swapped.len() > 5 {
        let _ = write!(message, " and {} more;", swapped.len() - 5);
    }
    let crs = crs.to_string();
    Err(TrustError::LatLonSwapped { message, crs })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn poi(x: f64, y: f64, z: f64) -> Poi {
        Poi {
            id: format!("p{x}"),
            position: DVec3::new(x, y, z),
            normal: None,
        }
    }

    fn scene() -> Bbox {
        Bbox::of_points(&[
            DVec3::new(678000.0, 5403800.0, 400.0),
            DVec3::new(678200.0, 5404000.0, 440.0),
        ])
    }

    #[test]
    fn margin_is_inclusive_and_three_dimensional() {
        assert!(
            check_pois_near(&scene(), &[poi(678200.0 + 999.0, 5403900.0, 420.0)], 1000.0).is_ok()
        );
        assert!(check_pois_near(
            &scene(),
            &[poi(678200.0 + 1001.0, 5403900.0, 420.0)],
            1000.0
        )
        .is_err());
        // 2 km above the city is as wrong as 2 km beside it.
        assert!(check_pois_near(&scene(), &[poi(678100.0, 5403900.0, 2500.0)], 1000.0).is_err());
    }

    #[test]
    fn swapped_axes_are_named() {
        let e = check_pois_near(&scene(), &[poi(5403900.0, 678100.0, 420.0)], 1000.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("x and y look swapped"), "{e}");
        assert!(e.contains("1 of 1 POI"), "{e}");
        assert!(e.contains("EPSG:4326 for latitude/longitude"), "{e}");
    }

    #[test]
    fn empty_scene_accepts() {
        assert!(check_pois_near(&Bbox::default(), &[poi(0.0, 0.0, 0.0)], 1.0).is_ok());
    }
}
