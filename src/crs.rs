//! Site latitude/longitude from a model's projected CRS, for the sun position, without PROJ:
//! the UTM CRSs that city models use most are recognised in `srsName` and inverted with the
//! `utm` crate (WGS84 ellipsoid; ETRS89 and WGS84 differ by less than a metre, far below what
//! a sun position needs).
//!
//! Recognised: EPSG:32601–32660 (WGS 84 / UTM north), EPSG:32701–32760 (south),
//! EPSG:25828–25838 (ETRS89 / UTM 28N–38N), EPSG:3043–3051 (ETRS89 / UTM 29N–37N, the older
//! "-TM" codes), EPSG:4647 (ETRS89 / UTM 32N with zone prefix in the easting) and the AdV names
//! `urn:adv:crs:ETRS89_UTM<zone>…`, in any of the usual spellings (`EPSG:25832`,
//! `urn:ogc:def:crs:EPSG::25832`, compound `urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783`,
//! `http://www.opengis.net/def/crs/EPSG/0/25832`). Anything else gives `None`: give the
//! latitude and longitude explicitly then.
//!
//! # Example
//! ```
//! use skylod::crs::{lat_lon, utm_zone};
//! assert_eq!(utm_zone("urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783"), Some((32, true)));
//! // Barcelona, the synthetic district's corner.
//! let (lat, lon) = lat_lon("EPSG:25831", 430000.0, 4581000.0).unwrap();
//! assert!((lat - 41.377).abs() < 0.01 && (lon - 2.162).abs() < 0.01);
//! ```

/// UTM zone and hemisphere (`true` = north) of a CRS name, if it is a recognised UTM CRS.
pub fn utm_zone(srs_name: &str) -> Option<(u8, bool)> {
    let upper = srs_name.to_ascii_uppercase();
    if let Some(i) = upper.find("ETRS89_UTM") {
        let digits: String = upper[i + "ETRS89_UTM".len()..]
            .chars()
            .take_while(char::is_ascii_digit)
            .collect();
        return digits
            .parse::<u8>()
            .ok()
            .filter(|z| (1..=60).contains(z))
            .map(|z| (z, true));
    }
    epsg_codes(&upper).into_iter().find_map(|code| match code {
        32601..=32660 => Some(((code - 32600) as u8, true)),
        32701..=32760 => Some(((code - 32700) as u8, false)),
        25828..=25838 => Some(((code - 25800) as u8, true)),
        3043..=3051 => Some(((code - 3043 + 29) as u8, true)),
        _ => None,
    })
}

/// The code after each `EPSG` authority in the name: the last number of the run of digits
/// and separators that follows it (`EPSG::25832`, `EPSG/0/25832`, `EPSG:6.12:31466`).
pub fn epsg_codes(upper: &str) -> Vec<u32> {
    upper
        .split("EPSG")
        .skip(1)
        .filter_map(|rest| {
            let token: &str = rest
                .split(|c: char| !(c.is_ascii_digit() || matches!(c, ':' | '/' | '.')))
                .next()?;
            token
                .rsplit(|c: char| !c.is_ascii_digit())
                .find(|d| !d.is_empty())?
                .parse()
                .ok()
        })
        .collect()
}

/// Latitude and longitude (degrees) of the point `(x, y)` in the CRS `srs_name`, if the CRS is
/// recognised (see the module docs) and the point lies in its zone's valid range.
pub fn lat_lon(srs_name: &str, x: f64, y: f64) -> Option<(f64, f64)> {
    let (zone, north) = utm_zone(srs_name)?;
    let letter = if north { 'N' } else { 'M' };
    utm::wsg84_utm_to_lat_lon(x, y, zone, letter).ok()
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
            ("EPSG:3044", Some((30, true))),
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
        assert_eq!(lat_lon("EPSG:4326", 48.0, 11.0), None);
    }
}
