//! `skylod convert`: read CityGML and write it back (envelopes recomputed) or in another
//! format; several inputs go to a mirrored directory or are merged into one document
//! ([`crate::outputs`]), files in parallel (`--jobs`), the same bytes whatever the number;
//! the inputs: [`skylod::pipeline::batch::convert_all`].

use crate::args::jobs::JobsArgs;
use crate::outputs;
use crate::Outcome;
use skylod::export::Format;
use skylod::export::TargetVersion;
use skylod::pipeline::batch::convert_all;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// CityGML or CityJSON files (.gml, .xml, .city.json, .city.jsonl, .gz; gzip is recognised by content), directories (searched
    /// recursively), glob patterns ('tiles/**/*.gml', quoted), or - for standard input.
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// Output: a file for one input (`-` for standard output; .gml/.xml (.gz to compress)
    /// CityGML, .obj OBJ, .city.json CityJSON 2.0, .city.jsonl CityJSONSeq, DIR/tileset.json
    /// a 3D Tiles 1.1 tileset in DIR); a directory
    /// that mirrors the input tree; or, for several inputs, one file (or `-`) that merges
    /// them (CityGML: one CityModel; OBJ, CityJSON: that merge converted, one origin;
    /// colliding gml:ids of later inputs renamed `<id>__<k>`).
    #[arg(short, long)]
    output: PathBuf,
    /// Output format when the output's name does not tell it.
    #[arg(long, value_name = "citygml|obj|cityjson|cityjsonseq|3dtiles", value_parser = crate::args::output::parse_format)]
    format: Option<Format>,
    /// Replace existing output files.
    #[arg(long)]
    overwrite: bool,
    #[command(flatten)]
    crs: crate::args::crs::SourceCrsArgs,
    /// With a 3D Tiles output, also write DIR/index.html: the tileset in CesiumJS (loaded
    /// from its CDN by the browser), coloured by class, a click showing an object's data.
    #[arg(long)]
    viewer: bool,
    /// CityGML version written for CityJSON inputs (CityGML inputs keep theirs).
    #[arg(long, value_name = "2.0|3.0", default_value = "2.0")]
    citygml_version: TargetVersion,
    #[command(flatten)]
    jobs: JobsArgs,
    #[command(flatten)]
    shard: crate::args::shard::ShardArgs,
    #[command(flatten)]
    stream: crate::args::stream::StreamArgs,
}

pub fn run(args: Args) -> anyhow::Result<Outcome> {
    let t0 = Instant::now();
    // `-` (standard input) is spooled to a file: the writer re-reads its source.
    let (inputs, _spool) = crate::inputs::expand_inputs_relative(&args.inputs)?;
    let shard = args.shard.resolve()?;
    let out = (args.output.as_path(), args.format, args.overwrite);
    let mut batch = outputs::batch("convert", &inputs, out, false, shard)?;
    for w in [&mut batch.wopts, &mut batch.targets.write_opts] {
        (w.source_crs, w.viewer) = (args.crs.source_crs.clone(), args.viewer);
    }
    let paths: Vec<PathBuf> = inputs.iter().map(|i| i.path.clone()).collect();
    // Files in parallel; messages in input order whatever finished first (an OBJ or
    // CityJSON file's line as soon as it is written).
    let (progress, o) = (
        crate::log::reporter(),
        (args.citygml_version, args.stream.stream_chunk),
    );
    let note = |l: String| crate::log::info!("{l}");
    let written = |l: String| crate::log::summary!("{l}");
    let results =
        (args.jobs).install(|| convert_all(&batch, &paths, o, &progress, &note, &written))?;
    let results = (results.into_iter())
        .map(|(i, o, r)| (i, o, r.map_err(Into::into)))
        .collect();
    let failure = |e: &anyhow::Error| crate::message(e);
    Ok(outputs::finish(
        &batch,
        "convert",
        results,
        failure,
        paths.len(),
        t0,
    ))
}
