//! skylod: skyline-controlled mixed level-of-detail CityGML for solar analysis.
//!
//! The library follows the pipeline of `DESIGN.md`:
//! read (CityGML -> [`model::CityModel`]) -> rough -> sky -> trace -> select -> write.
//! It never prints and never panics on input.
#![warn(missing_docs)]

pub mod bound;
pub mod checks;
pub mod citygml;
pub mod crs;
pub mod evaluate;
pub mod export;
pub mod geom;
pub mod inputs;
pub mod level;
pub mod lod;
pub mod model;
pub mod poi;
pub mod region;
pub mod report;
pub mod reproject;
pub mod rough;
pub mod scene;
pub mod scene_radius;
pub mod select;
pub mod shard;
pub mod shard_levels;
pub mod sky;
pub mod solar;
pub mod stats;
pub mod synth;
pub mod trace;
