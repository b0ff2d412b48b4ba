//! Evaluation (paper 5, Tables 1 and 2): for each POI, its own mixed-LoD model is built
//! in memory, and SVF, sky exposure and (optionally) sun hours are computed on the full
//! model, on that LoD model and on the all-boxes model (every asset as its oriented box,
//! the paper's baseline), with relative errors against the full model and polygon counts.
//!
//! The three models are traced with the *same* ray bundles and sun table, so the errors
//! measure the models, not sampling noise. With a weather year ([`evaluate_irradiance`]),
//! each model's annual global irradiation ([`crate::solar::poi_irradiance`], the same SVF
//! bundle and the weather's hours) and its error against the full model are added.
//!
//! # Example
//! ```
//! use skylod::lod::{EvalOptions, evaluate};
//! use skylod::model::Poi;
//! use skylod::solar::{Site, SunTable};
//! use skylod::model::synth::{generate, pois, Preset};
//! let opts = Preset::Small.defaults();
//! let mut xml = Vec::new();
//! generate(&opts, &mut xml).unwrap();
//! let model = skylod::io::citygml::read_bytes(&xml, "small.gml").unwrap();
//! let pois: Vec<Poi> = pois(&opts).into_iter().map(Into::into).collect();
//! let table = SunTable::year(2025, 60, &Site::new(41.39, 2.17)).unwrap();
//! let e = evaluate(&model, &pois, &EvalOptions::default(), Some(&table)).unwrap();
//! assert_eq!(e.pois.len(), pois.len());
//! let p = &e.pois[0];
//! assert!(p.lod.polygons < p.full.polygons);
//! assert!(p.lod.svf_rel_error(&p.full) < 0.05);
//! ```

use crate::lod::bound::rel;
use crate::lod::poi::checks::{poi_flags_around, PoiFlag, Surroundings};
use crate::lod::rough::{all_boxes, rough_model};
use crate::lod::scene::{full_scene, mixed_scene, rough_scene, selection_scene};
use crate::lod::select::{select, SelectError};
use crate::lod::LodOptions;
use crate::model::runtime::progress::{check, stage, Cancelled, Progress, Silent, Stage};
use crate::model::CityModel;
use crate::model::Poi;
use crate::solar::irradiance::IrradianceSetting;
use crate::solar::sky::SkyError;
use crate::solar::trace::TraceScene;
use crate::solar::{poi_irradiance, poi_sky_view, poi_sun_hours, SkyBundles, SunTable};
use serde::Serialize;
use std::time::Instant;

/// Options of [`evaluate`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EvalOptions {
    /// The LoD pipeline (rough and selection options).
    pub lod: LodOptions,
    /// Rays of each SVF bundle.
    pub svf_rays: usize,
    /// Seed of the SVF bundles.
    pub svf_seed: u64,
}

impl Default for EvalOptions {
    fn default() -> Self {
        EvalOptions {
            lod: LodOptions::default(),
            svf_rays: 20_000,
            svf_seed: 7,
        }
    }
}

/// Errors of [`evaluate`].
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EvalError {
    /// The selection failed.
    #[error(transparent)]
    Select(#[from] SelectError),
    /// The SVF bundle could not be made.
    #[error("SVF bundle: {0}")]
    Sky(#[from] SkyError),
    /// The caller asked to stop ([`evaluate_with`]).
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}

/// Solar figures of one model at one POI.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, schemars::JsonSchema)]
pub struct ModelFigures {
    /// Polygons of the model (the whole scene, not only what the POI sees).
    pub polygons: usize,
    /// Sky view factor.
    pub svf: f64,
    /// Sky exposure.
    pub sky_exposure: f64,
    /// Hours of direct sun over the table, if a table was given.
    pub sun_hours: Option<f64>,
    /// Milliseconds building this model's scene (BVH), 0 when shared.
    pub bvh_ms: f64,
    /// Milliseconds of the SVF and sun-hours tracing.
    pub trace_ms: f64,
    /// Annual global irradiation on the POI's plane (kWh/m²), with a weather year
    /// (`evaluate --weather`); absent otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = 0))]
    pub global_kwh_m2: Option<f64>,
}

impl ModelFigures {
    /// Relative SVF error against `full`.
    pub fn svf_rel_error(&self, full: &ModelFigures) -> f64 {
        rel(self.svf, full.svf)
    }
    /// Relative sun-hours error against `full` (`None` without sun hours).
    pub fn sun_rel_error(&self, full: &ModelFigures) -> Option<f64> {
        Some(rel(self.sun_hours?, full.sun_hours?))
    }
    /// Relative annual-irradiation error against `full` (`None` without a weather year).
    pub fn irradiance_rel_error(&self, full: &ModelFigures) -> Option<f64> {
        Some(rel(self.global_kwh_m2?, full.global_kwh_m2?))
    }
    /// Signed annual-irradiation error against `full`, kWh/m² (`None` without a weather
    /// year).
    pub fn irradiance_abs_error(&self, full: &ModelFigures) -> Option<f64> {
        Some(self.global_kwh_m2? - full.global_kwh_m2?)
    }
}

/// One POI's evaluation.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct PoiEval {
    /// POI id.
    pub id: String,
    /// The full-detail model.
    pub full: ModelFigures,
    /// The POI's mixed-LoD model.
    pub lod: ModelFigures,
    /// The all-boxes model.
    pub boxes: ModelFigures,
    /// Assets per level `[0, 1, 2]` in this POI's LoD model.
    pub levels: [usize; 3],
    /// Milliseconds of this POI's selection.
    pub select_ms: f64,
    /// Relative SVF error of the LoD model (infinite, written `null`, when the full model's
    /// SVF is 0 and this one's is not).
    #[schemars(with = "Option<f64>")]
    pub lod_svf_error: f64,
    /// Relative SVF error of the all-boxes model (infinite, written `null`, likewise).
    #[schemars(with = "Option<f64>")]
    pub boxes_svf_error: f64,
    /// Relative sun-hours error of the LoD model.
    pub lod_sun_error: Option<f64>,
    /// Relative sun-hours error of the all-boxes model.
    pub boxes_sun_error: Option<f64>,
    /// Relative annual-irradiation error of the LoD model (with a weather year; infinite,
    /// written `null`, when the full model's is 0 and this one's is not).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lod_irradiance_error: Option<f64>,
    /// LoD minus full annual irradiation, kWh/m² (with a weather year).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lod_irradiance_abs_error_kwh_m2: Option<f64>,
    /// Relative annual-irradiation error of the all-boxes model (with a weather year).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub boxes_irradiance_error: Option<f64>,
    /// All-boxes minus full annual irradiation, kWh/m² (with a weather year).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub boxes_irradiance_abs_error_kwh_m2: Option<f64>,
    /// What makes this POI's figures suspect (inside a building, no sky), from the full model.
    pub flags: Vec<PoiFlag>,
}

/// The whole evaluation.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[non_exhaustive]
pub struct Evaluation {
    /// Per POI, in input order.
    pub pois: Vec<PoiEval>,
    /// Milliseconds of the rough stage (shared by all POIs).
    pub rough_ms: f64,
    /// Milliseconds building the selection scene (shared).
    pub selection_bvh_ms: f64,
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn figures(
    scene: &TraceScene,
    polygons: usize,
    poi: &Poi,
    bundles: &SkyBundles,
    table: Option<&SunTable>,
    irr: Option<&IrradianceSetting>,
    bvh_ms: f64,
) -> ModelFigures {
    let t = Instant::now();
    let v = poi_sky_view(scene, poi, bundles);
    let sun = table.map(|tb| poi_sun_hours(scene, poi, tb).hours);
    let global =
        irr.map(|w| poi_irradiance(scene, poi, bundles, &w.table, &w.opts, None).global_kwh_m2);
    ModelFigures {
        polygons,
        svf: v.svf,
        sky_exposure: v.sky_exposure,
        sun_hours: sun,
        bvh_ms,
        trace_ms: ms(t),
        global_kwh_m2: global,
    }
}

/// Evaluate `pois` on `model` (see the module docs). Sun hours are computed when `table`
/// is given.
///
/// # Errors
/// `EvalError` when the selection or the SVF bundle cannot be made.
pub fn evaluate(
    model: &CityModel,
    pois: &[Poi],
    opts: &EvalOptions,
    table: Option<&SunTable>,
) -> Result<Evaluation, EvalError> {
    evaluate_with(model, pois, opts, table, &Silent)
}

/// [`evaluate`] reporting its stages to `progress`: [`Stage::Rough`] (assets),
/// [`Stage::Bvh`] (the selection, full and all-boxes scenes, one item each), [`Stage::Trace`]
/// (one item per POI selected and traced on the three models); it stops with
/// [`EvalError::Cancelled`] when `progress` asks to (checked before each POI).
///
/// # Errors
/// As [`evaluate`], and [`EvalError::Cancelled`].
pub fn evaluate_with(
    model: &CityModel,
    pois: &[Poi],
    opts: &EvalOptions,
    table: Option<&SunTable>,
    progress: &dyn Progress,
) -> Result<Evaluation, EvalError> {
    evaluate_irradiance(model, pois, opts, table, None, progress)
}

/// [`evaluate_with`], and with `irradiance` each model's annual global irradiation
/// ([`ModelFigures::global_kwh_m2`]) and the LoD and all-boxes models' errors against the
/// full one (traced with the SVF bundle and the weather's hours).
///
/// # Errors
/// As [`evaluate_with`].
pub fn evaluate_irradiance(
    model: &CityModel,
    pois: &[Poi],
    opts: &EvalOptions,
    table: Option<&SunTable>,
    irradiance: Option<&IrradianceSetting>,
    progress: &dyn Progress,
) -> Result<Evaluation, EvalError> {
    let bundles = SkyBundles::new(opts.svf_rays, opts.svf_seed)?;
    check(progress, Stage::Rough)?;
    let n = model.assets.len() as u64;
    let t = Instant::now();
    let rough = stage(progress, Stage::Rough, n, 0, || {
        let r = rough_model(model, &opts.lod.rough);
        progress.advance(Stage::Rough, n, 0, None);
        r
    });
    let rough_ms = ms(t);
    check(progress, Stage::Bvh)?;
    progress.start(Stage::Bvh, 3, 0);
    let t = Instant::now();
    let sel_scene = selection_scene(model, &rough);
    let selection_bvh_ms = ms(t);
    progress.advance(Stage::Bvh, 1, 0, Some("selection scene"));

    let t = Instant::now();
    let full = full_scene(model);
    let full_bvh = ms(t);
    let around = Surroundings::new(model);
    let full_polys = model.polygon_count();
    progress.advance(Stage::Bvh, 1, 0, Some("full scene"));
    let t = Instant::now();
    let boxes_geo = all_boxes(model);
    let boxes = rough_scene(&boxes_geo);
    let boxes_bvh = ms(t);
    let boxes_polys: usize = boxes_geo.iter().map(|r| r.polygon_count()).sum();
    progress.advance(Stage::Bvh, 1, 0, Some("all-boxes scene"));
    progress.finish(Stage::Bvh);

    // Each POI in turn (its selection scene and bundles are shared); cancellable before each.
    progress.start(Stage::Trace, pois.len() as u64, 0);
    let out: Result<Vec<PoiEval>, EvalError> = pois
        .iter()
        .map(|poi| {
            check(progress, Stage::Trace)?;
            let t = Instant::now();
            let sel = select(
                model,
                &rough,
                &sel_scene,
                std::slice::from_ref(poi),
                &opts.lod.select,
            )?;
            let select_ms = ms(t);
            let t = Instant::now();
            let lod_scene = mixed_scene(model, &rough, &sel.levels);
            let lod_bvh = ms(t);
            let lod_polys = crate::lod::level::model_polygon_count(model, &rough, &sel.levels);
            let irr = irradiance;
            let f = figures(&full, full_polys, poi, &bundles, table, irr, full_bvh);
            let l = figures(&lod_scene, lod_polys, poi, &bundles, table, irr, lod_bvh);
            let b = figures(&boxes, boxes_polys, poi, &bundles, table, irr, boxes_bvh);
            let sky_rays = (f.sky_exposure == 0.0).then_some(0);
            let e = PoiEval {
                id: poi.id.clone(),
                flags: poi_flags_around(&full, model, &around, poi, sky_rays),
                lod_svf_error: l.svf_rel_error(&f),
                boxes_svf_error: b.svf_rel_error(&f),
                lod_sun_error: l.sun_rel_error(&f),
                boxes_sun_error: b.sun_rel_error(&f),
                lod_irradiance_error: l.irradiance_rel_error(&f),
                lod_irradiance_abs_error_kwh_m2: l.irradiance_abs_error(&f),
                boxes_irradiance_error: b.irradiance_rel_error(&f),
                boxes_irradiance_abs_error_kwh_m2: b.irradiance_abs_error(&f),
                full: f,
                lod: l,
                boxes: b,
                levels: sel.level_counts(),
                select_ms,
            };
            progress.advance(Stage::Trace, 1, 0, Some(&poi.id));
            Ok(e)
        })
        .collect();
    progress.finish(Stage::Trace);
    Ok(Evaluation {
        pois: out?,
        rough_ms,
        selection_bvh_ms,
    })
}
