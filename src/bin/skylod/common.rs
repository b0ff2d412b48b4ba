//! Shared by the commands that trace POIs (`lod`, `evaluate`, `svf`, `sun-hours`, `fisheye`): inputs merged into one model, POIs.

use crate::Outcome;
use anyhow::{bail, Context};
use rayon::prelude::*;
use skylod::citygml::read_file;
use skylod::model::CityModel;
use skylod::poi::{parse_poi, read_pois_csv, Poi};
use std::path::PathBuf;
use std::time::Instant;

/// Inputs and points of interest.
#[derive(clap::Args, Debug)]
pub struct PoiArgs {
    /// CityGML files (.gml, .xml, .gz); all are merged into one scene.
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
    /// CSV file of POIs (header `id,x,y,z[,nx,ny,nz]`), read after the --poi points.
    #[arg(long, value_name = "FILE.csv")]
    pub pois: Option<PathBuf>,
}

impl PoiArgs {
    /// The POIs in order (--poi first, then the CSV). No POI at all is a usage error.
    pub fn points(&self) -> anyhow::Result<Vec<Poi>> {
        let mut out = Vec::new();
        for (i, t) in self.poi.iter().enumerate() {
            out.push(parse_poi(t, i)?);
        }
        if let Some(f) = &self.pois {
            out.extend(read_pois_csv(f)?);
        }
        if out.is_empty() {
            bail!("no point of interest: give --poi X,Y,Z[,NX,NY,NZ] or --pois FILE.csv");
        }
        Ok(out)
    }
}

/// The inputs that could be read, merged in input order.
pub struct Loaded {
    pub model: CityModel,
    /// Paths read successfully.
    pub inputs: Vec<String>,
    /// Some input failed (reported on stderr).
    pub failed: bool,
    pub read_ms: f64,
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

/// Read every input in parallel and merge them; errors go to stderr.
pub fn load(inputs: &[PathBuf]) -> Loaded {
    let t = Instant::now();
    let results: Vec<_> = inputs.par_iter().map(|p| read_file(p)).collect();
    let mut model = CityModel::default();
    let mut ok = Vec::new();
    let mut failed = false;
    for (p, r) in inputs.iter().zip(results) {
        match r {
            Ok(m) => {
                model.merge(m);
                ok.push(p.display().to_string());
            }
            Err(e) => {
                eprintln!("error: {e}");
                failed = true;
            }
        }
    }
    Loaded {
        model,
        inputs: ok,
        failed,
        read_ms: ms(t),
    }
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
    /// from its CRS (UTM zones of WGS 84 and ETRS89).
    #[arg(long, allow_hyphen_values = true)]
    pub lat: Option<f64>,
    /// Site longitude in degrees (WGS84, east positive). Default: as --lat.
    #[arg(long, allow_hyphen_values = true)]
    pub lon: Option<f64>,
}

impl SiteArgs {
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
            eprintln!("{cmd}: site lat {a:.5}, lon {o:.5}: the centre of the model in {srs}");
            return Ok((a, o));
        }
    }
    bail!(
        "{cmd} needs the site's --lat and --lon (WGS84 degrees): the input's CRS ({}) is not one \
         skylod converts (UTM zones of WGS 84 and ETRS89)",
        srs.unwrap_or("none given")
    )
}

/// Context helper for writing to stdout.
pub fn out_err<T>(r: std::io::Result<T>) -> anyhow::Result<T> {
    r.context("writing to stdout")
}

/// One result per POI (in POI order) computed in parallel against the full-detail scene of
/// `model`, with the milliseconds spent building the scene and tracing.
pub fn trace_full<T: Send>(
    model: &CityModel,
    pois: &[Poi],
    f: impl Fn(&skylod::trace::Scene, &Poi) -> T + Sync,
) -> (Vec<T>, f64, f64) {
    let t = Instant::now();
    let scene = skylod::scene::full_scene(model);
    let bvh_ms = ms(t);
    let t = Instant::now();
    let out = pois.par_iter().map(|p| f(&scene, p)).collect();
    (out, bvh_ms, ms(t))
}

/// Output path per input for commands writing one document per input (`rough`,
/// `reproject`): one input writes the file `output`; several write `output/<input name>`
/// (the directory is created; two inputs of the same name are refused).
pub fn outputs_per_input(
    inputs: &[PathBuf],
    output: &std::path::Path,
) -> anyhow::Result<Vec<(PathBuf, PathBuf)>> {
    if inputs.len() == 1 {
        if output.is_dir() {
            bail!(
                "{}: is a directory; with one input, -o names the output file",
                output.display()
            );
        }
        return Ok(vec![(inputs[0].clone(), output.to_path_buf())]);
    }
    if output.exists() && !output.is_dir() {
        bail!(
            "{}: with several inputs, -o must be a directory",
            output.display()
        );
    }
    let mut seen = std::collections::HashSet::new();
    let mut v = Vec::new();
    for i in inputs {
        let Some(name) = i.file_name() else {
            bail!("{}: not a file name", i.display());
        };
        if !seen.insert(name.to_os_string()) {
            bail!(
                "two inputs are named {}: their outputs would collide",
                std::path::Path::new(name).display()
            );
        }
        v.push((i.clone(), output.join(name)));
    }
    std::fs::create_dir_all(output)
        .map_err(|e| anyhow::anyhow!("{}: cannot create: {e}", output.display()))?;
    Ok(v)
}
