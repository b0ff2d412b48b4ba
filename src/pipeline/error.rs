//! The errors that stop the pipeline.

use crate::lod::bound::BoundError;
use crate::lod::evaluation::EvalError;
use crate::lod::poi::checks::TrustError;
use crate::lod::poi::PoiError;
use crate::lod::select::SelectError;
use crate::model::crs::CrsError;
use crate::model::runtime::progress::Cancelled;
use crate::solar::SolarError;

/// The POIs could not be brought from their CRS to the model's (one definition for
/// [`PipelineError::PoiCrs`] and [`crate::Error::PoiCrs`]).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PoiCrsError {
    /// The conversion failed.
    #[error("POIs in {from}: {source}")]
    Convert {
        /// The POIs' CRS.
        from: String,
        /// Why.
        source: CrsError,
    },
    /// The POIs are in another CRS but the model's is not known.
    #[error("POIs in {from}: the model's CRS ({model}) is not known, so POIs cannot be converted to it (give the model's CRS)")]
    UnknownModelCrs {
        /// The POIs' CRS.
        from: String,
        /// The model's CRS as named.
        model: String,
    },
}

/// Errors of the pipeline that stop it (a file that cannot be read does not: see
/// [`Inputs::failures`](super::Inputs::failures)).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PipelineError {
    /// A POI is invalid (not finite, zero normal, a duplicate id: [`crate::lod::poi::check_poi_list`]).
    #[error(transparent)]
    Poi(#[from] PoiError),
    /// The model or the POIs would give a confidently wrong answer.
    #[error(transparent)]
    Trust(#[from] TrustError),
    /// The POIs could not be brought from their CRS to the model's.
    #[error(transparent)]
    PoiCrs(#[from] PoiCrsError),
    /// The selection failed (or was cancelled).
    #[error(transparent)]
    Select(#[from] SelectError),
    /// The error bound could not be computed.
    #[error(transparent)]
    Bound(#[from] BoundError),
    /// The evaluation could not be made.
    #[error(transparent)]
    Eval(EvalError),
    /// Invalid solar options (e.g. a horizon step out of range).
    #[error(transparent)]
    Solar(#[from] SolarError),
    /// The caller asked to stop.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}
