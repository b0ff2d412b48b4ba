//! skylod: skyline-controlled mixed level-of-detail CityGML for solar analysis.
//!
//! The library follows the pipeline of `DESIGN.md`:
//! read (CityGML -> [`model::CityModel`]) -> rough -> sky -> trace -> select -> write.
//! It never prints and never panics on input.
#![warn(missing_docs)]

pub mod model;
pub mod synth;
