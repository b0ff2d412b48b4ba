//! `skylod convert`.

use crate::Outcome;
use skylod::citygml::read_file;
use skylod::citygml::write::{check_target, write_document, WriteOptions};
use skylod::export::{Content, Format};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// CityGML file (.gml, .xml, .gz; gzip is recognised by content), or - for standard input.
    input: PathBuf,
    /// Output file (`-` for standard output): .gml/.xml (.gz to compress) CityGML, .obj OBJ,
    /// .city.json CityJSON 2.0, .city.jsonl CityJSONSeq.
    #[arg(short, long)]
    output: PathBuf,
    /// Output format when the output's name does not tell it.
    #[arg(long, value_name = "citygml|obj|cityjson|cityjsonseq", value_parser = crate::export::parse_format)]
    format: Option<Format>,
    /// Replace an existing output file.
    #[arg(long)]
    overwrite: bool,
    #[command(flatten)]
    shard: crate::shard_args::ShardArgs,
}

pub fn run(mut args: Args) -> anyhow::Result<Outcome> {
    // `-` (standard input) is spooled to a file: the writer re-reads its source.
    let mut inputs = vec![args.input.clone()];
    let _spool = crate::common::expand_inputs(&mut inputs)?;
    match inputs.as_slice() {
        [one] => args.input = one.clone(),
        _ => anyhow::bail!(
            "{}: convert takes one input file ({} found)",
            args.input.display(),
            inputs.len()
        ),
    }
    // One input: shard 0 converts it, the others have nothing to do.
    let shard = args.shard.resolve()?;
    if crate::shard_args::files(shard, vec![()], "convert").is_empty() {
        return Ok(Outcome::Ok);
    }
    let format = crate::export::resolve(1, &args.output, args.format)?;
    let opts = WriteOptions {
        overwrite: args.overwrite,
        protect: vec![args.input.clone()],
        keep_envelopes: false,
    };
    // Refuse a bad target before spending time on the input.
    if let Err(e) = check_target(&args.output, &opts, [args.input.as_path()]) {
        eprintln!("error: {e}");
        return Ok(Outcome::SomeFailed);
    }
    let model = match read_file(&args.input) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("error: {e}");
            return Ok(Outcome::SomeFailed);
        }
    };
    if format != Format::CityGml {
        return match crate::export::write(format, &model, 0, Content::Full, &args.output, &opts) {
            Ok(()) => Ok(Outcome::Ok),
            Err(e) => {
                eprintln!("error: writing {}: {e}", args.output.display());
                Ok(Outcome::SomeFailed)
            }
        };
    }
    // A failed write (refused target, unwritable directory, disk full) fails this input like a
    // read error: exit 1, and no output or temporary file is left behind.
    let summary = match write_document(&model, 0, Vec::new(), &args.output, &opts) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return Ok(Outcome::SomeFailed);
        }
    };
    eprintln!(
        "{} -> {}: {} bytes, {} envelope(s) recomputed, {} warning(s)",
        args.input.display(),
        args.output.display(),
        summary.bytes,
        summary.edits,
        model.warnings.len()
    );
    Ok(Outcome::Ok)
}
