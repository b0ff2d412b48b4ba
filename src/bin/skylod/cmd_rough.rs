//! `skylod rough`: the rough model (every asset at level 1) written as CityGML.

use crate::frames::SourceCrsArgs;
use crate::Outcome;
use anyhow::bail;
use rayon::prelude::*;
use skylod::citygml::mixed::write_mixed;
use skylod::citygml::read_file;
use skylod::citygml::write::{check_target, is_stdout, WriteOptions};
use skylod::crs::{model_crs, LocalFrame};
use skylod::export::{Content, Format};
use skylod::rough::{rough_model, RoughOptions};
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// CityGML files (.gml, .xml, .gz), directories (searched recursively), glob patterns
    /// ('tiles/**/*.gml', quoted), or - for standard input.
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    #[command(flatten)]
    out: crate::common::OutputArgs,
    #[command(flatten)]
    rough: crate::common::RoughArgs,
    #[command(flatten)]
    crs: SourceCrsArgs,
    #[command(flatten)]
    jobs: crate::common::JobsArgs,
    #[command(flatten)]
    shard: crate::shard_args::ShardArgs,
}

pub fn run(mut args: Args) -> anyhow::Result<Outcome> {
    let t0 = std::time::Instant::now();
    let shard = args.shard.resolve()?;
    let _spool = crate::common::expand_inputs(&mut args.inputs)?;
    let format = crate::export::resolve(args.inputs.len(), &args.out.output, args.out.format)?;
    let opts = args.rough.options()?;
    let targets: Vec<(PathBuf, PathBuf)> = if args.inputs.len() == 1 {
        if args.out.output.is_dir() {
            bail!(
                "{}: is a directory; with one input, -o names the output file",
                args.out.output.display()
            );
        }
        vec![(args.inputs[0].clone(), args.out.output.clone())]
    } else {
        if is_stdout(&args.out.output) {
            bail!("several inputs cannot be written to standard output: give -o DIR");
        }
        if args.out.output.exists() && !args.out.output.is_dir() {
            bail!(
                "{}: with several inputs, -o must be a directory",
                args.out.output.display()
            );
        }
        let mut seen = std::collections::HashSet::new();
        let mut v = Vec::new();
        for i in &args.inputs {
            let Some(out) = crate::export::in_dir(&args.out.output, i, format) else {
                bail!("{}: not a file name", i.display());
            };
            if !seen.insert(out.clone()) {
                bail!("two inputs would both be written to {}", out.display());
            }
            v.push((i.clone(), out));
        }
        v
    };
    // Laid out for all inputs, then this shard's part: each file goes where the serial run
    // writes it.
    let targets = crate::shard_args::files(shard, targets, "rough");
    let wopts = WriteOptions {
        overwrite: args.out.overwrite,
        protect: args.inputs.clone(),
        keep_envelopes: false,
    };
    // Every target is checked before any work: an input whose output is refused fails
    // (exit 1) without being read; the others are done.
    let mut failed = 0usize;
    let mut todo = Vec::with_capacity(targets.len());
    for (input, out) in &targets {
        match check_target(out, &wopts, args.inputs.iter().map(PathBuf::as_path)) {
            Ok(()) => todo.push((input, out)),
            Err(e) => {
                crate::log::error!("{e}");
                failed += 1;
            }
        }
    }
    if args.inputs.len() > 1 {
        std::fs::create_dir_all(&args.out.output)
            .map_err(|e| anyhow::anyhow!("{}: cannot create: {e}", args.out.output.display()))?;
    }
    // Files in parallel (--jobs); messages in input order, whatever finished first.
    let results: Vec<anyhow::Result<Done>> = args.jobs.install(|| {
        todo.par_iter()
            .map(|(input, out)| one(input, out, format, &opts, &wopts, &args.crs))
            .collect()
    })?;
    let (mut ok, mut warnings, mut polys) = (0, 0, (0, 0));
    for r in results {
        match r {
            Ok(d) => {
                if let Some(line) = d.line {
                    crate::log::summary!("{line}");
                }
                ok += 1;
                warnings += d.warnings;
                polys.0 += d.polygons.0;
                polys.1 += d.polygons.1;
            }
            Err(e) => {
                crate::log::error!("{e}");
                failed += 1;
            }
        }
    }
    crate::log::summary!(
        "{}",
        crate::common::summary_line(
            "rough",
            ok,
            failed,
            warnings,
            (format == Format::CityGml).then_some(polys),
            t0
        )
    );
    Ok(if failed > 0 {
        Outcome::SomeFailed
    } else {
        Outcome::Ok
    })
}

/// What one input gave: its summary line (printed in input order), warnings, polygons in/out.
struct Done {
    line: Option<String>,
    warnings: usize,
    polygons: (usize, usize),
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
        crate::log::warning!("rough: warning: {}: {w}", input.display());
    }
    let local = frame.model_to_local(&model);
    let rough = frame.rough_to_source(&local, &model, &rough_model(&local, opts));
    let levels = vec![1u8; model.assets.len()];
    if format != Format::CityGml {
        let content = Content::Levels {
            rough: &rough,
            levels: &levels,
        };
        crate::export::write(format, &model, 0, content, out, wopts)?;
        return Ok(Done {
            line: None,
            warnings: model.warnings.len(),
            polygons: (0, 0),
        });
    }
    let s = write_mixed(&model, 0, &rough, &levels, out, wopts)?;
    let pct = if s.polygons_in > 0 {
        100.0 * s.polygons_out as f64 / s.polygons_in as f64
    } else {
        100.0
    };
    let line = format!(
        "{} -> {}: {} assets, polygons {} -> {} ({pct:.1}%), {} href(s) and {} appearance target(s) pruned",
        input.display(),
        out.display(),
        s.levels[1],
        s.polygons_in,
        s.polygons_out,
        s.hrefs_pruned,
        s.appearance_targets_pruned,
    );
    Ok(Done {
        line: Some(line),
        warnings: model.warnings.len(),
        polygons: (s.polygons_in, s.polygons_out),
    })
}
