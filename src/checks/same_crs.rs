//! Inputs in different CRSs must not be merged into one scene: tiles in EPSG:25832 and in
//! EPSG:4326 would be traced side by side thousands of kilometres apart (or on top of each
//! other), silently. Names that spell the same EPSG code differently (`EPSG:25832`,
//! `urn:ogc:def:crs:EPSG::25832`, `http://www.opengis.net/def/crs/EPSG/0/25832`) agree; a
//! file without `srsName` agrees with anything (nothing is known about it).
//!
//! # Example
//! ```
//! use skylod::checks::same_crs::same_crs;
//! assert!(same_crs("EPSG:25832", "urn:ogc:def:crs:EPSG::25832"));
//! assert!(!same_crs("EPSG:25832", "EPSG:25833"));
//! ```

use super::TrustError;
use crate::model::CityModel;

/// The key two names are compared by: their EPSG codes when they carry any, otherwise the
/// trimmed name.
fn key(name: &str) -> String {
    let codes = crate::crs::epsg_codes(&name.to_ascii_uppercase());
    if codes.is_empty() {
        name.trim().to_string()
    } else {
        codes
            .iter()
            .map(u32::to_string)
            .collect::<Vec<_>>()
            .join("+")
    }
}

/// Whether two `srsName`s denote the same CRS.
pub fn same_crs(a: &str, b: &str) -> bool {
    key(a) == key(b)
}

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
