//! skylod: skyline-controlled mixed level-of-detail CityGML for solar analysis.
//!
//! The library follows the pipeline of `DESIGN.md`:
//! read (CityGML, CityJSON → [`CityModel`]) → rough → sky → trace → select → write.
//! A program runs it through one session: a [`Scene`] (the inputs read and checked) framed
//! with its POIs into a [`Study`], which chooses levels, traces (SVF, sun hours, horizons,
//! irradiance, evaluation) and writes, with progress and cancellation through a
//! [`Progress`]. The `skylod` binary is a front end over the same session and the batch
//! work of [`pipeline::batch`]. The library never prints and never panics on input.
//!
//! The crate root and [`prelude`] re-export the session, its options and results, the model,
//! POIs, formats, errors and progress; the six modules below hold the rest, layered
//! [`model`] < [`io`] < [`solar`] < [`lod`] < [`export`] < [`pipeline`], each importing only
//! the groups before it (`ARCHITECTURE.md`).
//!
//! Cargo features: `cli` (default) builds the `skylod` program and its dependencies (clap,
//! anyhow, indicatif, clap_complete, clap_mangen); `skylod = { default-features = false }`
//! is the library alone. `proj` adds reprojection through PROJ.
//!
//! # Example: read → POIs → levels → write
//! ```
//! use skylod::prelude::*;
//! use std::path::Path;
//!
//! let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
//! // Inputs: every file is read (in parallel) and merged into one scene; one CRS, heights
//! // present, or an error.
//! let scene = Scene::load(&[dir.join("synth-small.gml")], &SceneOptions::default(), &Silent)?;
//! // POIs: a CSV `id,x,y,z[,nx,ny,nz]` in the model's CRS.
//! let pois = read_pois_csv(&dir.join("synth-small.pois.csv"))?
//!     .into_iter()
//!     .map(|l| l.poi)
//!     .collect();
//! // The study: model and POIs in the local metric frame, POIs far outside refused.
//! let mut study = scene.frame(pois)?;
//! // Levels: rough model, selection scene, silhouette selection (0 dropped, 1 rough, 2 full).
//! let lv = study.levels(&LevelsOptions::default(), &Silent)?;
//! let [dropped, rough, full] = lv.lod.selection.level_counts();
//! assert_eq!(dropped + rough + full, study.source().assets.len());
//! // Outputs: the input file with every asset at its level, written atomically.
//! let tmp = tempfile::tempdir()?;
//! let out = tmp.path().join("lod.gml");
//! let written = study.write_levels(&lv, &out, Some(Format::CityGml), false, &Silent)?;
//! let (_, w) = &written[0];
//! assert!(w.polygons_out < w.polygons_in);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![warn(missing_docs)]

// The data every stage passes: the city model, POIs, triangulation; georeferencing (`crs`),
// generated districts (`synth`), progress and cancellation (`runtime`).
pub mod model;
// Files and the city formats: file helpers (`files`), CityGML (`citygml`), CityJSON (`cityjson`).
pub mod io;
// Solar analysis: ray tracing (`trace`), sky, sun, SVF, sun hours, horizons, fisheye, irradiance.
pub mod solar;
// The LoD stage: POIs (`poi`), rough model, scenes, selection, levels, error bound, the mixed
// writer, the evaluation against the full model.
pub mod lod;
// Outputs: OBJ and CityJSON writers, and what the commands report (`report`: typed JSON).
pub mod export;
// The calls a program runs (read, frame, levels, analyse, write), the owned session
// (`session`: Scene -> Study), batch work (`batch`: inputs, shards, reduce).
pub mod pipeline;

// The facade: read → POIs → levels → write, and the solar numbers, from the root.
pub use export::Format;
/// The vector types of positions and normals ([`glam::DVec3`]), so that a program needs no
/// `glam` dependency of its own.
pub use glam;
pub use io::citygml::{read_file, ReadError, WriteError};
pub use model::{Asset, AssetKind, CityModel, Poi};
pub use pipeline::session::{Error, Result, Scene, SceneOptions, Study, SunOptions};
pub use pipeline::{
    EvaluateOptions, FrameOptions, Framed, Inputs, Levels, LevelsOptions, Traced, Written,
};
pub use solar::{HorizonOptions, Site, SkyBundles, SkyView, SunHours};

/// What a program embedding skylod needs, in one `use skylod::prelude::*;`: the session
/// ([`Scene`] → [`Study`]), its options and results, POIs, formats, progress and errors.
pub mod prelude {
    pub use crate::glam::DVec3;
    pub use crate::{
        read_pois_csv, CityModel, Error, EvaluateOptions, Format, HorizonOptions, Levels,
        LevelsOptions, Poi, Progress, Result, Scene, SceneOptions, Silent, Site, SkyBundles,
        SkyView, Study, SunHours, SunOptions, Traced, Written,
    };
}
pub use lod::poi::{read_pois_csv, PoiError};
pub use model::runtime::progress::{Cancelled, Progress, Silent};
