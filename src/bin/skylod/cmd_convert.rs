//! `skylod convert`.

use crate::Outcome;
use anyhow::Context;
use skylod::citygml::read_file;
use skylod::citygml::write::{write_document, WriteOptions};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// CityGML file (.gml, .xml, .gz).
    input: PathBuf,
    /// Output file (.gz to compress).
    #[arg(short, long)]
    output: PathBuf,
    /// Replace an existing output file.
    #[arg(long)]
    overwrite: bool,
}

pub fn run(args: Args) -> anyhow::Result<Outcome> {
    let model = match read_file(&args.input) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("error: {e}");
            return Ok(Outcome::SomeFailed);
        }
    };
    let opts = WriteOptions {
        overwrite: args.overwrite,
        protect: vec![args.input.clone()],
        keep_envelopes: false,
    };
    let summary = write_document(&model, 0, Vec::new(), &args.output, &opts)
        .with_context(|| format!("writing {}", args.output.display()))?;
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
