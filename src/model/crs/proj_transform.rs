//! [`ProjTransform`] (feature `proj`): points between any two CRSs PROJ knows, for POIs in
//! `--poi-crs` and the sun's site.
//!
//! It tries [`Builtin`] first (so every conversion the default build does gives the same
//! result with the feature on) and falls back to PROJ through
//! [`crate::model::crs::proj::Reprojector`], with its axis-order handling: geographic CRSs in their
//! EPSG order (EPSG:4326 latitude first), projected CRSs easting first. The CRS is handed to
//! PROJ by its EPSG codes ([`CrsName::from_crs`]); a CRS without one that [`Builtin`] knows
//! (OGC:CRS84) goes through EPSG:4326. Heights pass through unchanged, as with [`Builtin`].
//!
//! PROJ objects are not `Send`, so the transformations are cached per thread.
//!
//! # Example
//! ```
//! use glam::DVec3;
//! use skylod::model::crs::{Crs, PointTransform, ProjTransform};
//! // Karlsruhe in WGS 84 (lat, lon) into DHDN / 3-degree Gauss-Kruger zone 3 (Bessel datum).
//! let p = ProjTransform
//!     .position(&Crs::epsg(4326), &Crs::epsg(31467), DVec3::new(49.0, 8.4, 115.0))
//!     .unwrap();
//! assert!((p.x - 3_456_000.0).abs() < 2_000.0 && (p.y - 5_430_000.0).abs() < 2_000.0);
//! assert_eq!(p.z, 115.0);
//! ```

use super::convert::{Builtin, CrsError, PointTransform};
use super::name::CrsName;
use super::parse::Crs;
use super::proj::Reprojector;
use glam::DVec3;
use std::cell::RefCell;
use std::collections::hash_map::Entry;
use std::collections::HashMap;

/// [`Builtin`] first, then PROJ (module docs).
#[derive(Debug, Clone, Copy, Default)]
pub struct ProjTransform;

thread_local! {
    /// PROJ transformations by (source, target) horizontal EPSG codes.
    static CACHE: RefCell<HashMap<(u32, u32), Reprojector>> = RefCell::new(HashMap::new());
}

/// `p` from EPSG `from` to EPSG `to` through PROJ (file axis order, z unchanged).
fn through_proj(from: CrsName, to: CrsName, p: DVec3) -> Result<DVec3, CrsError> {
    let err = |message: String| CrsError::Proj {
        from: from.to_string(),
        to: to.to_string(),
        message,
    };
    CACHE.with(|cache| {
        let mut cache = cache.borrow_mut();
        let r = match cache.entry((from.horizontal, to.horizontal)) {
            Entry::Occupied(e) => e.into_mut(),
            Entry::Vacant(e) => {
                e.insert(Reprojector::new(from, to).map_err(|e| err(e.to_string()))?)
            }
        };
        let mut pts = [p];
        r.transform(&mut pts).map_err(err)?;
        Ok(pts[0])
    })
}

impl PointTransform for ProjTransform {
    fn position(&self, from: &Crs, to: &Crs, p: DVec3) -> Result<DVec3, CrsError> {
        match Builtin.position(from, to, p) {
            Err(CrsError::NotConvertible { .. }) => {}
            r => return r,
        }
        let wgs84 = Crs::epsg(4326);
        let wgs84_name = CrsName {
            horizontal: 4326,
            vertical: None,
        };
        // A CRS without an EPSG code: through WGS 84 with the builtin conversion.
        let (src, p) = match CrsName::from_crs(from) {
            Some(n) => (n, p),
            None => (wgs84_name, Builtin.position(from, &wgs84, p)?),
        };
        match CrsName::from_crs(to) {
            Some(dst) => through_proj(src, dst, p),
            None => {
                let q = through_proj(src, wgs84_name, p)?;
                Builtin.position(&wgs84, to, q)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_first_then_proj() {
        // Builtin's CRSs give Builtin's result exactly.
        let p = DVec3::new(41.39, 2.17, 20.0);
        let (wgs, utm) = (Crs::epsg(4326), Crs::epsg(25831));
        assert_eq!(
            ProjTransform.position(&wgs, &utm, p).unwrap(),
            Builtin.position(&wgs, &utm, p).unwrap()
        );
        // Beyond Builtin: Gauss-Kruger zone 3 and back, and OGC:CRS84 (no EPSG code).
        let gk = Crs::epsg(31467);
        let q = ProjTransform
            .position(&wgs, &gk, DVec3::new(49.0, 9.0, 3.0))
            .unwrap();
        // On the zone's central meridian (9 E): easting 3 500 000 m (± the datum shift).
        assert!((q.x - 3_500_000.0).abs() < 200.0, "{q}");
        let crs84 = Crs::parse("urn:ogc:def:crs:OGC:1.3:CRS84");
        let back = ProjTransform.position(&gk, &crs84, q).unwrap();
        assert!(
            (back - DVec3::new(9.0, 49.0, 3.0)).abs().max_element() < 1e-8,
            "{back}"
        );
        // The Helmert shift and its inverse: a round trip within a millimetre.
        let r = ProjTransform.position(&crs84, &gk, back).unwrap();
        assert!((r - q).abs().max_element() < 1e-3, "{r} {q}");
    }

    #[test]
    fn unknown_to_proj_is_an_error() {
        let e = ProjTransform
            .position(
                &Crs::epsg(4326),
                &Crs::epsg(999_999),
                DVec3::new(49.0, 9.0, 0.0),
            )
            .unwrap_err();
        assert!(matches!(e, CrsError::Proj { .. }), "{e}");
    }
}
