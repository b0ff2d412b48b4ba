//! The errors that stop the pipeline.

use crate::model::crs::CrsError;

/// The POIs could not be brought from their CRS to the model's ([`crate::Error::PoiCrs`]).
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
