//! `skylod lod`: the skyline-controlled mixed-LoD model for a set of POIs.

pub mod shard;

use crate::args::output::OutputArgs;
use crate::args::poi::PoiArgs;
use crate::args::rough::RoughArgs;
use crate::args::select::SelectArgs;
use crate::commands::{ms, warn_flags};
use crate::log::{error, summary};
use crate::Outcome;
use anyhow::{bail, Context};
use skylod::batch::outputs::{Plan, Targets};
use skylod::citygml::write::{atomic_write_bytes, is_stdout, WriteOptions};
use skylod::lod::LodOptions;
use skylod::output::report::{Parameters, Report, Timings};
use skylod::pipeline::{levels, levels_of, write_all, LevelsOptions};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub(crate) pois: PoiArgs,
    #[command(flatten)]
    pub(crate) region: crate::args::region::RegionArgs,
    #[command(flatten)]
    pub(crate) out: OutputArgs,
    #[command(flatten)]
    pub(crate) select: SelectArgs,
    #[command(flatten)]
    pub(crate) rough: RoughArgs,
    /// Write a JSON report (schemas/report.schema.json; `-` for standard output).
    #[arg(long, value_name = "FILE.json")]
    pub(crate) report: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) bound: crate::args::bound::BoundArgs,
    /// With --shard (or a scheduler's index), -o names this shard's levels file (JSON lines,
    /// `.jsonl`) instead of a model. Without: the model is written as usual.
    #[command(flatten)]
    pub(crate) shard: crate::args::shard::ShardArgs,
    #[command(flatten)]
    pub(crate) scene: crate::args::scene::SceneArgs,
    /// Reduce step: write the model (and --report) from the levels files of all shards
    /// (levels combine by maximum) instead of tracing; POIs and options come from the files,
    /// the inputs must be the shards' inputs.
    #[arg(long, value_name = "LEVELS.jsonl", num_args = 1..)]
    pub(crate) reduce: Vec<PathBuf>,
}

pub fn run(mut args: Args) -> anyhow::Result<Outcome> {
    let (inputs, _spool) = crate::inputs::expand_inputs_relative(&args.pois.inputs)?;
    args.pois.inputs = inputs.iter().map(|i| i.path.clone()).collect();
    let t_all = Instant::now();
    args.bound.check()?;
    let shard = args.shard.resolve()?;
    if let Some(s) = shard {
        return crate::commands::lod::shard::shard(args, s, t_all);
    }
    let reduce = crate::commands::lod::shard::read(&mut args)?;
    let pois = match &reduce {
        Some(r) => r.pois().to_vec(),
        None => args.region.points(&args.pois)?,
    };
    let (plan, format) = crate::outputs::plan(&inputs, &args.out.output, args.out.format)?;
    // Every target is checked before any work: a refusal after minutes of reading and
    // tracing helps nobody, and one scene needs every input, so any refusal is fatal. A merge
    // (-o FILE or -o - for several inputs) writes each input's model to a staging directory,
    // then merges them into the target.
    let wopts = WriteOptions {
        overwrite: args.out.overwrite,
        protect: args.pois.inputs.clone(),
        keep_envelopes: false,
    };
    let (
        Targets {
            todo,
            staging,
            mirror,
            write_opts,
            ..
        },
        refused,
    ) = crate::outputs::targets(&plan, &args.pois.inputs, &wopts, None, "lod", true, |e| {
        error!("{e:#}");
    })?;
    if refused > 0 {
        bail!("{refused} output(s) refused (above): lod writes every input's model, nothing done");
    }
    let mut outputs: Vec<Option<PathBuf>> = vec![None; inputs.len()];
    for (k, out) in todo {
        if let Some(o) = outputs.get_mut(k) {
            *o = Some(out);
        }
    }
    if let Some(path) = &args.report {
        if is_stdout(path) && is_stdout(&args.out.output) {
            bail!("the model and the report cannot both go to standard output");
        }
        check_report_target(path, &args)?;
    }
    let rough_opts = args.rough.options()?;
    let select_opts = args.select.options();
    // Outputs are laid out for every input; --scene-radius then leaves out the far ones.
    let all_inputs = args.pois.inputs.clone();
    let region = args.region.active();
    args.scene
        .filter(&mut args.pois, &pois, None, region, "lod")?;
    let mut loaded = args.pois.load_checked()?;
    if loaded.inputs.is_empty() {
        return Ok(Outcome::SomeFailed);
    }
    let combined = match reduce {
        Some(r) => Some(r.combine(&loaded.model)?),
        None => None,
    };
    let pois = match &combined {
        Some(_) => pois,
        None => args.region.extend(pois, &loaded.model)?,
    };
    let mut failed = loaded.failed;
    let framed = args.pois.frame_checked(&mut loaded.model, pois, "lod")?;
    let opts = LevelsOptions {
        lod: LodOptions {
            rough: rough_opts,
            select: select_opts,
        },
        bound: args.bound.spec(framed.source, args.select.seed)?,
    };
    let progress = crate::log::reporter();
    let lv = match combined {
        Some(c) => {
            let lod = skylod::batch::reduce::lod_result(&framed.model, c, &opts.lod);
            levels_of(&framed, &opts, lod, &progress)?
        }
        None => levels(&framed, &opts, &progress)?,
    };
    warn_flags(&framed.pois, &lv.lod.flags);
    if let Some(b) = &lv.bound {
        summary!(
            "error bound: {} promotion(s) in {} round(s), largest SVF error {:.3}%, {:.0} ms",
            b.promotions.len(),
            b.rounds,
            100.0 * b.pois.iter().map(|p| p.svf_error).fold(0.0, f64::max),
            lv.bound_s * 1e3
        );
        if !b.met {
            error!(
                "the error bound cannot be met at these POIs (nothing written):\n{}",
                crate::args::bound::failing_lines(b)
            );
            return Ok(Outcome::SomeFailed);
        }
    }
    let result = &lv.lod;
    // Written geometry and the report are in the input's CRS.
    let model = framed.source;
    let pois = &framed.pois;
    let rough = lv.rough_source();

    // Files of the model are the inputs that could be read, in input order.
    let targets: Vec<(usize, PathBuf)> = model
        .files
        .iter()
        .enumerate()
        .filter_map(|(f, src)| {
            let k = all_inputs.iter().position(|p| p == &src.path)?;
            Some((f, outputs.get(k)?.clone()?))
        })
        .collect();
    let t_write = Instant::now();
    if mirror {
        for (_, out) in &targets {
            crate::outputs::create_parent(out)?;
        }
    }
    // In a merge, the messages and the report name the merged document.
    let shown = |out: &Path| match &plan {
        Plan::Merge(t) => t.display().to_string(),
        _ => out.display().to_string(),
    };
    let results = write_all(model, &targets, &lv, format, &write_opts, &progress)?;
    let mut written: Vec<Option<(String, usize)>> = vec![None; model.files.len()];
    for ((f, out), r) in targets.iter().zip(results) {
        let s = match r {
            Ok(s) => s,
            Err(e) => {
                error!("{e}");
                failed = true;
                continue;
            }
        };
        match &s.export {
            Some(e) => summary!("{}", crate::outputs::describe(e, format, model, *f, out)),
            None => summary!(
                "{} -> {}: assets at level 0/1/2 = {}/{}/{}, polygons {} -> {}, {} building(s) dropped",
                model.files[*f].path.display(),
                shown(out),
                s.levels[0],
                s.levels[1],
                s.levels[2],
                s.polygons_in,
                s.polygons_out,
                s.buildings_dropped
            ),
        }
        if let Some(w) = written.get_mut(*f) {
            *w = Some((shown(out), s.buildings_dropped));
        }
    }
    if let (Some(_), Plan::Merge(t)) = (&staging, &plan) {
        let (parts, names): (Vec<PathBuf>, Vec<PathBuf>) = targets
            .iter()
            .filter(|(f, _)| written.get(*f).is_some_and(Option::is_some))
            .map(|(f, out)| (out.clone(), model.files[*f].path.clone()))
            .unzip();
        if !crate::outputs::merge(&parts, &names, t, &wopts, targets.len()) {
            failed = true;
            written.iter_mut().for_each(|w| *w = None);
        }
    }
    let write_ms = ms(t_write);

    let timings = Timings {
        read: loaded.read_ms,
        rough: result.rough_s * 1e3,
        bvh: result.bvh_s * 1e3,
        select: result.select_s * 1e3,
        write: write_ms,
        total: ms(t_all),
    };
    let mut report = Report::new(
        model,
        rough,
        &result.selection,
        pois,
        Parameters::of(
            &result.selection,
            args.select.seed,
            args.select.silhouette.roof_tolerance,
            &rough_opts,
        ),
        timings,
    );
    report.set_flags(&result.flags);
    report.bound = lv.bound.clone();
    for (f, w) in written.into_iter().enumerate() {
        if let Some((path, dropped)) = w {
            let in_file = model.buildings.iter().filter(|b| b.file == f).count();
            report.record_output(f, path, in_file, dropped);
        }
    }
    let t = &report.totals;
    summary!(
        "{} POI(s), {} rays each: assets at level 0/1/2 = {}/{}/{}; polygons {} -> {} ({:.1}%); \
         {} triangles traced; read {:.0} ms, rough {:.0} ms, bvh {:.0} ms, select {:.0} ms, write {:.0} ms",
        pois.len(),
        result.selection.rays,
        t.levels[0],
        t.levels[1],
        t.levels[2],
        t.polygons_in,
        t.polygons_out,
        100.0 * t.polygon_fraction,
        result.triangles,
        timings.read,
        timings.rough,
        timings.bvh,
        timings.select,
        timings.write
    );
    if args.region.active() {
        summary!(
            "region: one model of {} polygons for {} POIs; their own models hold {:.0} on average, \
             {} at most ({:.2}x)",
            t.polygons_out,
            pois.len(),
            t.single_poi_polygons_mean,
            t.single_poi_polygons_max,
            t.region_over_single_poi
        );
    }
    if let Some(path) = &args.report {
        let mut json = serde_json::to_vec_pretty(&report)?;
        json.push(b'\n');
        atomic_write_bytes(path, &json).context("writing the report")?;
    }
    // The process ends here: handing a city's model back to the allocator piece by piece
    // would cost ~6 % of the run for nothing (the temporary input spool is still removed).
    std::mem::forget(report);
    std::mem::forget(lv);
    std::mem::forget(framed);
    std::mem::forget(loaded);
    Ok(if failed {
        Outcome::SomeFailed
    } else {
        Outcome::Ok
    })
}

fn check_report_target(path: &Path, args: &Args) -> anyhow::Result<()> {
    let opts = WriteOptions {
        overwrite: args.out.overwrite,
        ..Default::default()
    };
    skylod::citygml::write::check_target(path, &opts, args.pois.inputs.iter().map(|p| p.as_path()))
        .context("the report")?;
    Ok(())
}
