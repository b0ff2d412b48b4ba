//! skylod: skyline-controlled mixed level-of-detail CityGML for solar analysis.
//!
//! The library follows the pipeline of `DESIGN.md`:
//! read (CityGML -> [`model::CityModel`]) -> rough -> sky -> trace -> select -> write.
//! [`pipeline`] runs it for a program in four calls — inputs → scene → levels → outputs —
//! with progress and cancellation through a [`runtime::progress::Progress`]; the `skylod` binary
//! is a thin front end over the same calls. The library never prints and never panics on
//! input.
//!
//! Cargo features: `cli` (default) builds the `skylod` program and its dependencies (clap,
//! anyhow, indicatif, clap_complete, clap_mangen); `skylod = { default-features = false }`
//! is the library alone. `proj` adds reprojection through PROJ.
//!
//! # Example: read → POIs → levels → write
//! ```
//! use skylod::export::Format;
//! use skylod::pipeline::{frame, levels, read_inputs, write_levels, FrameOptions, LevelsOptions};
//! use skylod::poi::read_pois_csv;
//! use skylod::runtime::progress::Silent;
//! use std::path::Path;
//!
//! let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
//! // Inputs: every file is read (in parallel) and merged into one scene.
//! let mut inputs = read_inputs(&[dir.join("synth-small.gml")], &Silent)?;
//! inputs.check(false)?; // one CRS, heights present
//! // POIs: a CSV `id,x,y,z[,nx,ny,nz]` in the model's CRS.
//! let pois = read_pois_csv(&dir.join("synth-small.pois.csv"))?
//!     .into_iter()
//!     .map(|l| l.poi)
//!     .collect();
//! // Scene: model and POIs in the local metric frame, POIs far outside refused.
//! let framed = frame(&mut inputs.model, pois, &FrameOptions::default())?;
//! // Levels: rough model, selection scene, silhouette selection (0 dropped, 1 rough, 2 full).
//! let lv = levels(&framed, &LevelsOptions::default(), &Silent)?;
//! let [dropped, rough, full] = lv.lod.selection.level_counts();
//! assert_eq!(dropped + rough + full, framed.source.assets.len());
//! // Outputs: the input file with every asset at its level, written atomically.
//! let tmp = tempfile::tempdir()?;
//! let out = tmp.path().join("lod.gml");
//! let w = write_levels(framed.source, 0, &lv, &out, Format::CityGml, &Default::default())?;
//! assert!(w.polygons_out < w.polygons_in);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![warn(missing_docs)]

pub mod batch;
pub mod citygml;
pub mod crs;
pub mod export;
pub mod io;
pub mod lod;
pub mod model;
pub mod output;
pub mod pipeline;
pub mod poi;
pub mod runtime;
pub mod solar;
pub mod synth;
pub mod trace;

// The paths of release 0.1, kept for one release (moved in 0.2, see CHANGELOG.md).
#[doc(hidden)]
pub use batch::{inputs, scene_radius, shard, shard_levels};
/// Moved: [`crs::CrsName`], `crs::proj` (feature `proj`), [`citygml::reproject`].
#[doc(hidden)]
pub mod reproject {
    pub use crate::citygml::reproject::ReprojectError;
    #[cfg(feature = "proj")]
    pub use crate::citygml::reproject::{reproject_file, ReprojectSummary};
    #[cfg(feature = "proj")]
    pub use crate::crs::proj::{crs_info, CrsInfo, Reprojector};
    pub use crate::crs::CrsName;
}
#[doc(hidden)]
pub use lod::{bound, level, rough, scene, select};
#[doc(hidden)]
pub use output::{report, stats};
#[doc(hidden)]
pub use pipeline::evaluation as evaluate;
#[doc(hidden)]
pub use poi::{checks, region};
#[doc(hidden)]
pub use runtime::{mem, progress};
#[doc(hidden)]
pub use solar::sky;
/// Moved: polygon triangulation is [`mod@model::triangulate`], the exact ray tests [`trace::ray`].
#[doc(hidden)]
pub mod geom {
    pub use crate::model::triangulate::{self, triangulate};
    pub use crate::trace::ray::{self, ray_aabb, ray_triangle, RayTriangleHit};
}
