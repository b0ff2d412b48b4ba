//! Site latitude/longitude from a model's CRS for the sun position (see [`super::convert`]
//! for what converts; with feature `proj`, any CRS PROJ converts to WGS 84 as well). Without
//! PROJ: geographic CRSs on GRS 1980/WGS 84 directly,
//! the UTM CRSs of WGS 84, ETRS89, JGD2000/2011, NAD83 and GDA through `proj4rs`
//! (the datums differ by a metre or two at most, far below what a sun position needs), and
//! the other EPSG projected CRSs in metres through `proj4rs` (national grids: see
//! [`super::convert`]).
//!
//! Recognised UTM codes: EPSG:32601–32660 (WGS 84 north), 32701–32760 (south), 25828–25838
//! (ETRS89 28N–38N), 3040–3049 (ETRS89 28N–37N, "N-E"), 4647/5649/5650 (zone-prefixed
//! eastings), 6688–6692 and 3097–3101 (JGD2011/JGD2000 51N–55N), 26901–26923 (NAD83),
//! 28348–28358 and 7846–7859 (GDA94/GDA2020 MGA), and the AdV names
//! `urn:adv:crs:ETRS89_UTM<zone>…`, in any spelling [`Crs::parse`] reads.
//!
//! # Example
//! ```
//! use skylod::model::crs::{lat_lon, utm_zone};
//! assert_eq!(utm_zone("urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783"), Some((32, true)));
//! // Barcelona, the synthetic district's corner.
//! let (lat, lon) = lat_lon("EPSG:25831", 430000.0, 4581000.0).unwrap();
//! assert!((lat - 41.377).abs() < 0.01 && (lon - 2.162).abs() < 0.01);
//! // PLATEAU (JGD2011, latitude first): the point itself.
//! assert_eq!(lat_lon("http://www.opengis.net/def/crs/EPSG/0/6697", 35.54, 139.777), Some((35.54, 139.777)));
//! ```

use super::convert::site_lat_lon;
use super::parse::Crs;
use glam::DVec3;

/// UTM zone and hemisphere (`true` = north) of a CRS name, if it is a recognised UTM CRS.
pub fn utm_zone(srs_name: &str) -> Option<(u8, bool)> {
    Crs::parse(srs_name)
        .epsg
        .and_then(super::convert::utm_zone)
        .map(|(z, n, _)| (z, n))
}

/// Latitude and longitude (degrees) of the point `(x, y)` in the CRS `srs_name`, if the CRS
/// is one the default build converts (see the module docs) and the point is in its range.
pub fn lat_lon(srs_name: &str, x: f64, y: f64) -> Option<(f64, f64)> {
    site_lat_lon(&Crs::parse(srs_name), DVec3::new(x, y, 0.0))
}

/// Where the sun is seen from for a model: the centre of its bounding box in WGS 84, with
/// the CRS it was converted from ([`model_site`]).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct ModelSite {
    /// Latitude, degrees north.
    pub lat: f64,
    /// Longitude, degrees east (-180..180).
    pub lon: f64,
    /// The model's CRS the centre was converted from.
    pub crs: Crs,
}

/// Why a model gives no site ([`model_site`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "the input's CRS ({}) is not one skylod converts (geographic, or UTM zones of WGS 84, \
     ETRS89, JGD2011, NAD83, GDA)",
    .crs.as_deref().unwrap_or("none given")
)]
#[non_exhaustive]
pub struct NoSite {
    /// The CRS as named (`None`: no file names one), or the model is empty.
    pub crs: Option<String>,
}

/// The site of the sun for `model` in `crs` (the model's, [`super::model_crs`]): the centre
/// of its bounding box converted to latitude/longitude. The one place the CLI and the library
/// take a site from a model.
///
/// # Errors
/// [`NoSite`] for an empty model or a CRS the build does not convert.
pub fn model_site(model: &crate::model::CityModel, crs: &Crs) -> Result<ModelSite, NoSite> {
    box_site(&model.bbox(), crs)
}

/// [`model_site`] of a model whose box (every point of every asset,
/// [`crate::model::CityModel::bbox`]) is `bbox`, for a caller that has it already.
///
/// # Errors
/// As [`model_site`].
pub fn box_site(bbox: &crate::model::Bbox, crs: &Crs) -> Result<ModelSite, NoSite> {
    let no = || NoSite {
        crs: (!crs.name.is_empty()).then(|| crs.name.clone()),
    };
    if bbox.is_empty() {
        return Err(no());
    }
    let c = bbox.center();
    let (lat, lon) = site_lat_lon(crs, DVec3::new(c.x, c.y, 0.0)).ok_or_else(no)?;
    Ok(ModelSite {
        lat,
        lon,
        crs: crs.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spellings() {
        for (name, z) in [
            ("EPSG:25831", Some((31, true))),
            ("urn:ogc:def:crs:EPSG::25832", Some((32, true))),
            (
                "urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783",
                Some((32, true)),
            ),
            (
                "urn:ogc:def:crs,crs:EPSG:6.12:31466,crs:EPSG:6.12:5783",
                None,
            ),
            (
                "http://www.opengis.net/def/crs/EPSG/0/32632",
                Some((32, true)),
            ),
            ("EPSG:32733", Some((33, false))),
            ("urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH", Some((32, true))),
            // ETRS89 / UTM zone 32N (N-E) (pyproj: CRS.from_epsg(3044).name).
            ("EPSG:3044", Some((32, true))),
            ("EPSG:6691", Some((54, true))),
            ("EPSG:6697", None),
            ("#local-CRS-1", None),
            ("", None),
        ] {
            assert_eq!(utm_zone(name), z, "{name}");
        }
    }

    #[test]
    fn known_points() {
        // Karlsruhe (FZK-Haus sample, ETRS89 / UTM 32N): about 49.1 N, 8.4 E.
        let (lat, lon) =
            lat_lon("urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH", 458877.0, 5438353.0).unwrap();
        assert!(
            (lat - 49.10).abs() < 0.02 && (lon - 8.43).abs() < 0.02,
            "{lat} {lon}"
        );
        // Ingolstadt (WGS 84 / UTM 32N): about 48.76 N, 11.43 E.
        let (lat, lon) = lat_lon("EPSG:32632", 678100.0, 5403700.0).unwrap();
        assert!(
            (lat - 48.76).abs() < 0.02 && (lon - 11.43).abs() < 0.02,
            "{lat} {lon}"
        );
        // Out of the zone's range: no answer.
        assert_eq!(lat_lon("EPSG:25832", 5.0, 5.0), None);
        // Geographic: the point itself (latitude first for EPSG:4326).
        assert_eq!(lat_lon("EPSG:4326", 48.0, 11.0), Some((48.0, 11.0)));
        assert_eq!(lat_lon("EPSG:4326", 480000.0, 11.0), None);
        // Feet: not without PROJ; with it, New York (Long Island State Plane, US feet).
        let ny = lat_lon("EPSG:2263", 987654.0, 212345.0);
        #[cfg(not(feature = "proj"))]
        assert_eq!(ny, None);
        #[cfg(feature = "proj")]
        {
            let (lat, lon) = ny.unwrap();
            assert!(
                (lat - 40.75).abs() < 0.05 && (lon + 73.98).abs() < 0.05,
                "{lat} {lon}"
            );
        }
    }
}

#[cfg(test)]
mod site_tests {
    use super::*;

    #[test]
    fn site_of_a_model_is_the_centre_of_its_box() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/synth-small.gml");
        let m = crate::io::citygml::read_file(&path).unwrap();
        let crs = super::super::model_crs(&m, None);
        let s = model_site(&m, &crs).unwrap();
        let c = m.bbox().center();
        assert_eq!(Some((s.lat, s.lon)), lat_lon(&crs.name, c.x, c.y));
        let e = model_site(&m, &Crs::parse("")).unwrap_err();
        assert!(e.to_string().contains("(none given)"), "{e}");
        let empty = crate::model::CityModel::default();
        assert!(model_site(&empty, &crs).is_err());
    }
}
