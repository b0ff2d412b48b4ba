//! The path every tracing command takes, as a library API: **inputs → scene → levels →
//! outputs**, with progress and cancellation through a
//! [`Progress`](crate::model::runtime::progress::Progress).
//!
//! 1. [`read_inputs`]: files read in parallel and merged into one model (occluders of a
//!    neighbouring tile count); a file that cannot be read is reported, the others are used.
//!    [`Inputs::check`] refuses a model that would give a confidently wrong answer whatever
//!    the POIs (mixed CRSs, no heights).
//! 2. [`frame`](fn@frame): the model and the POIs in the local metric frame the tracing works in
//!    (ENU for degrees, metres for feet; `source_crs`, `poi_crs`), POIs far outside the scene
//!    refused.
//! 3. [`levels`](fn@levels): rough model → selection scene (BVH) → selection, then the error bound when
//!    one is asked for; the rough geometry is brought back to the input's CRS for writing.
//! 4. [`write_levels`]: each input file written with its assets at their levels (mixed-LoD
//!    CityGML, OBJ, CityJSON), atomically.
//!
//! 5. Or, after step 2, the POIs traced instead of levels chosen: [`evaluate`] (full vs LoD
//!    vs all-boxes model per POI), [`trace`] against the full-detail scene ([`svf`],
//!    [`sun_hours`], [`horizon`]), one
//!    [`Stage::Trace`](crate::model::runtime::progress::Stage::Trace) item per POI, cancellable before each.
//!
//! `skylod lod` is steps 1–4 plus messages; `evaluate`, `svf`, `sun-hours` and `horizon` are
//! steps 1, 2 and 5; `fisheye` is steps 1, 2 and [`sky_pictures`]. Nothing here prints: warnings are returned
//! ([`Framed::warnings`]), progress goes to the
//! [`Progress`](crate::model::runtime::progress::Progress).
//!
//! # Example
//! ```
//! use skylod::pipeline::{frame, levels, read_inputs, write_levels, FrameOptions, LevelsOptions};
//! use skylod::model::Silent;
//! use skylod::export::Format;
//! use std::path::PathBuf;
//! let input = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/synth-small.gml");
//! let mut inputs = read_inputs(&[input], &Silent).unwrap();
//! inputs.check(false).unwrap();
//! let b = inputs.model.bbox();
//! let poi = skylod::model::Poi { id: "street".into(), position: b.center(), normal: None };
//! let framed = frame(&mut inputs.model, vec![poi], &FrameOptions::default()).unwrap();
//! let lv = levels(&framed, &LevelsOptions::default(), &Silent).unwrap();
//! let dir = tempfile::tempdir().unwrap();
//! let out = dir.path().join("lod.gml");
//! let written = write_levels((framed.source, 0), &lv, &out, Format::CityGml, &Default::default()).unwrap();
//! assert!(written.polygons_out <= written.polygons_in);
//! assert!(out.exists());
//! ```

mod analyse;
pub(crate) mod attributes;
// Batch work: input files, shards, levels files and their reduce, scene radius.
pub mod batch;
mod error;
mod fisheye;
mod frame;
mod irradiance;
mod levels;
mod read;
// The owned session (Scene -> Study) and the one error of the library.
pub mod session;
#[cfg(test)]
pub(crate) mod test_support;
mod write;
pub use attributes::{insertion_point, write_surface_means, AttributesError};

pub(crate) use analyse::trace_in;
pub use analyse::{evaluate, horizon, sun_hours, svf, trace, EvaluateOptions, Traced};
pub use error::PoiCrsError;
pub use fisheye::{sky_pictures, SkyPicture, SkyPictureOptions};
pub(crate) use frame::frame_in;
pub use frame::{frame, FrameOptions, Framed};
pub use irradiance::{irradiance, PoiIrradiance};
pub use levels::{levels, levels_of, BoundSpec, Levels, LevelsInput, LevelsOptions};
pub(crate) use read::check_model_in;
pub use read::{check_model, read_inputs, read_sources, Inputs};
pub use write::{
    buildings_without_kept_assets, write_all, write_levels, write_levels_to, write_merged_levels,
    Written,
};
