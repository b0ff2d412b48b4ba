//! The JSON of `skylod evaluate --json`: per POI the full, LoD and all-boxes models' solar
//! figures and their errors ([`PoiEval`]), the rays, the sun table and the timings.

use super::sun_hours::SunSetting;
use crate::pipeline::evaluation::PoiEval;
use schemars::JsonSchema;
use serde::Serialize;

/// The whole `evaluate --json` document.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
#[non_exhaustive]
pub struct EvaluateOutput {
    /// Paths read.
    pub inputs: Vec<String>,
    /// Rays per POI of the selection.
    pub rays: usize,
    /// Rays of each SVF bundle.
    pub svf_rays: usize,
    /// Seed of the selection's ray jitter.
    pub seed: u64,
    /// The sun table, `null` without sun hours (`--no-sun`).
    pub sun: Option<SunSetting>,
    /// One entry per POI, in input order.
    pub pois: Vec<PoiEval>,
    /// Wall-clock milliseconds per stage.
    pub timings_ms: EvaluateTimings,
}

impl EvaluateOutput {
    /// The document of an evaluation with `rays` selection rays, `svf_rays` SVF rays and
    /// seed `seed`.
    pub fn new(
        inputs: Vec<String>,
        rays: usize,
        svf_rays: usize,
        seed: u64,
        sun: Option<SunSetting>,
        pois: Vec<PoiEval>,
        timings_ms: EvaluateTimings,
    ) -> Self {
        EvaluateOutput {
            inputs,
            rays,
            svf_rays,
            seed,
            sun,
            pois,
            timings_ms,
        }
    }
}

/// Milliseconds per stage of `evaluate`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
pub struct EvaluateTimings {
    /// Reading the inputs.
    #[schemars(range(min = 0))]
    pub read: f64,
    /// The rough model (shared by all POIs).
    #[schemars(range(min = 0))]
    pub rough: f64,
    /// The selection scene (shared by all POIs).
    #[schemars(range(min = 0))]
    pub selection_bvh: f64,
    /// The whole command.
    #[schemars(range(min = 0))]
    pub total: f64,
}
