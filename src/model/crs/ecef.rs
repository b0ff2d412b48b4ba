//! A model's points on the WGS 84 ellipsoid: earth-centred, earth-fixed coordinates
//! (EPSG:4978), what 3D Tiles places content with.
//!
//! The horizontal position goes to latitude and longitude by [`LatLon`] (the pure-Rust
//! conversions of [`super::Builtin`], prepared once: UTM zones, geographic CRSs on GRS 1980 /
//! WGS 84, the projected CRSs of `proj4rs`), or with feature `proj` by PROJ where those do
//! not reach. The height is taken as ellipsoidal, in metres (feet converted): no geoid model
//! is applied, so a model in orthometric heights (most are) sits the geoid's undulation below
//! its true place (about 47 m in Germany, 37 m in Japan; −106 m to +85 m on Earth), and on a
//! globe without terrain (the ellipsoid) it stands at its height above sea level.
//!
//! # Example
//! ```
//! use glam::DVec3;
//! use skylod::model::crs::{Crs, ToEcef};
//! let to = ToEcef::new(&Crs::epsg(25832)).unwrap();
//! // pyproj (EPSG:25832 → 4979 → 4978): (4,128,489.594, 833,130.993, 4,774,223.722)
//! let p = to.ecef(DVec3::new(677_000.0, 5_405_000.0, 370.0)).unwrap();
//! assert!((p - DVec3::new(4_128_489.594, 833_130.993, 4_774_223.722)).length() < 0.01, "{p}");
//! ```

use super::convert::{CrsError, LatLon};
use super::geodesy::geodetic_to_ecef;
use super::parse::{Crs, CrsKind, Ellipsoid};
use glam::DVec3;

/// The conversion of a CRS's points to ECEF (see the module docs).
#[derive(Debug)]
pub struct ToEcef {
    by: By,
    /// Metres per unit of the heights.
    vertical: f64,
}

#[derive(Debug)]
enum By {
    Builtin(LatLon),
    #[cfg(feature = "proj")]
    Proj(Crs),
}

impl ToEcef {
    /// The conversion of `crs`'s points.
    ///
    /// # Errors
    /// [`CrsError::NotConvertible`] for a CRS this build cannot place on the globe (an
    /// unknown name; without feature `proj`, a CRS outside [`super::Builtin`]'s).
    pub fn new(crs: &Crs) -> Result<ToEcef, CrsError> {
        let not = || CrsError::NotConvertible {
            from: crs.to_string(),
            to: "EPSG:4978 (ECEF)".into(),
        };
        if matches!(crs.kind, CrsKind::Unknown) {
            return Err(not());
        }
        let by = match LatLon::new(crs) {
            Ok(l) => By::Builtin(l),
            #[cfg(feature = "proj")]
            Err(CrsError::NotConvertible { .. }) if crs.epsg.is_some() => By::Proj(crs.clone()),
            Err(_) => return Err(not()),
        };
        Ok(ToEcef {
            by,
            vertical: crs.vertical_metres_per_unit,
        })
    }

    /// Latitude, longitude (degrees) and height (m) of `p`.
    ///
    /// # Errors
    /// [`CrsError::OutOfRange`] (or PROJ's error) for a point the conversion does not cover.
    pub fn geodetic(&self, p: DVec3) -> Result<(f64, f64, f64), CrsError> {
        let (lat, lon) = match &self.by {
            By::Builtin(l) => l.of(p)?,
            #[cfg(feature = "proj")]
            By::Proj(crs) => {
                use super::PointTransform;
                let q = super::build_transform().position(crs, &Crs::epsg(4326), p)?;
                (q.x, q.y)
            }
        };
        Ok((lat, lon, p.z * self.vertical))
    }

    /// ECEF coordinates (m) of `p`.
    ///
    /// # Errors
    /// As [`ToEcef::geodetic`].
    pub fn ecef(&self, p: DVec3) -> Result<DVec3, CrsError> {
        let (lat, lon, h) = self.geodetic(p)?;
        Ok(geodetic_to_ecef(
            Ellipsoid::WGS84,
            lat.to_radians(),
            lon.to_radians(),
            h,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geographic_and_unknown() {
        let to = ToEcef::new(&Crs::epsg(4326)).unwrap();
        let p = to.ecef(DVec3::new(0.0, 0.0, 10.0)).unwrap();
        assert!((p - DVec3::new(6_378_147.0, 0.0, 0.0)).length() < 1e-6);
        let north = to.ecef(DVec3::new(90.0, 0.0, 0.0)).unwrap();
        assert!((north.z - 6_356_752.314).abs() < 1e-3 && north.x.abs() < 1e-6);
        assert!(ToEcef::new(&Crs::parse("")).is_err());
        assert!(to.ecef(DVec3::new(95.0, 0.0, 0.0)).is_err());
    }
}
