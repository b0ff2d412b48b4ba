//! The `skylod lod` pipeline in memory: rough model -> selection scene (BVH) -> selection,
//! with the time of each stage. Reading and writing stay with the caller (the command
//! writes with [`crate::citygml::mixed::write_mixed`]; `evaluate` traces the result).
//!
//! # Example
//! ```
//! use skylod::lod::{lod, LodOptions};
//! use skylod::poi::Poi;
//! use skylod::synth::{generate, pois, Preset};
//! let opts = Preset::Small.defaults();
//! let mut xml = Vec::new();
//! generate(&opts, &mut xml).unwrap();
//! let model = skylod::citygml::read::read_bytes(&xml, "small.gml").unwrap();
//! let pois: Vec<Poi> = pois(&opts).into_iter().map(Into::into).collect();
//! let r = lod(&model, &pois, &LodOptions::default()).unwrap();
//! let [l0, l1, l2] = r.selection.level_counts();
//! assert_eq!(l0 + l1 + l2, model.assets.len());
//! assert!(l1 > 0 && l0 > 0);
//! ```

use crate::checks::{poi_flags, PoiFlag};
use crate::model::CityModel;
use crate::poi::Poi;
use crate::rough::{rough_model, RoughGeometry, RoughOptions};
use crate::scene::selection_scene;
use crate::select::{select, SelectError, SelectOptions, Selection};
use rayon::prelude::*;
use std::time::Instant;

/// Options of the whole pipeline.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LodOptions {
    /// The rough stage.
    pub rough: RoughOptions,
    /// The selection stage.
    pub select: SelectOptions,
}

/// What the pipeline made.
#[derive(Debug, Clone)]
pub struct LodResult {
    /// Rough geometry per asset.
    pub rough: Vec<RoughGeometry>,
    /// Levels and hits per asset.
    pub selection: Selection,
    /// Seconds in the rough stage.
    pub rough_s: f64,
    /// Seconds triangulating and building the BVH of the selection scene.
    pub bvh_s: f64,
    /// Seconds of the selection over all POIs.
    pub select_s: f64,
    /// Triangles of the selection scene.
    pub triangles: usize,
    /// Per POI, what makes its result suspect ([`poi_flags`] against the selection scene).
    pub flags: Vec<Vec<PoiFlag>>,
}

/// Run rough, scene and selection for `pois` on `model`.
///
/// # Errors
/// As [`select`].
pub fn lod(model: &CityModel, pois: &[Poi], opts: &LodOptions) -> Result<LodResult, SelectError> {
    let t = Instant::now();
    let rough = rough_model(model, &opts.rough);
    let rough_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let scene = selection_scene(model, &rough);
    let bvh_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let selection = select(model, &rough, &scene, pois, &opts.select)?;
    let select_s = t.elapsed().as_secs_f64();
    let flags = pois
        .par_iter()
        .zip(&selection.pois)
        .map(|(p, s)| poi_flags(&scene, model, p, Some(s.sky_rays)))
        .collect();
    Ok(LodResult {
        flags,
        rough,
        selection,
        rough_s,
        bvh_s,
        select_s,
        triangles: scene.len(),
    })
}
