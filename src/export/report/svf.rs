//! The JSON of `skylod svf --json`: per POI its sky view factor and sky exposure, the sky
//! bundle, the inputs and the timings.

use super::row::PoiRow;
use super::text::{run_part, TextContext};
use crate::lod::poi::checks::PoiFlag;
use crate::model::Poi;
use crate::solar::SkyView;
use schemars::JsonSchema;
use serde::Serialize;
use std::io::Write;

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
    /// Polygons of the model (all LoDs, as `stats` counts them: `CityModel::polygon_count`).
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

/// The table of `skylod svf`: a header line (if `header`), then one line per POI with its
/// position (`decimals` plan decimals, see [`crate::model::crs::Crs::plan_decimals`]), normal, sky
/// view factor and sky exposure.
pub fn write_table(
    out: &mut impl Write,
    pois: &[SvfPoi],
    decimals: usize,
    header: bool,
) -> std::io::Result<()> {
    if header {
        writeln!(
            out,
            "{:<20} {:>14} {:>14} {:>9} {:>8} {:>8} {:>8} {:>7} {:>12}",
            "id", "x", "y", "z", "nx", "ny", "nz", "svf", "sky_exposure"
        )?;
    }
    let dp = decimals;
    for p in pois {
        let n = p
            .normal
            .map_or(["-".to_string(), "-".into(), "-".into()], |n| {
                n.map(|c| format!("{c:.3}"))
            });
        writeln!(
            out,
            "{:<20} {:>14.dp$} {:>14.dp$} {:>9.3} {:>8} {:>8} {:>8} {:>7.4} {:>12.4}",
            p.id,
            p.poi[0],
            p.poi[1],
            p.poi[2],
            n[0],
            n[1],
            n[2],
            p.svf,
            p.sky_exposure,
            dp = dp
        )?;
    }
    Ok(())
}

/// One POI of `svf --json`.
pub type SvfPoi = PoiRow<SkyValues>;

/// What `svf` computed for one POI ([`SvfPoi`]).
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
#[non_exhaustive]
pub struct SkyValues {
    /// Sky view factor, cosine-weighted to the normal.
    #[schemars(range(min = 0, max = 1))]
    pub svf: f64,
    /// Unweighted solid-angle fraction of the sky hemisphere seen.
    #[schemars(range(min = 0, max = 1))]
    pub sky_exposure: f64,
    /// Rays cast (in front of the surface, above the horizon).
    pub rays: usize,
}

impl SvfPoi {
    /// The entry of `poi` with its sky view and flags.
    pub fn new(poi: &Poi, view: &SkyView, flags: &[PoiFlag]) -> Self {
        let values = SkyValues {
            svf: view.svf,
            sky_exposure: view.sky_exposure,
            rays: view.rays,
        };
        PoiRow::of(poi, values, flags)
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

impl TraceTimings {
    /// `(stage, ms)` in the order the summary line names them ([`run_part`]).
    pub(crate) fn stages(&self) -> [(&'static str, f64); 3] {
        [
            ("read", self.read),
            ("bvh", self.bvh),
            ("trace", self.trace),
        ]
    }

    /// `read_ms` with the seconds building the scene and tracing, as milliseconds rounded
    /// to 0.1.
    pub fn new(read_ms: f64, bvh_s: f64, trace_s: f64) -> Self {
        let ms = |s: f64| (s * 1e4).round() / 10.0;
        TraceTimings {
            read: read_ms,
            bvh: ms(bvh_s),
            trace: ms(trace_s),
        }
    }
}

impl super::text::Document for SvfOutput {
    fn write_table(&self, mut out: &mut dyn Write, cx: &TextContext) -> std::io::Result<()> {
        write_table(&mut out, &self.pois, cx.decimals, cx.header)
    }

    fn summary(&self, cx: &TextContext) -> Vec<String> {
        let t = self.timings_ms.stages();
        vec![format!(
            "{} POI(s), {} rays per bundle, seed {}; {}",
            self.pois.len(),
            self.rays,
            self.seed,
            run_part(self.polygons, cx, self.inputs.len(), &t)
        )]
    }
}
