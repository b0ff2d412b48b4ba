//! Inputs and POIs from Python into a [`Study`] (`Scene::load` → `Scene::frame`), as the
//! tracing commands read and frame them (`--poi`, `--pois`, `--poi-crs`, `--source-crs`,
//! `--poi-margin`, `--allow-mixed-crs`, `--surfaces` with `--spacing`).

use crate::relay::message;
use pyo3::prelude::*;
use skylod::lod::poi::{check_pois, read_pois_csv, Located, Poi, RegionSpec, SurfaceClass};
use skylod::model::crs::Crs;
use skylod::model::Progress;
use skylod::pipeline::batch::expand;
use skylod::pipeline::session::{Scene, SceneOptions, Study};
use std::path::PathBuf;
use std::time::Instant;

/// The inputs and POIs of a call (a dict built by `skylod/__init__.py`).
#[derive(FromPyObject, Debug, Clone)]
pub struct Setup {
    /// Files, directories, glob patterns.
    #[pyo3(item)]
    pub paths: Vec<PathBuf>,
    /// `[x, y, z]` or `[x, y, z, nx, ny, nz]` per POI.
    #[pyo3(item)]
    pub pois: Vec<Vec<f64>>,
    /// The ids of `pois` (default `poi-1`, `poi-2`, ...).
    #[pyo3(item)]
    pub ids: Option<Vec<String>>,
    /// A POI CSV file (`--pois`), read after `pois`.
    #[pyo3(item)]
    pub pois_csv: Option<PathBuf>,
    /// `--poi-crs`.
    #[pyo3(item)]
    pub poi_crs: Option<String>,
    /// `--source-crs`.
    #[pyo3(item)]
    pub source_crs: Option<String>,
    /// `--poi-margin` (m).
    #[pyo3(item)]
    pub poi_margin: f64,
    /// `--allow-mixed-crs`.
    #[pyo3(item)]
    pub allow_mixed_crs: bool,
    /// `--surfaces`: `"roof"` and/or `"wall"`, points on every such surface after `pois`.
    #[pyo3(item)]
    pub surfaces: Vec<String>,
    /// `--spacing` (m) of `surfaces`.
    #[pyo3(item)]
    pub spacing: f64,
}

impl Setup {
    /// The classes of [`Setup::surfaces`].
    pub fn surface_classes(&self) -> Result<Vec<SurfaceClass>, String> {
        (self.surfaces.iter())
            .map(|c| match c.as_str() {
                "roof" => Ok(SurfaceClass::Roof),
                "wall" => Ok(SurfaceClass::Wall),
                other => Err(format!("surfaces: \"roof\" or \"wall\", not {other:?}")),
            })
            .collect()
    }
}

/// A study and the milliseconds of its reading, as the documents of `lod` give them.
pub struct Loaded {
    pub study: Study,
    /// Milliseconds reading (as the CLI rounds them).
    pub read_ms: f64,
}

/// Milliseconds of `s` seconds, rounded to 0.1 ms as the CLI's documents.
pub fn s_to_ms(s: f64) -> f64 {
    (s * 1e4).round() / 10.0
}

/// Milliseconds since `t`, rounded as [`s_to_ms`].
pub fn ms(t: Instant) -> f64 {
    s_to_ms(t.elapsed().as_secs_f64())
}

/// A CRS named as on the command line (`EPSG:n` or any srsName form).
pub fn crs(name: &str, what: &str) -> Result<Crs, String> {
    Crs::parse_named(name).map_err(|e| format!("{what}: {e}"))
}

/// The POIs of `s` in order (`pois`, then the CSV), checked as the CLI checks them.
pub fn points(s: &Setup) -> Result<Vec<Poi>, String> {
    let mut out = Vec::with_capacity(s.pois.len());
    if let Some(ids) = s.ids.as_ref().filter(|ids| ids.len() != s.pois.len()) {
        return Err(format!("ids: {} ids for {} POIs", ids.len(), s.pois.len()));
    }
    for (i, v) in s.pois.iter().enumerate() {
        let id = match &s.ids {
            Some(ids) => ids[i].clone(),
            None => format!("poi-{}", i + 1),
        };
        let at = v
            .iter()
            .map(|x| x.to_string())
            .collect::<Vec<_>>()
            .join(",");
        let poi = match v.as_slice() {
            [x, y, z] => Poi::at(id, [*x, *y, *z]),
            [x, y, z, nx, ny, nz] => Poi::at(id, [*x, *y, *z]).facing([*nx, *ny, *nz]),
            _ => {
                return Err(format!(
                    "POI {} ({at}): expected (x, y, z) or (x, y, z, nx, ny, nz), got {} values",
                    i + 1,
                    v.len()
                ))
            }
        };
        out.push(Located {
            poi,
            at: format!("POI {} ({at})", i + 1),
        });
    }
    if let Some(csv) = &s.pois_csv {
        out.extend(read_pois_csv(csv).map_err(|e| message(&e))?);
    }
    if out.is_empty() && s.surfaces.is_empty() {
        return Err("no point of interest: give pois=[(x, y, z), ...] or a CSV file".into());
    }
    check_pois(&out).map_err(|e| message(&e))?;
    Ok(out.into_iter().map(|l| l.poi).collect())
}

/// Read the inputs of `s`, refuse what the CLI refuses (an input that cannot be read is an
/// error here: a program gets no partial answer), frame the POIs.
pub fn load(s: &Setup, progress: &dyn Progress) -> Result<Loaded, String> {
    let pois = points(s)?;
    let classes = s.surface_classes()?;
    let mut opts = SceneOptions::default();
    opts.frame.poi_margin = s.poi_margin;
    opts.frame.poi_crs = s
        .poi_crs
        .as_deref()
        .map(|c| crs(c, "poi_crs"))
        .transpose()?;
    opts.frame.source_crs = (s.source_crs.as_deref())
        .map(|c| crs(c, "source_crs"))
        .transpose()?;
    opts.allow_mixed_crs = s.allow_mixed_crs;
    let t = Instant::now();
    let inputs = expand(&s.paths).map_err(|e| message(&e))?;
    let scene = Scene::load_inputs(inputs, &opts, progress).map_err(|e| message(&e))?;
    let read_ms = ms(t);
    failures(scene.failures())?;
    let region = RegionSpec {
        surfaces: classes,
        spacing: s.spacing,
        ..RegionSpec::default()
    };
    let pois = region
        .extend(pois, scene.model())
        .map_err(|e| message(&e))?;
    let study = scene.frame(pois).map_err(|e| message(&e))?;
    Ok(Loaded { study, read_ms })
}

/// Every input that could not be read, one per line: an error.
pub fn failures(f: &[skylod::ReadError]) -> Result<(), String> {
    if f.is_empty() {
        return Ok(());
    }
    let lines: Vec<String> = f.iter().map(|e| message(e)).collect();
    Err(lines.join("\n"))
}
