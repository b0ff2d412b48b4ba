//! PROJ (feature `proj`, bundled build): what PROJ says of an EPSG CRS ([`crs_info`]) and a
//! transformation between two CRSs in the axis order of CityGML files ([`Reprojector`]):
//! geographic CRSs whose EPSG axis order is latitude first (4326, 4258, 6668, 6697, ...) are
//! read and written latitude first, as CityGML files (PLATEAU's among them) write them;
//! projected CRSs easting first, as city models write them whatever the EPSG order. Heights
//! are passed through unchanged: the horizontal CRS is transformed, and a change of vertical
//! datum would need geoid grids, which the bundled build has none of (PROJ itself falls back
//! to the same "ballpark" identity then). Rewriting a whole document is
//! [`crate::export::transform::citygml::reproject::reproject_file`]'s.

use super::name::CrsName;
use glam::DVec3;

/// PROJ could not create a transformation or describe a CRS.
#[derive(Debug, Clone, thiserror::Error)]
#[error("PROJ: {0}")]
pub struct ProjError(pub String);

/// How PROJ describes a CRS: geographic or not, axis order, dimension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CrsInfo {
    /// A geographic (latitude/longitude) CRS.
    pub geographic: bool,
    /// Its EPSG axis order starts with latitude (north).
    pub lat_first: bool,
    /// Number of axes of the horizontal part (2, or 3 for a 3-D CRS such as EPSG:4979).
    pub axes: usize,
    /// EPSG code of the vertical part of a compound CRS (EPSG:6697 = 6668 + 6695).
    pub vertical: Option<u32>,
}

/// The EPSG code in the `id` of a PROJJSON object.
fn epsg_id(v: &serde_json::Value) -> Option<u32> {
    let id = &v["id"];
    (id["authority"] == "EPSG")
        .then(|| id["code"].as_u64())
        .flatten()
        .and_then(|c| u32::try_from(c).ok())
}

/// Describe `EPSG:code` through PROJ's PROJJSON.
pub fn crs_info(code: u32) -> Result<CrsInfo, ProjError> {
    let def = format!("EPSG:{code}");
    let p = proj::Proj::new(&def).map_err(|e| ProjError(format!("{def}: {e}")))?;
    let json = p
        .to_projjson(Some(false), None, None)
        .map_err(|e| ProjError(format!("{def}: {e}")))?;
    let v: serde_json::Value =
        serde_json::from_str(&json).map_err(|e| ProjError(format!("{def}: PROJJSON: {e}")))?;
    // A compound CRS: its first component is the horizontal one.
    let h = if v["type"] == "CompoundCRS" {
        &v["components"][0]
    } else {
        &v
    };
    let ty = h["type"].as_str().unwrap_or("");
    let axes = h["coordinate_system"]["axis"]
        .as_array()
        .map_or(0, Vec::len);
    if axes == 0 {
        return Err(ProjError(format!("{def}: a {ty} without coordinate axes")));
    }
    let geographic = ty == "GeographicCRS"
        || (ty == "GeodeticCRS" && h["coordinate_system"]["subtype"] == "ellipsoidal");
    let lat_first = h["coordinate_system"]["axis"][0]["direction"] == "north";
    // The vertical part of a compound CRS: PROJJSON names it, and gives its id only when
    // it differs from the compound's; PROJ finds a CRS by its name in its database.
    let vertical = if v["type"] == "CompoundCRS" {
        let part = &v["components"][1];
        match epsg_id(part) {
            Some(c) => Some(c),
            None => part["name"].as_str().and_then(|name| {
                let p = proj::Proj::new(name).ok()?;
                let json = p.to_projjson(Some(false), None, None).ok()?;
                epsg_id(&serde_json::from_str(&json).ok()?)
            }),
        }
    } else {
        None
    };
    Ok(CrsInfo {
        geographic,
        lat_first,
        axes,
        vertical,
    })
}

/// A PROJ transformation between two CRSs in the axis order of CityGML files (module
/// docs), heights passed through.
pub struct Reprojector {
    proj: proj::Proj,
    swap_in: bool,
    swap_out: bool,
    /// The source CRS.
    pub source: CrsName,
    /// The target CRS as written into `srsName` (with the source's vertical CRS kept
    /// when the target is 2-D).
    pub target: CrsName,
    /// What the caller should know (heights passed into an ellipsoidal 3-D CRS).
    pub warnings: Vec<String>,
}

impl std::fmt::Debug for Reprojector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Reprojector")
            .field("source", &self.source)
            .field("target", &self.target)
            .field("swap_in", &self.swap_in)
            .field("swap_out", &self.swap_out)
            .finish()
    }
}

impl Reprojector {
    /// The transformation from `source` to `target` (horizontal parts).
    pub fn new(source: CrsName, target: CrsName) -> Result<Reprojector, ProjError> {
        let si = crs_info(source.horizontal)?;
        let ti = crs_info(target.horizontal)?;
        let (from, to) = (
            format!("EPSG:{}", source.horizontal),
            format!("EPSG:{}", target.horizontal),
        );
        let proj = proj::Proj::new_known_crs(&from, &to, None)
            .map_err(|e| ProjError(format!("{from} to {to}: {e}")))?;
        let mut warnings = Vec::new();
        let mut target = target;
        let source_vertical = source.vertical.or(si.vertical);
        if target.vertical.is_none() && ti.vertical.is_none() && ti.axes == 2 {
            target.vertical = source_vertical;
        }
        let target_vertical = target.vertical.or(ti.vertical);
        if let (Some(sv), Some(tv)) = (source_vertical, target_vertical) {
            if sv != tv {
                warnings.push(format!(
                    "heights are kept as they are: values in EPSG:{sv} are written as \
                     EPSG:{tv} (no geoid grids in this build)"
                ));
            }
        }
        if ti.axes == 3 && ti.geographic && target.vertical.is_none() {
            warnings.push(format!(
                "heights are kept as they are: EPSG:{} has ellipsoidal heights, and {} \
                 (no geoid grid in this build; PROJ's own fallback does the same)",
                target.horizontal,
                match source_vertical {
                    Some(v) => format!("the source's heights are in EPSG:{v}"),
                    None => "the source names no vertical CRS".to_string(),
                }
            ));
        }
        Ok(Reprojector {
            proj,
            swap_in: si.geographic && si.lat_first,
            swap_out: ti.geographic && ti.lat_first,
            source,
            target,
            warnings,
        })
    }

    /// Transform points in place (file axis order in and out; z unchanged).
    pub fn transform(&self, pts: &mut [DVec3]) -> Result<(), String> {
        let mut xy: Vec<(f64, f64)> = pts
            .iter()
            .map(|p| if self.swap_in { (p.y, p.x) } else { (p.x, p.y) })
            .collect();
        self.proj
            .convert_array(&mut xy)
            .map_err(|e| format!("{} to {}: {e}", self.source, self.target))?;
        for (p, (x, y)) in pts.iter_mut().zip(xy) {
            if !(x.is_finite() && y.is_finite()) {
                return Err(format!(
                    "({}, {}) has no image in {}",
                    p.x, p.y, self.target
                ));
            }
            (p.x, p.y) = if self.swap_out { (y, x) } else { (x, y) };
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_order_and_dimension_from_proj() {
        let g = crs_info(4326).unwrap();
        assert!(g.geographic && g.lat_first && g.axes == 2);
        assert_eq!(crs_info(4979).unwrap().axes, 3);
        let u = crs_info(25832).unwrap();
        assert!(!u.geographic && !u.lat_first);
        let j = crs_info(6697).unwrap();
        assert!(j.geographic && j.lat_first && j.axes == 2);
        assert_eq!(j.vertical, Some(6695));
    }

    #[test]
    fn utm_to_lat_lon_and_back() {
        let to = Reprojector::new(
            CrsName::parse("EPSG:25832+5783").unwrap(),
            CrsName::parse("EPSG:4326").unwrap(),
        )
        .unwrap();
        assert_eq!(to.target.vertical, Some(5783));
        // UTM 32N central meridian 9°E, false easting 500 km: on it, lon = 9.
        let mut p = [DVec3::new(500000.0, 5_400_000.0, 123.5)];
        to.transform(&mut p).unwrap();
        assert!((p[0].y - 9.0).abs() < 1e-9, "{p:?}"); // lat first: y is the longitude
        assert!(p[0].x > 48.0 && p[0].x < 49.0);
        assert_eq!(p[0].z, 123.5);
        let back = Reprojector::new(to.target, to.source).unwrap();
        back.transform(&mut p).unwrap();
        assert!((p[0].x - 500000.0).abs() < 1e-6 && (p[0].y - 5_400_000.0).abs() < 1e-6);
    }

    #[test]
    fn ellipsoidal_target_warns() {
        let r = Reprojector::new(
            CrsName::parse("EPSG:25832+5783").unwrap(),
            CrsName::parse("EPSG:4979").unwrap(),
        )
        .unwrap();
        assert_eq!(r.target.vertical, None);
        assert_eq!(r.warnings.len(), 1);
        // A compound target with another vertical datum: heights kept, and said so.
        let j = Reprojector::new(
            CrsName::parse("EPSG:25832+5783").unwrap(),
            CrsName::parse("EPSG:25832+7837").unwrap(),
        )
        .unwrap();
        assert!(j.warnings[0].contains("EPSG:5783"), "{:?}", j.warnings);
    }
}
