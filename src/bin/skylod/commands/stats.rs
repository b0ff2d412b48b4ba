//! `skylod stats`: each input's counts from [`skylod::pipeline::batch::convert::file_stats`].

use crate::args::crs::SourceCrsArgs;
use crate::commands::out_err;
use crate::Outcome;
use rayon::prelude::*;
use skylod::output::stats::{FileStats, Stats, StatsOutput};
use skylod::pipeline::batch::convert::{file_stats, StatsRead};
use skylod::runtime::progress::{Progress, Stage};
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// CityGML or CityJSON files (.gml, .xml, .city.json, .city.jsonl, .gz; gzip is recognised by content), directories
    /// (searched recursively), glob patterns ('tiles/**/*.gml', quoted), or - for standard
    /// input.
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
    /// Also print every warning (file:line:column: message) on stderr.
    #[arg(long, short)]
    verbose: bool,
    #[command(flatten)]
    crs: SourceCrsArgs,
    #[command(flatten)]
    jobs: crate::args::jobs::JobsArgs,
    #[command(flatten)]
    shard: crate::args::shard::ShardArgs,
    #[command(flatten)]
    stream: crate::args::stream::StreamArgs,
}

pub fn run(mut args: Args) -> anyhow::Result<Outcome> {
    let t0 = std::time::Instant::now();
    let shard = args.shard.resolve()?;
    let _spool = crate::inputs::expand_inputs(&mut args.inputs)?;
    args.inputs = crate::args::shard::files(shard, std::mem::take(&mut args.inputs), "stats");
    if args.inputs.is_empty() {
        return Ok(Outcome::Ok);
    }
    // One input: the process ends after its table, so its model is not handed back to the
    // allocator piece by piece (a fifth of the run on a 3 MB tile). A batch frees each model
    // after its statistics, so memory stays that of the files being read.
    let single = args.inputs.len() == 1;
    let progress = crate::log::reporter();
    let bytes = args
        .inputs
        .iter()
        .filter_map(|p| p.metadata().ok())
        .map(|m| m.len());
    progress.start(Stage::Read, args.inputs.len() as u64, bytes.sum());
    let (crs, note) = (args.crs.source_crs.as_ref(), |l: String| {
        crate::log::info!("{l}")
    });
    let results: Vec<_> = args.jobs.install(|| {
        (args.inputs.par_iter())
            .map(|p| {
                let chunk = (args.stream.chunk_for(p), args.verbose);
                let r = file_stats(p, crs, chunk, &progress, &note, single);
                progress.advance(Stage::Read, 1, 0, None);
                r
            })
            .collect()
    })?;
    progress.finish(Stage::Read);
    let mut ok = Vec::new();
    let mut failed = false;
    for (path, r) in args.inputs.iter().zip(results) {
        match r {
            Ok(StatsRead { stats: s, warnings }) => {
                if args.verbose {
                    for w in &warnings {
                        crate::log::warning!("warning: {w}");
                    }
                }
                if single {
                    std::mem::forget(warnings);
                }
                ok.push((path, s));
            }
            Err(e) => {
                crate::log::error!("{e}");
                failed = true;
            }
        }
    }
    let total = Stats::total(ok.iter().map(|(_, s)| s));
    if args.inputs.len() > 1 {
        let n_failed = args.inputs.len() - ok.len();
        crate::log::summary!(
            "{}",
            skylod::batch::run::summary_line(
                "stats",
                ok.len(),
                n_failed,
                total.warnings,
                None,
                t0.elapsed()
            )
        );
    }
    let files = ok
        .iter()
        .map(|(p, s)| FileStats::new(p.display().to_string(), s.clone()))
        .collect();
    // One shape whatever the number of inputs: a pipeline never has to test for it.
    let v = StatsOutput::new(files, total);
    let mut out = std::io::stdout().lock();
    if args.json {
        let json = serde_json::to_string_pretty(&v)?;
        out_err(writeln!(out, "{json}").and_then(|()| out.flush()))?;
    } else {
        out_err(v.write_table(&mut out).and_then(|()| out.flush()))?;
    }
    Ok(Outcome::failed_if(failed))
}
