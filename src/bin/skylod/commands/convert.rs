//! `skylod convert`: read CityGML and write it back (envelopes recomputed) or in another
//! format; several inputs go to a mirrored directory or are merged into one document
//! ([`crate::outputs`]), files in parallel (`--jobs`), the same bytes whatever the number.

use crate::args::jobs::JobsArgs;
use crate::outputs::{self, Done};
use crate::Outcome;
use rayon::prelude::*;
use skylod::batch::outputs::Targets;
use skylod::citygml::write::{write_document, WriteOptions};
use skylod::citygml::{read_file_observed, ReadOptions};
use skylod::export::citygml_from_cityjson::{citygml_from_cityjson, is_json_file, TargetVersion};
use skylod::export::{Content, Format};
use skylod::runtime::progress::{Progress, Stage};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// CityGML or CityJSON files (.gml, .xml, .city.json, .city.jsonl, .gz; gzip is recognised by content), directories (searched
    /// recursively), glob patterns ('tiles/**/*.gml', quoted), or - for standard input.
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// Output: a file for one input (`-` for standard output; .gml/.xml (.gz to compress)
    /// CityGML, .obj OBJ, .city.json CityJSON 2.0, .city.jsonl CityJSONSeq); a directory
    /// that mirrors the input tree; or, for several inputs, one file (or `-`) that merges
    /// them (CityGML: one CityModel; OBJ, CityJSON: that merge converted, one origin;
    /// colliding gml:ids of later inputs renamed `<id>__<k>`).
    #[arg(short, long)]
    output: PathBuf,
    /// Output format when the output's name does not tell it.
    #[arg(long, value_name = "citygml|obj|cityjson|cityjsonseq", value_parser = crate::args::output::parse_format)]
    format: Option<Format>,
    /// Replace existing output files.
    #[arg(long)]
    overwrite: bool,
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
    let batch = outputs::batch("convert", &inputs, out, false, shard)?;
    let paths: Vec<PathBuf> = inputs.iter().map(|i| i.path.clone()).collect();
    let Targets {
        todo,
        staging,
        mirror,
        write_opts,
        ..
    } = &batch.targets;
    let (format, mirror) = (batch.format, *mirror);
    let fmt = if staging.is_some() {
        Format::CityGml
    } else {
        format
    };
    // Files in parallel; messages in input order whatever finished first.
    let progress = crate::log::reporter();
    let size = |k: usize| paths[k].metadata().map_or(0, |m| m.len());
    let bytes: u64 = todo.iter().map(|(k, _)| size(*k)).sum();
    progress.start(Stage::Read, todo.len() as u64, bytes);
    let results = args.jobs.install(|| {
        todo.par_iter()
            .map(|(k, out)| {
                let (k, out) = (*k, out.clone());
                let chunk = args.stream.chunk_for(&paths[k]);
                let r = match chunk.map(|c| {
                    let p = &paths[k];
                    crate::commands::stream::export(fmt, p, &out, c, write_opts, mirror, &progress)
                }) {
                    Some(Ok(Some(done))) => Ok(done),
                    Some(Err(e)) => Err(e),
                    _ => {
                        let passed = |n| progress.advance(Stage::Read, 0, n, None);
                        let v = args.citygml_version;
                        one(&paths[k], &out, (fmt, v), write_opts, mirror, &passed)
                    }
                };
                progress.advance(Stage::Read, 1, 0, None);
                (paths[k].clone(), out, r)
            })
            .collect()
    })?;
    progress.finish(Stage::Read);
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

/// Read `input` and write it to `out`.
fn one(
    input: &Path,
    out: &Path,
    (format, version): (Format, TargetVersion),
    opts: &WriteOptions,
    mirror: bool,
    passed: &(dyn Fn(u64) + Sync),
) -> anyhow::Result<Done> {
    if crate::log::cancelled() {
        anyhow::bail!("{}: cancelled before reading", skylod::model::shown(input));
    }
    if format == Format::CityGml && is_json_file(input) {
        // CityJSON → CityGML from the document itself, feature by feature.
        if mirror {
            outputs::create_parent(out)?;
        }
        let s = citygml_from_cityjson(input, out, version, opts)?;
        let line = s.describe(input, out).replace(
            &format!(", {} bytes", s.bytes_out),
            &format!(", {}", outputs::size_note(out, s.bytes_out)),
        );
        let warnings = s.dropped.values().sum();
        let polygons = (s.polygons, s.polygons);
        let line = Some(line);
        return Ok(Done {
            line,
            warnings,
            polygons,
        });
    }
    let model = read_file_observed(input, &ReadOptions::default(), passed)?;
    let polygons = crate::commands::polygons(&model);
    let warnings = model.warnings.len();
    if mirror {
        outputs::create_parent(out)?;
    }
    if format != Format::CityGml {
        // The export's errors name the output.
        outputs::export(format, &model, 0, Content::Full, out, opts)?;
        return Ok(Done {
            line: None,
            warnings,
            polygons: (polygons, polygons),
        });
    }
    // A failed write (refused target, unwritable directory, disk full) fails this input like
    // a read error: no output or temporary file is left behind.
    let s = write_document(&model, 0, Vec::new(), out, opts)?;
    Ok(Done {
        line: Some(format!(
            "{} -> {}: {}, {} envelope(s) recomputed, {} warning(s)",
            skylod::model::shown(input),
            out.display(),
            outputs::size_note(out, s.bytes),
            s.edits,
            warnings
        )),
        warnings,
        polygons: (polygons, polygons),
    })
}
