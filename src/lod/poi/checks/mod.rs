//! Trust checks: inputs that would give a confidently wrong answer are refused before any
//! tracing, or flagged in every output (`../shared/DESIGN.md`, "Trust: no confident wrong
//! answer"). One check per file:
//!
//! - [`extent::check_pois_near`]: a POI far outside the scene (a wrong CRS, swapped axes);
//! - [`extent::check_lat_lon_order`]: `--poi-crs EPSG:4326` POIs given longitude first;
//! - [`heights::check_heights`]: a model without heights (2D footprints) cannot be traced;
//! - [`same_crs::check_same_crs`]: inputs in different CRSs are not merged into one scene;
//! - [`enclosure::poi_flags_around`]: a POI inside a closed building (judged on the full
//!   geometry), far below the buildings around it, with its normal into the surface it lies
//!   on, or with every ray blocked.
//!
//! The refusals are [`TrustError`]s; the flags are data ([`PoiFlag`]) that the commands
//! print as warnings and write into their JSON outputs.

pub(crate) mod enclosure;
pub(crate) mod extent;
pub(crate) mod heights;
pub(crate) mod same_crs;
pub(crate) mod surroundings;

pub use enclosure::{poi_flags, poi_flags_around, PoiFlag};
pub use extent::{
    check_lat_lon_order, check_pois_near, check_pois_near_in_frame, OutsideHint, PoisOutside,
    DEFAULT_POI_MARGIN,
};
pub use heights::{check_heights, check_heights_in};
pub use same_crs::check_same_crs;
pub use surroundings::Surroundings;

/// An input that would give a confidently wrong answer.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TrustError {
    /// POIs lie farther than the margin outside the scene's bounding box: which, how far.
    #[error("{0}")]
    PoiOutside(Box<PoisOutside>),
    /// POIs in a latitude-first geographic CRS given longitude first.
    #[error(
        "{message} the order is probably swapped: {crs}'s axis order is latitude, longitude \
         (a POI as LAT,LON,H; CSV columns lat, lon), not longitude, latitude"
    )]
    LatLonSwapped {
        /// Which POIs lie outside the model and inside it with their axes exchanged.
        message: String,
        /// The POIs' CRS, whose axis order is latitude first.
        crs: String,
    },
    /// The model has no heights.
    #[error(
        "{files}: the model has no heights ({reason}); tracing a flat model would give \
         SVF 1 and full sun everywhere. Use a model with 3D geometry (stats and convert \
         still read this one)"
    )]
    NoHeights {
        /// The files concerned, comma separated.
        files: String,
        /// `srsDimension="2"` or `every height is Z`.
        reason: String,
    },
    /// Inputs in different CRSs.
    #[error(
        "the inputs are in different CRSs and would be merged into one scene: {listing}. \
         Reproject them to one CRS first, or allow mixed CRSs if the names differ but the \
         CRS is the same"
    )]
    MixedCrs {
        /// `srs: n files (e.g. file)` per CRS, `; ` separated.
        listing: String,
    },
    /// No input could be read: there is no scene, every POI would see the whole sky.
    #[error("no input could be read ({failed} failed): there is no scene to trace")]
    NoInput {
        /// Inputs that failed.
        failed: usize,
    },
}
