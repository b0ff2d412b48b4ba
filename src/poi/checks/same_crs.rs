//! Inputs in different CRSs must not be merged into one scene: tiles in EPSG:25832 and in
//! EPSG:4326 would be traced side by side thousands of kilometres apart (or on top of each
//! other), silently. CRSs are compared by their horizontal part: names that spell the same
//! EPSG code differently (`EPSG:25832`, `urn:ogc:def:crs:EPSG::25832`,
//! `http://www.opengis.net/def/crs/EPSG/0/25832`, the compound
//! `urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783`, the AdV `urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH`)
//! agree; a vertical datum stated in one name and not in another does not make them differ
//! (heights differ by centimetres to a metre between such datums, far below what moves a
//! skyline). A file without `srsName` agrees with anything (nothing is known about it).
//!
//! # Example
//! ```
//! use skylod::crs::same_crs;
//! assert!(same_crs("EPSG:25832", "urn:ogc:def:crs:EPSG::25832"));
//! assert!(same_crs("urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH", "urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783"));
//! assert!(!same_crs("EPSG:25832", "EPSG:25833"));
//! ```

use super::TrustError;
pub use crate::crs::same_crs;
use crate::crs::srs_key as key;
use crate::model::CityModel;

/// Refuse a model merged from files in different CRSs, naming one file per CRS.
pub fn check_same_crs(model: &CityModel) -> Result<(), TrustError> {
    let mut seen: Vec<(String, &str, String)> = Vec::new();
    for f in &model.files {
        let Some(srs) = f.srs_name.as_deref() else {
            continue;
        };
        let k = key(srs);
        if !seen.iter().any(|(sk, _, _)| *sk == k) {
            seen.push((k, srs, f.path.display().to_string()));
        }
    }
    if seen.len() < 2 {
        return Ok(());
    }
    let listing = seen
        .iter()
        .map(|(_, srs, file)| format!("{file} ({srs})"))
        .collect::<Vec<_>>()
        .join("; ");
    Err(TrustError::MixedCrs { listing })
}

#[cfg(test)]
mod tests {
    use super::same_crs;

    #[test]
    fn spellings_of_one_crs_agree() {
        let names = [
            "EPSG:25832",
            "urn:ogc:def:crs:EPSG::25832",
            "http://www.opengis.net/def/crs/EPSG/0/25832",
            "urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783",
            "urn:ogc:def:crs:EPSG:25832, crs:EPSG:5783",
            "urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH",
            "urn:adv:crs:ETRS89_UTM32*DE_DHHN2016_NH",
        ];
        for a in names {
            for b in names {
                assert!(same_crs(a, b), "{a} vs {b}");
            }
        }
    }

    #[test]
    fn different_crs_differ() {
        assert!(!same_crs(
            "EPSG:25832",
            "http://www.opengis.net/def/crs/EPSG/0/6697"
        ));
        assert!(!same_crs(
            "urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH",
            "urn:adv:crs:ETRS89_UTM33*DE_DHHN92_NH"
        ));
        assert!(!same_crs("#local-CRS-1", "EPSG:25832"));
        assert!(same_crs("#local-CRS-1", " #local-CRS-1 "));
    }
}
