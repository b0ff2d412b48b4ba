//! The calls that write or count: `stats`, `lod` (levels, error bound, model and report) and
//! `convert`, laid out as the commands lay them out (one file, a mirrored tree, a merge).

use crate::relay::{message, run};
use crate::setup::{crs, failures, load, ms, Setup};
use pyo3::prelude::*;
use skylod::export::merge_named;
use skylod::export::report::Guarantee;
use skylod::export::report::{FileStats, Stats, StatsOutput};
use skylod::export::Format;
use skylod::export::TargetVersion;
use skylod::io::citygml::WriteOptions;
use skylod::lod::rough::RoughOptions;
use skylod::lod::LodOptions;
use skylod::lod::SelectOptions;
use skylod::model::crs::model_site;
use skylod::model::Silent;
use skylod::model::Stage;
use skylod::pipeline::batch::{convert_file, file_stats, ConvertOptions};
use skylod::pipeline::batch::{create_parent, plan, Plan, Targets};
use skylod::pipeline::batch::{expand, Input};
use skylod::pipeline::batch::{merge_parts, Said, Staging};
use skylod::pipeline::session::BoundRequest;
use skylod::pipeline::session::RunMs;
use skylod::pipeline::session::SiteError;
use skylod::pipeline::session::SunSite;
use skylod::pipeline::{BoundSpec, LevelsOptions};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Rough model and selection options (`--rays`, `--seed`, `--threshold`, `--roof-tolerance`,
/// `--angle`, `--thickness`, `--no-lod2`), a dict built by `skylod/__init__.py`.
#[derive(FromPyObject, Debug, Clone)]
pub struct LodArgs {
    #[pyo3(item)]
    pub rays: usize,
    #[pyo3(item)]
    pub seed: u64,
    #[pyo3(item)]
    pub threshold: Option<f64>,
    #[pyo3(item)]
    pub roof_tolerance: f64,
    #[pyo3(item)]
    pub angle: f64,
    #[pyo3(item)]
    pub thickness: f64,
    #[pyo3(item)]
    pub prefer_lod2: bool,
}

impl LodArgs {
    /// The library's options, checked as the CLI checks them.
    pub fn options(&self) -> Result<LodOptions, String> {
        if !(0.0..=90.0).contains(&self.angle) {
            return Err("angle must be between 0 and 90 degrees".into());
        }
        if self.thickness < 0.0 || self.roof_tolerance < 0.0 {
            return Err("thickness and roof_tolerance must not be negative".into());
        }
        let mut rough = RoughOptions::default();
        (rough.angle_deg, rough.thickness_m, rough.prefer_lod2) =
            (self.angle, self.thickness, self.prefer_lod2);
        let mut select = SelectOptions::default();
        (select.rays, select.seed) = (self.rays, self.seed);
        (select.threshold_deg, select.roof_tolerance_m) = (self.threshold, self.roof_tolerance);
        let mut lod = LodOptions::default();
        (lod.rough, lod.select) = (rough, select);
        Ok(lod)
    }
}

/// The error bound (`--max-svf-error`, `--max-sun-hours-error`, `--no-bound`,
/// `--bound-rays`, `--lat/--lon`, `--year`, `--step`).
#[derive(FromPyObject, Debug, Clone)]
pub struct BoundArgs {
    #[pyo3(item)]
    pub bound: bool,
    #[pyo3(item)]
    pub max_svf_error: Option<f64>,
    #[pyo3(item)]
    pub max_sun_hours_error: Option<f64>,
    #[pyo3(item)]
    pub bound_rays: usize,
    #[pyo3(item)]
    pub site: Option<(f64, f64)>,
    #[pyo3(item)]
    pub year: i32,
    #[pyo3(item)]
    pub step: u32,
}

impl BoundArgs {
    /// The bound and what the report says of it, as `skylod lod` decides them
    /// ([`BoundRequest`]), the options named as Python names them.
    fn spec(
        &self,
        study: &skylod::pipeline::session::Study,
        seed: u64,
    ) -> Result<(Option<BoundSpec>, Guarantee), String> {
        let mut r = BoundRequest::new(self.bound_rays, seed, ("bound=False", "site=(lat, lon)"));
        r.bound = self.bound;
        (r.max_svf_error, r.max_sun_hours_error) = (self.max_svf_error, self.max_sun_hours_error);
        (r.year, r.step_min) = (self.year, self.step);
        let site = match self.site {
            Some((a, o)) => Ok(SunSite::Given(a, o)),
            None => model_site(study.source(), study.crs())
                .map(|s| SunSite::Model(s.lat, s.lon, s.crs.name))
                .map_err(SiteError::from),
        };
        let plan = r
            .plan(site)
            .map_err(|why| format!("max_sun_hours_error needs the site (lat, lon): {why}"))?;
        let sun = plan.sun_table(&Silent).map_err(|e| message(&e))?;
        Ok(plan.finish(sun, None))
    }
}

/// Where the outputs go, checked before any work: (plan, format, targets).
fn layout(
    inputs: &[Input],
    output: &Path,
    format: Option<&str>,
    overwrite: bool,
) -> Result<(Plan, Format, Targets, WriteOptions), String> {
    let format = format
        .map(|f| f.parse::<Format>().map_err(|e| format!("format: {e}")))
        .transpose()?;
    let (plan, format) = plan(inputs, output, format).map_err(|e| message(&e))?;
    let paths: Vec<PathBuf> = inputs.iter().map(|i| i.path.clone()).collect();
    let mut wopts = WriteOptions::default();
    (wopts.overwrite, wopts.protect) = (overwrite, skylod::io::Protected::new(&paths));
    let targets = (plan.targets(&paths, &wopts, None, (true, false))).map_err(|e| message(&e))?;
    if let Some(e) = targets.refused.first() {
        return Err(message(e));
    }
    Ok((plan, format, targets, wopts))
}

/// Merge the staged parts of a merge plan into its target: CityGML parts into CityGML, or
/// (with `staging`) through a staged CityGML merge converted to `format`, as the CLI merges.
fn merge(
    plan: &Plan,
    parts: &[PathBuf],
    names: &[PathBuf],
    (format, staging): (Format, Option<&Staging>),
    w: &WriteOptions,
) -> Result<(), String> {
    let Plan::Merge(target) = plan else {
        return Ok(());
    };
    let Some(staging) = staging else {
        merge_named(parts, names, target, w).map_err(|e| message(&e))?;
        return Ok(());
    };
    let (merged, said) = merge_parts(parts, names, (target, format), staging, w, parts.len());
    if merged {
        return Ok(());
    }
    let errors: Vec<String> = (said.into_iter())
        .filter_map(|s| match s {
            Said::Error(e) => Some(e),
            _ => None,
        })
        .collect();
    Err(errors.join("; "))
}

/// `skylod stats --json`.
#[pyfunction]
#[pyo3(signature = (paths, source_crs=None, progress=None))]
pub fn stats(
    py: Python<'_>,
    paths: Vec<PathBuf>,
    source_crs: Option<String>,
    progress: Option<PyObject>,
) -> PyResult<String> {
    run(py, progress, move |p| {
        let source = source_crs
            .as_deref()
            .map(|c| crs(c, "source_crs"))
            .transpose()?;
        let inputs = expand(&paths).map_err(|e| message(&e))?;
        p.start(Stage::Read, inputs.len() as u64, 0);
        let (mut files, mut failed) = (Vec::new(), Vec::new());
        for i in &inputs {
            if p.is_cancelled() {
                return Err("cancelled while reading inputs".into());
            }
            let read = file_stats(
                &i.path,
                source.as_ref(),
                (None, false),
                &Silent,
                &|_| (),
                false,
            );
            match read {
                Ok(r) => files.push(FileStats::new(i.path.display().to_string(), r.stats)),
                Err(e) => failed.push(e),
            }
            p.advance(Stage::Read, 1, 0, None);
        }
        p.finish(Stage::Read);
        failures(&failed)?;
        let total = Stats::total(files.iter().map(|f| &f.stats));
        serde_json::to_string_pretty(&StatsOutput::new(files, total)).map_err(|e| e.to_string())
    })
}

/// `skylod lod -o OUTPUT --report`: levels (with the error bound), the model written, the
/// report returned.
#[pyfunction]
#[pyo3(signature = (setup, output, lod, bound, format=None, overwrite=false, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn lod(
    py: Python<'_>,
    setup: Setup,
    output: PathBuf,
    lod: LodArgs,
    bound: BoundArgs,
    format: Option<String>,
    overwrite: bool,
    progress: Option<PyObject>,
) -> PyResult<String> {
    run(py, progress, move |p| {
        let t_all = Instant::now();
        let lod_opts = lod.options()?;
        let expanded = expand(&setup.paths).map_err(|e| message(&e))?;
        // Every target is checked before any input is read.
        layout(&expanded, &output, format.as_deref(), overwrite)?;
        let mut l = load(&setup, p)?;
        let study = &mut l.study;
        let (plan, format, targets, wopts) =
            layout(study.inputs(), &output, format.as_deref(), overwrite)?;
        let (bound, guarantee) = bound.spec(study, lod.seed)?;
        let opts = LevelsOptions {
            lod: lod_opts,
            bound,
        };
        let lv = study.levels(&opts, p).map_err(|e| message(&e))?;
        if let Some(b) = lv.bound.as_ref().filter(|b| !b.met) {
            return Err(format!(
                "the error bound cannot be met at these POIs (nothing written):\n{}",
                b.failing_lines()
            ));
        }
        let t_write = Instant::now();
        if targets.mirror {
            for (_, out) in &targets.todo {
                create_parent(out).map_err(|e| message(&e))?;
            }
        }
        let results = (study.write_targets(&targets.todo, &lv, format, &targets.write_opts, p))
            .map_err(|e| message(&e))?;
        let mut written = Vec::with_capacity(results.len());
        for ((f, out), r) in targets.todo.iter().zip(results) {
            let w = r.map_err(|e| message(&e))?;
            let shown = match &plan {
                Plan::Merge(t) => t.display().to_string(),
                _ => out.display().to_string(),
            };
            written.push((*f, shown, w.buildings_dropped + w.parts_dropped));
        }
        let names: Vec<PathBuf> = study
            .source()
            .files
            .iter()
            .map(|f| f.path.clone())
            .collect();
        let parts: Vec<PathBuf> = targets.todo.iter().map(|(_, o)| o.clone()).collect();
        merge(&plan, &parts, &names, (format, None), &wopts)?;
        let (read, write, total) = (l.read_ms, ms(t_write), ms(t_all));
        let run = RunMs { read, write, total };
        let report = study.lod_report(&lv, &lod_opts, run, guarantee, written);
        serde_json::to_string_pretty(&report).map_err(|e| e.to_string())
    })
}

/// `skylod convert -o OUTPUT`: the outputs written, in input order (the merged file once).
#[pyfunction]
#[pyo3(signature = (paths, output, format=None, overwrite=false, source_crs=None, viewer=false, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn convert(
    py: Python<'_>,
    paths: Vec<PathBuf>,
    output: PathBuf,
    format: Option<String>,
    overwrite: bool,
    source_crs: Option<String>,
    viewer: bool,
    progress: Option<PyObject>,
) -> PyResult<Vec<PathBuf>> {
    run(py, progress, move |p| {
        let inputs = expand(&paths).map_err(|e| message(&e))?;
        let (plan, format, mut targets, mut wopts) =
            layout(&inputs, &output, format.as_deref(), overwrite)?;
        let crs = source_crs
            .map(|c| {
                skylod::model::crs::Crs::parse_named(&c).map_err(|e| format!("source_crs: {e}"))
            })
            .transpose()?;
        for w in [&mut wopts, &mut targets.write_opts] {
            (w.source_crs, w.viewer) = (crs.clone(), viewer);
        }
        let fmt = match targets.staging {
            Some(_) => Format::CityGml,
            None => format,
        };
        let (mut parts, mut names) = (Vec::new(), Vec::new());
        p.start(Stage::Read, targets.todo.len() as u64, 0);
        for (k, out) in &targets.todo {
            if p.is_cancelled() {
                return Err(format!(
                    "{}: cancelled before reading",
                    inputs[*k].path.display()
                ));
            }
            let input = &inputs[*k].path;
            // As `skylod convert` (CityJSON inputs to CityGML feature by feature).
            let o = ConvertOptions {
                format: fmt,
                version: TargetVersion::V2_0,
                write: &targets.write_opts,
                mirror: targets.mirror,
                chunk: None,
            };
            convert_file(input, out, &o, &Silent, &|_| ()).map_err(|e| message(&e))?;
            parts.push(out.clone());
            names.push(input.clone());
            p.advance(Stage::Read, 1, 0, None);
        }
        p.finish(Stage::Read);
        merge(
            &plan,
            &parts,
            &names,
            (format, targets.staging.as_ref()),
            &wopts,
        )?;
        Ok(match &plan {
            Plan::Merge(t) => vec![t.clone()],
            _ => parts,
        })
    })
}
