//! `skylod stats`: each input's counts from [`skylod::pipeline::batch::stats_files`].

use crate::commands::out_err;
use crate::Outcome;
use skylod::pipeline::batch::{stats_files, StatsFiles};
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
    files: crate::args::per_file::PerFileArgs,
    #[command(flatten)]
    stream: crate::args::stream::StreamArgs,
}

pub fn run(mut args: Args) -> anyhow::Result<Outcome> {
    let t0 = std::time::Instant::now();
    let shard = args.files.shard.resolve()?;
    let _spool = crate::inputs::expand_inputs(&mut args.inputs)?;
    args.inputs = crate::args::shard::files(shard, std::mem::take(&mut args.inputs), "stats");
    if args.inputs.is_empty() {
        return Ok(Outcome::Ok);
    }
    let o = StatsFiles {
        source_crs: args.files.crs.source_crs.as_ref(),
        chunk: args.stream.stream_chunk,
        verbose: args.verbose,
    };
    let (progress, note) = (crate::log::reporter(), |l: String| crate::log::info!("{l}"));
    let r = (args.files.jobs).install(|| stats_files(&args.inputs, &o, &progress, &note, t0))?;
    crate::outputs::say(r.said);
    let mut out = std::io::stdout().lock();
    if args.json {
        let json = serde_json::to_string_pretty(&r.output)?;
        out_err(writeln!(out, "{json}").and_then(|()| out.flush()))?;
    } else {
        out_err(r.output.write_table(&mut out).and_then(|()| out.flush()))?;
    }
    Ok(Outcome::failed_if(r.failed))
}
