//! Models without heights: 2D footprints (`srsDimension="2"`) or every coordinate at one
//! height. Tracing them gives SVF 1 and full sun everywhere with nothing to say it is wrong,
//! so the tracing commands refuse them; `stats` and `convert` still read them.
//!
//! # Example
//! ```
//! use glam::DVec3;
//! use skylod::lod::poi::check_heights;
//! use skylod::model::{Asset, AssetKind, CityModel, LodGeometry, Polygon};
//! let mut m = CityModel::default();
//! let flat = Polygon::new(vec![DVec3::ZERO, DVec3::X, DVec3::Y]);
//! m.assets.push(Asset {
//!     kind: AssetKind::Ground, id: None, element: "GroundSurface".into(), building: None,
//!     parent: None, span: 0..0, line: 1, function: None, file: 0,
//!     geometries: vec![LodGeometry { lod: 0, polygons: vec![flat], ..Default::default() }],
//! });
//! assert!(check_heights(&m).is_err());
//! ```

use super::TrustError;
use crate::model::{Bbox, CityModel};

/// Refuse a model whose geometry spans no height at all (within a millimetre).
pub fn check_heights(model: &CityModel) -> Result<(), TrustError> {
    check_heights_in(model, &model.bbox())
}

/// [`check_heights`] of a model whose box ([`CityModel::bbox`]) is `bbox`, for a caller that
/// has it already.
pub fn check_heights_in(model: &CityModel, bbox: &Bbox) -> Result<(), TrustError> {
    if bbox.is_empty() || bbox.max.z - bbox.min.z > 1e-3 {
        return Ok(());
    }
    let files: Vec<String> = model
        .files
        .iter()
        .map(|f| crate::model::shown(&f.path).to_string())
        .collect();
    let two_d = model
        .files
        .iter()
        .any(|f| f.envelopes.iter().any(|e| e.dimension == 2));
    let reason = if two_d {
        "srsDimension=\"2\": coordinates without heights".to_string()
    } else {
        format!("every height is {}", bbox.min.z)
    };
    Err(TrustError::NoHeights {
        files: if files.is_empty() {
            "model".into()
        } else {
            files.join(", ")
        },
        reason,
    })
}
