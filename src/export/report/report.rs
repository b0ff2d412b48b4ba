//! The JSON report of `skylod lod` (`--report FILE`), described by
//! `schemas/report.schema.json`: parameters, per-POI summaries, one entry per asset (id,
//! kind, building, hits, level, polygons in and out), totals and timings per stage.
//!
//! # Example
//! ```
//! use skylod::model::CityModel;
//! use skylod::export::report::{Parameters, Report, Timings};
//! use skylod::lod::Selection;
//! let model = CityModel::default();
//! let sel = Selection { levels: vec![], hits: vec![], roof_asset: vec![], pois: vec![],
//!     threshold_deg: 2.0, rays: 100 };
//! let r = Report::new(&model, &[], &sel, &[], Parameters::default(), Timings::default());
//! assert_eq!(r.totals.assets, 0);
//! let json = serde_json::to_string(&r).unwrap();
//! assert!(json.contains("\"timings_ms\""));
//! ```

use crate::lod::rough::{RoughGeometry, RoughOptions};
use crate::lod::select::{FullFacts, PoiSelection, Selection};
use crate::model::CityModel;
use crate::model::Poi;
use rayon::prelude::*;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Format version of the report (bumped on incompatible changes).
pub const REPORT_VERSION: u32 = 2;

/// The whole report.
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[schemars(
    title = "skylod lod report",
    description = "Written by `skylod lod --report FILE`: parameters, per-POI summaries, one entry per asset with its level, totals and timings per stage.",
    deny_unknown_fields,
    extend("$id" = "https://github.com/skylod/skylod/schemas/report.schema.json")
)]
pub struct Report {
    /// `REPORT_VERSION`.
    #[schemars(
        description = "Format version of the report (bumped on incompatible changes).",
        extend("const" = REPORT_VERSION)
    )]
    pub report_version: u32,
    /// Version of skylod that wrote it.
    pub skylod_version: String,
    /// Input files, in model file order.
    pub inputs: Vec<InputEntry>,
    /// Parameters of the run.
    pub parameters: Parameters,
    /// One entry per POI, in input order.
    pub pois: Vec<PoiEntry>,
    /// One entry per asset, in model order.
    pub assets: Vec<AssetEntry>,
    /// Sums over the assets.
    pub totals: Totals,
    /// Wall-clock milliseconds per stage.
    pub timings_ms: Timings,
    /// What the run guarantees at every POI: the errors bounded, and what is not and why.
    pub guarantee: Guarantee,
    /// The error bound check and its promotions (on by default; absent with `--no-bound`).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(with = "crate::lod::bound::BoundReport")]
    pub bound: Option<crate::lod::bound::BoundReport>,
}

/// What the LoD model guarantees at every POI against the full model (the error bound).
#[derive(Debug, Clone, Default, PartialEq, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
pub struct Guarantee {
    /// Largest relative SVF error at any POI, checked by tracing both models with the same
    /// rays (null: not bounded).
    #[schemars(range(min = 0))]
    pub svf_error: Option<f64>,
    /// Largest relative error of yearly sun hours at any POI (null: not bounded).
    #[schemars(range(min = 0))]
    pub sun_hours_error: Option<f64>,
    /// Largest relative error of the annual global irradiation at any POI, for the weather
    /// year of `--weather` (absent without it).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = 0))]
    pub irradiance_error: Option<f64>,
    /// What is not bounded and why (e.g. no site for the sun, or the bound turned off).
    pub not_bounded: Vec<String>,
}

impl Guarantee {
    /// One line for the run's summary: what holds at every POI, what does not and why.
    pub fn line(&self) -> String {
        let pct = |e: f64| format!("{}%", 100.0 * e);
        let mut held = Vec::new();
        if let Some(e) = self.svf_error {
            held.push(format!("SVF within {}", pct(e)));
        }
        if let Some(e) = self.sun_hours_error {
            held.push(format!("sun hours within {}", pct(e)));
        }
        if let Some(e) = self.irradiance_error {
            held.push(format!("annual irradiation within {}", pct(e)));
        }
        let mut line = if held.is_empty() {
            "guaranteed: nothing".to_string()
        } else {
            format!("guaranteed at every POI: {}", held.join(", "))
        };
        for why in &self.not_bounded {
            line.push_str("; not bounded: ");
            line.push_str(why);
        }
        line
    }
}

/// One input file.
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
pub struct InputEntry {
    /// Path as given.
    pub path: String,
    /// CityGML version ("1.0", "2.0", "3.0").
    #[schemars(extend("enum" = ["1.0", "2.0", "3.0"]))]
    pub citygml_version: String,
    /// `srsName` of the file, if any.
    pub srs_name: Option<String>,
    /// Output written for it, if any.
    pub output: Option<String>,
    /// Buildings and parts in the output written for it (0 when none was written).
    pub buildings_out: usize,
}

/// Parameters of the run.
#[derive(Debug, Clone, Serialize, JsonSchema, Default)]
#[schemars(deny_unknown_fields)]
pub struct Parameters {
    /// Rays per POI: cells of the equal-solid-angle hemisphere partition.
    #[schemars(range(min = 1))]
    pub rays: usize,
    /// Jitter seed.
    pub seed: u64,
    /// Silhouette threshold in degrees (the value used).
    #[schemars(extend("exclusiveMinimum" = 0, "maximum" = 90))]
    pub threshold_deg: f64,
    /// Tolerance below the roof edge for roof installations (m).
    pub roof_tolerance_m: f64,
    /// Rough-model plane angle (degrees).
    pub rough_angle_deg: f64,
    /// Rough-model plane thickness (m).
    pub rough_thickness_m: f64,
    /// Whether LoD2 geometry was preferred as rough input.
    pub rough_prefer_lod2: bool,
}

impl Parameters {
    /// Parameters from the stage options and the selection.
    pub fn of(sel: &Selection, seed: u64, roof_tolerance_m: f64, rough: &RoughOptions) -> Self {
        Parameters {
            rays: sel.rays,
            seed,
            threshold_deg: sel.threshold_deg,
            roof_tolerance_m,
            rough_angle_deg: rough.angle_deg,
            rough_thickness_m: rough.thickness_m,
            rough_prefer_lod2: rough.prefer_lod2,
        }
    }
}

/// Where a POI is and what its rays saw: the part of a POI's summary that the report
/// ([`PoiEntry`]) and a shard's levels file ([`crate::pipeline::batch::shard_levels::PoiRecord`]) share.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
pub struct PoiSeen {
    /// Id.
    pub id: String,
    /// Position in the model's CRS.
    pub position: [f64; 3],
    /// Surface normal, if given.
    pub normal: Option<[f64; 3]>,
    /// Rays cast (in front of the surface, above the horizon).
    pub rays: usize,
    /// Rays that reached the sky.
    pub sky_rays: usize,
    /// Assets hit.
    pub assets_hit: usize,
    /// Assets on this POI's silhouette.
    pub silhouette_assets: usize,
}

impl PoiSeen {
    /// The POI `p` (model CRS) with what its selection `s` saw.
    pub fn new(p: &Poi, s: &PoiSelection) -> Self {
        PoiSeen {
            id: s.id.clone(),
            position: p.position.to_array(),
            normal: p.normal.map(|n| n.to_array()),
            rays: s.rays,
            sky_rays: s.sky_rays,
            assets_hit: s.assets_hit,
            silhouette_assets: s.silhouette_assets,
        }
    }

    /// The POI again (model CRS).
    pub fn poi(&self) -> Poi {
        Poi {
            id: self.id.clone(),
            position: glam::DVec3::from_array(self.position),
            normal: self.normal.map(glam::DVec3::from_array),
        }
    }
}

/// One POI.
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
pub struct PoiEntry {
    /// Where the POI is and what its rays saw.
    #[serde(flatten)]
    pub seen: PoiSeen,
    /// Time of this POI's selection (ms).
    #[schemars(range(min = 0))]
    pub ms: f64,
    /// Polygons of this POI's own LoD model (its levels alone, before any error bound).
    pub polygons_own: usize,
    /// What makes this POI's result suspect ([`crate::lod::poi::checks::poi_flags`]); set by
    /// [`Report::set_flags`].
    #[schemars(
        description = "What makes this POI's results suspect: inside a closed building solid (every direction blocked), or no sky ray at all."
    )]
    pub flags: Vec<crate::lod::poi::checks::PoiFlag>,
}

/// One asset.
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
pub struct AssetEntry {
    /// `gml:id`, if any.
    pub id: Option<String>,
    /// Kind ("roof", "wall", "installation", ...).
    #[schemars(extend("enum" = ["roof", "wall", "ground", "closure", "outer_ceiling", "outer_floor", "installation", "window", "door", "body", "other"]))]
    pub kind: &'static str,
    /// `gml:id` of its building (or building part), if any.
    pub building: Option<String>,
    /// Index of its input file in `inputs`.
    pub file: usize,
    /// Ray hits over all POIs.
    pub hits: u64,
    /// Level 0 (dropped), 1 (rough) or 2 (full detail).
    #[schemars(extend("enum" = [0, 1, 2]))]
    pub level: u8,
    /// Whether it counts as a roof asset (candidate for level 2).
    pub roof_asset: bool,
    /// Polygons in the input (all LoDs).
    pub polygons_in: usize,
    /// Polygons in the output (`crate::lod::level::polygon_count` of its level).
    #[schemars(description = "Polygons in the output (at its level).")]
    pub polygons_out: usize,
}

/// Totals.
#[derive(Debug, Clone, Serialize, JsonSchema, Default)]
#[schemars(deny_unknown_fields)]
pub struct Totals {
    /// Assets in the input.
    pub assets: usize,
    /// Assets per level `[0, 1, 2]`.
    pub levels: [usize; 3],
    /// Polygons of all assets in the input.
    pub polygons_in: usize,
    /// Polygons of all assets in the output.
    pub polygons_out: usize,
    /// `polygons_out / polygons_in` (0 for an empty input).
    #[schemars(range(min = 0))]
    pub polygon_fraction: f64,
    /// Buildings and parts in the input.
    pub buildings_in: usize,
    /// The largest of the POIs' own LoD models (polygons): one model for all POIs (a
    /// region) costs `polygons_out` instead of one model per POI.
    pub single_poi_polygons_max: usize,
    /// The mean of the POIs' own LoD models (polygons).
    #[schemars(range(min = 0))]
    pub single_poi_polygons_mean: f64,
    /// `polygons_out / single_poi_polygons_max` (0 when no POI kept anything).
    #[schemars(range(min = 0))]
    pub region_over_single_poi: f64,
    /// Buildings and parts in the outputs written, as the writer counted them (see
    /// [`Report::record_output`]); 0 until outputs are recorded.
    #[schemars(
        description = "Buildings and parts in the outputs written, as the writer counted them; 0 when none was written."
    )]
    pub buildings_out: usize,
}

/// Milliseconds per stage.
#[derive(Debug, Clone, Copy, Serialize, JsonSchema, Default)]
#[schemars(deny_unknown_fields)]
pub struct Timings {
    /// Reading the inputs.
    #[schemars(range(min = 0))]
    pub read: f64,
    /// The rough model.
    #[schemars(range(min = 0))]
    pub rough: f64,
    /// Triangulation and BVH build of the rough scene.
    #[schemars(range(min = 0))]
    pub bvh: f64,
    /// Selection over all POIs.
    #[schemars(range(min = 0))]
    pub select: f64,
    /// Writing the outputs.
    #[schemars(range(min = 0))]
    pub write: f64,
    /// The whole command.
    #[schemars(range(min = 0))]
    pub total: f64,
}

impl Report {
    /// Build the report. `outputs[f]` is the output path of input file `f` (if any).
    pub fn new(
        model: &CityModel,
        rough: &[RoughGeometry],
        sel: &Selection,
        pois: &[Poi],
        parameters: Parameters,
        timings_ms: Timings,
    ) -> Report {
        Report::new_from(model, model, rough, sel, pois, parameters, timings_ms)
    }

    /// [`Report::new`] of a model whose polygon counts `facts` gives (the model itself, or a
    /// hollow read of it, `crate::lod::hollow::Hollow`, whose `model` has no polygons).
    pub fn new_from(
        model: &CityModel,
        facts: &dyn FullFacts,
        rough: &[RoughGeometry],
        sel: &Selection,
        pois: &[Poi],
        parameters: Parameters,
        timings_ms: Timings,
    ) -> Report {
        let inputs = model
            .files
            .iter()
            .map(|f| InputEntry {
                path: f.path.display().to_string(),
                citygml_version: f.version.as_str().to_string(),
                srs_name: f.srs_name.clone(),
                output: None,
                buildings_out: 0,
            })
            .collect();
        let mut totals = Totals {
            assets: model.assets.len(),
            buildings_in: model.buildings.len(),
            ..Default::default()
        };
        // an entry per asset on rayon's pool (a city's assets; the last step of `lod`), the
        // totals summed from them in order
        let assets: Vec<AssetEntry> = model
            .assets
            .par_iter()
            .enumerate()
            .map(|(i, a)| {
                let level = sel.levels.get(i).copied().unwrap_or(0);
                let polygons_in = facts.polygons(i);
                let out = facts.polygon_count(i, rough.get(i), level);
                AssetEntry {
                    id: a.id.as_deref().map(str::to_owned),
                    kind: a.kind.as_str(),
                    building: a
                        .building
                        .and_then(|b| model.buildings.get(b))
                        .and_then(|b| b.id.clone()),
                    file: a.file,
                    hits: sel.hits.get(i).copied().unwrap_or(0),
                    level,
                    roof_asset: sel.roof_asset.get(i).copied().unwrap_or(false),
                    polygons_in,
                    polygons_out: out,
                }
            })
            .collect();
        for a in &assets {
            totals.polygons_in += a.polygons_in;
            totals.polygons_out += a.polygons_out;
            if let Some(c) = totals.levels.get_mut(usize::from(a.level)) {
                *c += 1;
            }
        }
        totals.polygon_fraction = if totals.polygons_in == 0 {
            0.0
        } else {
            totals.polygons_out as f64 / totals.polygons_in as f64
        };
        totals.single_poi_polygons_max = sel.pois.iter().map(|p| p.polygons).max().unwrap_or(0);
        totals.single_poi_polygons_mean = if sel.pois.is_empty() {
            0.0
        } else {
            sel.pois.iter().map(|p| p.polygons as f64).sum::<f64>() / sel.pois.len() as f64
        };
        totals.region_over_single_poi = if totals.single_poi_polygons_max == 0 {
            0.0
        } else {
            totals.polygons_out as f64 / totals.single_poi_polygons_max as f64
        };
        let pois = sel
            .pois
            .iter()
            .zip(pois)
            .map(|(s, p)| PoiEntry {
                seen: PoiSeen::new(p, s),
                ms: s.seconds * 1e3,
                polygons_own: s.polygons,
                flags: Vec::new(),
            })
            .collect();
        Report {
            report_version: REPORT_VERSION,
            skylod_version: env!("CARGO_PKG_VERSION").to_string(),
            inputs,
            parameters,
            pois,
            assets,
            totals,
            timings_ms,
            guarantee: Guarantee::default(),
            bound: None,
        }
    }

    /// Set the flags of each POI (in POI order).
    pub fn set_flags(&mut self, flags: &[Vec<crate::lod::poi::checks::PoiFlag>]) {
        for (entry, f) in self.pois.iter_mut().zip(flags) {
            entry.flags = f.clone();
        }
    }

    /// Record the output written for input file `file`: its path and the buildings and parts
    /// it holds (`buildings_in_file` minus those the writer dropped), so that
    /// `totals.buildings_out` counts what the files hold, not what a rule guessed.
    pub fn record_output(
        &mut self,
        file: usize,
        path: String,
        buildings_in_file: usize,
        dropped: usize,
    ) {
        let n = buildings_in_file.saturating_sub(dropped);
        if let Some(entry) = self.inputs.get_mut(file) {
            self.totals.buildings_out = self.totals.buildings_out - entry.buildings_out + n;
            entry.output = Some(path);
            entry.buildings_out = n;
        }
    }
}
