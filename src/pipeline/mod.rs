//! The path every tracing command takes: **inputs → scene → levels → outputs**, with
//! progress and cancellation through a [`Progress`](crate::model::Progress), run through the
//! owned session of [`session`]: a [`Scene`](session::Scene) read and checked, framed with its
//! POIs into a [`Study`](session::Study).
//!
//! 1. Read: files read in parallel and merged into one model (occluders of a neighbouring tile
//!    count); a file that cannot be read is reported, the others are used; a model that would
//!    give a confidently wrong answer whatever the POIs (mixed CRSs, no heights) is refused.
//! 2. Frame: the model and the POIs in the local metric frame the tracing works in (ENU for
//!    degrees, metres for feet; `source_crs`, `poi_crs`), POIs far outside the scene refused.
//! 3. Levels: rough model → selection scene (BVH) → selection, then the error bound when one
//!    is asked for; the rough geometry is brought back to the input's CRS for writing.
//! 4. Write: each input file with its assets at their levels (mixed-LoD CityGML, OBJ,
//!    CityJSON), atomically.
//! 5. Or, after step 2, the POIs traced instead of levels chosen: the evaluation (full vs LoD
//!    vs all-boxes model per POI), SVF, sun hours, horizons, irradiance, sky pictures, one
//!    [`Stage::Trace`](crate::model::Stage::Trace) item per POI, cancellable before each.
//!
//! `skylod lod` is steps 1–4 plus messages; `evaluate`, `svf`, `sun-hours`, `horizon` and
//! `irradiance` are steps 1, 2 and 5. Nothing here prints: warnings are returned
//! ([`Framed::warnings`]). [`batch`] holds the work on many files (inputs, output layouts,
//! shards, levels files and their reduce).
//!
//! # Example
//! ```
//! use skylod::prelude::*;
//! let input = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/synth-small.gml");
//! let scene = Scene::load(&[input], &SceneOptions::default(), &Silent).unwrap();
//! let c = scene.model().bbox().center();
//! let mut study = scene.frame(vec![Poi::at("street", [c.x, c.y, c.z])]).unwrap();
//! let lv = study.levels(&LevelsOptions::default(), &Silent).unwrap();
//! let dir = tempfile::tempdir().unwrap();
//! let out = dir.path().join("lod.gml");
//! let written = study.write_levels(&lv, &out, None, false, &Silent).unwrap();
//! assert!(written[0].1.polygons_out <= written[0].1.polygons_in);
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

pub(crate) use analyse::{evaluate, horizon, trace_in};
pub use analyse::{EvaluateOptions, Scenes, Traced};
pub use error::PoiCrsError;
pub(crate) use fisheye::sky_pictures;
pub use fisheye::{SkyPicture, SkyPictureOptions};
pub(crate) use frame::frame_in;
pub use frame::{FrameOptions, Framed};
pub(crate) use irradiance::irradiance;
pub use irradiance::PoiIrradiance;
pub(crate) use levels::{levels, levels_of};
pub use levels::{BoundSpec, Levels, LevelsInput, LevelsOptions};
pub use read::Inputs;
pub(crate) use read::{check_model_in, read_inputs, read_sources};
pub use write::Written;
pub(crate) use write::{
    buildings_without_kept_assets, write_all, write_levels, write_levels_to, write_merged_levels,
};
