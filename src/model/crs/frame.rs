//! The local metric frame every tracing command works in, and its way back to the input's CRS.
//!
//! * Projected CRSs in metres (and unknown CRSs, with a warning): the identity; the scene
//!   shifts to its own origin in f32 as before ([`crate::solar::trace`]).
//! * Projected CRSs in feet: `x`, `y` times the foot (US survey foot 1200/3937 m or
//!   international foot 0.3048 m), `z` times the unit of the heights
//!   ([`Crs::vertical_metres_per_unit`]: the vertical CRS of a compound name, otherwise the
//!   horizontal unit, as in New York City's EPSG:2263 models).
//! * Geographic CRSs: east, north, up in metres at the centre of the model's box (ellipsoidal
//!   maths, [`super::geodesy`]). Heights are used as ellipsoidal heights: orthometric heights
//!   (PLATEAU's JGD2011 vertical) differ by the geoid undulation, which is constant over a
//!   city block to millimetres, so the scene is only shifted vertically, never bent.
//!
//! Normals given with POIs follow the axes of their CRS (for latitude-first CRSs:
//! north, east, up) and are mapped with the inverse transpose of the frame's linear part.
//! Geometry computed in the local frame is brought back with [`LocalFrame::to_source_rounded`]
//! (rough geometry: `crate::lod::rough::rough_to_source`) so that written CityGML stays in the
//! input's CRS and axis order.
//!
//! # Example
//! ```
//! use glam::DVec3;
//! use skylod::model::crs::{Crs, LocalFrame};
//! use skylod::model::Bbox;
//! let crs = Crs::parse("http://www.opengis.net/def/crs/EPSG/0/6697");
//! let bbox = Bbox { min: DVec3::new(35.538, 139.775, 2.0), max: DVec3::new(35.542, 139.779, 20.0) };
//! let (frame, warning) = LocalFrame::new(&crs, &bbox);
//! assert!(warning.is_none());
//! let p = frame.to_local(DVec3::new(35.541, 139.777, 11.0)); // 0.001 deg north of the centre
//! assert!((p.y - 110.95).abs() < 0.01 && p.x.abs() < 1e-6);
//! let back = frame.to_source(p);
//! assert!((back - DVec3::new(35.541, 139.777, 11.0)).abs().max_element() < 1e-9);
//! ```

use super::geodesy::Enu;
use super::parse::{Crs, CrsKind};
use crate::model::Poi;
use crate::model::{Bbox, CityModel};
use glam::DVec3;
use std::borrow::Cow;
use std::fmt;

/// How source coordinates map to the local metric frame.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Identity,
    Scale { h: f64, v: f64 },
    Enu { enu: Enu, lat_first: bool },
}

/// A map from a CRS's coordinates to a local right-handed metric frame (x east, y north,
/// z up, metres) and back. See the module docs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalFrame {
    kind: Kind,
}

/// Why a model is traced as if its coordinates were metres, or traced with another axis
/// order than its CRS says. The library returns it; the binary prints it.
#[derive(Debug, Clone, PartialEq)]
pub enum FrameWarning {
    /// No `srsName` in the input and none given.
    NoCrs,
    /// A CRS skylod does not know.
    UnknownCrs(String),
    /// A geographic CRS whose coordinates are not degrees (|latitude| > 90 either way).
    NotDegrees(String),
    /// A latitude-first CRS whose coordinates only make sense longitude first (or the
    /// reverse): traced with the axes swapped.
    AxesSwapped(String),
}

impl fmt::Display for FrameWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FrameWarning::NoCrs => f.write_str(
                "the input names no CRS (srsName): coordinates are taken as metres (give the source CRS)",
            ),
            FrameWarning::UnknownCrs(n) => write!(
                f,
                "CRS {n:?} is not one skylod knows: coordinates are taken as metres (give the source CRS, EPSG:n)"
            ),
            FrameWarning::NotDegrees(n) => write!(
                f,
                "CRS {n:?} is geographic but the coordinates are not degrees: taken as metres (give the source CRS)"
            ),
            FrameWarning::AxesSwapped(n) => write!(
                f,
                "CRS {n:?}: the coordinates are in the other axis order (longitude/latitude swapped); traced as they are"
            ),
        }
    }
}

impl LocalFrame {
    /// The identity (projected metres).
    pub const IDENTITY: LocalFrame = LocalFrame {
        kind: Kind::Identity,
    };

    /// The frame for a model in `crs` whose coordinates span `bbox` (geographic frames are
    /// centred on the box), and a warning when the coordinates are taken as they are.
    pub fn new(crs: &Crs, bbox: &Bbox) -> (LocalFrame, Option<FrameWarning>) {
        match crs.kind {
            CrsKind::Unknown if crs.name.is_empty() => (Self::IDENTITY, Some(FrameWarning::NoCrs)),
            CrsKind::Unknown => (
                Self::IDENTITY,
                Some(FrameWarning::UnknownCrs(crs.name.clone())),
            ),
            CrsKind::Projected { metres_per_unit } => {
                let v = crs.vertical_metres_per_unit;
                if metres_per_unit == 1.0 && v == 1.0 {
                    (Self::IDENTITY, None)
                } else {
                    (
                        LocalFrame {
                            kind: Kind::Scale {
                                h: metres_per_unit,
                                v,
                            },
                        },
                        None,
                    )
                }
            }
            CrsKind::Geographic {
                ellipsoid,
                lat_first,
            } => {
                let c = if bbox.is_empty() {
                    DVec3::ZERO
                } else {
                    bbox.center()
                };
                let lat_ok = |v: f64| v.abs() <= 90.0;
                let lon_ok = |v: f64| v.abs() <= 360.0;
                let fits = |lat_first: bool| {
                    bbox.is_empty()
                        || [bbox.min, bbox.max].iter().all(|p| {
                            let (a, o) = if lat_first { (p.x, p.y) } else { (p.y, p.x) };
                            lat_ok(a) && lon_ok(o)
                        })
                };
                let (order, warning) = if fits(lat_first) {
                    (lat_first, None)
                } else if fits(!lat_first) {
                    (
                        !lat_first,
                        Some(FrameWarning::AxesSwapped(crs.name.clone())),
                    )
                } else {
                    return (
                        Self::IDENTITY,
                        Some(FrameWarning::NotDegrees(crs.name.clone())),
                    );
                };
                let (lat, lon) = if order { (c.x, c.y) } else { (c.y, c.x) };
                let enu = Enu::new(ellipsoid, lat.to_radians(), lon.to_radians(), c.z);
                (
                    LocalFrame {
                        kind: Kind::Enu {
                            enu,
                            lat_first: order,
                        },
                    },
                    warning,
                )
            }
        }
    }

    /// True for the identity (nothing to convert).
    pub fn is_identity(&self) -> bool {
        self.kind == Kind::Identity
    }

    /// One line saying what the frame does, for progress messages.
    pub fn describe(&self) -> String {
        match self.kind {
            Kind::Identity => "projected metres (no conversion)".into(),
            Kind::Scale { h, v } => {
                format!("feet to metres (x, y x {h:.10}; z x {v:.10})")
            }
            Kind::Enu { enu, .. } => {
                let (lat, lon, h) = enu.to_geodetic(DVec3::ZERO);
                format!(
                    "geographic degrees to a local east-north-up frame (metres) at lat {:.6}, lon {:.6}, h {h:.2}",
                    lat.to_degrees(),
                    lon.to_degrees()
                )
            }
        }
    }

    /// A source point in the local frame.
    pub fn to_local(&self, p: DVec3) -> DVec3 {
        match self.kind {
            Kind::Identity => p,
            Kind::Scale { h, v } => DVec3::new(p.x * h, p.y * h, p.z * v),
            Kind::Enu { enu, lat_first } => {
                let (lat, lon) = if lat_first { (p.x, p.y) } else { (p.y, p.x) };
                enu.to_local(lat.to_radians(), lon.to_radians(), p.z)
            }
        }
    }

    /// A local point back in source coordinates.
    pub fn to_source(&self, p: DVec3) -> DVec3 {
        match self.kind {
            Kind::Identity => p,
            Kind::Scale { h, v } => DVec3::new(p.x / h, p.y / h, p.z / v),
            Kind::Enu { enu, lat_first } => {
                let (lat, lon, z) = enu.to_geodetic(p);
                let (lat, lon) = (lat.to_degrees(), lon.to_degrees());
                if lat_first {
                    DVec3::new(lat, lon, z)
                } else {
                    DVec3::new(lon, lat, z)
                }
            }
        }
    }

    /// A unit normal given along the source axes, in the local frame (unit).
    pub fn normal_to_local(&self, n: DVec3) -> DVec3 {
        match self.kind {
            Kind::Identity => n,
            Kind::Scale { h, v } => DVec3::new(n.x / h, n.y / h, n.z / v).normalize_or_zero(),
            Kind::Enu { lat_first, .. } => {
                if lat_first {
                    DVec3::new(n.y, n.x, n.z)
                } else {
                    n
                }
            }
        }
    }

    /// A unit normal of the local frame along the source axes (inverse of
    /// [`LocalFrame::normal_to_local`]).
    pub fn normal_to_source(&self, n: DVec3) -> DVec3 {
        match self.kind {
            Kind::Identity => n,
            Kind::Scale { h, v } => DVec3::new(n.x * h, n.y * h, n.z * v).normalize_or_zero(),
            Kind::Enu { lat_first, .. } => {
                if lat_first {
                    DVec3::new(n.y, n.x, n.z)
                } else {
                    n
                }
            }
        }
    }

    /// A POI (in source coordinates and axes) in the local frame.
    pub fn poi_to_local(&self, p: &Poi) -> Poi {
        Poi {
            id: p.id.clone(),
            position: self.to_local(p.position),
            normal: p.normal.map(|n| self.normal_to_local(n)),
        }
    }

    /// The model with every asset and building polygon in the local frame; borrowed
    /// unchanged for the identity. Envelopes and file records stay as read (they are only
    /// used to write, which works on the source model).
    pub fn model_to_local<'a>(&self, m: &'a CityModel) -> Cow<'a, CityModel> {
        if self.is_identity() {
            return Cow::Borrowed(m);
        }
        let mut out = m.clone();
        let geoms = out
            .assets
            .iter_mut()
            .flat_map(|a| a.geometries.iter_mut())
            .chain(
                out.buildings
                    .iter_mut()
                    .flat_map(|b| b.geometries.iter_mut()),
            );
        for g in geoms {
            for poly in &mut g.polygons {
                for q in poly.points_mut().iter_mut() {
                    *q = self.to_local(*q);
                }
            }
        }
        Cow::Owned(out)
    }

    /// A point of the local frame back in the source CRS, rounded to what the CRS's unit
    /// makes meaningful (1e-10 degree, 1e-6 metre or foot): what a writer puts in a file.
    pub fn to_source_rounded(&self, p: DVec3) -> DVec3 {
        self.round(self.to_source(p))
    }

    fn round(&self, p: DVec3) -> DVec3 {
        let r = |x: f64, step: f64| (x / step).round() * step;
        match self.kind {
            Kind::Identity => p,
            Kind::Scale { .. } => DVec3::new(r(p.x, 1e-6), r(p.y, 1e-6), r(p.z, 1e-6)),
            Kind::Enu { .. } => DVec3::new(r(p.x, 1e-10), r(p.y, 1e-10), r(p.z, 1e-6)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::crs::feet::US_SURVEY_FOOT;

    fn bbox(a: [f64; 3], b: [f64; 3]) -> Bbox {
        Bbox {
            min: DVec3::from(a),
            max: DVec3::from(b),
        }
    }

    #[test]
    fn kinds_and_warnings() {
        let b = bbox([430000.0, 4581000.0, 0.0], [430100.0, 4581100.0, 30.0]);
        let (f, w) = LocalFrame::new(&Crs::parse("EPSG:25831"), &b);
        assert!(f.is_identity() && w.is_none());
        let (f, w) = LocalFrame::new(&Crs::parse("#x"), &b);
        assert!(f.is_identity() && matches!(w, Some(FrameWarning::UnknownCrs(_))));
        let (f, w) = LocalFrame::new(&Crs::parse(""), &b);
        assert!(f.is_identity() && w == Some(FrameWarning::NoCrs));
        // A UTM model mislabelled as EPSG:4326.
        let (f, w) = LocalFrame::new(&Crs::parse("EPSG:4326"), &b);
        assert!(f.is_identity() && matches!(w, Some(FrameWarning::NotDegrees(_))));
        // lon, lat data labelled lat, lon.
        let b = bbox([139.77, 35.53, 0.0], [139.78, 35.54, 30.0]);
        let (f, w) = LocalFrame::new(&Crs::parse("EPSG:6697"), &b);
        assert!(matches!(w, Some(FrameWarning::AxesSwapped(_))));
        let p = f.to_local(DVec3::new(139.775, 35.535, 15.0));
        assert!(p.length() < 1e-6, "{p}");
    }

    #[test]
    fn feet_scale_and_back() {
        let (f, _) = LocalFrame::new(&Crs::parse("EPSG:2263"), &Bbox::EMPTY);
        let p = DVec3::new(987_654.0, 212_345.0, 100.0);
        let l = f.to_local(p);
        assert!((l.z - 100.0 * US_SURVEY_FOOT).abs() < 1e-12);
        assert!((l.x - 987_654.0 * 1200.0 / 3937.0).abs() < 1e-6);
        assert!((f.to_source(l) - p).length() < 1e-6);
        // Heights in metres when the compound names a metre vertical CRS.
        let (f, _) = LocalFrame::new(
            &Crs::parse("urn:ogc:def:crs,crs:EPSG::2263,crs:EPSG::5703"),
            &Bbox::EMPTY,
        );
        assert_eq!(f.to_local(p).z, 100.0);
        // Normals: inverse transpose, so a 45-degree roof in (ft, ft, m) stays a plane normal.
        let n = f.normal_to_local(DVec3::new(1.0, 0.0, 1.0).normalize());
        let t = DVec3::new(1.0, 0.0, -1.0); // a tangent in source units
        let tl = f.to_local(t) - f.to_local(DVec3::ZERO);
        assert!(n.dot(tl).abs() < 1e-12);
        assert!((f.normal_to_source(n) - DVec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-12);
    }

    #[test]
    fn enu_axes_follow_the_crs_order() {
        let b = bbox([35.538, 139.775, 2.0], [35.542, 139.779, 20.0]);
        let (f, w) = LocalFrame::new(&Crs::parse("EPSG:6697"), &b);
        assert!(w.is_none());
        // East of the centre is +x.
        let p = f.to_local(DVec3::new(35.540, 139.778, 11.0));
        assert!(p.x > 90.0 && p.y.abs() < 0.01, "{p}");
        // A north-facing normal in (lat, lon, up) is +y.
        assert_eq!(f.normal_to_local(DVec3::X), DVec3::Y);
        // The same model in CRS84 order gives the same local point.
        let b2 = bbox([139.775, 35.538, 2.0], [139.779, 35.542, 20.0]);
        let (g, w) = LocalFrame::new(&Crs::parse("urn:ogc:def:crs:OGC:1.3:CRS84"), &b2);
        assert!(w.is_none());
        let q = g.to_local(DVec3::new(139.778, 35.540, 11.0));
        assert!((p - q).length() < 1e-9);
    }
}
