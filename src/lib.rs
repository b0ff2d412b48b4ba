//! skylod: skyline-controlled mixed level-of-detail CityGML for solar analysis.
//!
//! The library follows the pipeline of `DESIGN.md`:
//! read (CityGML → [`CityModel`]) → rough → sky → trace → select → write.
//! [`pipeline`] runs it for a program in four calls — inputs → scene → levels → outputs —
//! with progress and cancellation through a [`Progress`]; the `skylod` binary is a thin front
//! end over the same calls. The library never prints and never panics on input.
//!
//! The crate root re-exports what a program needs for that path (the calls, their options and
//! results, the model, POIs, formats, errors, progress); the six modules below hold the rest,
//! layered [`model`] < [`io`] < [`solar`] < [`lod`] < [`export`] < [`pipeline`], each importing
//! only the groups before it (`ARCHITECTURE.md`).
//!
//! Cargo features: `cli` (default) builds the `skylod` program and its dependencies (clap,
//! anyhow, indicatif, clap_complete, clap_mangen); `skylod = { default-features = false }`
//! is the library alone. `proj` adds reprojection through PROJ.
//!
//! # Example: read → POIs → levels → write
//! ```
//! use skylod::{frame, levels, read_inputs, read_pois_csv, write_levels};
//! use skylod::{Format, FrameOptions, LevelsOptions, Silent};
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
//! let w = write_levels((framed.source, 0), &lv, &out, Format::CityGml, &Default::default())?;
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
    frame, levels, read_inputs, sun_hours, svf, write_all, write_levels, EvaluateOptions,
    FrameOptions, Framed, Inputs, Levels, LevelsOptions, Traced, Written,
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
