//! `skylod rough`: the rough model (every asset at level 1) written as CityGML.

use crate::args::crs::SourceCrsArgs;
use crate::outputs::{self, Done};
use crate::Outcome;
use rayon::prelude::*;
use skylod::batch::outputs::Targets;
use skylod::citygml::read_file;
use skylod::citygml::write::WriteOptions;
use skylod::crs::{model_crs, LocalFrame};
use skylod::export::{Content, Format};
use skylod::lod::mixed::write_mixed;
use skylod::lod::rough::{rough_model, RoughOptions};
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
    crs: SourceCrsArgs,
    #[command(flatten)]
    jobs: crate::args::jobs::JobsArgs,
    #[command(flatten)]
    shard: crate::args::shard::ShardArgs,
}

pub fn run(mut args: Args) -> anyhow::Result<Outcome> {
    let t0 = std::time::Instant::now();
    let shard = args.shard.resolve()?;
    let (inputs, _spool) = crate::inputs::expand_inputs_relative(&args.inputs)?;
    args.inputs = inputs.iter().map(|i| i.path.clone()).collect();
    let opts = args.rough.options()?;
    let out = (
        args.out.output.as_path(),
        args.out.format,
        args.out.overwrite,
    );
    // Every target is checked before any work: an input whose output is refused fails
    // (exit 1) without being read; the others are done. A merge writes every input to a
    // staging directory, then merges them into the target.
    let batch = outputs::batch("rough", &inputs, out, false, shard)?;
    // A merge into OBJ or CityJSON stages CityGML parts, merged then converted (as `convert`).
    let format = batch
        .targets
        .staging
        .as_ref()
        .map_or(batch.format, |_| Format::CityGml);
    let Targets {
        todo,
        mirror,
        write_opts,
        ..
    } = &batch.targets;
    // Files in parallel (--jobs); messages in input order, whatever finished first.
    let results = args.jobs.install(|| {
        todo.par_iter()
            .map(|(k, out)| {
                let input = &args.inputs[*k];
                let r = if *mirror {
                    crate::outputs::create_parent(out)
                } else {
                    Ok(())
                };
                let r = r.and_then(|()| one(input, out, format, &opts, write_opts, &args.crs));
                (input.clone(), out.clone(), r)
            })
            .collect()
    })?;
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

fn one(
    input: &Path,
    out: &Path,
    format: Format,
    opts: &RoughOptions,
    wopts: &WriteOptions,
    crs: &SourceCrsArgs,
) -> anyhow::Result<Done> {
    let mut model = read_file(input)?;
    crs.apply(&mut model);
    // Generalise in metres (thickness, angles), write in the input's CRS.
    let (frame, warning) =
        LocalFrame::new(&model_crs(&model, crs.source_crs.as_ref()), &model.bbox());
    if let Some(w) = warning {
        let w = crate::errors::frame_warning(&w);
        crate::log::warning!("rough: warning: {}: {w}", skylod::model::shown(input));
    }
    let local = frame.model_to_local(&model);
    let rough_local = rough_model(&local, opts);
    let rough = skylod::lod::rough::rough_to_source(&frame, &local, &model, &rough_local, None);
    let levels = vec![1u8; model.assets.len()];
    if format != Format::CityGml {
        let content = Content::Levels {
            rough: &rough,
            levels: &levels,
        };
        crate::outputs::export(format, &model, 0, content, out, wopts)?;
        return Ok(Done {
            line: None,
            warnings: model.warnings.len(),
            polygons: (0, 0),
        });
    }
    if skylod::export::citygml_via_cityjson::is_cityjson_source(&model, 0) {
        // A CityJSON source has no XML to copy: its CityJSON output converted to CityGML 2.0.
        let content = Content::Levels {
            rough: &rough,
            levels: &levels,
        };
        let s = skylod::export::citygml_via_cityjson::write_citygml_levels(
            &model, 0, content, out, wopts,
        )?;
        return Ok(Done {
            line: Some(s.describe(input, out)),
            warnings: model.warnings.len(),
            polygons: (
                model.assets.iter().map(|a| a.detail_polygons().len()).sum(),
                s.polygons,
            ),
        });
    }
    let s = write_mixed(&model, 0, &rough, &levels, out, wopts)?;
    Ok(Done {
        line: Some(s.rough_line(input, out)),
        warnings: model.warnings.len(),
        polygons: (s.polygons_in, s.polygons_out),
    })
}
