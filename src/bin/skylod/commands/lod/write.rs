//! The outputs of `skylod lod`: laid out and checked before any work, then the model
//! written per input (or merged).

use super::Args;
use crate::log::{error, summary};
use anyhow::{bail, Context};
use skylod::batch::inputs::Input;
use skylod::batch::outputs::Plan;
use skylod::batch::run::Batch;
use skylod::citygml::write::{check_target, is_stdout, WriteOptions};
use skylod::model::CityModel;
use skylod::pipeline::{buildings_without_kept_assets, write_all, write_merged_levels, Levels};
use skylod::runtime::progress::Progress;
use std::path::{Path, PathBuf};

/// Where the model goes, laid out before any input is read.
pub struct Layout {
    batch: Batch,
    /// The output of each input (in input order), `None` when it is not written.
    outputs: Vec<Option<PathBuf>>,
}

/// Every target is checked before any work: a refusal after minutes of reading and tracing
/// helps nobody, and one scene needs every input, so any refusal is fatal. A merge (-o FILE
/// or -o - for several inputs) writes each input's model to a staging directory, then merges
/// them into the target.
pub fn layout(args: &Args, inputs: &[Input]) -> anyhow::Result<Layout> {
    let out = (
        args.out.output.as_path(),
        args.out.format,
        args.out.overwrite,
    );
    let batch = crate::outputs::batch("lod", inputs, out, false, None)?;
    if batch.refused > 0 {
        let refused = batch.refused;
        bail!("{refused} output(s) refused (above): lod writes every input's model, nothing done");
    }
    let mut outputs: Vec<Option<PathBuf>> = vec![None; inputs.len()];
    for (k, out) in &batch.targets.todo {
        if let Some(o) = outputs.get_mut(*k) {
            *o = Some(out.clone());
        }
    }
    if let Some(path) = &args.report {
        if is_stdout(path) && is_stdout(&args.out.output) {
            bail!("the model and the report cannot both go to standard output");
        }
        let opts = WriteOptions {
            overwrite: args.out.overwrite,
            ..Default::default()
        };
        check_target(path, &opts, args.pois.inputs.iter().map(|p| p.as_path()))
            .context("the report")?;
    }
    Ok(Layout { batch, outputs })
}

/// What was written of each file of the model: the path shown, the buildings dropped.
pub type Written = Vec<Option<(String, usize)>>;

/// Write every file of `model` (the inputs that could be read, in input order) at its
/// levels, then merge them when the layout says so. Whether some output failed.
pub fn outputs(
    model: &CityModel,
    all_inputs: &[PathBuf],
    layout: &Layout,
    lv: &Levels,
    progress: &dyn Progress,
) -> anyhow::Result<(Written, bool)> {
    let targets: Vec<(usize, PathBuf)> = model
        .files
        .iter()
        .enumerate()
        .filter_map(|(f, src)| {
            let k = all_inputs.iter().position(|p| p == &src.path)?;
            Some((f, layout.outputs.get(k)?.clone()?))
        })
        .collect();
    let batch = &layout.batch;
    if batch.targets.mirror {
        for (_, out) in &targets {
            crate::outputs::create_parent(out)?;
        }
    }
    // In a merge, the messages and the report name the merged document.
    let shown = |out: &Path| batch.shown(out).display().to_string();
    let format = batch.format;
    let wopts = &batch.targets.write_opts;
    if let (Some(_), Plan::Merge(t)) = (&batch.targets.staging, &batch.plan) {
        if format != skylod::export::Format::CityGml {
            return Ok(merged_export(model, &targets, t, lv, batch));
        }
    }
    let results = write_all(model, &targets, lv, format, wopts, progress)?;
    let mut failed = false;
    let mut written: Written = vec![None; model.files.len()];
    for ((f, out), r) in targets.iter().zip(results) {
        let s = match r {
            Ok(s) => s,
            Err(e) => {
                error!("{}", crate::errors::cli_text(&e));
                failed = true;
                continue;
            }
        };
        match &s.export {
            Some(e) => summary!("{}", crate::outputs::describe(e, format, model, *f, out)),
            None => summary!(
                "{} -> {}: assets at level 0/1/2 = {}/{}/{}, polygons {} -> {}, {} building(s) and {} part(s) dropped",
                skylod::model::shown(&model.files[*f].path),
                shown(out),
                s.levels[0],
                s.levels[1],
                s.levels[2],
                s.polygons_in,
                s.polygons_out,
                s.buildings_dropped,
                s.parts_dropped
            ),
        }
        if let Some(w) = written.get_mut(*f) {
            *w = Some((shown(out), s.buildings_dropped + s.parts_dropped));
        }
    }
    if let (Some(_), Plan::Merge(t)) = (&batch.targets.staging, &batch.plan) {
        let (parts, names): (Vec<PathBuf>, Vec<PathBuf>) = targets
            .iter()
            .filter(|(f, _)| written.get(*f).is_some_and(Option::is_some))
            .map(|(f, out)| (out.clone(), model.files[*f].path.clone()))
            .unzip();
        if !crate::outputs::merge(&parts, &names, t, &batch.wopts, targets.len()) {
            failed = true;
            written.iter_mut().for_each(|w| *w = None);
        }
    }
    Ok((written, failed))
}

/// Several inputs merged into one OBJ / CityJSON / CityJSONSeq file `target`, written from
/// the model in memory ([`skylod::pipeline::write_merged_levels`]).
fn merged_export(
    model: &CityModel,
    targets: &[(usize, PathBuf)],
    target: &Path,
    lv: &Levels,
    batch: &Batch,
) -> (Written, bool) {
    let files: Vec<usize> = targets.iter().map(|(f, _)| *f).collect();
    let mut written: Written = vec![None; model.files.len()];
    let r = write_merged_levels(model, &files, lv, target, batch.format, &batch.wopts);
    match r {
        Ok(s) => {
            if let Some(e) = &s.export {
                let label = skylod::export::merged::label(model, &files);
                summary!("{}", e.describe(batch.format, Path::new(&label), target));
            }
            for &f in &files {
                let (b, p) = buildings_without_kept_assets(model, f, lv.levels());
                if let Some(w) = written.get_mut(f) {
                    *w = Some((target.display().to_string(), b + p));
                }
            }
            (written, false)
        }
        Err(e) => {
            error!("{}", crate::errors::cli_text(&e));
            (written, true)
        }
    }
}
