//! Points from one CRS to another: POIs given with `--poi-crs`, and the sun's site.
//!
//! [`PointTransform`] is the hook: [`Builtin`] is the pure-Rust implementation of the default
//! build; with feature `proj`, `ProjTransform` tries it first and
//! falls back to PROJ. [`build_transform`] gives the build's best one, [`site_lat_lon`] uses it.
//!
//! [`Builtin`] converts between
//! * geographic CRSs on GRS 1980 / WGS 84 (WGS 84, ETRS89, JGD2000/2011, NAD83, GDA, ...):
//!   axes reordered, no datum shift. This is EPSG's own null transformation between these
//!   datums, which PROJ and pyproj also apply when no grid is installed; JGD2011, ETRS89 and
//!   WGS 84 (G1762 and later) agree to well under a metre (ETRS89 drifts ~2.5 cm a year from
//!   WGS 84; NAD83 differs by 1-2 m);
//! * those and the UTM CRSs of [`utm_zone`] (WGS 84, ETRS89, JGD2000/2011, NAD83, GDA; the
//!   `proj4rs` crate's extended transverse Mercator, sub-millimetre across a zone).
//!
//! * every other EPSG projected CRS in metres that the pure-Rust `proj4rs` crate covers with the
//!   proj4 definition of `crs-definitions` (national grids: MGI Austria GK 31254-31259, DHDN
//!   Gauss-Krüger 31466-31469 and the AdV `DE_DHDN_3GK*` names, RD New 28992, Lambert-93 2154,
//!   the CC zones 3942-3950, NTF Lambert II étendu 27572, CH1903+ LV95 2056, ...), through
//!   WGS 84 longitude/latitude. The datum shift is the definition's `+towgs84` (3- or
//!   7-parameter Helmert), not a grid: this agrees with pyproj given the same proj4 string to
//!   well under 0.1 m (tests/it/national_crs.rs checks it), but EPSG's grid-based
//!   transformations (NTv2 BETA2007 for DHDN, RDNAPTRANS for RD New, ntf_r93 for NTF) differ
//!   from it by up to about a metre: plenty for a sun position and for POIs, not for survey
//!   work (use the `proj` build and `skylod reproject` for that).
//!
//! Heights pass through unchanged: a POI's height is taken in the model's vertical datum.
//! Anything else (State Plane feet, CRSs `crs-definitions` lacks) is
//! [`CrsError::NotConvertible`].
//!
//! # Example
//! ```
//! use glam::DVec3;
//! use skylod::model::crs::{Builtin, Crs, PointTransform};
//! // A point in WGS 84 (lat, lon) into a UTM 31N model.
//! let p = Builtin.position(&Crs::epsg(4326), &Crs::epsg(25831), DVec3::new(41.39, 2.17, 20.0)).unwrap();
//! // pyproj: (430608.497, 4582384.561).
//! assert!((p.x - 430_608.497).abs() < 0.01 && (p.y - 4_582_384.561).abs() < 0.01 && p.z == 20.0);
//! ```

use super::frame::LocalFrame;
use super::parse::{Crs, CrsKind, Ellipsoid};
use crate::model::Bbox;
use crate::model::Poi;
use glam::DVec3;

/// Errors converting between CRSs.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CrsError {
    /// This build cannot convert between the two CRSs.
    #[error("cannot convert from {from} to {to} in this build (geographic CRSs on GRS 1980/WGS 84, UTM zones and the EPSG projected CRSs in metres of proj4rs/crs-definitions only; other CRSs need the `proj` feature)")]
    NotConvertible {
        /// Source CRS.
        from: String,
        /// Target CRS.
        to: String,
    },
    /// The point is outside the range of the conversion.
    #[error("point ({x}, {y}) is out of the range of {crs}")]
    OutOfRange {
        /// CRS whose range is exceeded.
        crs: String,
        /// First coordinate.
        x: f64,
        /// Second coordinate.
        y: f64,
    },
    /// PROJ could not convert between the two CRSs (feature `proj`).
    #[error("cannot convert from {from} to {to}: {message}")]
    Proj {
        /// Source CRS.
        from: String,
        /// Target CRS.
        to: String,
        /// PROJ's message.
        message: String,
    },
    /// A CRS argument that names no CRS skylod knows.
    #[error("{0:?} is not a CRS skylod knows (give EPSG:n)")]
    Unknown(String),
}

/// Converts points between CRSs (axis order of each CRS as [`Crs`] describes it).
pub trait PointTransform: Sync {
    /// `p` in `from` to `to`.
    fn position(&self, from: &Crs, to: &Crs, p: DVec3) -> Result<DVec3, CrsError>;

    /// A unit normal at `p` given along `from`'s axes, along `to`'s axes: the direction is
    /// followed for one metre in `from`'s local metric frame at `p` and converted, so that
    /// grid convergence and axis order are accounted for.
    fn normal(&self, from: &Crs, to: &Crs, p: DVec3, n: DVec3) -> Result<DVec3, CrsError> {
        let at = |c: &Crs, q: DVec3| LocalFrame::new(c, &Bbox { min: q, max: q }).0;
        let ff = at(from, p);
        let q = self.position(from, to, p)?;
        let ft = at(to, q);
        let d = ff.normal_to_local(n);
        let p2 = ff.to_source(ff.to_local(p) + d);
        let q2 = self.position(from, to, p2)?;
        let dt = (ft.to_local(q2) - ft.to_local(q)).normalize_or_zero();
        Ok(ft.normal_to_source(dt))
    }

    /// POIs given in `from` in the CRS `to` (ids kept).
    fn pois(&self, from: &Crs, to: &Crs, pois: &[Poi]) -> Result<Vec<Poi>, CrsError> {
        pois.iter()
            .map(|p| {
                Ok(Poi {
                    id: p.id.clone(),
                    position: self.position(from, to, p.position)?,
                    normal: match p.normal {
                        Some(n) => Some(self.normal(from, to, p.position, n)?),
                        None => None,
                    },
                })
            })
            .collect()
    }
}

/// The pure-Rust conversions of the default build (see the module docs).
#[derive(Debug, Clone, Copy, Default)]
pub struct Builtin;

/// UTM zone, hemisphere (`true` north) and false-easting zone prefix (`4647`-style codes
/// write the zone number before the easting: 32 500 000 m) of an EPSG code.
pub fn utm_zone(code: u32) -> Option<(u8, bool, f64)> {
    let z = |c: u32, base: u32| Some(((c - base) as u8, true, 0.0));
    match code {
        32601..=32660 => z(code, 32600),
        32701..=32760 => Some(((code - 32700) as u8, false, 0.0)),
        25828..=25838 => z(code, 25800),
        3040..=3049 => z(code, 3012),
        4647 => Some((32, true, 32e6)),
        5649 => Some((31, true, 31e6)),
        5650 => Some((33, true, 33e6)),
        6688..=6692 => z(code, 6637),
        3097..=3101 => z(code, 3046),
        26901..=26923 => z(code, 26900),
        28348..=28358 => Some(((code - 28300) as u8, false, 0.0)),
        7846..=7859 => Some(((code - 7800) as u8, false, 0.0)),
        _ => None,
    }
}

/// Geographic on GRS 1980 / WGS 84: `Some(lat_first)`.
fn geographic_grs80(c: &Crs) -> Option<bool> {
    match c.kind {
        CrsKind::Geographic {
            ellipsoid,
            lat_first,
        } if ellipsoid.a == Ellipsoid::GRS80.a
            && (ellipsoid.inv_f - Ellipsoid::GRS80.inv_f).abs() < 1e-5 =>
        {
            Some(lat_first)
        }
        _ => None,
    }
}

/// Latitude, longitude (degrees) of `p` in `c`, when `c` is one of [`Builtin`]'s CRSs.
fn to_lat_lon(c: &Crs, p: DVec3) -> Result<(f64, f64), CrsError> {
    LatLon::new(c)?.of(p)
}

/// The conversion of one CRS's points to latitude and longitude, prepared once for many
/// points (a `proj4rs` definition is parsed once, not per point): [`Builtin`]'s CRSs.
#[derive(Debug)]
pub struct LatLon {
    crs: String,
    how: LatLonBy,
}

#[derive(Debug)]
enum LatLonBy {
    /// Geographic on GRS 1980 / WGS 84: axes reordered.
    Geographic { lat_first: bool },
    /// A projected CRS of `proj4rs` (a UTM zone of [`utm_zone`] among them) and WGS 84
    /// longitude/latitude; `prefix`: the zone number written before the easting.
    /// `utm`: a UTM zone, whose eastings outside 100 km to 1,000 km and northings outside
    /// 0 to 10,000 km are out of its range (as the `utm` crate held them).
    Proj4 {
        pair: Box<(proj4rs::Proj, proj4rs::Proj)>,
        prefix: f64,
        utm: bool,
    },
}

impl LatLon {
    /// The conversion of `c`'s points.
    ///
    /// # Errors
    /// [`CrsError::NotConvertible`] when `c` is not one of [`Builtin`]'s CRSs.
    pub fn new(c: &Crs) -> Result<LatLon, CrsError> {
        let how = if let Some(lat_first) = geographic_grs80(c) {
            LatLonBy::Geographic { lat_first }
        } else if let Some((pair, prefix)) = proj4_utm(c) {
            LatLonBy::Proj4 {
                pair: Box::new(pair),
                prefix,
                utm: true,
            }
        } else if let Some(pair) = proj4_projected(c) {
            LatLonBy::Proj4 {
                pair: Box::new(pair),
                prefix: 0.0,
                utm: false,
            }
        } else {
            return Err(CrsError::NotConvertible {
                from: c.to_string(),
                to: "latitude/longitude".into(),
            });
        };
        Ok(LatLon {
            crs: c.to_string(),
            how,
        })
    }

    /// Latitude and longitude (degrees) of `p`.
    ///
    /// # Errors
    /// [`CrsError::OutOfRange`] for a point the conversion does not cover.
    pub fn of(&self, p: DVec3) -> Result<(f64, f64), CrsError> {
        let out = || CrsError::OutOfRange {
            crs: self.crs.clone(),
            x: p.x,
            y: p.y,
        };
        match &self.how {
            LatLonBy::Geographic { lat_first } => {
                let (lat, lon) = if *lat_first { (p.x, p.y) } else { (p.y, p.x) };
                if lat.abs() > 90.0 || lon.abs() > 360.0 {
                    return Err(out());
                }
                Ok((lat, lon))
            }
            LatLonBy::Proj4 { pair, prefix, utm } => {
                let mut q = (p.x - prefix, p.y, 0.0);
                let in_zone =
                    (100_000.0..1_000_000.0).contains(&q.0) && (0.0..=10_000_000.0).contains(&q.1);
                if *utm && !in_zone {
                    return Err(out());
                }
                match proj4rs::transform::transform(&pair.0, &pair.1, &mut q) {
                    Ok(()) if q.0.is_finite() && q.1.is_finite() => {
                        Ok((q.1.to_degrees(), q.0.to_degrees()))
                    }
                    _ => Err(out()),
                }
            }
        }
    }
}

/// The `proj4rs` projection of a projected CRS in metres with an EPSG code that
/// `crs-definitions` knows (and that is not a longitude/latitude definition). Not with
/// feature `proj`: PROJ converts these then, with the operation pyproj picks (e.g. a regional
/// ED50 shift instead of the definition's `+towgs84`: 4 m apart in Barcelona).
fn proj4_projected(c: &Crs) -> Option<(proj4rs::Proj, proj4rs::Proj)> {
    if cfg!(feature = "proj") {
        return None;
    }
    let CrsKind::Projected { metres_per_unit } = c.kind else {
        return None;
    };
    if metres_per_unit != 1.0 {
        return None;
    }
    let code = u16::try_from(c.epsg?).ok()?;
    let def = proj4_definition(code)?;
    let proj = proj4rs::Proj::from_proj_string(def).ok()?;
    (!proj.is_latlong()).then_some((proj, wgs84()?))
}

/// The `proj4rs` projection of a UTM CRS of [`utm_zone`] (Poder/Engsager's extended
/// transverse Mercator, sub-millimetre across the zone: the `utm` crate's series drift 5 cm
/// at 180 km from the central meridian) with WGS 84 longitude/latitude, and the zone prefix of
/// its eastings. GRS 1980 and WGS 84 differ by 0.1 mm in the semi-minor axis: one ellipsoid
/// serves both.
fn proj4_utm(c: &Crs) -> Option<((proj4rs::Proj, proj4rs::Proj), f64)> {
    let (zone, north, prefix) = c.epsg.and_then(utm_zone)?;
    let south = if north { "" } else { " +south" };
    let def = format!("+proj=utm +zone={zone}{south} +datum=WGS84 +units=m +no_defs");
    let proj = proj4rs::Proj::from_proj_string(&def).ok()?;
    Some(((proj, wgs84()?), prefix))
}

/// The proj4 definition `crs-definitions` gives an EPSG code (metres only: a definition in
/// other units is left to the `proj` build).
pub fn proj4_definition(code: u16) -> Option<&'static str> {
    let def = crs_definitions::from_code(code)?.proj4;
    let metres = !def.contains("+units=") || def.contains("+units=m ") || def.ends_with("+units=m");
    (metres && !def.contains("+to_meter")).then_some(def)
}

/// WGS 84 longitude/latitude (radians), the hub of the `proj4rs` conversions.
fn wgs84() -> Option<proj4rs::Proj> {
    proj4rs::Proj::from_proj_string("+proj=longlat +datum=WGS84 +no_defs").ok()
}

/// `p`'s horizontal position in `c` from latitude, longitude (degrees).
fn from_lat_lon(c: &Crs, lat: f64, lon: f64, z: f64) -> Result<DVec3, CrsError> {
    if let Some(lat_first) = geographic_grs80(c) {
        return Ok(if lat_first {
            DVec3::new(lat, lon, z)
        } else {
            DVec3::new(lon, lat, z)
        });
    }
    let utm = proj4_utm(c);
    let prefix = utm.as_ref().map_or(0.0, |u| u.1);
    if let Some((proj, wgs84)) = utm.map(|u| u.0).or_else(|| proj4_projected(c)) {
        let mut q = (lon.to_radians(), lat.to_radians(), 0.0);
        return match proj4rs::transform::transform(&wgs84, &proj, &mut q) {
            Ok(()) if q.0.is_finite() && q.1.is_finite() => Ok(DVec3::new(q.0 + prefix, q.1, z)),
            _ => Err(CrsError::OutOfRange {
                crs: c.to_string(),
                x: lon,
                y: lat,
            }),
        };
    }
    Err(CrsError::NotConvertible {
        from: "latitude/longitude".into(),
        to: c.to_string(),
    })
}

impl PointTransform for Builtin {
    fn position(&self, from: &Crs, to: &Crs, p: DVec3) -> Result<DVec3, CrsError> {
        if from == to {
            return Ok(p);
        }
        let not = || CrsError::NotConvertible {
            from: from.to_string(),
            to: to.to_string(),
        };
        let (lat, lon) = to_lat_lon(from, p).map_err(|e| match e {
            CrsError::NotConvertible { .. } => not(),
            e => e,
        })?;
        from_lat_lon(to, lat, lon, p.z).map_err(|e| match e {
            CrsError::NotConvertible { .. } => not(),
            e => e,
        })
    }
}

/// The most capable [`PointTransform`] of this build: [`Builtin`] in the default build,
/// `ProjTransform` (builtin first, then PROJ) with feature `proj`.
#[cfg(not(feature = "proj"))]
pub fn build_transform() -> Builtin {
    Builtin
}

/// The most capable [`PointTransform`] of this build: [`Builtin`] in the default build,
/// `ProjTransform` (builtin first, then PROJ) with feature `proj`.
#[cfg(feature = "proj")]
pub fn build_transform() -> super::ProjTransform {
    super::ProjTransform
}

/// Site latitude and longitude (degrees) of the point `p` of a model in `crs`, when this
/// build can convert it: geographic on GRS 1980/WGS 84, their UTM zones and the projected
/// CRSs of `proj4rs` in the default build, and with feature `proj` any CRS PROJ converts to WGS 84 (EPSG:4326).
pub fn site_lat_lon(crs: &Crs, p: DVec3) -> Option<(f64, f64)> {
    let (lat, lon) = match to_lat_lon(crs, p) {
        Ok(ll) => ll,
        #[cfg(feature = "proj")]
        Err(CrsError::NotConvertible { .. }) => {
            let q = build_transform().position(crs, &Crs::epsg(4326), p).ok()?;
            (q.x, q.y)
        }
        Err(_) => return None,
    };
    let lon = if lon > 180.0 { lon - 360.0 } else { lon };
    Some((lat, lon))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geographic_reorders_axes_only() {
        let p = DVec3::new(35.54, 139.777, 7.0);
        let crs84 = Crs::parse("urn:ogc:def:crs:OGC:1.3:CRS84");
        let q = Builtin.position(&Crs::epsg(4326), &crs84, p).unwrap();
        assert_eq!(q, DVec3::new(139.777, 35.54, 7.0));
        assert_eq!(
            Builtin
                .position(&Crs::epsg(4326), &Crs::epsg(6697), p)
                .unwrap(),
            p
        );
        // Normal north (lat axis) -> lon-first CRS: second axis.
        let n = Builtin
            .normal(&Crs::epsg(4326), &crs84, p, DVec3::X)
            .unwrap();
        assert!((n - DVec3::Y).length() < 1e-6, "{n}");
    }

    #[test]
    fn utm_round_trip_and_convergence() {
        let wgs = Crs::epsg(4326);
        let utm = Crs::epsg(32631);
        let p = DVec3::new(41.39, 2.17, 0.0);
        let q = Builtin.position(&wgs, &utm, p).unwrap();
        let back = Builtin.position(&utm, &wgs, q).unwrap();
        assert!((back - p).abs().max_element() < 1e-7, "{back}");
        // West of the central meridian (3 E) meridians lean towards it going north: true
        // north points east of grid north by the convergence |atan(tan(lon - lon0) sin(lat))|,
        // about 0.55 degrees.
        let n = Builtin.normal(&wgs, &utm, p, DVec3::X).unwrap();
        let gamma = n.x.atan2(n.y).to_degrees();
        let expect = ((2.17f64 - 3.0).to_radians().tan() * 41.39f64.to_radians().sin())
            .atan()
            .to_degrees();
        assert!((gamma + expect).abs() < 0.01, "{gamma} vs {expect}");
        // Zone-prefixed eastings.
        let z = Builtin
            .position(&wgs, &Crs::epsg(4647), DVec3::new(49.1, 8.43, 0.0))
            .unwrap();
        assert!(z.x > 32_400_000.0 && z.x < 32_500_000.0, "{z}");
    }

    #[test]
    fn not_convertible() {
        // (from, to, point, refused as not convertible): NAD83 / New York Long Island
        // (ftUS); the Tokyo datum (Bessel: hundreds of metres from JGD2011), not done without
        // PROJ; a latitude of 135 degrees.
        let cases = [
            (4326, 2263, DVec3::new(40.7, -74.0, 0.0), true),
            (4301, 6668, DVec3::new(35.0, 139.0, 0.0), false),
            (4326, 6697, DVec3::new(135.0, 35.0, 0.0), false),
        ];
        for (from, to, p, not_convertible) in cases {
            let e = Builtin
                .position(&Crs::epsg(from), &Crs::epsg(to), p)
                .unwrap_err();
            let refused = matches!(e, CrsError::NotConvertible { .. });
            assert!(refused || !not_convertible, "{from} {to}: {e}");
        }
    }

    #[test]
    fn sites() {
        let (lat, lon) = site_lat_lon(&Crs::epsg(6697), DVec3::new(35.54, 139.777, 0.0)).unwrap();
        assert_eq!((lat, lon), (35.54, 139.777));
        let ny = site_lat_lon(&Crs::epsg(2263), DVec3::new(987_654.0, 212_345.0, 0.0));
        assert_eq!(ny.is_none(), cfg!(not(feature = "proj")), "{ny:?}");
        // EPSG:3044 is ETRS89 / UTM zone 32N (N-E), not 30N.
        assert_eq!(utm_zone(3044), Some((32, true, 0.0)));
        assert_eq!(utm_zone(3049), Some((37, true, 0.0)));
        assert_eq!(utm_zone(6691), Some((54, true, 0.0)));
    }
}
