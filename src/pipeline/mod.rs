//! The path every tracing command takes, as a library API: **inputs → scene → levels →
//! outputs**, with progress and cancellation through a [`Progress`].
//!
//! 1. [`read_inputs`]: files read in parallel and merged into one model (occluders of a
//!    neighbouring tile count); a file that cannot be read is reported, the others are used.
//!    [`Inputs::check`] refuses a model that would give a confidently wrong answer whatever
//!    the POIs (mixed CRSs, no heights).
//! 2. [`frame`]: the model and the POIs in the local metric frame the tracing works in
//!    (ENU for degrees, metres for feet; `source_crs`, `poi_crs`), POIs far outside the scene
//!    refused.
//! 3. [`levels`]: rough model → selection scene (BVH) → selection, then the error bound when
//!    one is asked for; the rough geometry is brought back to the input's CRS for writing.
//! 4. [`write_levels`]: each input file written with its assets at their levels (mixed-LoD
//!    CityGML, OBJ, CityJSON), atomically.
//!
//! 5. Or, after step 2, the POIs traced instead of levels chosen: [`evaluate`] (full vs LoD
//!    vs all-boxes model per POI), [`trace`] against the full-detail scene ([`svf`],
//!    [`sun_hours`], [`horizon`]), one [`Stage::Trace`] item per POI, cancellable before each.
//!
//! `skylod lod` is steps 1–4 plus messages; `evaluate`, `svf`, `sun-hours` and `horizon` are
//! steps 1, 2 and 5; `fisheye` is steps 1, 2 and [`sky_pictures`]. Nothing here prints: warnings are returned
//! ([`Framed::warnings`]), progress goes to the [`Progress`].
//!
//! # Example
//! ```
//! use skylod::pipeline::{frame, levels, read_inputs, write_levels, FrameOptions, LevelsOptions};
//! use skylod::runtime::progress::Silent;
//! use skylod::export::Format;
//! use std::path::PathBuf;
//! let input = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/synth-small.gml");
//! let mut inputs = read_inputs(&[input], &Silent).unwrap();
//! inputs.check(false).unwrap();
//! let b = inputs.model.bbox();
//! let poi = skylod::poi::Poi { id: "street".into(), position: b.center(), normal: None };
//! let framed = frame(&mut inputs.model, vec![poi], &FrameOptions::default()).unwrap();
//! let lv = levels(&framed, &LevelsOptions::default(), &Silent).unwrap();
//! let dir = tempfile::tempdir().unwrap();
//! let out = dir.path().join("lod.gml");
//! let written = write_levels(framed.source, 0, &lv, &out, Format::CityGml, &Default::default()).unwrap();
//! assert!(written.polygons_out <= written.polygons_in);
//! assert!(out.exists());
//! ```

pub mod evaluation;

use crate::citygml::write::WriteOptions;
use crate::citygml::{read_file, ReadError, WriteError};
use crate::crs::{build_transform, model_crs, Crs, CrsError, LocalFrame, PointTransform};
use crate::export::{Content, Format};
use crate::lod::bound::{bound, BoundError, BoundOptions, BoundReport};
use crate::lod::mixed::write_mixed;
use crate::lod::rough::rough_model;
use crate::lod::rough::RoughGeometry;
use crate::lod::scene::{full_scene, selection_scene};
use crate::lod::select::select;
use crate::lod::select::SelectError;
use crate::lod::sky::SkyPartition;
use crate::lod::{lod_with, LodOptions, LodResult};
use crate::model::CityModel;
use crate::pipeline::evaluation::{evaluate_with, EvalError, EvalOptions, Evaluation};
use crate::poi::checks::{self, PoiFlag, TrustError};
use crate::poi::Poi;
use crate::poi::POI_OFFSET;
use crate::runtime::progress::{check, Cancelled, Progress, Stage};
use crate::solar::fisheye::{classify_cells, CellClass};
use crate::solar::{
    poi_horizon, poi_sky_view, poi_sun_hours, HorizonOptions, HorizonProfile, SkyBundles, SkyView,
    SolarError, SunHours, SunTable,
};
use crate::trace::Scene;
use rayon::prelude::*;
use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Errors of the pipeline that stop it (a file that cannot be read does not: see
/// [`Inputs::failures`]).
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// The model or the POIs would give a confidently wrong answer.
    #[error(transparent)]
    Trust(#[from] TrustError),
    /// The POIs could not be converted from their CRS to the model's.
    #[error("--poi-crs {from}: {source}")]
    PoiCrs {
        /// The POIs' CRS.
        from: String,
        /// Why.
        source: CrsError,
    },
    /// The POIs are in another CRS but the model's is not known.
    #[error("--poi-crs {from}: the model's CRS ({model}) is not known, so POIs cannot be converted to it (give --source-crs)")]
    UnknownModelCrs {
        /// The POIs' CRS.
        from: String,
        /// The model's CRS as named.
        model: String,
    },
    /// The selection failed (or was cancelled).
    #[error(transparent)]
    Select(#[from] SelectError),
    /// The error bound could not be computed.
    #[error(transparent)]
    Bound(#[from] BoundError),
    /// The evaluation could not be made.
    #[error(transparent)]
    Eval(EvalError),
    /// Invalid solar options (e.g. a horizon step out of range).
    #[error(transparent)]
    Solar(#[from] SolarError),
    /// The caller asked to stop.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}

/// The inputs that could be read, merged in input order.
#[derive(Debug, Default)]
pub struct Inputs {
    /// All inputs read, merged ([`CityModel::merge`]): `model.files[k]` is `read[k]`.
    pub model: CityModel,
    /// Paths read successfully, in input order.
    pub read: Vec<PathBuf>,
    /// Inputs that could not be read (file, line:column, reason), in input order.
    pub failures: Vec<ReadError>,
    /// Seconds spent reading.
    pub read_s: f64,
}

impl Inputs {
    /// Refuse a model that would give a confidently wrong answer whatever the POIs: inputs
    /// whose CRSs differ (unless `allow_mixed_crs`), a model without heights. Nothing read
    /// passes.
    ///
    /// # Errors
    /// [`TrustError`].
    pub fn check(&self, allow_mixed_crs: bool) -> Result<(), TrustError> {
        if self.read.is_empty() {
            return Ok(());
        }
        check_model(&self.model, allow_mixed_crs)
    }
}

/// The checks of [`Inputs::check`] on a model.
///
/// # Errors
/// [`TrustError`].
pub fn check_model(model: &CityModel, allow_mixed_crs: bool) -> Result<(), TrustError> {
    if !allow_mixed_crs {
        checks::check_same_crs(model)?;
    }
    checks::check_heights(model)
}

/// Read `paths` in parallel ([`Stage::Read`]: files and bytes) and merge them in input
/// order. A file that cannot be read goes to [`Inputs::failures`].
///
/// # Errors
/// [`Cancelled`] when `progress` asks to stop (before a file is started).
pub fn read_inputs(paths: &[PathBuf], progress: &dyn Progress) -> Result<Inputs, Cancelled> {
    let t = Instant::now();
    let sizes: Vec<u64> = paths
        .iter()
        .map(|p| std::fs::metadata(p).map_or(0, |m| m.len()))
        .collect();
    progress.start(Stage::Read, paths.len() as u64, sizes.iter().sum());
    let results: Result<Vec<_>, Cancelled> = paths
        .par_iter()
        .zip(&sizes)
        .map(|(p, size)| {
            check(progress, Stage::Read)?;
            let r = read_file(p);
            progress.advance(Stage::Read, 1, *size, Some(&p.display().to_string()));
            Ok(r)
        })
        .collect();
    progress.finish(Stage::Read);
    let mut inputs = Inputs::default();
    for (p, r) in paths.iter().zip(results?) {
        match r {
            Ok(m) => {
                inputs.model.merge(m);
                inputs.read.push(p.clone());
            }
            Err(e) => inputs.failures.push(e),
        }
    }
    // the reader's registry, id log and arena are freed: a large model's pages go back
    // before the next stage's large blocks are mapped
    crate::runtime::mem::give_back_for(inputs.model.assets.len());
    inputs.read_s = t.elapsed().as_secs_f64();
    Ok(inputs)
}

/// How the model and the POIs are brought into the tracing frame ([`frame`]).
#[derive(Debug, Clone, PartialEq)]
pub struct FrameOptions {
    /// CRS of the inputs instead of their `srsName` (written into the model's files, so
    /// reports and the sun's site see it).
    pub source_crs: Option<Crs>,
    /// CRS of the POIs when it is not the model's.
    pub poi_crs: Option<Crs>,
    /// POIs farther than this (m) outside the scene's bounding box are refused.
    pub poi_margin: f64,
}

impl Default for FrameOptions {
    fn default() -> Self {
        FrameOptions {
            source_crs: None,
            poi_crs: None,
            poi_margin: checks::DEFAULT_POI_MARGIN,
        }
    }
}

/// The model and POIs in the local metric frame, with what reports need.
#[derive(Debug)]
pub struct Framed<'a> {
    /// The model as read (CRS of the input): what outputs are written from.
    pub source: &'a CityModel,
    /// The model in the local frame: what is traced.
    pub model: Cow<'a, CityModel>,
    /// The model's CRS.
    pub crs: Crs,
    /// The frame.
    pub frame: LocalFrame,
    /// POIs in the model's CRS (for reports).
    pub pois: Vec<Poi>,
    /// POIs in the local frame (for tracing).
    pub local_pois: Vec<Poi>,
    /// What the caller should tell the user (other CRSs named by the inputs, the frame
    /// chosen, its accuracy).
    pub warnings: Vec<String>,
    /// A note on the frame when it is not the identity ("tracing in ...").
    pub note: Option<String>,
}

/// Apply `source_crs`, choose the frame, convert `pois` from `poi_crs` to the model's CRS
/// and everything into the frame; refuse POIs farther than `poi_margin` outside the scene.
///
/// # Errors
/// [`PipelineError::PoiCrs`], [`PipelineError::UnknownModelCrs`], [`PipelineError::Trust`].
pub fn frame<'a>(
    model: &'a mut CityModel,
    pois: Vec<Poi>,
    opts: &FrameOptions,
) -> Result<Framed<'a>, PipelineError> {
    if let Some(c) = &opts.source_crs {
        for f in &mut model.files {
            f.srs_name = Some(c.name.clone());
        }
    }
    let source: &'a CityModel = model;
    let crs = model_crs(source, opts.source_crs.as_ref());
    let mut warnings = Vec::new();
    let others: Vec<String> = source
        .files
        .iter()
        .filter_map(|f| f.srs_name.as_deref())
        .map(Crs::parse)
        .filter(|c| !c.compatible(&crs))
        .map(|c| c.to_string())
        .collect();
    if !others.is_empty() {
        warnings.push(format!(
            "inputs name other CRSs than {crs} ({}); all are traced as {crs}",
            others.join(", ")
        ));
    }
    // every point of a city: one pass for the frame and the POI check (and none more when
    // the frame is the identity)
    let source_bbox = source.bbox();
    let (frame, warning) = LocalFrame::new(&crs, &source_bbox);
    warnings.extend(warning.map(|w| w.to_string()));
    let note = (!frame.is_identity()).then(|| format!("{crs}: tracing in {}", frame.describe()));
    let pois = match &opts.poi_crs {
        Some(pc) => {
            if !crs.is_known() {
                return Err(PipelineError::UnknownModelCrs {
                    from: pc.to_string(),
                    model: crs.to_string(),
                });
            }
            build_transform()
                .pois(pc, &crs, &pois)
                .map_err(|source| PipelineError::PoiCrs {
                    from: pc.to_string(),
                    source,
                })?
        }
        None => pois,
    };
    let local_pois: Vec<Poi> = pois.iter().map(|p| frame.poi_to_local(p)).collect();
    let local = frame.model_to_local(source);
    let local_bbox = match &local {
        Cow::Borrowed(_) => source_bbox,
        Cow::Owned(m) => m.bbox(),
    };
    checks::check_pois_near_in_frame(
        &local_bbox,
        &local_pois,
        &source_bbox,
        &pois,
        opts.poi_margin,
    )?;
    Ok(Framed {
        source,
        model: local,
        crs,
        frame,
        pois,
        local_pois,
        warnings,
        note,
    })
}

/// The error bound of [`levels`]: options and, for a sun-hours bound, the sun table.
#[derive(Debug, Clone)]
pub struct BoundSpec {
    /// Bound options (SVF and sun-hours errors allowed, rays).
    pub options: BoundOptions,
    /// The sun positions of the sun-hours bound.
    pub sun: Option<SunTable>,
}

/// Options of [`levels`].
#[derive(Debug, Clone, Default)]
pub struct LevelsOptions {
    /// Rough model and selection.
    pub lod: LodOptions,
    /// An error bound to meet by promoting assets, if any.
    pub bound: Option<BoundSpec>,
}

/// The levels chosen, and what writing them needs.
#[derive(Debug, Clone)]
pub struct Levels {
    /// Rough model (local frame), selection and timings; after a bound, its levels are the
    /// promoted ones.
    pub lod: LodResult,
    /// The rough geometry in the input's CRS when the frame is not the identity (only the
    /// level-1 assets', the others empty); `None` when it is the rough model itself
    /// ([`Levels::rough_source`]).
    pub rough_source: Option<Vec<RoughGeometry>>,
    /// The bound's report, when one was asked for (`met` says whether it holds; when it
    /// does not, nothing should be written).
    pub bound: Option<BoundReport>,
    /// Seconds of the bound check.
    pub bound_s: f64,
}

impl Levels {
    /// The level of each asset.
    pub fn levels(&self) -> &[u8] {
        &self.lod.selection.levels
    }

    /// The rough geometry in the input's CRS, what is written: [`LodResult::rough`] itself
    /// when the frame is the identity (no copy), the level-1 assets' converted otherwise.
    pub fn rough_source(&self) -> &[RoughGeometry] {
        self.rough_source.as_deref().unwrap_or(&self.lod.rough)
    }

    /// Whether the bound holds (true without a bound).
    pub fn bound_met(&self) -> bool {
        self.bound.as_ref().is_none_or(|b| b.met)
    }
}

/// Rough model ([`Stage::Rough`]) → selection scene ([`Stage::Bvh`]) → selection
/// ([`Stage::Select`], per POI, cancellable) → error bound ([`Stage::Trace`]) when asked.
///
/// # Errors
/// [`PipelineError::Select`], [`PipelineError::Bound`], [`PipelineError::Cancelled`].
pub fn levels(
    framed: &Framed<'_>,
    opts: &LevelsOptions,
    progress: &dyn Progress,
) -> Result<Levels, PipelineError> {
    let lod = lod_with(&framed.model, &framed.local_pois, &opts.lod, progress)?;
    levels_of(framed, opts, lod, progress)
}

/// The rest of [`levels`] for a selection made elsewhere (e.g. the levels of every shard of
/// an array job combined): the error bound when asked, the rough model back to the source CRS.
///
/// # Errors
/// [`PipelineError::Bound`], [`PipelineError::Cancelled`].
pub fn levels_of(
    framed: &Framed<'_>,
    opts: &LevelsOptions,
    mut lod: LodResult,
    progress: &dyn Progress,
) -> Result<Levels, PipelineError> {
    let model: &CityModel = &framed.model;
    let pois = &framed.local_pois;
    let mut bound_report = None;
    let t = Instant::now();
    if let Some(spec) = &opts.bound {
        check(progress, Stage::Trace)?;
        let b =
            crate::runtime::progress::stage(progress, Stage::Trace, pois.len() as u64, 0, || {
                bound(
                    model,
                    &lod.rough,
                    &lod.selection.levels,
                    pois,
                    &spec.options,
                    spec.sun.as_ref(),
                )
            })?;
        bound_report = Some(BoundReport::new(&b, &spec.options));
        lod.selection.levels = b.levels;
    }
    let bound_s = t.elapsed().as_secs_f64();
    let rough_source = match crate::lod::rough::rough_to_source(
        &framed.frame,
        model,
        framed.source,
        &lod.rough,
        Some(&lod.selection.levels),
    ) {
        Cow::Borrowed(_) => None,
        Cow::Owned(v) => Some(v),
    };
    Ok(Levels {
        lod,
        rough_source,
        bound: bound_report,
        bound_s,
    })
}

/// What [`trace`] (and [`svf`], [`sun_hours`], [`horizon`]) computed: one result per POI
/// against the full-detail scene, in POI order.
#[derive(Debug, Clone)]
pub struct Traced<T> {
    /// One result per POI, in the order of [`Framed::local_pois`].
    pub results: Vec<T>,
    /// The trust flags of each POI ([`checks::poi_flags`]: inside a building, no sky).
    pub flags: Vec<Vec<PoiFlag>>,
    /// Seconds building the full-detail scene.
    pub bvh_s: f64,
    /// Seconds tracing the POIs.
    pub trace_s: f64,
}

/// `f` for every POI of `framed` (local frame, in parallel) against the full-detail scene of
/// its model ([`Stage::Bvh`], then [`Stage::Trace`]: one item per POI, cancellable before
/// each POI), with each POI's flags; `sky_rays` of a result, when it knows them, adds the
/// no-sky flag.
///
/// # Errors
/// [`Cancelled`] when `progress` asks to stop.
pub fn trace<T: Send>(
    framed: &Framed<'_>,
    f: impl Fn(&Scene, &Poi) -> T + Sync,
    sky_rays: impl Fn(&T) -> Option<usize> + Sync,
    progress: &dyn Progress,
) -> Result<Traced<T>, Cancelled> {
    let model: &CityModel = &framed.model;
    let pois = &framed.local_pois;
    check(progress, Stage::Bvh)?;
    let t = Instant::now();
    let scene = crate::runtime::progress::stage(progress, Stage::Bvh, 1, 0, || full_scene(model));
    let bvh_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let traced: Result<Vec<(T, Vec<PoiFlag>)>, Cancelled> =
        crate::runtime::progress::stage(progress, Stage::Trace, pois.len() as u64, 0, || {
            pois.par_iter()
                .map(|p| {
                    check(progress, Stage::Trace)?;
                    let r = f(&scene, p);
                    let flags = checks::poi_flags(&scene, model, p, sky_rays(&r));
                    // No name: many cheap POIs in parallel (a log line each would drown the log).
                    progress.advance(Stage::Trace, 1, 0, None);
                    Ok((r, flags))
                })
                .collect()
        });
    let (results, flags) = traced?.into_iter().unzip();
    Ok(Traced {
        results,
        flags,
        bvh_s,
        trace_s: t.elapsed().as_secs_f64(),
    })
}

/// Sky view factor and sky exposure of every POI ([`poi_sky_view`]), through [`trace`].
///
/// # Errors
/// [`Cancelled`] when `progress` asks to stop.
pub fn svf(
    framed: &Framed<'_>,
    bundles: &SkyBundles,
    progress: &dyn Progress,
) -> Result<Traced<SkyView>, Cancelled> {
    trace(
        framed,
        |s, p| poi_sky_view(s, p, bundles),
        |v| (v.sky_exposure == 0.0).then_some(0),
        progress,
    )
}

/// Hours of direct sun of every POI over `table` ([`poi_sun_hours`]), through [`trace`].
///
/// # Errors
/// [`Cancelled`] when `progress` asks to stop.
pub fn sun_hours(
    framed: &Framed<'_>,
    table: &SunTable,
    progress: &dyn Progress,
) -> Result<Traced<SunHours>, Cancelled> {
    trace(
        framed,
        |s, p| poi_sun_hours(s, p, table),
        |_| None,
        progress,
    )
}

/// Horizon profile of every POI ([`poi_horizon`]; azimuths from north of the local frame),
/// through [`trace`].
///
/// # Errors
/// [`PipelineError::Solar`] for invalid options (checked before any work),
/// [`PipelineError::Cancelled`].
pub fn horizon(
    framed: &Framed<'_>,
    opts: &HorizonOptions,
    progress: &dyn Progress,
) -> Result<Traced<HorizonProfile>, PipelineError> {
    opts.validate()?;
    let t = trace(framed, |s, p| poi_horizon(s, p, opts), |_| None, progress)?;
    Ok(Traced {
        results: t.results.into_iter().collect::<Result<_, _>>()?,
        flags: t.flags,
        bvh_s: t.bvh_s,
        trace_s: t.trace_s,
    })
}

/// Options of [`evaluate`].
#[derive(Debug, Clone, Default)]
pub struct EvaluateOptions {
    /// Rough model, selection and SVF bundle.
    pub eval: EvalOptions,
    /// The sun positions of the sun hours; `None` skips sun hours.
    pub sun: Option<SunTable>,
}

/// Full vs LoD vs all-boxes model at every POI of `framed` ([`evaluation::evaluate_with`]): rough
/// model ([`Stage::Rough`]), scenes ([`Stage::Bvh`]), then each POI selected and traced
/// ([`Stage::Trace`], cancellable before each POI).
///
/// # Errors
/// [`PipelineError::Eval`], [`PipelineError::Cancelled`].
pub fn evaluate(
    framed: &Framed<'_>,
    opts: &EvaluateOptions,
    progress: &dyn Progress,
) -> Result<Evaluation, PipelineError> {
    evaluate_with(
        &framed.model,
        &framed.local_pois,
        &opts.eval,
        opts.sun.as_ref(),
        progress,
    )
    .map_err(|e| match e {
        EvalError::Cancelled(c) => PipelineError::Cancelled(c),
        e => PipelineError::Eval(e),
    })
}

/// Options of [`sky_pictures`].
#[derive(Debug, Clone, Copy)]
pub struct SkyPictureOptions<'o> {
    /// The cells of the picture (one ray through each centre).
    pub partition: &'o SkyPartition,
    /// The bundles of the SVF and sky exposure printed with the picture.
    pub bundles: &'o SkyBundles,
    /// When given, each POI's levels as `skylod lod` selects them for that POI alone.
    pub levels: Option<LodOptions>,
}

/// What a fisheye picture of one POI shows ([`sky_pictures`]).
#[derive(Debug, Clone)]
pub struct SkyPicture {
    /// What each cell of the partition sees (sky, below the surface, or the asset hit).
    pub cells: Vec<CellClass>,
    /// SVF and sky exposure of the POI against the full-detail scene.
    pub view: SkyView,
    /// The POI's trust flags ([`checks::poi_flags`]).
    pub flags: Vec<PoiFlag>,
    /// The level of each asset for this POI, when asked: an opening (window, door) left
    /// out shows its wall's level, since the rough wall's plane closes it in the LoD model.
    pub levels: Option<Vec<u8>>,
}

/// The fisheye pictures of the POIs of `framed`, one at a time, handed to `each` (POI index,
/// picture) as soon as each is made (so a caller writes it before the next is traced): the
/// full-detail scene and, with [`SkyPictureOptions::levels`], the rough model and selection
/// scene built once ([`Stage::Bvh`]), then per POI ([`Stage::Trace`], cancellable before
/// each) its cells, SVF, flags and levels.
///
/// # Errors
/// [`PipelineError::Select`], [`PipelineError::Cancelled`] (as `E`), or what `each` returns.
pub fn sky_pictures<E: From<PipelineError>>(
    framed: &Framed<'_>,
    opts: &SkyPictureOptions<'_>,
    progress: &dyn Progress,
    mut each: impl FnMut(usize, SkyPicture) -> Result<(), E>,
) -> Result<(), E> {
    let model: &CityModel = &framed.model;
    check(progress, Stage::Bvh).map_err(PipelineError::from)?;
    let n = if opts.levels.is_some() { 2 } else { 1 };
    progress.start(Stage::Bvh, n, 0);
    let scene = full_scene(model);
    progress.advance(Stage::Bvh, 1, 0, Some("full scene"));
    let selection = opts.levels.map(|lod| {
        let rough = rough_model(model, &lod.rough);
        let scene = selection_scene(model, &rough);
        progress.advance(Stage::Bvh, 1, 0, Some("selection scene"));
        (lod, rough, scene)
    });
    progress.finish(Stage::Bvh);
    progress.start(Stage::Trace, framed.local_pois.len() as u64, 0);
    let r = framed
        .local_pois
        .iter()
        .enumerate()
        .try_for_each(|(k, poi)| {
            check(progress, Stage::Trace).map_err(PipelineError::from)?;
            let cells = classify_cells(
                opts.partition,
                &scene,
                poi.ray_origin(),
                poi.normal,
                POI_OFFSET,
            );
            let view = poi_sky_view(&scene, poi, opts.bundles);
            let flags =
                checks::poi_flags(&scene, model, poi, (view.sky_exposure == 0.0).then_some(0));
            let levels = match &selection {
                None => None,
                Some((lod, rough, sel_scene)) => {
                    let sel = select(
                        model,
                        rough,
                        sel_scene,
                        std::slice::from_ref(poi),
                        &lod.select,
                    )
                    .map_err(PipelineError::from)?;
                    Some(shown_levels(model, sel.levels))
                }
            };
            let picture = SkyPicture {
                cells,
                view,
                flags,
                levels,
            };
            each(k, picture)?;
            progress.advance(Stage::Trace, 1, 0, Some(&poi.id));
            Ok(())
        });
    progress.finish(Stage::Trace);
    r
}

/// `levels` with each opening left out at its wall's level (see [`SkyPicture::levels`]).
fn shown_levels(model: &CityModel, mut levels: Vec<u8>) -> Vec<u8> {
    for (i, a) in model.assets.iter().enumerate() {
        if a.kind.is_opening() && levels.get(i) == Some(&0) {
            if let Some(p) = a.parent.and_then(|p| levels.get(p).copied()) {
                levels[i] = p;
            }
        }
    }
    levels
}

/// What [`write_levels`] wrote.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Written {
    /// Bytes written (before compression).
    pub bytes: u64,
    /// Assets of the file per level (CityGML only; zeros for other formats).
    pub levels: [usize; 3],
    /// Asset polygons of the file in the input (CityGML only).
    pub polygons_in: usize,
    /// Asset polygons written (CityGML only).
    pub polygons_out: usize,
    /// Buildings and building parts left out because nothing of them was kept.
    pub buildings_dropped: usize,
    /// What the OBJ / CityJSON writer wrote (formats other than CityGML).
    pub export: Option<crate::export::ExportSummary>,
}

/// Write file `file` of `model` (as read, [`Framed::source`]) to `out` in `format` with
/// every asset at its level.
///
/// # Errors
/// [`WriteError`] (the target is checked first; nothing partial is left behind).
pub fn write_levels(
    model: &CityModel,
    file: usize,
    levels: &Levels,
    out: &Path,
    format: Format,
    wopts: &WriteOptions,
) -> Result<Written, WriteError> {
    if format == Format::CityGml {
        let s = write_mixed(
            model,
            file,
            levels.rough_source(),
            levels.levels(),
            out,
            wopts,
        )?;
        return Ok(Written {
            bytes: s.bytes,
            levels: s.levels,
            polygons_in: s.polygons_in,
            polygons_out: s.polygons_out,
            buildings_dropped: s.buildings_dropped,
            export: None,
        });
    }
    let content = Content::Levels {
        rough: levels.rough_source(),
        levels: levels.levels(),
    };
    let s = crate::export::write(format, model, file, content, out, wopts)?;
    Ok(Written {
        bytes: s.bytes,
        buildings_dropped: buildings_without_kept_assets(model, file, levels.levels()),
        export: Some(s),
        ..Written::default()
    })
}

/// [`write_levels`] for each `(file, output)` pair, files in parallel ([`Stage::Write`],
/// cancellable between files); one result per pair, in the order of `targets`.
///
/// # Errors
/// [`Cancelled`] when `progress` asks to stop (files already written stay).
pub fn write_all(
    model: &CityModel,
    targets: &[(usize, PathBuf)],
    levels: &Levels,
    format: Format,
    wopts: &WriteOptions,
    progress: &dyn Progress,
) -> Result<Vec<Result<Written, WriteError>>, Cancelled> {
    progress.start(Stage::Write, targets.len() as u64, 0);
    // Files in parallel (the caller's rayon pool); results in the order of `targets`.
    let out: Result<Vec<_>, Cancelled> = targets
        .par_iter()
        .map(|(f, path)| {
            check(progress, Stage::Write)?;
            let r = write_levels(model, *f, levels, path, format, wopts);
            progress.advance(Stage::Write, 1, 0, Some(&path.display().to_string()));
            Ok(r)
        })
        .collect();
    progress.finish(Stage::Write);
    out
}

/// Buildings and parts of file `f` that keep no asset (through any part below them): what
/// the OBJ and CityJSON writers leave out.
pub fn buildings_without_kept_assets(model: &CityModel, f: usize, levels: &[u8]) -> usize {
    let mut kept = vec![false; model.buildings.len()];
    for (a, l) in model.assets.iter().zip(levels) {
        if *l == 0 {
            continue;
        }
        let mut b = a.building;
        let mut steps = 0;
        while let Some(k) = b {
            if let Some(x) = kept.get_mut(k) {
                *x = true;
            }
            b = model.buildings.get(k).and_then(|x| x.parent);
            steps += 1;
            if steps > model.buildings.len() {
                break;
            }
        }
    }
    model
        .buildings
        .iter()
        .zip(&kept)
        .filter(|(b, k)| b.file == f && !**k)
        .count()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::runtime::progress::Silent;
    use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

    fn fixture() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/synth-small.gml")
    }

    /// Counts POIs of `stage` (selected or traced); cancels after `stop_after` of them.
    struct Stopper {
        stage: Stage,
        selected: AtomicU64,
        stop_after: u64,
        stopped: AtomicBool,
    }

    impl Stopper {
        fn new(stage: Stage, stop_after: u64) -> Self {
            Stopper {
                stage,
                selected: AtomicU64::new(0),
                stop_after,
                stopped: AtomicBool::new(false),
            }
        }
    }

    impl Progress for Stopper {
        fn advance(&self, stage: Stage, items: u64, _: u64, _: Option<&str>) {
            if stage == self.stage
                && self.selected.fetch_add(items, Ordering::SeqCst) + items >= self.stop_after
            {
                self.stopped.store(true, Ordering::SeqCst);
            }
        }
        fn is_cancelled(&self) -> bool {
            self.stopped.load(Ordering::SeqCst)
        }
    }

    fn grid_pois(model: &CityModel, n: usize) -> Vec<Poi> {
        let b = model.bbox();
        let c = b.center();
        (0..n)
            .map(|i| Poi {
                id: format!("p{i}"),
                position: glam::DVec3::new(c.x + i as f64 * 0.1, c.y, b.min.z + 1.5),
                normal: None,
            })
            .collect()
    }

    #[test]
    fn selection_stops_when_cancelled() {
        let mut inputs = read_inputs(&[fixture()], &crate::runtime::progress::Silent).unwrap();
        assert!(inputs.failures.is_empty());
        let pois = grid_pois(&inputs.model, 64);
        let framed = frame(&mut inputs.model, pois, &FrameOptions::default()).unwrap();
        let opts = LevelsOptions {
            lod: LodOptions {
                select: crate::lod::select::SelectOptions {
                    rays: 500,
                    ..Default::default()
                },
                ..Default::default()
            },
            bound: None,
        };
        let stop = Stopper::new(Stage::Select, 2);
        let r = levels(&framed, &opts, &stop);
        assert!(
            matches!(
                r,
                Err(PipelineError::Select(SelectError::Cancelled(Cancelled {
                    stage: Stage::Select
                })))
            ),
            "{r:?}"
        );
        // Without cancellation the same call selects every POI.
        let all = Stopper {
            stop_after: u64::MAX,
            ..stop
        };
        all.stopped.store(false, Ordering::SeqCst);
        all.selected.store(0, Ordering::SeqCst);
        let lv = levels(&framed, &opts, &all).unwrap();
        assert_eq!(all.selected.load(Ordering::SeqCst), 64);
        assert_eq!(lv.lod.selection.pois.len(), 64);
    }

    /// Sums what each stage was told and what it got.
    #[derive(Default)]
    struct Tally(std::sync::Mutex<Vec<(Stage, &'static str, u64, u64)>>);

    impl Progress for Tally {
        fn start(&self, stage: Stage, items: u64, bytes: u64) {
            self.0.lock().unwrap().push((stage, "start", items, bytes));
        }
        fn advance(&self, stage: Stage, items: u64, bytes: u64, _: Option<&str>) {
            self.0
                .lock()
                .unwrap()
                .push((stage, "advance", items, bytes));
        }
    }

    impl Tally {
        fn sum(&self, stage: Stage, what: &str) -> (u64, u64) {
            self.0
                .lock()
                .unwrap()
                .iter()
                .filter(|e| e.0 == stage && e.1 == what)
                .fold((0, 0), |a, e| (a.0 + e.2, a.1 + e.3))
        }
    }

    #[test]
    fn every_stage_advances_as_far_as_it_announced() {
        let tally = Tally::default();
        let size = std::fs::metadata(fixture()).unwrap().len();
        let mut inputs = read_inputs(&[fixture()], &tally).unwrap();
        assert_eq!(tally.sum(Stage::Read, "start"), (1, size));
        assert_eq!(tally.sum(Stage::Read, "advance"), (1, size));
        let pois = grid_pois(&inputs.model, 5);
        let framed = frame(&mut inputs.model, pois, &FrameOptions::default()).unwrap();
        let lv = levels(&framed, &LevelsOptions::default(), &tally).unwrap();
        assert_eq!(tally.sum(Stage::Select, "start").0, 5);
        assert_eq!(tally.sum(Stage::Select, "advance").0, 5);
        let n = framed.source.assets.len() as u64;
        assert_eq!(tally.sum(Stage::Rough, "advance").0, n);
        let dir = tempfile::tempdir().unwrap();
        let targets = vec![(0, dir.path().join("a.gml")), (0, dir.path().join("b.gml"))];
        let w = write_all(
            framed.source,
            &targets,
            &lv,
            Format::CityGml,
            &WriteOptions::default(),
            &tally,
        )
        .unwrap();
        assert!(w.iter().all(Result::is_ok));
        assert_eq!(tally.sum(Stage::Write, "start").0, 2);
        assert_eq!(tally.sum(Stage::Write, "advance").0, 2);
    }

    #[test]
    fn unreadable_input_is_a_failure_not_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let bad = dir.path().join("bad.gml");
        std::fs::write(&bad, "<CityModel").unwrap();
        let inputs =
            read_inputs(&[fixture(), bad.clone()], &crate::runtime::progress::Silent).unwrap();
        assert_eq!(inputs.read, vec![fixture()]);
        assert_eq!(inputs.failures.len(), 1);
        assert!(inputs.failures[0].to_string().contains("bad.gml"));
    }

    /// `n` POIs on the diagonal of the fixture at 1.5 m (streets and buildings), framed.
    fn framed_with(inputs: &mut Inputs, n: usize) -> Framed<'_> {
        let b = inputs.model.bbox();
        let pois = (0..n)
            .map(|i| {
                let t = (i as f64 + 0.5) / n as f64;
                Poi {
                    id: format!("d{i}"),
                    position: b.min.lerp(b.max, t).with_z(b.min.z + 1.5),
                    normal: None,
                }
            })
            .collect();
        frame(&mut inputs.model, pois, &FrameOptions::default()).unwrap()
    }

    #[test]
    fn solar_entry_points_trace_every_poi_and_stop_when_cancelled() {
        let mut inputs = read_inputs(&[fixture()], &crate::runtime::progress::Silent).unwrap();
        let framed = framed_with(&mut inputs, 24);
        let scene = full_scene(&framed.model);
        let bundles = SkyBundles::new(400, 3).unwrap();
        let site = crate::solar::Site::new(48.76, 11.42);
        let table = SunTable::year(2025, 120, &site).unwrap();
        let hopts = HorizonOptions::default().with_step(10.0);

        // Each entry point: every POI announced and advanced once, results in POI order
        // (against the per-POI functions on the full scene), one flag list per POI.
        let tally = Tally::default();
        let v = svf(&framed, &bundles, &tally).unwrap();
        let h = sun_hours(&framed, &table, &tally).unwrap();
        let z = horizon(&framed, &hopts, &tally).unwrap();
        assert_eq!(tally.sum(Stage::Trace, "start").0, 3 * 24);
        assert_eq!(tally.sum(Stage::Trace, "advance").0, 3 * 24);
        assert_eq!(tally.sum(Stage::Bvh, "start").0, 3);
        for (k, p) in framed.local_pois.iter().enumerate() {
            assert_eq!(v.results[k], poi_sky_view(&scene, p, &bundles), "{}", p.id);
            assert_eq!(h.results[k], poi_sun_hours(&scene, p, &table), "{}", p.id);
            assert_eq!(z.results[k], poi_horizon(&scene, p, &hopts).unwrap());
        }
        // Streets and courtyards (some sky, some flags) as well as inside buildings.
        assert!(v.results.iter().any(|r| r.svf > 0.0 && r.svf < 1.0));
        assert!(v.flags.iter().any(Vec::is_empty));
        assert_eq!((v.flags.len(), h.flags.len(), z.flags.len()), (24, 24, 24));

        // Cancelled after 2 POIs: no results, the trace stage named.
        let stop = Stopper::new(Stage::Trace, 2);
        let r = svf(&framed, &bundles, &stop);
        assert_eq!(
            r.unwrap_err(),
            Cancelled {
                stage: Stage::Trace
            }
        );
        assert!(stop.selected.load(Ordering::SeqCst) < 24);
        let stop = Stopper::new(Stage::Trace, 2);
        assert!(sun_hours(&framed, &table, &stop).is_err());
        let stop = Stopper::new(Stage::Trace, 2);
        assert!(matches!(
            horizon(&framed, &hopts, &stop),
            Err(PipelineError::Cancelled(Cancelled {
                stage: Stage::Trace
            }))
        ));
        // Invalid options are refused before any work.
        let tally = Tally::default();
        let bad = HorizonOptions::default().with_step(0.0);
        assert!(matches!(
            horizon(&framed, &bad, &tally),
            Err(PipelineError::Solar(_))
        ));
        assert_eq!(tally.sum(Stage::Bvh, "start").0, 0);
    }

    #[test]
    fn evaluate_reports_each_poi_and_stops_when_cancelled() {
        let mut inputs = read_inputs(&[fixture()], &crate::runtime::progress::Silent).unwrap();
        let framed = framed_with(&mut inputs, 6);
        let site = crate::solar::Site::new(48.76, 11.42);
        let opts = EvaluateOptions {
            eval: EvalOptions {
                lod: LodOptions {
                    select: crate::lod::select::SelectOptions {
                        rays: 500,
                        ..Default::default()
                    },
                    ..Default::default()
                },
                svf_rays: 500,
                ..Default::default()
            },
            sun: Some(SunTable::year(2025, 120, &site).unwrap()),
        };
        let tally = Tally::default();
        let e = evaluate(&framed, &opts, &tally).unwrap();
        assert_eq!(tally.sum(Stage::Trace, "start").0, 6);
        assert_eq!(tally.sum(Stage::Trace, "advance").0, 6);
        assert_eq!(tally.sum(Stage::Bvh, "advance").0, 3);
        let n = framed.source.assets.len() as u64;
        assert_eq!(tally.sum(Stage::Rough, "advance").0, n);
        // The same figures as the evaluation called directly (timings aside).
        let direct = crate::pipeline::evaluation::evaluate(
            &framed.model,
            &framed.local_pois,
            &opts.eval,
            opts.sun.as_ref(),
        )
        .unwrap();
        assert_eq!(e.pois.len(), 6);
        for (a, b) in e.pois.iter().zip(&direct.pois) {
            assert_eq!(a.id, b.id);
            assert_eq!(
                (a.full.svf, a.lod.svf, a.boxes.svf),
                (b.full.svf, b.lod.svf, b.boxes.svf)
            );
            assert_eq!(a.lod.sun_hours, b.lod.sun_hours);
            assert_eq!(a.levels, b.levels);
            assert!(a.full.sun_hours.is_some());
        }
        let stop = Stopper::new(Stage::Trace, 2);
        let r = evaluate(&framed, &opts, &stop);
        assert!(
            matches!(
                r,
                Err(PipelineError::Cancelled(Cancelled {
                    stage: Stage::Trace
                }))
            ),
            "{r:?}"
        );
        assert_eq!(stop.selected.load(Ordering::SeqCst), 2);
    }

    #[test]
    fn sky_pictures_come_one_per_poi_and_stop_when_cancelled() {
        let mut inputs = read_inputs(&[fixture()], &crate::runtime::progress::Silent).unwrap();
        let framed = framed_with(&mut inputs, 5);
        let partition =
            SkyPartition::new(300, crate::lod::sky::SkyVariant::EqualSolidAngle).unwrap();
        let bundles = SkyBundles::new(400, 1).unwrap();
        let lod = LodOptions {
            select: crate::lod::select::SelectOptions {
                rays: 500,
                ..Default::default()
            },
            ..Default::default()
        };
        let opts = SkyPictureOptions {
            partition: &partition,
            bundles: &bundles,
            levels: Some(lod),
        };
        let tally = Tally::default();
        let mut got = Vec::new();
        sky_pictures(
            &framed,
            &opts,
            &tally,
            |k, p| -> Result<(), PipelineError> {
                got.push((k, p));
                Ok(())
            },
        )
        .unwrap();
        assert_eq!(got.iter().map(|g| g.0).collect::<Vec<_>>(), [0, 1, 2, 3, 4]);
        assert_eq!(tally.sum(Stage::Trace, "start").0, 5);
        assert_eq!(tally.sum(Stage::Trace, "advance").0, 5);
        assert_eq!(tally.sum(Stage::Bvh, "advance").0, 2);
        let scene = full_scene(&framed.model);
        for (k, pic) in &got {
            let poi = &framed.local_pois[*k];
            assert_eq!(pic.cells.len(), partition.len());
            assert_eq!(pic.view, poi_sky_view(&scene, poi, &bundles));
            // The levels `lod` selects for this POI alone, openings shown at their wall's.
            let alone = crate::lod::lod(&framed.model, std::slice::from_ref(poi), &lod).unwrap();
            let want = shown_levels(&framed.model, alone.selection.levels);
            assert_eq!(pic.levels.as_deref(), Some(&want[..]));
        }

        // Cancelled after the first picture: `each` saw one, the trace stage is named.
        let stop = Stopper::new(Stage::Trace, 1);
        let mut seen = 0;
        let r = sky_pictures(&framed, &opts, &stop, |_, _| -> Result<(), PipelineError> {
            seen += 1;
            Ok(())
        });
        assert!(matches!(
            r,
            Err(PipelineError::Cancelled(Cancelled {
                stage: Stage::Trace
            }))
        ));
        assert_eq!(seen, 1);
        // An error of `each` stops the work and is returned as is.
        let mut calls = 0;
        let r = sky_pictures(&framed, &opts, &Silent, |_, _| {
            calls += 1;
            Err::<(), _>(PipelineError::Cancelled(Cancelled {
                stage: Stage::Write,
            }))
        });
        assert!(matches!(
            r,
            Err(PipelineError::Cancelled(Cancelled {
                stage: Stage::Write
            }))
        ));
        assert_eq!(calls, 1);
    }
}
