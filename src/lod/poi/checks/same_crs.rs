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
//! use skylod::model::crs::same_crs;
//! assert!(same_crs("EPSG:25832", "urn:ogc:def:crs:EPSG::25832"));
//! assert!(same_crs("urn:adv:crs:ETRS89_UTM32*DE_DHHN92_NH", "urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783"));
//! assert!(!same_crs("EPSG:25832", "EPSG:25833"));
//! ```

use super::TrustError;
use crate::model::crs::srs_key as key;
use crate::model::CityModel;

/// Refuse a model merged from files in different CRSs, naming each CRS once with its number
/// of files and one of them: `EPSG:28992: 3 files (e.g. a.gml); EPSG:32632: 1 file (b.gml)`.
pub fn check_same_crs(model: &CityModel) -> Result<(), TrustError> {
    // (key, the first spelling, files, the first file)
    let mut seen: Vec<(String, &str, usize, String)> = Vec::new();
    for f in &model.files {
        let Some(srs) = f.srs_name.as_deref() else {
            continue;
        };
        let k = key(srs);
        match seen.iter_mut().find(|(sk, ..)| *sk == k) {
            Some((_, _, n, _)) => *n += 1,
            None => seen.push((k, srs, 1, crate::model::shown(&f.path).to_string())),
        }
    }
    if seen.len() < 2 {
        return Ok(());
    }
    Err(TrustError::MixedCrs {
        listing: listing(&seen),
    })
}

fn listing(seen: &[(String, &str, usize, String)]) -> String {
    seen.iter()
        .map(|(_, srs, n, file)| match n {
            1 => format!("{srs}: 1 file ({file})"),
            _ => format!("{srs}: {n} files (e.g. {file})"),
        })
        .collect::<Vec<_>>()
        .join("; ")
}

#[cfg(test)]
mod tests {
    use super::check_same_crs;
    use crate::model::crs::same_crs;
    use crate::model::{CityGmlVersion, CityModel, SourceFile};

    #[test]
    fn each_crs_is_named_once_with_its_files() {
        let mut model = CityModel::default();
        for (name, srs) in [
            ("a.gml", Some("EPSG:28992")),
            ("b.gml", Some("urn:ogc:def:crs:EPSG::28992")),
            ("c.gml", None),
            ("d.gml", Some("EPSG:32632")),
            ("e.gml", Some("EPSG:28992")),
        ] {
            model.files.push(SourceFile {
                srs_name: srs.map(Into::into),
                ..SourceFile::new(name, CityGmlVersion::V2_0)
            });
        }
        let e = check_same_crs(&model).unwrap_err().to_string();
        assert!(
            e.contains("EPSG:28992: 3 files (e.g. a.gml); EPSG:32632: 1 file (d.gml)"),
            "{e}"
        );
        assert_eq!(e.matches("28992").count(), 1, "{e}");
        model.files.truncate(3);
        assert!(check_same_crs(&model).is_ok());
    }

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
