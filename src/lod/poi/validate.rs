//! One validation of POIs for every path, library and CLI alike: finite coordinates, a
//! finite non-zero normal when there is one, ids unique in a run. What fails it would
//! otherwise give a clean-looking wrong answer (a NaN POI or a zero normal traced as SVF 1,
//! two rows under one id).
//!
//! ```
//! use glam::DVec3;
//! use skylod::lod::poi::{check_poi_list, Poi, PoiError};
//! let p = |id: &str, x: f64| Poi { id: id.into(), position: DVec3::new(x, 0.0, 0.0), normal: None };
//! assert!(check_poi_list(&[p("a", 0.0), p("b", 1.0)]).is_ok());
//! assert!(matches!(check_poi_list(&[p("a", f64::NAN)]), Err(PoiError::NotFinite { .. })));
//! assert!(matches!(check_poi_list(&[p("a", 0.0), p("a", 1.0)]), Err(PoiError::DuplicateId { .. })));
//! let flat = Poi { normal: Some(DVec3::ZERO), ..p("w", 0.0) };
//! assert!(matches!(check_poi_list(&[flat]), Err(PoiError::ZeroNormal { .. })));
//! ```

use super::{Located, PoiError};
use crate::model::Poi;
use std::collections::HashMap;

/// Shortest normal accepted (a normal is a direction: its length does not matter otherwise).
pub const MIN_NORMAL_LENGTH: f64 = 1e-12;

/// Check one POI given at `at`: finite position, finite non-zero normal.
///
/// # Errors
/// [`PoiError::NotFinite`], [`PoiError::ZeroNormal`].
pub fn check_poi(p: &Poi, at: &str) -> Result<(), PoiError> {
    let normal_finite = p.normal.is_none_or(|n| n.is_finite());
    if !p.position.is_finite() || !normal_finite {
        return Err(PoiError::NotFinite {
            id: p.id.clone(),
            at: at.to_string(),
        });
    }
    if p.normal.is_some_and(|n| n.length() < MIN_NORMAL_LENGTH) {
        return Err(PoiError::ZeroNormal {
            id: p.id.clone(),
            at: at.to_string(),
        });
    }
    Ok(())
}

fn check_all<'a>(items: impl Iterator<Item = (&'a Poi, String)>) -> Result<(), PoiError> {
    let mut first: HashMap<&str, String> = HashMap::new();
    for (p, at) in items {
        check_poi(p, &at)?;
        if let Some(prev) = first.get(p.id.as_str()) {
            return Err(PoiError::DuplicateId {
                id: p.id.clone(),
                first: prev.clone(),
                second: at,
            });
        }
        first.insert(&p.id, at);
    }
    Ok(())
}

/// Check POIs read with their places (`--poi …`, `file:line`): each as [`check_poi`], ids
/// unique (the error names both places).
///
/// # Errors
/// [`PoiError::NotFinite`], [`PoiError::ZeroNormal`], [`PoiError::DuplicateId`].
pub fn check_pois(pois: &[Located]) -> Result<(), PoiError> {
    check_all(pois.iter().map(|l| (&l.poi, l.at.clone())))
}

/// [`check_pois`] for POIs without places: a POI is named by its position in the list
/// (`POI 3`, counted from 1). Every pipeline path calls it
/// (`pipeline::frame`).
///
/// # Errors
/// As [`check_pois`].
pub fn check_poi_list(pois: &[Poi]) -> Result<(), PoiError> {
    check_all(
        pois.iter()
            .enumerate()
            .map(|(k, p)| (p, format!("POI {}", k + 1))),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn poi(id: &str, x: f64) -> Poi {
        Poi {
            id: id.into(),
            position: DVec3::new(x, 2.0, 3.0),
            normal: None,
        }
    }

    #[test]
    fn refusals_name_the_poi_and_its_place() {
        let e = check_poi_list(&[poi("a", 1.0), poi("b", f64::INFINITY)]).unwrap_err();
        assert!(
            matches!(&e, PoiError::NotFinite { id, at } if id == "b" && at == "POI 2"),
            "{e:?}"
        );
        let bad_normal = Poi {
            normal: Some(DVec3::new(0.0, f64::NAN, 1.0)),
            ..poi("n", 0.0)
        };
        assert!(matches!(
            check_poi_list(&[bad_normal]),
            Err(PoiError::NotFinite { .. })
        ));
        let tiny = Poi {
            normal: Some(DVec3::new(0.0, 0.0, 1e-13)),
            ..poi("t", 0.0)
        };
        let e = check_poi_list(&[tiny]).unwrap_err().to_string();
        assert!(e.contains("\"t\"") && e.contains("zero length"), "{e}");
        // A non-unit normal is a direction: accepted.
        let long = Poi {
            normal: Some(DVec3::new(0.0, -3.0, 0.0)),
            ..poi("l", 0.0)
        };
        assert!(check_poi_list(&[long]).is_ok());
        let located = vec![
            Located {
                poi: poi("a", 0.0),
                at: "p.csv:2".into(),
            },
            Located {
                poi: poi("a", 1.0),
                at: "p.csv:5".into(),
            },
        ];
        let e = check_pois(&located).unwrap_err().to_string();
        assert!(e.contains("p.csv:2") && e.contains("p.csv:5"), "{e}");
        assert!(check_pois(&[]).is_ok());
    }
}
