//! `skylod lod`: the skyline-controlled mixed-LoD model for a set of POIs, step by step:
//! outputs laid out and checked ([`layout`]), inputs read, levels selected (or reduced from
//! the shards' levels files, [`shard`]), the error bound, outputs written
//! ([`skylod::pipeline::session::lod_write`]) and the report ([`skylod::pipeline::session::report`]).

mod lines;
mod read_note;
pub mod shard;

use crate::args::{output::OutputArgs, poi::PoiArgs, rough::RoughArgs, select::SelectArgs};
use crate::flags::frame_said;
use crate::log::{error, info, summary, warning};
use crate::Outcome;
use anyhow::Context;
use lines::{bound_lines, lod_lines};
use skylod::lod::LodOptions;
use skylod::pipeline::batch::Input;
use skylod::pipeline::batch::Said;
use skylod::pipeline::session::ms_since;
use skylod::pipeline::session::RunMs;
use skylod::pipeline::session::{
    check_report, write_report, FileOutcome, LodLayout, LodWritten, ReportTargetError,
};
use skylod::pipeline::session::{lod_read, LodRead};
use skylod::pipeline::session::{SceneOptions, Study};
use skylod::pipeline::LevelsOptions;
use std::path::PathBuf;
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
    #[command(flatten)]
    pub(crate) stream: crate::args::stream::StreamArgs,
    /// The memory lod may take for reading a file whole, e.g. 2GiB (default: 1GiB, or half
    /// of what the system and the job's memory limit leave where that is less): a larger
    /// file is read hollow, a chunk at a time, in less memory and a little more CPU.
    #[arg(long, value_name = "SIZE", value_parser = skylod::pipeline::session::memory_size)]
    pub(crate) max_memory: Option<u64>,
    /// Reduce step: write the model (and --report) from the levels files of all shards
    /// (levels combine by maximum) instead of tracing; POIs and options come from the files,
    /// the inputs must be the shards' inputs.
    #[arg(long, value_name = "LEVELS.jsonl", num_args = 1..)]
    pub(crate) reduce: Vec<PathBuf>,
}

pub fn run(mut args: Args) -> anyhow::Result<Outcome> {
    let (inputs, spool) = crate::inputs::expand_inputs_relative(&args.pois.inputs)?;
    args.pois.inputs = inputs.iter().map(|i| i.path.clone()).collect();
    let t_all = Instant::now();
    args.bound.check()?;
    if let Some(s) = args.shard.resolve()? {
        return shard::shard(args, s, spool, t_all);
    }
    let reduce = shard::read(&args)?;
    let pois = match &reduce {
        Some(r) => r.pois().to_vec(),
        None => args.region.points(&args.pois)?,
    };
    let layout = layout(&args, &inputs)?;
    // A reduce writes the model exactly as the shards selected it.
    let lod = match &reduce {
        Some(r) => r.options(),
        None => LodOptions {
            rough: args.rough.options()?,
            select: args.select.options(),
        },
    };
    // Outputs are laid out for every input; --scene-radius then leaves out the far ones.
    let all_inputs = args.pois.inputs.clone();
    let region = args.region.active();
    args.scene
        .filter(&mut args.pois, &pois, None, region, "lod")?;
    let (ins, c) = (&args.pois.inputs, &args.pois.crs);
    let given = [c.poi_crs.is_some(), region, reduce.is_some()];
    let (chunk, crs) = (args.stream.stream_chunk, c.source.source_crs.as_ref());
    let read = lod_read(ins, spool.is_used(), chunk, crs, given, args.max_memory)
        .served(layout.batch.format == skylod::export::Format::CityGml);
    read_note::read_note(&read, ins)
        .iter()
        .for_each(|l| info!("{l}"));
    // The sun's table, but for the site the model gives, computed while the model is read
    // (in rayon's pool: sized first), near the site of the first input's first objects.
    args.pois.jobs.global()?;
    let ahead = args.bound.ephemeris(ins.first().map(PathBuf::as_path));
    let (p, progress) = (&args.pois, crate::log::reporter());
    let so = SceneOptions::new(c.frame_options(p.poi_margin), p.allow_mixed_crs);
    let hollow = match (&read, &ins[..]) {
        (LodRead::Hollow { chunk }, [path]) => {
            Study::read_hollow(path, *chunk, pois.clone(), &lod.rough, &so, &progress)?
        }
        _ => None,
    };
    let (mut study, combined, unread, _spool) = match hollow {
        Some(h) => {
            (frame_said(h.warnings(), h.frame_warning()).iter())
                .for_each(|w| warning!("lod: warning: {w}"));
            (h, None, false, spool)
        }
        _ => {
            let Some(scene) = args.pois.scene()? else {
                return Ok(Outcome::SomeFailed);
            };
            let (combined, pois) = match reduce {
                Some(r) => (Some(r.combine(scene.model())?), pois),
                None => (None, args.region.extend(pois, scene.model())?),
            };
            let s = args.pois.study(scene, pois, None, spool, "lod")?;
            (s.study, combined, s.failed, s._spool)
        }
    };
    let (bound, guarantee) = args.bound.spec(&study, lod.select.seed, ahead.as_ref())?;
    let opts = LevelsOptions { lod, bound };
    let lv = match combined {
        Some(c) => study.levels_combined(c, &opts, &progress)?,
        None => study.levels(&opts, &progress)?,
    };
    crate::commands::warn_flags(study.pois(), &lv.lod.flags);
    let (said, failed) = bound_lines(&lv, &guarantee);
    said.iter().for_each(|l| summary!("{l}"));
    if let Some(e) = failed {
        error!("{e}");
        return Ok(Outcome::SomeFailed);
    }
    // Written geometry and the report are in the input's CRS.
    let t_write = Instant::now();
    let mut w = layout.write(&mut study, &all_inputs, &lv, &progress)?;
    crate::outputs::say(written_said(&mut w));
    let written = (w.written.into_iter().enumerate())
        .filter_map(|(f, w)| w.map(|(path, dropped)| (f, path, dropped)));
    let (read, write, total) = (study.read_ms(), ms_since(t_write), ms_since(t_all));
    let run = RunMs { read, write, total };
    let report = study.lod_report(&lv, &opts.lod, run, guarantee, written);
    let lines = lod_lines(&report, &lv, study.pois().len(), args.region.active());
    lines.iter().for_each(|l| summary!("{l}"));
    if let Some(path) = &args.report {
        write_report(path, &report).context("writing the report")?;
    }
    // The process ends here: handing a city's model back to the allocator piece by piece
    // would cost time for nothing (the temporary input spool is still removed).
    std::mem::forget((report, lv, study));
    Ok(Outcome::failed_if(unread || w.failed))
}

/// What to tell the user of the outputs written, in order: each file's line (a failure in
/// the command line's words), then the merge's.
fn written_said(w: &mut LodWritten) -> Vec<Said> {
    let files = (std::mem::take(&mut w.files).into_iter()).map(|f| match f {
        FileOutcome::Written(line) => Said::Summary(line),
        FileOutcome::Failed(e) => Said::Error(crate::flags::cli_text(&e)),
    });
    files.chain(std::mem::take(&mut w.merge)).collect()
}

/// Where the model goes, every target checked before any work (a refused target is fatal:
/// one scene needs every input), and the report's target.
fn layout(args: &Args, inputs: &[Input]) -> anyhow::Result<LodLayout> {
    let batch = crate::outputs::batch("lod", inputs, args.out.target(), false, None)?;
    let layout = LodLayout::new(batch, inputs.len())?;
    if let Some(path) = &args.report {
        let (model, overwrite) = (&args.out.output, args.out.overwrite);
        check_report(path, model, overwrite, &args.pois.inputs).map_err(|e| match e {
            ReportTargetError::Target(w) => anyhow::Error::new(w).context("the report"),
            e => e.into(),
        })?;
    }
    Ok(layout)
}
