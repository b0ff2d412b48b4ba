//! Coordinate reference systems and the local metric frame tracing works in.
//!
//! * `parse`: `srsName` (every spelling CityGML files use) → [`Crs`] with its kind
//!   (projected metres, projected feet, geographic with axis order and ellipsoid, unknown).
//! * `frame`: [`LocalFrame`], source coordinates ⇄ a local east-north-up metric frame
//!   (identity for projected metres, a scale for feet, ellipsoidal ENU for degrees).
//! * `geodesy`: geodetic ⇄ ECEF ⇄ ENU on an ellipsoid (pure Rust, no PROJ).
//! * `ecef`: [`ToEcef`], a model's points in ECEF (EPSG:4978), for 3D Tiles.
//! * `convert`: [`PointTransform`], points between CRSs (POIs in `--poi-crs`, the sun's
//!   site); [`Builtin`] is the default build's, [`build_transform`] the build's best.
//! * `name`: [`CrsName`], a CRS by its EPSG codes (read by [`Crs::parse`]), for PROJ and
//!   `skylod reproject`.
//! * `proj` (feature `proj`): what PROJ says of a CRS, and `Reprojector`, PROJ in the axis
//!   order of CityGML files.
//! * `proj_transform` (feature `proj`): `ProjTransform`, [`Builtin`] first, then PROJ.
//! * `feet`: the EPSG projected CRSs in US survey feet and international feet.
//! * `site`: site latitude/longitude from a CRS name for the sun.
//!
//! # Example: trace a PLATEAU (EPSG:6697, latitude, longitude, metres) POI in metres
//! ```
//! use glam::DVec3;
//! use skylod::model::crs::{Builtin, Crs, LocalFrame, PointTransform};
//! use skylod::model::Bbox;
//! let model_crs = Crs::parse("http://www.opengis.net/def/crs/EPSG/0/6697");
//! let bbox = Bbox { min: DVec3::new(35.538, 139.775, 2.0), max: DVec3::new(35.542, 139.779, 20.0) };
//! let (frame, _) = LocalFrame::new(&model_crs, &bbox);
//! // A POI given in WGS 84 (lat, lon): in the model's CRS, then in the frame.
//! let p = Builtin.position(&Crs::epsg(4326), &model_crs, DVec3::new(35.540, 139.777, 1.5)).unwrap();
//! let local = frame.to_local(p);
//! assert!(local.truncate().length() < 1e-6 && (local.z - (1.5 - 11.0)).abs() < 1e-3);
//! ```

pub(crate) mod convert;
pub(crate) mod ecef;
pub(crate) mod feet;
pub(crate) mod frame;
pub(crate) mod geodesy;
pub(crate) mod name;
pub(crate) mod parse;
#[cfg(feature = "proj")]
pub(crate) mod proj;
#[cfg(feature = "proj")]
pub(crate) mod proj_transform;
pub(crate) mod site;
pub use convert::proj4_definition;
pub use feet::{foot_codes, US_SURVEY_FOOT};
pub use geodesy::{ecef_to_geodetic, geodetic_to_ecef, Enu};
pub use parse::{GEOGRAPHIC, PROJECTED_METRES};
#[cfg(feature = "proj")]
pub use proj::crs_info;

pub use convert::{build_transform, site_lat_lon, Builtin, CrsError, LatLon, PointTransform};
pub use ecef::ToEcef;
pub use frame::{FrameWarning, LocalFrame};
pub use name::CrsName;
pub use parse::{same_crs, srs_key, Crs, CrsKind, Ellipsoid};
#[cfg(feature = "proj")]
pub use proj_transform::ProjTransform;
pub use site::{box_site, lat_lon, model_site, utm_zone, ModelSite, NoSite};

/// The CRS of a model: `override_crs` (`--source-crs`) when given, otherwise the first
/// `srsName` of its files (an empty name when none has one, i.e. unknown).
pub fn model_crs(model: &crate::model::CityModel, override_crs: Option<&Crs>) -> Crs {
    if let Some(c) = override_crs {
        return c.clone();
    }
    Crs::parse(
        model
            .files
            .iter()
            .find_map(|f| f.srs_name.as_deref())
            .unwrap_or(""),
    )
}
