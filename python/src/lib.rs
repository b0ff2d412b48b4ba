//! `skylod._skylod`: the native part of the Python package `skylod` (PyO3, abi3). Each call
//! reads, frames and traces through the library's owned API (`skylod::pipeline::session`) on its own
//! thread with the GIL released ([`relay::run`]) and returns the JSON document the matching
//! command prints with `--json` (the same output types), which `skylod/__init__.py` turns into
//! dicts and numpy arrays. Errors are `SkylodError` with the library's message.

mod relay;
mod setup;
mod write;

use pyo3::prelude::*;
use relay::{message, run, SkylodError};
use setup::{load, ms, Setup};
use skylod::export::report::{surface_rows, SunSetting, MONTH_COLUMNS};
use skylod::lod::poi::{cadastre_surfaces, surface_of_poi};
use skylod::model::Progress;
use skylod::pipeline::session::weather_site;
use skylod::pipeline::session::{EvaluateRequest, IrradianceRequest, IrradianceRun};
use skylod::solar::irradiance::SkyModel;
use skylod::solar::read_weather;
use skylod::solar::{HorizonOptions, Site, SkyBundles, SunTable};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A document as pretty JSON, as the commands print it.
fn json<T: serde::Serialize>(doc: &T) -> Result<String, String> {
    serde_json::to_string_pretty(doc).map_err(|e| e.to_string())
}

/// `(lat, lon)` given, or the centre of the study's model from its CRS.
fn site(
    study: &skylod::pipeline::session::Study,
    given: Option<(f64, f64)>,
) -> Result<(f64, f64), String> {
    if let Some(s) = given {
        return Ok(s);
    }
    let s = study
        .site()
        .map_err(|e| format!("the sun needs the site's lat and lon (WGS84 degrees): {e}"))?;
    Ok((s.lat, s.lon))
}

/// `skylod svf --json`.
#[pyfunction]
#[pyo3(signature = (setup, rays, seed, progress=None))]
fn svf(
    py: Python<'_>,
    setup: Setup,
    rays: usize,
    seed: u64,
    progress: Option<PyObject>,
) -> PyResult<String> {
    run(py, progress, move |p| {
        let bundles = SkyBundles::new(rays, seed).map_err(|e| message(&e))?;
        let l = load(&setup, p)?;
        let a = (l.study.svf_output(&bundles, (rays, seed), p)).map_err(|e| message(&e))?;
        json(&a.doc)
    })
}

/// `skylod sun-hours --json`.
#[pyfunction]
#[pyo3(signature = (setup, site=None, year=2025, step=15, timezone="UTC".to_string(), progress=None))]
fn sun_hours(
    py: Python<'_>,
    setup: Setup,
    site: Option<(f64, f64)>,
    year: i32,
    step: u32,
    timezone: String,
    progress: Option<PyObject>,
) -> PyResult<String> {
    run(py, progress, move |p| {
        let l = load(&setup, p)?;
        let site = self::site(&l.study, site)?;
        let a = l
            .study
            .sun_hours_output(site, (year, step), &timezone, p)
            .map_err(|e| message(&e))?;
        json(&a.doc)
    })
}

/// `skylod horizon --json`.
#[pyfunction]
#[pyo3(signature = (setup, step=1.0, progress=None))]
fn horizon(
    py: Python<'_>,
    setup: Setup,
    step: f64,
    progress: Option<PyObject>,
) -> PyResult<String> {
    run(py, progress, move |p| {
        let opts = HorizonOptions::default().with_step(step);
        opts.validate()
            .map_err(|e| format!("step: {}", message(&e)))?;
        let l = load(&setup, p)?;
        let a = l.study.horizon_output(&opts, p).map_err(|e| message(&e))?;
        json(&a.doc)
    })
}

/// The inputs of `setup` read and `irradiance` run on them under `weather` at `site` (the
/// model's when `None`), with `sky` and albedo, rays and seed.
fn irradiance_run(
    setup: &Setup,
    weather: &Path,
    site: Option<(f64, f64)>,
    (sky, albedo): (SkyModel, f64),
    (rays, seed): (usize, u64),
    p: &dyn Progress,
) -> Result<(setup::Loaded, IrradianceRun), String> {
    let t0 = Instant::now();
    let w = read_weather(weather).map_err(|e| message(&e))?;
    if !setup.surfaces.is_empty() {
        // a cadastre's figures are annual
        (w.check_year(&weather.display().to_string())).map_err(|e| message(&e))?;
    }
    let weather_ms = ms(t0);
    let bundles = SkyBundles::new(rays, seed).map_err(|e| message(&e))?;
    let l = load(setup, p)?;
    let model = skylod::model::crs::model_site(l.study.source(), l.study.crs());
    let at = weather_site(site, model, &w)
        .map_err(|e| format!("irradiance: {e}; give site=(lat, lon) to use this weather anyway"))?;
    let req = IrradianceRequest {
        path: weather,
        weather: &w,
        weather_ms,
        site: at.lat_lon().into(),
        sky,
        albedo,
        bundles: &bundles,
        rays,
        hourly: false,
        cadastre: !setup.surfaces.is_empty(),
        rows: setup.surfaces.is_empty(),
    };
    let run = (l.study.irradiance_output(&req, p)).map_err(|e| message(&e))?;
    Ok((l, run))
}

/// The sky model named `sky`.
fn sky_model(sky: &str) -> PyResult<SkyModel> {
    match sky {
        "all-weather" => Ok(SkyModel::AllWeather),
        "perez" => Ok(SkyModel::Perez),
        "isotropic" => Ok(SkyModel::Isotropic),
        other => Err(SkylodError::new_err(format!(
            "sky must be \"all-weather\", \"perez\" or \"isotropic\" (got {other:?})"
        ))),
    }
}

/// An albedo in 0..1.
fn check_albedo(albedo: f64) -> PyResult<()> {
    if !(0.0..=1.0).contains(&albedo) {
        return Err(SkylodError::new_err(format!(
            "albedo must be in 0..1 (got {albedo})"
        )));
    }
    Ok(())
}

/// `skylod irradiance --json`.
#[pyfunction]
#[pyo3(signature = (setup, weather, site=None, sky="all-weather", albedo=0.2, rays=10_000, seed=1, progress=None))]
#[allow(clippy::too_many_arguments)]
fn irradiance(
    py: Python<'_>,
    setup: Setup,
    weather: PathBuf,
    site: Option<(f64, f64)>,
    sky: &str,
    albedo: f64,
    rays: usize,
    seed: u64,
    progress: Option<PyObject>,
) -> PyResult<String> {
    let sky = sky_model(sky)?;
    check_albedo(albedo)?;
    run(py, progress, move |p| {
        let (_, run) = irradiance_run(&setup, &weather, site, (sky, albedo), (rays, seed), p)?;
        json(&run.doc.doc)
    })
}

/// `skylod irradiance --surfaces … --table --points`: `{"surfaces": [rows], "points":
/// [rows]}` as JSON, rows as the CSV files' (numbers unrounded).
#[pyfunction]
#[pyo3(signature = (setup, weather, site=None, sky="all-weather", albedo=0.2, rays=10_000, seed=1, threshold=None, monthly=false, progress=None))]
#[allow(clippy::too_many_arguments)]
fn irradiance_surfaces(
    py: Python<'_>,
    setup: Setup,
    weather: PathBuf,
    site: Option<(f64, f64)>,
    sky: &str,
    albedo: f64,
    rays: usize,
    seed: u64,
    threshold: Option<f64>,
    monthly: bool,
    progress: Option<PyObject>,
) -> PyResult<String> {
    let sky = sky_model(sky)?;
    check_albedo(albedo)?;
    if setup.surfaces.is_empty() {
        return Err(SkylodError::new_err(
            "surfaces: give \"roof\" and/or \"wall\"",
        ));
    }
    run(py, progress, move |p| {
        let (l, run) = irradiance_run(&setup, &weather, site, (sky, albedo), (rays, seed), p)?;
        let classes = setup.surface_classes()?;
        let list = cadastre_surfaces(l.study.local_model(), &classes);
        let annual = &run.traced.results;
        let rows = surface_rows(&list, l.study.pois(), annual, threshold, monthly);
        // twelve columns `jan_kwh_m2` … `dec_kwh_m2` after the others, as the CLI's tables
        let months = |row: &mut serde_json::Value, m: &[f64; 12]| {
            for (name, v) in MONTH_COLUMNS.iter().zip(m) {
                row[*name] = serde_json::json!(v);
            }
        };
        let surfaces: Vec<serde_json::Value> = rows
            .iter()
            .map(|r| {
                let mut row = serde_json::json!({
                    "surface_id": r.surface_id, "building_id": r.building_id,
                    "kind": r.kind.as_str(), "area_m2": r.area_m2, "points": r.points,
                    "mean_kwh_m2": r.mean_kwh_m2, "min_kwh_m2": r.min_kwh_m2,
                    "max_kwh_m2": r.max_kwh_m2, "area_above_m2": r.area_above_m2,
                });
                if let Some(m) = &r.monthly_mean_kwh_m2 {
                    months(&mut row, m);
                }
                row["building_roof_kwh"] = serde_json::json!(r.building_roof_kwh);
                row
            })
            .collect();
        let points: Vec<serde_json::Value> = (l.study.pois().iter().zip(annual))
            .map(|(p, r)| {
                let r = &r.annual;
                let (nx, ny, nz) = p.normal.map_or((0.0, 0.0, 1.0), |n| (n.x, n.y, n.z));
                let mut row = serde_json::json!({
                    "surface_id": surface_of_poi(&p.id), "x": p.position.x,
                    "y": p.position.y, "z": p.position.z, "nx": nx, "ny": ny, "nz": nz,
                    "global_kwh_m2": r.global_kwh_m2, "direct_kwh_m2": r.direct_kwh_m2,
                    "diffuse_kwh_m2": r.diffuse_kwh_m2, "reflected_kwh_m2": r.reflected_kwh_m2,
                });
                if monthly {
                    months(&mut row, &r.monthly_global_kwh_m2);
                }
                row
            })
            .collect();
        json(&serde_json::json!({"surfaces": surfaces, "points": points}))
    })
}

/// `skylod evaluate --json`.
#[pyfunction]
#[pyo3(signature = (setup, lod, svf_rays=20_000, sun=true, site=None, year=2025, step=15, progress=None))]
#[allow(clippy::too_many_arguments)]
fn evaluate(
    py: Python<'_>,
    setup: Setup,
    lod: write::LodArgs,
    svf_rays: usize,
    sun: bool,
    site: Option<(f64, f64)>,
    year: i32,
    step: u32,
    progress: Option<PyObject>,
) -> PyResult<String> {
    run(py, progress, move |p| {
        let t_all = Instant::now();
        let lod_opts = lod.options()?;
        let l = load(&setup, p)?;
        let site = match sun {
            true => Some(self::site(&l.study, site)?),
            false => None,
        };
        let mut req = EvaluateRequest::new(lod_opts, svf_rays);
        if let Some((lat, lon)) = site {
            let table =
                SunTable::year(year, step, &Site::new(lat, lon)).map_err(|e| message(&e))?;
            req.sun = Some((SunSetting::new(lat, lon, year, step), table));
        }
        let a = l.study.evaluate_output(req, t_all, p);
        json(&a.map_err(|e| message(&e))?.doc)
    })
}

/// The native module.
#[pymodule]
fn _skylod(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("SkylodError", m.py().get_type::<SkylodError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(svf, m)?)?;
    m.add_function(wrap_pyfunction!(sun_hours, m)?)?;
    m.add_function(wrap_pyfunction!(horizon, m)?)?;
    m.add_function(wrap_pyfunction!(irradiance, m)?)?;
    m.add_function(wrap_pyfunction!(irradiance_surfaces, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(write::stats, m)?)?;
    m.add_function(wrap_pyfunction!(write::lod, m)?)?;
    m.add_function(wrap_pyfunction!(write::convert, m)?)?;
    Ok(())
}
