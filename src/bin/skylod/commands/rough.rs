//! `skylod rough`: the rough model (every asset at level 1) written as CityGML.

use crate::log::{summary, warning};
use crate::outputs;
use crate::Outcome;
use skylod::export::Format;
use skylod::io::citygml::WriteOptions;
use skylod::model::crs::FrameWarning;
use skylod::pipeline::batch::{rough_file, RoughFile};
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// CityGML or CityJSON files (.gml, .xml, .city.json, .city.jsonl, .gz), directories (searched recursively), glob patterns
    /// ('tiles/**/*.gml', quoted), or - for standard input.
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    #[command(flatten)]
    out: crate::args::output::OutputArgs,
    #[command(flatten)]
    rough: crate::args::rough::RoughArgs,
    #[command(flatten)]
    files: crate::args::per_file::PerFileArgs,
}

pub fn run(mut args: Args) -> anyhow::Result<Outcome> {
    let t0 = std::time::Instant::now();
    let shard = args.files.shard.resolve()?;
    let (inputs, _spool) = crate::inputs::expand_inputs_relative(&args.inputs)?;
    args.inputs = inputs.iter().map(|i| i.path.clone()).collect();
    let opts = args.rough.options()?;
    // Every target is checked before any work: an input whose output is refused fails
    // (exit 1) without being read; the others are done. A merge writes every input to a
    // staging directory, then merges them into the target.
    let batch = outputs::batch("rough", &inputs, args.out.target(), false, shard)?;
    // A merge into OBJ or CityJSON stages CityGML parts, merged then converted (as `convert`).
    let format = (batch.targets.staging.as_ref()).map_or(batch.format, |_| Format::CityGml);
    let source_crs = args.files.crs.source_crs.as_ref();
    let o = RoughFile {
        format,
        rough: &opts,
        write: &batch.targets.write_opts,
        source_crs,
    };
    // Files in parallel (--jobs); messages in input order, whatever finished first (an OBJ
    // or CityJSON file's line is said as it is written).
    let each = |input: &Path, out: &Path, _: &Path, _: &WriteOptions| {
        let warned = |w: &FrameWarning| {
            let w = crate::flags::frame_warning_text(w);
            warning!("rough: warning: {}: {w}", skylod::model::shown(input));
        };
        let mut d = rough_file(input, out, &o, &warned)?;
        if format != Format::CityGml {
            d.line.take().into_iter().for_each(|l| summary!("{l}"));
        }
        anyhow::Ok(d)
    };
    let results = (args.files.jobs).install(|| batch.run_each(&inputs, true, &each))?;
    let failure = |e: &anyhow::Error| e.to_string();
    Ok(outputs::finish(
        &batch,
        "rough",
        results,
        failure,
        args.inputs.len(),
        t0,
    ))
}
