//! Shared by the commands: inputs merged into one model, POIs, and the argument groups
//! (rough model, selection, site, sun, output) flattened into each command so that the
//! commands cannot drift apart.

use crate::args::crs::{frame, Framed};
use crate::log::{error, summary, warning};
use crate::Outcome;
use anyhow::{bail, Context};
use skylod::export::Format;
use skylod::lod::rough::RoughOptions;
use skylod::lod::select::SelectOptions;
use skylod::model::CityModel;
use skylod::poi::checks::{PoiFlag, DEFAULT_POI_MARGIN};
use skylod::poi::{check_unique_ids, parse_poi, read_pois_csv, Located, Poi};
use std::path::PathBuf;
use std::time::Instant;

/// Default year of `--year`: a fixed year so that results are reproducible.
pub const DEFAULT_YEAR: i32 = 2025;

/// Inputs and points of interest.
#[derive(clap::Args, Debug)]
pub struct PoiArgs {
    /// CityGML files (.gml, .xml, .gz; gzip is recognised by content), directories (searched
    /// recursively), glob patterns ('tiles/**/*.gml', quoted), or - for standard input; all
    /// are merged into one scene.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Point of interest X,Y,Z or X,Y,Z,NX,NY,NZ (model CRS; the normal is the outward
    /// normal of the surface the point lies on). Repeatable.
    #[arg(
        long = "poi",
        value_name = "X,Y,Z[,NX,NY,NZ]",
        allow_hyphen_values = true
    )]
    pub poi: Vec<String>,
    /// CSV file of POIs (header `id,x,y,z[,nx,ny,nz]`, columns in any order; quoted
    /// fields, a UTF-8 BOM and `#` comment lines are fine), read after the --poi points.
    #[arg(long, value_name = "FILE.csv")]
    pub pois: Option<PathBuf>,
    /// Refuse POIs farther than this (m) outside the scene's bounding box: they are almost
    /// always in another CRS or have x and y swapped.
    #[arg(long, value_name = "M", default_value_t = DEFAULT_POI_MARGIN, value_parser = non_negative, allow_hyphen_values = true)]
    pub poi_margin: f64,
    /// Merge inputs whose srsName denote different CRSs into one scene anyway (only when
    /// the names differ but the coordinates really are in one CRS).
    #[arg(long)]
    pub allow_mixed_crs: bool,
    /// `--source-crs`, `--poi-crs`: applied by `crate::args::crs::frame` after reading.
    #[command(flatten)]
    pub crs: crate::args::crs::CrsArgs,
    /// `--jobs`: threads reading the inputs and tracing the POIs.
    #[command(flatten)]
    pub jobs: JobsArgs,
}

/// `--jobs`: how many input files are worked on at once.
#[derive(clap::Args, Debug, Clone, Copy, Default)]
pub struct JobsArgs {
    /// Worker threads: input files read or written at once, parts of one large uncompressed
    /// file read at once, POIs traced at once (default: one per core). The outputs are the
    /// same whatever the number.
    #[arg(long, short = 'j', value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    pub jobs: Option<u16>,
}

impl JobsArgs {
    /// Make rayon's global pool `--jobs` threads wide (for commands whose every parallel step,
    /// in the binary and in the library, should use it). Call before any parallel work.
    pub fn global(&self) -> anyhow::Result<()> {
        if let Some(n) = self.jobs {
            rayon::ThreadPoolBuilder::new()
                .num_threads(usize::from(n))
                .build_global()
                .context("starting the worker threads")?;
        }
        Ok(())
    }

    /// Run `f` in a thread pool of `--jobs` threads (rayon's global pool without it).
    pub fn install<T: Send>(&self, f: impl FnOnce() -> T + Send) -> anyhow::Result<T> {
        match self.jobs {
            None => Ok(f()),
            Some(n) => Ok(rayon::ThreadPoolBuilder::new()
                .num_threads(usize::from(n))
                .build()
                .context("starting the worker threads")?
                .install(f)),
        }
    }
}

/// The closing line of a batch: files ok / failed, warnings, polygons in / out, wall time.
pub fn summary_line(
    cmd: &str,
    ok: usize,
    failed: usize,
    warnings: usize,
    polygons: Option<(usize, usize)>,
    t: Instant,
) -> String {
    let polys = polygons.map_or(String::new(), |(i, o)| format!(", polygons {i} -> {o}"));
    format!(
        "{cmd}: {ok} file(s) ok, {failed} failed, {warnings} warning(s){polys}, {:.2} s",
        t.elapsed().as_secs_f64()
    )
}

/// A clap value parser: a finite number ≥ 0.
pub fn non_negative(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(format!("must be a finite number >= 0, got {s}"))
    }
}

/// A clap value parser: a finite number > 0.
pub fn positive(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("must be a finite number > 0, got {s}"))
    }
}

impl PoiArgs {
    /// The POIs in order (--poi first, then the CSV). No POI at all, or two with the same
    /// id, is a usage error.
    pub fn points(&self) -> anyhow::Result<Vec<Poi>> {
        let mut out = Vec::new();
        for (i, t) in self.poi.iter().enumerate() {
            out.push(Located {
                poi: parse_poi(t, i)?,
                at: format!("--poi {t}"),
            });
        }
        if let Some(f) = &self.pois {
            out.extend(read_pois_csv(f)?);
        }
        if out.is_empty() {
            bail!("no point of interest: give --poi X,Y,Z[,NX,NY,NZ] or --pois FILE.csv");
        }
        check_unique_ids(&out)?;
        Ok(out.into_iter().map(|l| l.poi).collect())
    }

    /// Size the thread pool (`--jobs`), read the inputs ([`load`]) and refuse a model that would give a confidently wrong
    /// answer whatever the POIs (`skylod::poi::checks`): inputs in different CRSs (unless
    /// --allow-mixed-crs), a model without heights.
    pub fn load_checked(&self) -> anyhow::Result<Loaded> {
        self.jobs.global()?;
        let loaded = load(&self.inputs)?;
        loaded.check(self.allow_mixed_crs)?;
        Ok(loaded)
    }

    /// Bring the model and `pois` into the local metric frame ([`frame`]: `--source-crs`,
    /// `--poi-crs`) and refuse POIs farther than `--poi-margin` metres outside the scene.
    pub fn frame_checked<'a>(
        &self,
        model: &'a mut CityModel,
        pois: Vec<Poi>,
        cmd: &str,
    ) -> anyhow::Result<Framed<'a>> {
        frame(model, &self.crs, pois, self.poi_margin, cmd)
    }
}

/// Standard input spooled to a temporary file (removed when this is dropped): the writer
/// re-reads its source, and a pipe can be read only once.
pub struct Spool(#[allow(dead_code)] Option<tempfile::TempDir>);

/// Expand the input arguments in place ([`skylod::batch::inputs::expand`]: files, directories,
/// glob patterns, `-`), spooling standard input to a temporary file. Keep the returned
/// [`Spool`] alive while the inputs are read and written.
pub fn expand_inputs(inputs: &mut Vec<PathBuf>) -> anyhow::Result<Spool> {
    let (expanded, spool) = expand_inputs_relative(inputs)?;
    *inputs = expanded.into_iter().map(|i| i.path).collect();
    Ok(spool)
}

/// [`expand_inputs`], keeping each input's path relative to its argument (for `-o DIR`; the
/// spooled standard input is `stdin.gml`).
pub fn expand_inputs_relative(
    inputs: &[PathBuf],
) -> anyhow::Result<(Vec<skylod::batch::inputs::Input>, Spool)> {
    let expanded = skylod::batch::inputs::expand(inputs)?;
    let mut spool = None;
    let mut out = Vec::with_capacity(expanded.len());
    for i in expanded {
        if i.path.as_os_str() == "-" {
            if spool.is_some() {
                bail!("standard input (-) can be read only once");
            }
            let dir = tempfile::Builder::new().prefix("skylod-stdin-").tempdir()?;
            let path = dir.path().join("stdin");
            let mut f = std::fs::File::create(&path)
                .with_context(|| format!("spooling standard input to {}", path.display()))?;
            std::io::copy(&mut std::io::stdin().lock(), &mut f)
                .context("reading standard input")?;
            out.push(skylod::batch::inputs::Input {
                path,
                relative: PathBuf::from("stdin.gml"),
            });
            spool = Some(dir);
        } else {
            out.push(i);
        }
    }
    Ok((out, Spool(spool)))
}

/// The inputs that could be read, merged in input order ([`skylod::pipeline::Inputs`]).
pub struct Loaded {
    pub model: CityModel,
    /// Paths read successfully.
    pub inputs: Vec<String>,
    /// Some input failed (reported on stderr).
    pub failed: bool,
    pub read_ms: f64,
}

impl Loaded {
    /// [`skylod::pipeline::Inputs::check`].
    pub fn check(&self, allow_mixed_crs: bool) -> anyhow::Result<()> {
        if !self.inputs.is_empty() {
            skylod::pipeline::check_model(&self.model, allow_mixed_crs)?;
        }
        Ok(())
    }
}

impl Loaded {
    /// Exit outcome: some inputs failed, or all were read.
    pub fn outcome(&self) -> Outcome {
        if self.failed {
            Outcome::SomeFailed
        } else {
            Outcome::Ok
        }
    }
}

/// Read every input in parallel and merge them ([`skylod::pipeline::read_inputs`], with
/// progress); errors go to stderr.
pub fn load(inputs: &[PathBuf]) -> anyhow::Result<Loaded> {
    let r = skylod::pipeline::read_inputs(inputs, &crate::log::reporter())?;
    for e in &r.failures {
        error!("{e}");
    }
    Ok(Loaded {
        model: r.model,
        inputs: r.read.iter().map(|p| p.display().to_string()).collect(),
        failed: !r.failures.is_empty(),
        read_ms: (r.read_s * 1e4).round() / 10.0,
    })
}

/// Milliseconds since `t`, rounded to 0.1.
pub fn ms(t: Instant) -> f64 {
    (t.elapsed().as_secs_f64() * 1e4).round() / 10.0
}

/// Number of polygons at full detail.
pub fn polygons(m: &CityModel) -> usize {
    m.assets.iter().map(|a| a.detail_polygons().len()).sum()
}

/// A `[x, y, z]` array for JSON.
pub fn arr(v: glam::DVec3) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// Check `--lat`/`--lon` given together, or say that they are needed.
pub fn lat_lon(lat: Option<f64>, lon: Option<f64>, cmd: &str) -> anyhow::Result<(f64, f64)> {
    match (lat, lon) {
        (Some(a), Some(o)) => {
            if !(-90.0..=90.0).contains(&a) || !(-180.0..=180.0).contains(&o) {
                bail!("--lat must be in -90..90 and --lon in -180..180 (got {a}, {o})");
            }
            Ok((a, o))
        }
        _ => bail!("{cmd} needs both --lat and --lon of the site, in degrees (WGS84)"),
    }
}

/// The site of the sun position: `--lat`/`--lon`, both or neither (then from the model's CRS).
#[derive(clap::Args, Debug)]
pub struct SiteArgs {
    /// Site latitude in degrees (WGS84, north positive). Default: the centre of the model,
    /// from its CRS (geographic, or UTM zones of WGS 84, ETRS89, JGD2011, NAD83, GDA).
    #[arg(long, allow_hyphen_values = true)]
    pub lat: Option<f64>,
    /// Site longitude in degrees (WGS84, east positive). Default: as --lat.
    #[arg(long, allow_hyphen_values = true)]
    pub lon: Option<f64>,
}

impl SiteArgs {
    /// Both flags, when given.
    pub fn given(&self) -> Option<(f64, f64)> {
        self.lat.zip(self.lon)
    }

    /// Usage check before any input is read: both flags or neither.
    pub fn check(&self, cmd: &str) -> anyhow::Result<()> {
        if self.lat.is_some() != self.lon.is_some() {
            lat_lon(self.lat, self.lon, cmd)?;
        }
        Ok(())
    }

    /// The site, from the flags or from `model` ([`site_lat_lon`]).
    pub fn resolve(&self, model: &CityModel, cmd: &str) -> anyhow::Result<(f64, f64)> {
        site_lat_lon(self.lat, self.lon, model, cmd)
    }
}

/// The site for the sun position: `--lat`/`--lon` when given (both), otherwise the centre of
/// the model converted from its CRS when that is a UTM CRS skylod knows ([`skylod::crs`]).
pub fn site_lat_lon(
    lat: Option<f64>,
    lon: Option<f64>,
    model: &CityModel,
    cmd: &str,
) -> anyhow::Result<(f64, f64)> {
    if lat.is_some() || lon.is_some() {
        return lat_lon(lat, lon, cmd);
    }
    let srs = model.files.iter().find_map(|f| f.srs_name.as_deref());
    let bbox = model.bbox();
    let centre = (!bbox.is_empty()).then(|| bbox.center());
    if let (Some(srs), Some(c)) = (srs, centre) {
        if let Some((a, o)) = skylod::crs::lat_lon(srs, c.x, c.y) {
            summary!("{cmd}: site lat {a:.5}, lon {o:.5}: the centre of the model in {srs}");
            return Ok((a, o));
        }
    }
    bail!(
        "{cmd} needs the site's --lat and --lon (WGS84 degrees): the input's CRS ({}) is not one \
         skylod converts (geographic, or UTM zones of WGS 84, ETRS89, JGD2011, NAD83, GDA)",
        srs.unwrap_or("none given")
    )
}

/// Context helper for writing to stdout.
pub fn out_err<T>(r: std::io::Result<T>) -> anyhow::Result<T> {
    r.context("writing to stdout")
}

/// Seconds as milliseconds rounded to 0.1 (the timings of the reports).
pub fn s_to_ms(s: f64) -> f64 {
    (s * 1e4).round() / 10.0
}

/// Print each POI's flags as a warning on stderr.
pub fn warn_flags(pois: &[Poi], flags: &[Vec<PoiFlag>]) {
    for (p, fl) in pois.iter().zip(flags) {
        for f in fl {
            warning!("warning: {}", f.message(p));
        }
    }
}
/// Rough-model options, the same on every command that builds the rough model (`lod`,
/// `evaluate`, `rough`, `fisheye`), so that the commands cannot drift apart.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct RoughArgs {
    /// Rough model: largest angle (degrees, 0 to 90) between the normals of polygons merged
    /// into one plane.
    #[arg(long, default_value_t = RoughOptions::default().angle_deg, value_name = "DEG", value_parser = non_negative, allow_hyphen_values = true)]
    pub angle: f64,
    /// Rough model: largest distance (m) of a polygon from its plane to be merged or absorbed.
    #[arg(long, default_value_t = RoughOptions::default().thickness_m, value_name = "M", value_parser = non_negative, allow_hyphen_values = true)]
    pub thickness: f64,
    /// Rough model: do not use an asset's LoD2 geometry in place of its higher LoD.
    #[arg(long)]
    pub no_lod2: bool,
}

impl RoughArgs {
    /// The library's options; an angle over 90 degrees is a usage error.
    pub fn options(&self) -> anyhow::Result<RoughOptions> {
        if self.angle > 90.0 {
            bail!("--angle must be between 0 and 90 degrees");
        }
        Ok(RoughOptions {
            angle_deg: self.angle,
            thickness_m: self.thickness,
            prefer_lod2: !self.no_lod2,
        })
    }
}

/// The silhouette test of the selection (`lod`, `evaluate`, `fisheye --colour-by level`).
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct SilhouetteArgs {
    /// Silhouette threshold in degrees (default: 1.5 x the cell's angular size).
    #[arg(long, value_name = "DEG", value_parser = positive, allow_hyphen_values = true)]
    pub threshold: Option<f64>,
    /// How far (m) below the lowest roof edge an installation may start and still count as
    /// standing on the roof.
    #[arg(long, default_value_t = SelectOptions::default().roof_tolerance_m, value_name = "M", value_parser = non_negative, allow_hyphen_values = true)]
    pub roof_tolerance: f64,
}

/// The selection bundle and silhouette test (`lod`, `evaluate`).
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct SelectArgs {
    /// Rays per POI of the selection bundle (cells of the equal-solid-angle hemisphere
    /// partition).
    #[arg(long, default_value_t = SelectOptions::default().rays)]
    pub rays: usize,
    /// Seed of the ray jitter inside each cell (same seed, same output).
    #[arg(long, default_value_t = SelectOptions::default().seed)]
    pub seed: u64,
    #[command(flatten)]
    pub silhouette: SilhouetteArgs,
}

impl SelectArgs {
    /// The library's options.
    pub fn options(&self) -> SelectOptions {
        self.silhouette.options(self.rays, self.seed)
    }
}

impl SilhouetteArgs {
    /// The library's options with this bundle.
    pub fn options(&self, rays: usize, seed: u64) -> SelectOptions {
        SelectOptions {
            rays,
            seed,
            threshold_deg: self.threshold,
            roof_tolerance_m: self.roof_tolerance,
        }
    }
}

/// The simulated year of the sun (`sun-hours`, `evaluate`, `lod --max-sun-hours-error`).
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct SunArgs {
    /// Calendar year (UTC) simulated.
    #[arg(long, default_value_t = DEFAULT_YEAR)]
    pub year: i32,
    /// Time step in minutes (the sun is evaluated at the middle of each step).
    #[arg(long, default_value_t = 15)]
    pub step: u32,
}

/// `--format` values.
pub fn parse_format(s: &str) -> Result<Format, String> {
    s.parse()
}

/// Where a command writes its model (`lod`, `rough`).
#[derive(clap::Args, Debug, Clone)]
pub struct OutputArgs {
    /// Output file for one input (`-` for standard output; `.gz` compresses; the format
    /// follows the name: .gml/.xml CityGML, .obj OBJ, .city.json CityJSON, .city.jsonl
    /// CityJSONSeq); a directory that mirrors the input tree (created if missing); or, for
    /// several inputs, one CityGML file (or `-`) that merges them.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Output format when the output's name does not tell it (in a directory: the format of
    /// every output, named after its input with the format's ending).
    #[arg(long, value_name = "citygml|obj|cityjson|cityjsonseq", value_parser = parse_format)]
    pub format: Option<Format>,
    /// Replace existing output files.
    #[arg(long)]
    pub overwrite: bool,
}
