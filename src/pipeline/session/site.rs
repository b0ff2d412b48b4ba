//! The site of the sun as a caller gives it: a latitude and a longitude given together (or
//! neither), in range, else the centre of the model from its CRS ([`site_of`]), with the
//! note a program tells its user when the site comes from the model ([`SunSite::note`]).

use super::weather::SunSite;
use crate::io::citygml::read::{stream_citygml, ReadOptions};
use crate::io::citygml::source;
use crate::io::files::is_gzip;
use crate::model::crs::{box_site, model_crs, model_site, NoSite};
use crate::model::{Bbox, CityModel};
use std::path::Path;

/// Why a site cannot be used. The caller names its own options in what it says.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SiteError {
    /// Only one of the latitude and the longitude is given.
    #[error("the site needs both a latitude and a longitude (WGS84 degrees)")]
    Half,
    /// The latitude is outside -90..90 or the longitude outside -180..180.
    #[error("latitude must be in -90..90 and longitude in -180..180 (got {lat}, {lon})")]
    OutOfRange {
        /// The latitude given.
        lat: f64,
        /// The longitude given.
        lon: f64,
    },
    /// None given, and the model gives none (empty, or a CRS not converted).
    #[error(transparent)]
    NoSite(#[from] NoSite),
}

/// The latitude and longitude given: both (`Some`) or neither (`None`); one alone is
/// [`SiteError::Half`]. With `in_range`, a pair outside -90..90, -180..180 is
/// [`SiteError::OutOfRange`].
///
/// # Errors
/// [`SiteError::Half`], [`SiteError::OutOfRange`].
pub fn given_site(
    lat: Option<f64>,
    lon: Option<f64>,
    in_range: bool,
) -> Result<Option<(f64, f64)>, SiteError> {
    match (lat, lon) {
        (None, None) => Ok(None),
        (Some(lat), Some(lon)) => {
            let ok = (-90.0..=90.0).contains(&lat) && (-180.0..=180.0).contains(&lon);
            if in_range && !ok {
                return Err(SiteError::OutOfRange { lat, lon });
            }
            Ok(Some((lat, lon)))
        }
        _ => Err(SiteError::Half),
    }
}

/// The site of the sun: the latitude and longitude given (both, in range), or when neither
/// is given the centre of `model` in its own CRS ([`model_site`]).
///
/// # Errors
/// As [`given_site`]; [`SiteError::NoSite`] when the model gives none.
pub fn site_of(
    lat: Option<f64>,
    lon: Option<f64>,
    model: &CityModel,
) -> Result<SunSite, SiteError> {
    site_from(lat, lon, model, || model.bbox())
}

/// [`site_of`] of a model whose box ([`CityModel::bbox`]) is `bbox`, for a caller that has
/// it already ([`super::Study::sun_site`]).
///
/// # Errors
/// As [`site_of`].
pub fn site_in(
    lat: Option<f64>,
    lon: Option<f64>,
    model: &CityModel,
    bbox: &Bbox,
) -> Result<SunSite, SiteError> {
    site_from(lat, lon, model, || *bbox)
}

/// [`site_of`] with the model's box from `bbox`, taken only when no site is given.
fn site_from(
    lat: Option<f64>,
    lon: Option<f64>,
    model: &CityModel,
    bbox: impl FnOnce() -> Bbox,
) -> Result<SunSite, SiteError> {
    if let Some((a, o)) = given_site(lat, lon, true)? {
        return Ok(SunSite::Given(a, o));
    }
    let s = box_site(&bbox(), &model_crs(model, None))?;
    Ok(SunSite::Model(s.lat, s.lon, s.crs.name))
}

/// Bytes of a document whose city objects give [`site_hint`] its site (the first chunk of
/// whole members from about this far on).
const HINT_BYTES: u64 = 64 << 10;

/// A site near the sun's ([`site_of`]), known before the model is read, for work done ahead
/// of the sun's table ([`crate::solar::ephemeris::SunEphemeris::year_near`]): the latitude
/// and longitude given, else the centre of the first city objects of `first` (about 64 KiB
/// of an uncompressed CityGML file, read as a chunk of [`stream_citygml`]) in the file's CRS.
/// `None` for a gzip-compressed or CityJSON file, standard input, or where those objects give
/// no site.
pub fn site_hint(lat: Option<f64>, lon: Option<f64>, first: Option<&Path>) -> Option<(f64, f64)> {
    if let Ok(Some(given)) = given_site(lat, lon, true) {
        return Some(given);
    }
    let head = head_model(first?, HINT_BYTES)?;
    let site = model_site(&head, &model_crs(&head, None)).ok()?;
    Some((site.lat, site.lon))
}

/// The city objects of the first chunk of whole top-level members from about `bytes` on
/// ([`stream_citygml`]) of the uncompressed CityGML file at `path`, known before the model is
/// read (its CRS, where its first objects stand). `None` for a gzip-compressed or CityJSON
/// file (told from the first bytes: a gzip file would be decompressed whole before its first
/// chunk, and CityJSON is not streamed), a path that is not a file, or a document that does
/// not stream.
pub fn head_model(path: &Path, bytes: u64) -> Option<CityModel> {
    if !std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
        return None;
    }
    let mut file = std::io::BufReader::new(std::fs::File::open(path).ok()?);
    let head = std::io::BufRead::fill_buf(&mut file).ok()?;
    if is_gzip(head) || source::is_json(head) {
        return None;
    }
    let mut head = None;
    let opts = ReadOptions::default();
    let _ = stream_citygml(path, &opts, bytes, &|_| {}, |c| {
        head = Some(c.model);
        Err(())
    });
    head
}

impl SunSite {
    /// What to tell the user of a site taken from the model or a weather station
    /// (`station`: its name), `None` for a site given.
    pub fn note(&self, station: &str) -> Option<String> {
        match self {
            SunSite::Given(..) => None,
            SunSite::Model(a, o, srs) => Some(format!(
                "site lat {a:.5}, lon {o:.5}: the centre of the model in {srs}"
            )),
            SunSite::Station(a, o, why) => Some(format!(
                "site of the weather station {station:?} (lat {a}, lon {o}): {why}"
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::test_support::fixture_inputs;

    #[test]
    fn a_site_given_is_a_pair_in_range() {
        assert_eq!(given_site(None, None, true), Ok(None));
        assert_eq!(given_site(Some(41.0), None, false), Err(SiteError::Half));
        assert_eq!(given_site(None, Some(2.0), true), Err(SiteError::Half));
        assert_eq!(
            given_site(Some(41.0), Some(2.0), true),
            Ok(Some((41.0, 2.0)))
        );
        let out = SiteError::OutOfRange {
            lat: 91.0,
            lon: 2.0,
        };
        assert_eq!(given_site(Some(91.0), Some(2.0), true), Err(out));
        assert_eq!(
            given_site(Some(41.0), Some(-181.0), true),
            Err(SiteError::OutOfRange {
                lat: 41.0,
                lon: -181.0
            })
        );
        // Unchecked: the pair as given (the range is checked later).
        assert_eq!(
            given_site(Some(91.0), Some(2.0), false),
            Ok(Some((91.0, 2.0)))
        );
        assert_eq!(
            given_site(Some(-90.0), Some(180.0), true),
            Ok(Some((-90.0, 180.0)))
        );
    }

    #[test]
    fn the_site_is_given_or_the_model_s_centre() {
        let m = fixture_inputs().model;
        assert_eq!(
            site_of(Some(1.0), Some(2.0), &m),
            Ok(SunSite::Given(1.0, 2.0))
        );
        let s = site_of(None, None, &m).unwrap();
        let (lat, lon) = s.lat_lon();
        assert!(
            (lat - 41.377).abs() < 0.01 && (lon - 2.162).abs() < 0.01,
            "{s:?}"
        );
        let note = s.note("").unwrap();
        assert!(
            note.starts_with(&format!("site lat {lat:.5}, lon {lon:.5}: ")),
            "{note}"
        );
        assert!(note.contains("centre of the model in EPSG:25831"), "{note}");
        assert_eq!(SunSite::Given(1.0, 2.0).note("x"), None);
        assert_eq!(site_of(Some(1.0), None, &m), Err(SiteError::Half));
        // An empty model: no site, and why.
        let e = site_of(None, None, &CityModel::default()).unwrap_err();
        assert!(matches!(e, SiteError::NoSite(_)), "{e:?}");
        let why = NoSite { crs: None };
        let station = SunSite::Station(41.5, 2.5, why.clone())
            .note("BCN")
            .unwrap();
        assert_eq!(
            station,
            format!("site of the weather station \"BCN\" (lat 41.5, lon 2.5): {why}")
        );
    }
    /// The hint before the read: the site given, else near the model's centre (the first
    /// objects of a 314 KB district are within a few hundred metres of it); nothing from a
    /// file that is missing, compressed or not CityGML.
    #[test]
    fn a_site_hint_is_the_site_given_or_near_the_model_s() {
        let path = crate::pipeline::test_support::fixture();
        assert_eq!(
            site_hint(Some(1.0), Some(2.0), Some(&path)),
            Some((1.0, 2.0))
        );
        let (lat, lon) = site_of(None, None, &fixture_inputs().model)
            .unwrap()
            .lat_lon();
        let (a, o) = site_hint(None, None, Some(&path)).unwrap();
        assert!((a - lat).abs() < 0.01 && (o - lon).abs() < 0.01, "{a} {o}");
        assert!((a, o) != (lat, lon), "the first objects only");
        assert_eq!(site_hint(None, None, None), None);
        let dir = tempfile::tempdir().unwrap();
        let gz = crate::pipeline::test_support::gzip_copy(&path, dir.path());
        assert_eq!(site_hint(None, None, Some(&gz)), None);
        let json = dir.path().join("x.city.json");
        std::fs::write(&json, " {\"type\": \"CityJSON\", \"CityObjects\": {}}").unwrap();
        assert_eq!(site_hint(None, None, Some(&json)), None);
        assert_eq!(site_hint(None, None, Some(dir.path())), None);
        assert_eq!(
            site_hint(None, None, Some(&dir.path().join("none.gml"))),
            None
        );
    }
}
