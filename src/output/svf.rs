//! The JSON of `skylod svf --json`: per POI its sky view factor and sky exposure, the sky
//! bundle, the inputs and the timings.

use crate::model::Poi;
use crate::poi::checks::PoiFlag;
use crate::solar::SkyView;
use schemars::JsonSchema;
use serde::Serialize;

/// The whole `svf --json` document.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
#[non_exhaustive]
pub struct SvfOutput {
    /// One entry per POI, in input order.
    pub pois: Vec<SvfPoi>,
    /// Rays per bundle.
    pub rays: usize,
    /// Seed of the ray jitter.
    pub seed: u64,
    /// Paths read.
    pub inputs: Vec<String>,
    /// Polygons of the scene at full detail.
    pub polygons: usize,
    /// Wall-clock milliseconds per stage.
    pub timings_ms: TraceTimings,
}

impl SvfOutput {
    /// The document of a run with `rays` rays per bundle and seed `seed`.
    pub fn new(
        pois: Vec<SvfPoi>,
        rays: usize,
        seed: u64,
        inputs: Vec<String>,
        polygons: usize,
        timings_ms: TraceTimings,
    ) -> Self {
        SvfOutput {
            pois,
            rays,
            seed,
            inputs,
            polygons,
            timings_ms,
        }
    }
}

/// One POI of `svf --json`.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
#[non_exhaustive]
pub struct SvfPoi {
    /// Id.
    pub id: String,
    /// Position in the model's CRS.
    pub poi: [f64; 3],
    /// Surface normal, if given.
    pub normal: Option<[f64; 3]>,
    /// Sky view factor, cosine-weighted to the normal.
    #[schemars(range(min = 0, max = 1))]
    pub svf: f64,
    /// Unweighted solid-angle fraction of the sky hemisphere seen.
    #[schemars(range(min = 0, max = 1))]
    pub sky_exposure: f64,
    /// Rays cast (in front of the surface, above the horizon).
    pub rays: usize,
    /// What makes this POI's result suspect.
    pub flags: Vec<PoiFlag>,
}

impl SvfPoi {
    /// The entry of `poi` with its sky view and flags.
    pub fn new(poi: &Poi, view: &SkyView, flags: &[PoiFlag]) -> Self {
        SvfPoi {
            id: poi.id.clone(),
            poi: poi.position.to_array(),
            normal: poi.normal.map(|n| n.to_array()),
            svf: view.svf,
            sky_exposure: view.sky_exposure,
            rays: view.rays,
            flags: flags.to_vec(),
        }
    }
}

/// Milliseconds per stage of a traced command (`svf`, `horizon`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
pub struct TraceTimings {
    /// Reading the inputs.
    #[schemars(range(min = 0))]
    pub read: f64,
    /// Triangulation and BVH build of the scene.
    #[schemars(range(min = 0))]
    pub bvh: f64,
    /// Tracing.
    #[schemars(range(min = 0))]
    pub trace: f64,
}
