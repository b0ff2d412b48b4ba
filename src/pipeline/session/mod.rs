//! An owned session over the pipeline: [`Scene::load`] (inputs read, merged, checked) →
//! [`Scene::frame`] (POIs checked and framed) → a [`Study`] that owns its model and answers
//! [`Study::levels`], [`Study::svf`], [`Study::sun_hours`], [`Study::horizon`],
//! [`Study::evaluate`] and [`Study::write_levels`], with the CLI's defaults (sky bundles, site
//! from the model's CRS, year and step) and the full-detail scene and the sun table built
//! once and reused. Nothing borrowed: a function can build a [`Study`] and return it.
//!
//! ```
//! use skylod::prelude::*;
//! let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
//! let scene = Scene::load(&[dir.join("synth-small.gml")], &SceneOptions::default(), &Silent)?;
//! let c = scene.model().bbox().center();
//! let study = scene.frame(vec![Poi::at("street", [c.x, c.y, 1.5])])?;
//! let svf = study.svf(&SkyBundles::default(), &Silent)?;
//! let sun = study.sun_hours(&SunOptions::default(), &Silent)?; // site from the CRS
//! assert!(svf.results[0].svf <= 1.0 && sun.results[0].hours >= 0.0);
//! # Ok::<(), skylod::Error>(())
//! ```

pub(crate) mod bound_plan;
pub(crate) mod documents;
mod error;
mod lod;
pub(crate) mod lod_read;
pub(crate) mod lod_write;
pub(crate) mod pictures;
mod read_hollow;
pub(crate) mod report;
pub(crate) mod site;
pub(crate) mod weather;
pub use bound_plan::BoundRequest;
pub use documents::{ms_since, EvaluateRequest, IrradianceRequest, IrradianceRun};
pub use lod_read::{lod_read, memory_size, mib, Budget, LodRead, Unserved, WholeWhy};
pub use lod_write::{
    check_report, write_report, FileOutcome, LodLayout, LodWritten, ReportTargetError,
};
pub use pictures::{PictureSvg, Pictures};
pub use report::RunMs;
pub use site::{given_site, site_of, SiteError};
pub use weather::{weather_site, SunSite, WeatherYear};

pub use error::{Error, Result};

use crate::export::Format;
use crate::io::citygml::write::WriteOptions;
use crate::io::citygml::ReadError;
use crate::io::citygml::WriteError;
use crate::io::files::Protected;
use crate::lod::evaluation::Evaluation;
use crate::lod::mixed::MixedSource;
use crate::lod::poi::checks::TrustError;
use crate::lod::scene::full_scene;
use crate::lod::LodOptions;
use crate::model::crs::{box_site, Crs, LocalFrame, ModelSite};
use crate::model::runtime::progress::{check, Progress, Stage};
use crate::model::{Bbox, CityModel, Poi, Source};
use crate::pipeline::batch::inputs::{expand, Input};
use crate::pipeline::batch::outputs::{create_parent, plan, Plan};
use crate::pipeline::{check_model_in, PoiIrradiance, Traced, Written};
use crate::pipeline::{evaluate, frame_in, horizon, levels, read_inputs, read_sources};
use crate::pipeline::{trace_in, write_all, write_levels};
use crate::pipeline::{EvaluateOptions, FrameOptions, Framed, Levels, LevelsInput, LevelsOptions};
use crate::solar::irradiance::{IrradianceOptions, IrradianceTable};
use crate::solar::{poi_horizon, poi_sky_view, poi_sun_hours, HorizonOptions, HorizonProfile};
use crate::solar::{Site, SkyBundles, SkyView, SunHours, SunTable, DEFAULT_STEP_MIN, DEFAULT_YEAR};
use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

/// How a [`Scene`] is read and framed.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct SceneOptions {
    /// CRSs of the inputs and the POIs, the margin around the scene ([`FrameOptions`]).
    pub frame: FrameOptions,
    /// Merge inputs whose `srsName`s name different CRSs anyway.
    pub allow_mixed_crs: bool,
    /// Give free heap pages back to the system between stages for large models
    /// (`malloc_trim`, process-wide: `crate::model::runtime::mem::set_give_back`).
    pub trim_memory: bool,
}

impl Default for SceneOptions {
    fn default() -> Self {
        SceneOptions {
            frame: FrameOptions::default(),
            allow_mixed_crs: false,
            trim_memory: true,
        }
    }
}

/// The sun of [`Study::sun_hours`]: the site (`None`: the centre of the model from its CRS,
/// [`Study::site`]), the simulated year and the step, with the CLI's defaults.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct SunOptions {
    /// Where the sun is seen from; `None`: from the model's CRS.
    pub site: Option<Site>,
    /// Calendar year (UTC).
    pub year: i32,
    /// Minutes per step.
    pub step_min: u32,
}

impl Default for SunOptions {
    fn default() -> Self {
        SunOptions {
            site: None,
            year: DEFAULT_YEAR,
            step_min: DEFAULT_STEP_MIN,
        }
    }
}

impl SunOptions {
    /// The sun at `site` over `year` in steps of `step_min` minutes.
    pub fn new(site: Option<Site>, year: i32, step_min: u32) -> Self {
        SunOptions {
            site,
            year,
            step_min,
        }
    }

    /// The same at `site`.
    pub fn at(mut self, site: Site) -> Self {
        self.site = Some(site);
        self
    }
}

impl SceneOptions {
    /// Inputs framed with `frame`, merged across CRSs with `allow_mixed_crs`, memory given
    /// back between stages.
    pub fn new(frame: FrameOptions, allow_mixed_crs: bool) -> Self {
        SceneOptions {
            frame,
            allow_mixed_crs,
            ..SceneOptions::default()
        }
    }
}

/// Inputs read and merged into one model, checked ([`crate::pipeline::Inputs::check`]).
#[derive(Debug)]
pub struct Scene {
    inputs: Vec<Input>,
    model: CityModel,
    /// The model's box ([`CityModel::bbox`]), taken once for the checks, the frame and the
    /// sun's site: [`Scene::frame`] gives it to the [`Study`], which keeps it alone.
    bbox: Bbox,
    failures: Vec<ReadError>,
    options: SceneOptions,
    read_s: f64,
}

impl Scene {
    /// Read `paths` (files, directories searched recursively, glob patterns:
    /// [`crate::pipeline::batch::inputs::expand`]) in parallel and merge them ([`Scene::load_inputs`]).
    ///
    /// # Errors
    /// [`Error::Input`] (nothing found), then as [`Scene::load_inputs`].
    pub fn load<P: AsRef<Path>>(
        paths: &[P],
        options: &SceneOptions,
        progress: &dyn Progress,
    ) -> Result<Scene> {
        let args: Vec<PathBuf> = paths.iter().map(|p| p.as_ref().to_path_buf()).collect();
        Scene::load_inputs(expand(&args)?, options, progress)
    }

    /// Read `inputs` (with the paths outputs mirror) and refuse a model that would give a
    /// confidently wrong answer: nothing read, mixed CRSs, no heights ([`Scene::check`]). An
    /// input that cannot be read is kept in [`Scene::failures`] while the others are used.
    ///
    /// # Errors
    /// [`Error::Trust`], [`Error::Cancelled`].
    pub fn load_inputs(
        inputs: Vec<Input>,
        options: &SceneOptions,
        progress: &dyn Progress,
    ) -> Result<Scene> {
        let scene = Scene::read(inputs, options, progress)?;
        scene.check()?;
        Ok(scene)
    }

    /// [`Scene::load_inputs`] without its checks: a caller that reports the failures
    /// itself (as the CLI does, each on its own) then calls [`Scene::check`].
    ///
    /// # Errors
    /// [`Error::Cancelled`].
    pub fn read(
        inputs: Vec<Input>,
        options: &SceneOptions,
        progress: &dyn Progress,
    ) -> Result<Scene> {
        crate::model::runtime::mem::set_give_back(options.trim_memory);
        let paths: Vec<PathBuf> = inputs.iter().map(|i| i.path.clone()).collect();
        let read = read_inputs(&paths, progress)?;
        Ok(Scene::from_read(inputs, read, options))
    }

    /// [`Scene::load_inputs`] of documents wherever they are: `(name, source)` pairs, a
    /// [`Source::Memory`] for bytes a program holds (a download, a database blob), plain or
    /// gzip. The name is the input's path in the model, messages and outputs (`-o DIR` puts
    /// its output at its file name); every writer copies from the bytes as from a file.
    ///
    /// # Errors
    /// As [`Scene::load_inputs`].
    pub fn load_sources(
        sources: Vec<(PathBuf, Source)>,
        options: &SceneOptions,
        progress: &dyn Progress,
    ) -> Result<Scene> {
        crate::model::runtime::mem::set_give_back(options.trim_memory);
        let inputs = sources
            .iter()
            .map(|(name, _)| Input {
                path: name.clone(),
                relative: name.file_name().map_or_else(|| name.clone(), PathBuf::from),
            })
            .collect();
        let read = read_sources(sources, progress)?;
        let scene = Scene::from_read(inputs, read, options);
        scene.check()?;
        Ok(scene)
    }

    /// The scene of `read`; `inputs` cut to those read.
    fn from_read(
        inputs: Vec<Input>,
        read: crate::pipeline::Inputs,
        options: &SceneOptions,
    ) -> Scene {
        let mut left = read.read.iter().peekable();
        let inputs = inputs
            .into_iter()
            .filter(|i| left.next_if(|p| **p == i.path).is_some())
            .collect();
        Scene {
            inputs,
            bbox: read.model.bbox(),
            model: read.model,
            failures: read.failures,
            options: options.clone(),
            read_s: read.read_s,
        }
    }

    /// Refuse a model that would give a confidently wrong answer whatever the POIs: nothing
    /// read, inputs in different CRSs (unless [`SceneOptions::allow_mixed_crs`]), no heights
    /// ([`crate::pipeline::Inputs::check`]).
    ///
    /// # Errors
    /// [`Error::Trust`].
    pub fn check(&self) -> Result<()> {
        if self.inputs.is_empty() {
            return Err(TrustError::NoInput {
                failed: self.failures.len(),
            }
            .into());
        }
        let mixed = self.options.allow_mixed_crs;
        Ok(check_model_in(&self.model, &self.bbox, mixed)?)
    }

    /// Seconds spent reading the inputs.
    pub fn read_s(&self) -> f64 {
        self.read_s
    }

    /// The merged model, as read.
    pub fn model(&self) -> &CityModel {
        &self.model
    }

    /// The inputs read, in order (`model.files[k]` is `inputs()[k]`).
    pub fn inputs(&self) -> &[Input] {
        &self.inputs
    }

    /// The inputs that could not be read.
    pub fn failures(&self) -> &[ReadError] {
        &self.failures
    }

    /// Check `pois` ([`crate::lod::poi::check_poi_list`]) and bring them and the model into the
    /// local metric frame (`crate::pipeline::frame`), refusing POIs far outside the scene.
    ///
    /// # Errors
    /// [`Error::Poi`], [`Error::PoiCrs`], [`Error::Trust`].
    pub fn frame(self, pois: Vec<Poi>) -> Result<Study> {
        let Scene {
            inputs,
            mut model,
            bbox,
            failures,
            options,
            read_s,
        } = self;
        let f = Frame::from(frame_in(&mut model, Some(bbox), pois, &options.frame)?);
        let read = Read::Whole(model);
        Ok(Study::new((inputs, read, bbox), f, failures, read_s))
    }
}

/// What the frame gave a [`Study`], owned: the model in the local frame where it is not the
/// identity, the POIs in both frames, what to tell the user.
#[derive(Debug)]
struct Frame {
    local: Option<CityModel>,
    crs: Crs,
    frame: LocalFrame,
    pois: Vec<Poi>,
    /// The POIs in the local frame; `None` where the frame is the identity (they are
    /// [`Frame::pois`]: a city's millions of points held once).
    local_pois: Option<Vec<Poi>>,
    warnings: Vec<String>,
    note: Option<String>,
    frame_warning: Option<crate::model::crs::FrameWarning>,
}

impl From<Framed<'_>> for Frame {
    fn from(f: Framed<'_>) -> Self {
        Frame {
            local: match f.model {
                Cow::Owned(m) => Some(m),
                Cow::Borrowed(_) => None,
            },
            crs: f.crs,
            frame: f.frame,
            pois: f.pois.into_owned(),
            local_pois: (!f.frame.is_identity()).then(|| f.local_pois.into_owned()),
            warnings: f.warnings,
            note: f.note,
            frame_warning: f.frame_warning,
        }
    }
}

/// A framed scene with its POIs, owning its model: levels, solar figures and outputs
/// ([`Scene::frame`]). The full-detail scene and the sun table are built on first use.
///
/// A study of one large document may be read hollow ([`Study::read_hollow`]): it holds the
/// polygons of the POIs' surroundings only, and gives the levels, the report and the CityGML
/// output of the whole read; what traces or exports the full model asks for a whole read
/// ([`Error::Hollow`]).
#[derive(Debug)]
pub struct Study {
    inputs: Vec<Input>,
    read: Read,
    /// The source's box ([`CityModel::bbox`]): the one the [`Scene`] took, kept here alone
    /// ([`Framed`] does not carry it).
    bbox: Bbox,
    framed: Frame,
    failures: Vec<ReadError>,
    read_s: f64,
    full: OnceLock<crate::solar::trace::TraceScene>,
    sun: Mutex<Option<(SunOptions, Arc<SunTable>)>>,
}

/// What a [`Study`] read: its model whole, or one document hollow.
#[derive(Debug)]
enum Read {
    Whole(CityModel),
    Hollow(Box<read_hollow::HollowRead>),
}

impl Study {
    /// The study of what was `read` (from `inputs`, its box `bbox`) framed as `f`, with the
    /// inputs that could not be read and the seconds reading took.
    fn new(
        (inputs, read, bbox): (Vec<Input>, Read, Bbox),
        f: Frame,
        failures: Vec<ReadError>,
        read_s: f64,
    ) -> Study {
        Study {
            inputs,
            read,
            bbox,
            framed: f,
            failures,
            read_s,
            full: OnceLock::new(),
            sun: Mutex::new(None),
        }
    }

    /// The borrowed view the pipeline's functions take.
    pub fn framed(&self) -> Framed<'_> {
        Framed {
            source: self.source(),
            model: Cow::Borrowed(self.local_model()),
            crs: self.framed.crs.clone(),
            frame: self.framed.frame,
            pois: Cow::Borrowed(&self.framed.pois),
            local_pois: Cow::Borrowed(
                self.framed
                    .local_pois
                    .as_deref()
                    .unwrap_or(&self.framed.pois),
            ),
            warnings: self.framed.warnings.clone(),
            note: self.framed.note.clone(),
            frame_warning: self.framed.frame_warning.clone(),
        }
    }

    /// The model as read (the input's CRS; read hollow, the polygons of a few assets only).
    pub fn source(&self) -> &CityModel {
        match &self.read {
            Read::Whole(m) => m,
            Read::Hollow(h) => &h.hollow.model,
        }
    }

    /// The model read whole: [`Error::Hollow`] for a study read hollow.
    pub(super) fn whole(&self) -> Result<&CityModel> {
        match &self.read {
            Read::Whole(m) => Ok(m),
            Read::Hollow(h) => Err(Error::Hollow {
                file: h.reread.path().to_path_buf(),
            }),
        }
    }

    /// The box of every asset as read ([`CityModel::bbox`] of the whole read).
    pub fn bbox(&self) -> Bbox {
        self.bbox
    }

    /// The POIs in the model's CRS, in order.
    pub fn pois(&self) -> &[Poi] {
        &self.framed.pois
    }

    /// The model's CRS.
    pub fn crs(&self) -> &Crs {
        &self.framed.crs
    }

    /// The inputs read, in order.
    pub fn inputs(&self) -> &[Input] {
        &self.inputs
    }

    /// The inputs that could not be read.
    pub fn failures(&self) -> &[ReadError] {
        &self.failures
    }

    /// What to tell the user: other CRSs named by the inputs, the frame's accuracy.
    pub fn warnings(&self) -> &[String] {
        &self.framed.warnings
    }

    /// The frame's warning, structured (its text is the last of [`Study::warnings`]).
    pub fn frame_warning(&self) -> Option<&crate::model::crs::FrameWarning> {
        self.framed.frame_warning.as_ref()
    }

    /// A note on the frame when it is not the identity ("tracing in ...").
    pub fn note(&self) -> Option<&str> {
        self.framed.note.as_deref()
    }

    /// Seconds spent reading the inputs ([`Scene::read_s`]).
    pub fn read_s(&self) -> f64 {
        self.read_s
    }

    /// The model in the local metric frame: what is traced.
    pub fn local_model(&self) -> &CityModel {
        self.framed.local.as_ref().unwrap_or(self.source())
    }

    /// The site of the sun from the model's CRS: the centre of the model in WGS 84.
    ///
    /// # Errors
    /// [`Error::Site`] for an empty model or a CRS the build does not convert.
    pub fn site(&self) -> Result<ModelSite> {
        Ok(box_site(&self.bbox, &self.framed.crs)?)
    }

    /// The sun's site as [`site::site_of`] gives it for [`Study::source`] (the `lat`, `lon`
    /// given, else the centre of the model in its own CRS), from the box the scene took when
    /// it was read.
    ///
    /// # Errors
    /// As [`site::site_of`].
    pub fn sun_site(
        &self,
        lat: Option<f64>,
        lon: Option<f64>,
    ) -> std::result::Result<SunSite, site::SiteError> {
        site::site_in(lat, lon, self.source(), &self.bbox)
    }

    /// Levels of every asset (`crate::pipeline::levels`; read hollow, with the rough forms
    /// of the read).
    ///
    /// # Errors
    /// [`Error::Select`], [`Error::Bound`], [`Error::Cancelled`].
    pub fn levels(&self, opts: &LevelsOptions, progress: &dyn Progress) -> Result<Levels> {
        let Read::Hollow(h) = &self.read else {
            return levels(&self.framed(), opts, progress);
        };
        let opts = LevelsOptions {
            lod: self.lod_options(&opts.lod),
            bound: opts.bound.clone(),
        };
        let input = LevelsInput::Hollow {
            hollow: &h.hollow,
            reread: &h.reread,
            pois: &self.framed.pois,
        };
        levels(input, &opts, progress)
    }

    /// `opts`, with the rough forms of the read where it was hollow.
    fn lod_options(&self, opts: &LodOptions) -> LodOptions {
        match &self.read {
            Read::Whole(_) => *opts,
            Read::Hollow(h) => LodOptions {
                rough: h.rough,
                select: opts.select,
            },
        }
    }

    /// The full-detail scene (built on first use) and the seconds this call spent building it.
    fn full(&self, progress: &dyn Progress) -> Result<(&crate::solar::trace::TraceScene, f64)> {
        if let Some(s) = self.full.get() {
            return Ok((s, 0.0));
        }
        check(progress, Stage::Bvh)?;
        let t = std::time::Instant::now();
        let model = self.local_model();
        let s = crate::model::runtime::progress::stage(progress, Stage::Bvh, 1, 0, || {
            let s = full_scene(model);
            progress.advance(Stage::Bvh, 1, 0, None);
            s
        });
        let s = self.full.get_or_init(|| s);
        Ok((s, t.elapsed().as_secs_f64()))
    }

    /// `f` for every POI against the full-detail scene, with the seconds of building it.
    fn trace<T: Send>(
        &self,
        f: impl Fn(&crate::solar::trace::TraceScene, &Poi) -> T + Sync,
        sky_rays: impl Fn(&T) -> Option<usize> + Sync,
        progress: &dyn Progress,
    ) -> Result<Traced<T>> {
        self.whole()?;
        let (scene, bvh_s) = self.full(progress)?;
        let mut t = trace_in(&self.framed(), scene, f, sky_rays, progress)?;
        t.bvh_s = bvh_s;
        Ok(t)
    }

    /// The sun table of `sun` (built once per options and kept).
    ///
    /// # Errors
    /// [`Error::Site`] without a site, [`Error::Solar`] for invalid options.
    pub fn sun_table(&self, sun: &SunOptions) -> Result<Arc<SunTable>> {
        self.sun_table_with(sun, &crate::model::runtime::progress::Silent)
    }

    /// [`Study::sun_table`], built as the progress stage [`Stage::Sun`].
    ///
    /// # Errors
    /// As [`Study::sun_table`]; [`Error::Cancelled`].
    pub fn sun_table_with(
        &self,
        sun: &SunOptions,
        progress: &dyn Progress,
    ) -> Result<Arc<SunTable>> {
        let mut cached = self.sun.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((o, t)) = cached.as_ref() {
            if o == sun {
                return Ok(t.clone());
            }
        }
        let site = match sun.site {
            Some(s) => s,
            None => {
                let s = self.site()?;
                Site::new(s.lat, s.lon)
            }
        };
        let t = SunTable::year_with(sun.year, sun.step_min, &site, progress)?;
        let t = Arc::new(t);
        *cached = Some((*sun, t.clone()));
        Ok(t)
    }

    /// SVF and sky exposure of every POI against the full-detail scene.
    ///
    /// # Errors
    /// [`Error::Cancelled`].
    pub fn svf(&self, bundles: &SkyBundles, progress: &dyn Progress) -> Result<Traced<SkyView>> {
        let f = |s: &_, p: &Poi| poi_sky_view(s, p, bundles);
        let no_sky = |v: &SkyView| (v.sky_exposure == 0.0).then_some(0);
        self.trace(f, no_sky, progress)
    }

    /// Hours of direct sun of every POI over the year of `sun`.
    ///
    /// # Errors
    /// As [`Study::sun_table`], [`Error::Cancelled`].
    pub fn sun_hours(&self, sun: &SunOptions, progress: &dyn Progress) -> Result<Traced<SunHours>> {
        let table = self.sun_table_with(sun, progress)?;
        let f = |s: &_, p: &Poi| poi_sun_hours(s, p, &table);
        self.trace(f, |_| None, progress)
    }

    /// Horizon profile of every POI.
    ///
    /// # Errors
    /// [`Error::Solar`] for invalid options, [`Error::Cancelled`].
    pub fn horizon(
        &self,
        opts: &HorizonOptions,
        progress: &dyn Progress,
    ) -> Result<Traced<HorizonProfile>> {
        self.whole()?;
        if self.full.get().is_none() {
            return horizon(&self.framed(), opts, progress);
        }
        opts.validate()?;
        let f = |s: &_, p: &Poi| poi_horizon(s, p, opts);
        let t = self.trace(f, |_| None, progress)?;
        Ok(Traced {
            results: t.results.into_iter().collect::<Result<_, _>>()?,
            flags: t.flags,
            bvh_s: t.bvh_s,
            trace_s: t.trace_s,
        })
    }

    /// Annual irradiation of every POI under `table`'s weather
    /// (`crate::pipeline::irradiance`) against the scenes `scenes`; `hourly` keeps each
    /// hour's value.
    ///
    /// # Errors
    /// [`Error::Cancelled`].
    pub fn irradiance(
        &self,
        bundles: &SkyBundles,
        table: &IrradianceTable,
        opts: &IrradianceOptions,
        hourly: bool,
        scenes: crate::pipeline::Scenes,
        progress: &dyn Progress,
    ) -> Result<Traced<PoiIrradiance>> {
        self.whole()?;
        let f = self.framed();
        Ok(crate::pipeline::irradiance(
            &f, bundles, table, opts, hourly, scenes, progress,
        )?)
    }

    /// Full vs LoD vs all-boxes model at every POI (`crate::pipeline::evaluate`).
    ///
    /// # Errors
    /// [`Error::Eval`], [`Error::Cancelled`].
    pub fn evaluate(&self, opts: &EvaluateOptions, progress: &dyn Progress) -> Result<Evaluation> {
        self.whole()?;
        evaluate(&self.framed(), opts, progress)
    }

    /// Write every input at `levels` to `out` in `format` (`None`: from `out`'s ending, else
    /// CityGML): one input to a file, several mirrored below a directory (parent folders
    /// created) or merged into one CityGML file ([`crate::pipeline::batch::outputs::plan`]). An
    /// existing output is replaced only with `overwrite`. The outputs written, in input order.
    /// A study read hollow writes CityGML only.
    ///
    /// # Errors
    /// [`Error::Plan`] (before anything is written), [`Error::Write`] (the first output
    /// that failed; the others are written), [`Error::Hollow`], [`Error::Cancelled`].
    pub fn write_levels(
        &mut self,
        levels: &Levels,
        out: &Path,
        format: Option<Format>,
        overwrite: bool,
        progress: &dyn Progress,
    ) -> Result<Vec<(PathBuf, Written)>> {
        let (plan, format) = plan(&self.inputs, out, format)?;
        if format != Format::CityGml {
            self.whole()?;
        }
        let paths: Vec<PathBuf> = self.inputs.iter().map(|i| i.path.clone()).collect();
        let wopts = WriteOptions {
            overwrite,
            protect: Protected::new(&paths),
            ..WriteOptions::default()
        };
        let targets = plan.targets(&paths, &wopts, None, (true, false))?;
        if let Some(e) = targets.refused.into_iter().next() {
            return Err(e.into());
        }
        for (_, p) in &targets.todo {
            create_parent(p)?;
        }
        let results =
            self.write_targets(&targets.todo, levels, format, &targets.write_opts, progress)?;
        let mut written = Vec::with_capacity(results.len());
        for ((_, p), r) in targets.todo.iter().zip(results) {
            written.push((p.clone(), r?));
        }
        if let (Plan::Merge(target), Some(staging)) = (&plan, &targets.staging) {
            let parts: Vec<PathBuf> = (0..paths.len()).map(|k| staging.part(k)).collect();
            crate::export::merge::merge_named(&parts, &paths, target, &wopts)
                .map_err(|e| Error::Merge(Box::new(e)))?;
            let total = written.iter().fold(Written::default(), |mut a, (_, w)| {
                a.bytes += w.bytes;
                a.polygons_in += w.polygons_in;
                a.polygons_out += w.polygons_out;
                a
            });
            return Ok(vec![(target.clone(), total)]);
        }
        Ok(written)
    }

    /// Each input `file` of the study at `levels` to its output in `targets` ((file, output)
    /// pairs laid out beforehand, e.g. by [`crate::pipeline::batch::plan`]: parent folders
    /// made, targets checked), in parallel; the result of each, in order. Read hollow, its
    /// one document is written a chunk at a time (CityGML only).
    ///
    /// # Errors
    /// [`Error::Cancelled`].
    pub fn write_targets(
        &mut self,
        targets: &[(usize, PathBuf)],
        levels: &Levels,
        format: Format,
        wopts: &WriteOptions,
        progress: &dyn Progress,
    ) -> Result<Vec<std::result::Result<Written, WriteError>>> {
        let Some((hollow, rr, chunk)) = self.hollow_mut() else {
            return Ok(write_all(
                self.source(),
                targets,
                levels,
                format,
                wopts,
                progress,
            )?);
        };
        check(progress, Stage::Write)?;
        progress.start(Stage::Write, targets.len() as u64, 0);
        let mut results = Vec::with_capacity(targets.len());
        for (_, out) in targets {
            let src = MixedSource::Hollow(hollow, rr, chunk);
            results.push(write_levels(src, levels, out, format, wopts));
            progress.advance(Stage::Write, 1, 0, Some(&out.display().to_string()));
        }
        progress.finish(Stage::Write);
        Ok(results)
    }

    /// Write input `file` at `levels` in `format` to `w` (e.g. a buffer or a socket),
    /// uncompressed (`crate::pipeline::write_levels_to`).
    ///
    /// # Errors
    /// [`Error::Write`].
    pub fn write_levels_to(
        &self,
        levels: &Levels,
        file: usize,
        format: Format,
        w: &mut dyn std::io::Write,
    ) -> Result<Written> {
        let wopts = WriteOptions::default();
        Ok(crate::pipeline::write_levels_to(
            self.whole()?,
            file,
            levels,
            w,
            format,
            &wopts,
        )?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lod::poi::checks::TrustError;
    use crate::model::runtime::progress::Silent;
    use crate::pipeline::test_support::*;

    #[test]
    fn full_scene_and_sun_table_are_built_once_and_give_the_pipeline_s_answers() {
        let s = study(4);
        let tally = Tally::default();
        let bundles = SkyBundles::new(300, 2).unwrap();
        let sun = SunOptions {
            step_min: 120,
            ..SunOptions::default()
        };
        let v = s.svf(&bundles, &tally).unwrap();
        let h = s.sun_hours(&sun, &tally).unwrap();
        // The scene's building time goes to the call that built it.
        assert!(v.bvh_s > 0.0 && h.bvh_s == 0.0, "{} {}", v.bvh_s, h.bvh_s);
        assert!(s.read_s() > 0.0);
        let z = s.horizon(&HorizonOptions::default().with_step(10.0), &tally);
        assert!(z.is_ok());
        assert_eq!(tally.sum(Stage::Bvh, "start").0, 1);
        assert_eq!(tally.sum(Stage::Bvh, "advance").0, 1);
        assert_eq!(tally.sum(Stage::Trace, "advance").0, 3 * 4);
        // the sun table: a stage that advances as far as it announced (a year at 2 h)
        assert_eq!(tally.sum(Stage::Sun, "start").0, 365 * 12);
        assert_eq!(tally.sum(Stage::Sun, "advance").0, 365 * 12);
        assert!(Arc::ptr_eq(
            &s.sun_table(&sun).unwrap(),
            &s.sun_table(&sun).unwrap()
        ));
        // The same figures as the borrowed pipeline, site from the CRS, default year.
        let framed = s.framed();
        let site = s.site().unwrap();
        let table = SunTable::year(DEFAULT_YEAR, 120, &Site::new(site.lat, site.lon)).unwrap();
        assert_eq!(
            v.results,
            crate::pipeline::test_support::svf(&framed, &bundles, &Silent)
                .unwrap()
                .results
        );
        let direct = crate::pipeline::test_support::sun_hours(&framed, &table, &Silent).unwrap();
        assert_eq!(h.results, direct.results);
        assert_eq!(v.flags.len(), 4);
        // Results serialise for a program's JSON.
        let j = serde_json::to_value(&v).unwrap();
        assert!(j["results"][0]["svf"].is_number(), "{j}");
        assert!(serde_json::to_value(&h).unwrap()["results"][0]["hours"].is_number());
    }

    #[test]
    fn writes_create_folders_and_reach_a_writer() {
        let mut s = study(2);
        let lv = s.levels(&LevelsOptions::default(), &Silent).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("a/b/lod.gml");
        let w = s.write_levels(&lv, &out, None, false, &Silent).unwrap();
        assert_eq!(w.len(), 1);
        assert_eq!(w[0].0, out);
        let on_disk = std::fs::read(&out).unwrap();
        assert_eq!(w[0].1.bytes, on_disk.len() as u64);
        // Again without overwrite: refused, naming the output.
        let e = s.write_levels(&lv, &out, None, false, &Silent).unwrap_err();
        assert!(matches!(&e, Error::Write(crate::io::citygml::WriteError::Exists(p)) if *p == out));
        let mut buf = Vec::new();
        let w = s
            .write_levels_to(&lv, 0, Format::CityGml, &mut buf)
            .unwrap();
        assert_eq!(buf, on_disk);
        assert_eq!(w.bytes, buf.len() as u64);
    }

    #[test]
    fn a_scene_from_memory_writes_what_its_file_writes() {
        let bytes: Arc<[u8]> = std::fs::read(fixture()).unwrap().into();
        let name = PathBuf::from("mem/small.gml");
        let sources = vec![(name.clone(), Source::Memory(bytes))];
        let scene = Scene::load_sources(sources, &SceneOptions::default(), &Silent).unwrap();
        assert_eq!(scene.inputs()[0].relative, PathBuf::from("small.gml"));
        assert_eq!(scene.model().files[0].path, name);
        let pois = grid_pois(scene.model(), 2);
        let m = scene.frame(pois).unwrap();
        let f = study(2);
        let opts = LevelsOptions::default();
        let (lm, lf) = (
            m.levels(&opts, &Silent).unwrap(),
            f.levels(&opts, &Silent).unwrap(),
        );
        for format in [Format::CityGml, Format::Obj, Format::CityJson] {
            let (mut a, mut b) = (Vec::new(), Vec::new());
            m.write_levels_to(&lm, 0, format, &mut a).unwrap();
            f.write_levels_to(&lf, 0, format, &mut b).unwrap();
            if format == Format::Obj {
                // the comment line names the source
                let from = format!("OBJ of {};", fixture().display());
                let b2 = String::from_utf8(b)
                    .unwrap()
                    .replacen(&from, "OBJ of mem/small.gml;", 1);
                b = b2.into_bytes();
            }
            assert!(!a.is_empty() && a == b, "{format:?}");
        }
    }

    #[test]
    fn nothing_read_is_refused_at_load() {
        let dir = tempfile::tempdir().unwrap();
        let bad = dir.path().join("bad.gml");
        std::fs::write(&bad, "<CityModel").unwrap();
        let r = Scene::load(&[&bad], &SceneOptions::default(), &Silent);
        assert!(
            matches!(r, Err(Error::Trust(TrustError::NoInput { failed: 1 }))),
            "{r:?}"
        );
        // Read without the checks: the failure is kept for the caller to report.
        let input = Input {
            path: bad.clone(),
            relative: "bad.gml".into(),
        };
        let scene = Scene::read(vec![input], &SceneOptions::default(), &Silent).unwrap();
        assert!(scene.inputs().is_empty());
        assert_eq!(scene.failures().len(), 1);
        assert!(matches!(
            scene.check(),
            Err(Error::Trust(TrustError::NoInput { failed: 1 }))
        ));
    }
}
