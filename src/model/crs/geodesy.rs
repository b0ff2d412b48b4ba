//! Ellipsoid maths for the local frames: geodetic ⇄ ECEF ⇄ east-north-up, in f64.
//!
//! Geodetic → ECEF is the closed form; ECEF → geodetic iterates Bowring's latitude formula
//! until it moves less than 1e-14 rad (three or four rounds near the surface; sub-nanometre).
//!
//! # Example
//! ```
//! use glam::DVec3;
//! use skylod::model::crs::{Ellipsoid, Enu};
//! let enu = Enu::new(Ellipsoid::GRS80, 35.54_f64.to_radians(), 139.777_f64.to_radians(), 10.0);
//! // 0.001 degree of latitude north of the origin is 110.95 m north (pyproj's geodesic:
//! // 110.9505 m), and a little lower (the Earth curves away: ~1 mm at this distance).
//! let p = enu.to_local(35.541_f64.to_radians(), 139.777_f64.to_radians(), 10.0);
//! assert!((p.y - 110.95).abs() < 0.01 && p.x.abs() < 1e-6 && p.z < 0.0 && p.z > -0.01);
//! let (lat, lon, h) = enu.to_geodetic(p);
//! assert!((lat.to_degrees() - 35.541).abs() < 1e-12 && (h - 10.0).abs() < 1e-6);
//! # let _ = lon;
//! ```

use super::parse::Ellipsoid;
use glam::{DMat3, DVec3};

/// ECEF coordinates (m) of latitude, longitude (radians) and ellipsoidal height (m).
pub fn geodetic_to_ecef(e: Ellipsoid, lat: f64, lon: f64, h: f64) -> DVec3 {
    let e2 = e.e2();
    let (sl, cl) = lat.sin_cos();
    let n = e.a / (1.0 - e2 * sl * sl).sqrt();
    let (so, co) = lon.sin_cos();
    DVec3::new(
        (n + h) * cl * co,
        (n + h) * cl * so,
        (n * (1.0 - e2) + h) * sl,
    )
}

/// Latitude, longitude (radians) and ellipsoidal height (m) of an ECEF point.
pub fn ecef_to_geodetic(e: Ellipsoid, p: DVec3) -> (f64, f64, f64) {
    let e2 = e.e2();
    let lon = p.y.atan2(p.x);
    let r = (p.x * p.x + p.y * p.y).sqrt();
    let mut lat = p.z.atan2(r * (1.0 - e2));
    let mut h = 0.0;
    for _ in 0..20 {
        let sl = lat.sin();
        let n = e.a / (1.0 - e2 * sl * sl).sqrt();
        h = if lat.cos().abs() > 1e-3 {
            r / lat.cos() - n
        } else {
            p.z / sl - n * (1.0 - e2)
        };
        let next = p.z.atan2(r * (1.0 - e2 * n / (n + h)));
        let done = (next - lat).abs() < 1e-14;
        lat = next;
        if done {
            break;
        }
    }
    (lat, lon, h)
}

/// A local east-north-up frame tangent to the ellipsoid at an origin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Enu {
    ellipsoid: Ellipsoid,
    origin: DVec3,
    /// Rows: east, north, up unit vectors in ECEF.
    rot: DMat3,
}

impl Enu {
    /// The frame at latitude, longitude (radians) and height `h` (m).
    pub fn new(ellipsoid: Ellipsoid, lat: f64, lon: f64, h: f64) -> Enu {
        let (sl, cl) = lat.sin_cos();
        let (so, co) = lon.sin_cos();
        let east = DVec3::new(-so, co, 0.0);
        let north = DVec3::new(-sl * co, -sl * so, cl);
        let up = DVec3::new(cl * co, cl * so, sl);
        Enu {
            ellipsoid,
            origin: geodetic_to_ecef(ellipsoid, lat, lon, h),
            // columns east, north, up: the transpose maps ECEF offsets to ENU.
            rot: DMat3::from_cols(east, north, up).transpose(),
        }
    }

    /// Local east, north, up (m) of a geodetic point (radians, m).
    pub fn to_local(&self, lat: f64, lon: f64, h: f64) -> DVec3 {
        self.rot * (geodetic_to_ecef(self.ellipsoid, lat, lon, h) - self.origin)
    }

    /// Geodetic latitude, longitude (radians) and height (m) of a local point.
    pub fn to_geodetic(&self, p: DVec3) -> (f64, f64, f64) {
        ecef_to_geodetic(self.ellipsoid, self.origin + self.rot.transpose() * p)
    }

    /// Local east, north, up (m) of an ECEF point.
    pub fn from_ecef(&self, p: DVec3) -> DVec3 {
        self.rot * (p - self.origin)
    }

    /// ECEF coordinates of a local point.
    pub fn to_ecef(&self, p: DVec3) -> DVec3 {
        self.origin + self.rot.transpose() * p
    }

    /// The frame as a matrix from local coordinates to ECEF (columns east, north, up and the
    /// origin): a 3D Tiles tile's `transform`.
    pub fn to_ecef_matrix(&self) -> glam::DMat4 {
        let r = self.rot.transpose();
        glam::DMat4::from_cols(
            r.x_axis.extend(0.0),
            r.y_axis.extend(0.0),
            r.z_axis.extend(0.0),
            self.origin.extend(1.0),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips() {
        let e = Ellipsoid::GRS80;
        for (lat, lon, h) in [
            (35.54, 139.777, 12.5),
            (-33.9, 18.4, 0.0),
            (89.9999, 10.0, 100.0),
            (0.0, -179.9, -30.0),
        ] {
            let p = geodetic_to_ecef(e, f64::to_radians(lat), f64::to_radians(lon), h);
            let (a, o, hh) = ecef_to_geodetic(e, p);
            assert!((a.to_degrees() - lat).abs() < 1e-11, "{lat}");
            assert!((o.to_degrees() - lon).abs() < 1e-11, "{lon}");
            assert!((hh - h).abs() < 1e-6, "{h} {hh}");
        }
    }

    #[test]
    fn ecef_known_point() {
        // Equator, Greenwich meridian: (a + h, 0, 0); the pole: (0, 0, b + h).
        let e = Ellipsoid::WGS84;
        let p = geodetic_to_ecef(e, 0.0, 0.0, 10.0);
        assert!((p - DVec3::new(6_378_147.0, 0.0, 0.0)).length() < 1e-6);
        let b = e.a * (1.0 - e.f());
        let q = geodetic_to_ecef(e, std::f64::consts::FRAC_PI_2, 0.0, 0.0);
        assert!((q.z - b).abs() < 1e-6 && q.x.abs() < 1e-6);
    }

    #[test]
    fn enu_axes_and_distances() {
        let e = Ellipsoid::GRS80;
        let (lat, lon) = (35.54_f64.to_radians(), 139.777_f64.to_radians());
        let f = Enu::new(e, lat, lon, 5.0);
        assert!(f.to_local(lat, lon, 5.0).length() < 1e-6);
        // 10 m up is +z.
        assert!((f.to_local(lat, lon, 15.0) - DVec3::new(0.0, 0.0, 10.0)).length() < 1e-6);
        // A small step east: x grows by N cos(lat) dlon.
        let n = e.a / (1.0 - e.e2() * lat.sin().powi(2)).sqrt();
        let d = 1e-6;
        let p = f.to_local(lat, lon + d, 5.0);
        assert!((p.x - (n + 5.0) * lat.cos() * d).abs() < 1e-6, "{p}");
        // Round trip.
        let q = DVec3::new(-250.0, 410.0, 33.0);
        let (a, o, h) = f.to_geodetic(q);
        assert!((f.to_local(a, o, h) - q).length() < 1e-7);
    }
}
