//! The `skylod lod` pipeline in memory: rough model -> selection scene (BVH) -> selection,
//! with the time of each stage. Reading and writing stay with the caller (the command
//! writes with [`crate::lod::mixed::write_mixed`]; `evaluate` traces the result).
//!
//! # Example
//! ```
//! use skylod::lod::{lod, LodOptions};
//! use skylod::lod::poi::Poi;
//! use skylod::model::synth::{generate, pois, Preset};
//! let opts = Preset::Small.defaults();
//! let mut xml = Vec::new();
//! generate(&opts, &mut xml).unwrap();
//! let model = skylod::io::citygml::read_bytes(&xml, "small.gml").unwrap();
//! let pois: Vec<Poi> = pois(&opts).into_iter().map(Into::into).collect();
//! let silent = &skylod::model::Silent;
//! let r = lod(&model, &pois, &LodOptions::default(), silent).unwrap();
//! let [l0, l1, l2] = r.selection.level_counts();
//! assert_eq!(l0 + l1 + l2, model.assets.len());
//! assert!(l1 > 0 && l0 > 0);
//! ```

pub(crate) mod bound;
mod bound_report;
// The hollow read: rough forms, boxes and counts made chunk by chunk, polygons dropped.
pub(crate) mod hollow;
// Full vs LoD vs all-boxes model per POI (paper 5, Tables 1 and 2).
pub(crate) mod evaluation;
pub(crate) mod level;
pub(crate) mod mixed;
// Reading POIs, POIs from regions and facades, trust checks.
pub mod poi;
pub mod rough;
pub(crate) mod scene;
pub(crate) mod select;
pub use bound::{
    bound, bound_against_from, full_answers_from, BoundError, BoundOptions, Bounded, FullSource,
    HollowSource,
};
pub use evaluation::{evaluate, EvalOptions};
pub use hollow::{hollowed, near_pois, read_hollow};
pub use level::{polygon_count, properties, traced};
pub use mixed::{write_mixed, write_mixed_to, MixedSummary};
pub use scene::{detail_boxes, detail_key, full_scene, mixed_scene, rough_scene, selection_scene};
pub use select::{select, SelectError, SelectOptions, Selection};

use crate::lod::poi::checks::enclosure::ON_SURFACE;
use crate::lod::poi::checks::{poi_flags_around, PoiFlag, Surroundings};
use crate::lod::rough::{rough_model, RoughGeometry, RoughOptions};
use crate::lod::scene::selection_scene_for_rays;
use crate::lod::select::{select_facts, FullFacts};
use crate::model::runtime::progress::{check, stage, Progress, Stage};
use crate::model::CityModel;
use crate::model::Poi;
use glam::DVec3;
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
    /// Per POI, what makes its result suspect (`poi_flags_around`: inside a building judged
    /// on the full geometry of the buildings whose box holds the POI, not on the selection scene).
    pub flags: Vec<Vec<PoiFlag>>,
}

/// What the LoD stage runs on: a model read whole, or one document read hollow
/// ([`hollow::read_hollow`], its POI checks' geometry kept with [`hollow::near_pois`]),
/// whose rough forms the read made and whose full polygons' facts it kept. The two give the
/// same result; they differ only in where the rough forms and the facts come from
/// ([`lod`]).
#[derive(Debug, Clone, Copy)]
pub enum LodInput<'a> {
    /// The model with every polygon.
    Whole(&'a CityModel),
    /// A document read hollow.
    Hollow(&'a hollow::Hollow),
}

impl<'a> LodInput<'a> {
    /// The model the stage runs on (a hollow read's holds the polygons of a few assets).
    pub fn model(&self) -> &'a CityModel {
        match *self {
            LodInput::Whole(m) => m,
            LodInput::Hollow(h) => &h.model,
        }
    }
}

impl<'a> From<&'a CityModel> for LodInput<'a> {
    fn from(m: &'a CityModel) -> Self {
        LodInput::Whole(m)
    }
}

impl<'a> From<&'a hollow::Hollow> for LodInput<'a> {
    fn from(h: &'a hollow::Hollow) -> Self {
        LodInput::Hollow(h)
    }
}

/// Rough model ([`Stage::Rough`]), selection scene ([`Stage::Bvh`]) and selection
/// ([`Stage::Select`] per POI) for `pois` on `input`, reported to `progress` and stopped with
/// [`SelectError::Cancelled`] when it asks to. A hollow read's rough forms are the read's
/// (the rough stage takes no time), a whole model's are made here.
///
/// # Errors
/// As [`crate::lod::select::select`], and [`SelectError::Cancelled`].
pub fn lod<'a>(
    input: impl Into<LodInput<'a>>,
    pois: &[Poi],
    opts: &LodOptions,
    progress: &dyn Progress,
) -> Result<LodResult, SelectError> {
    let input = input.into();
    let model = input.model();
    let n = model.assets.len() as u64;
    check(progress, Stage::Rough)?;
    let t = Instant::now();
    let rough = stage(progress, Stage::Rough, n, 0, || {
        let r = match input {
            LodInput::Whole(m) => rough_model(m, &opts.rough),
            LodInput::Hollow(h) => h.rough.clone(),
        };
        progress.advance(Stage::Rough, n, 0, None);
        r
    });
    let (facts, around, rough_s): (&dyn FullFacts, _, _) = match input {
        LodInput::Whole(m) => {
            crate::model::runtime::mem::give_back_for(m.assets.len());
            (m, Surroundings::new(m), t.elapsed().as_secs_f64())
        }
        LodInput::Hollow(h) => (h, Surroundings::with_boxes(&h.model, &h.boxes), 0.0),
    };
    select_and_flag(
        (model, facts, &around),
        rough,
        rough_s,
        pois,
        opts,
        progress,
    )
}

/// The rest of [`lod`] after the rough stage: selection scene, selection, POI flags.
fn select_and_flag(
    (model, facts, around): (&CityModel, &dyn FullFacts, &Surroundings),
    rough: Vec<RoughGeometry>,
    rough_s: f64,
    pois: &[Poi],
    opts: &LodOptions,
    progress: &dyn Progress,
) -> Result<LodResult, SelectError> {
    check(progress, Stage::Bvh)?;
    let t = Instant::now();
    let scene = stage(progress, Stage::Bvh, 1, 0, || {
        selection_scene_for_rays(model, &rough, pois.len().saturating_mul(opts.select.rays))
    });
    let bvh_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let selection = stage(progress, Stage::Select, pois.len() as u64, 0, || {
        select_facts(model, facts, &rough, &scene, pois, &opts.select, progress)
    })?;
    let select_s = t.elapsed().as_secs_f64();
    // Inside a building is judged on the full geometry (the rough model may close what the
    // full one leaves open): the buildings whose box holds a POI.
    let points: Vec<DVec3> = pois.iter().map(|p| p.position).collect();
    let full_near = around.scene_holding(model, &points, ON_SURFACE);
    let flags = pois
        .par_iter()
        .zip(&selection.pois)
        .map(|(p, s)| poi_flags_around(&full_near, model, around, p, Some(s.sky_rays)))
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
