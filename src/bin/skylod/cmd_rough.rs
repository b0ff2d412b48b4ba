//! `skylod rough`: the rough model (every asset at level 1) written as CityGML.

use crate::frames::SourceCrsArgs;
use crate::Outcome;
use anyhow::bail;
use rayon::prelude::*;
use skylod::citygml::mixed::write_mixed;
use skylod::citygml::read_file;
use skylod::citygml::write::{check_target, WriteOptions};
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
    let (inputs, _spool) = crate::common::expand_inputs_relative(&args.inputs)?;
    args.inputs = inputs.iter().map(|i| i.path.clone()).collect();
    let opts = args.rough.options()?;
    let (plan, format) = crate::outputs::plan(&inputs, &args.out.output, args.out.format)?;
    if let (Some(s), crate::outputs::Plan::Merge(t)) = (shard, &plan) {
        bail!(
            "shard {s} cannot merge into {}: a merge needs every input (give -o DIR to the \
             shards, then merge their outputs with `skylod convert DIR -o FILE`)",
            t.display()
        );
    }
    // A merge: every input is written to a staging directory, then merged into the target.
    let staging = match &plan {
        crate::outputs::Plan::Merge(t) => Some(crate::outputs::Staging::new(t)?),
        _ => None,
    };
    let targets: Vec<(PathBuf, PathBuf)> = match (&plan, &staging) {
        (crate::outputs::Plan::PerInput(outs) | crate::outputs::Plan::Mirror(outs), _) => args
            .inputs
            .iter()
            .cloned()
            .zip(outs.iter().cloned())
            .collect(),
        (_, Some(st)) => args
            .inputs
            .iter()
            .enumerate()
            .map(|(k, i)| (i.clone(), st.part(k)))
            .collect(),
        _ => Vec::new(),
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
    if let crate::outputs::Plan::Merge(t) = &plan {
        check_target(t, &wopts, args.inputs.iter().map(PathBuf::as_path))?;
    }
    let part_opts = WriteOptions {
        overwrite: true,
        ..wopts.clone()
    };
    for (input, out) in &targets {
        if staging.is_some() {
            todo.push((input, out));
            continue;
        }
        match check_target(out, &wopts, args.inputs.iter().map(PathBuf::as_path)) {
            Ok(()) => todo.push((input, out)),
            Err(e) => {
                crate::log::error!("{e}");
                failed += 1;
            }
        }
    }
    let write_opts = if staging.is_some() {
        &part_opts
    } else {
        &wopts
    };
    // Files in parallel (--jobs); messages in input order, whatever finished first.
    let results: Vec<anyhow::Result<(Done, PathBuf, PathBuf)>> = args.jobs.install(|| {
        todo.par_iter()
            .map(|(input, out)| {
                if matches!(plan, crate::outputs::Plan::Mirror(_)) {
                    crate::outputs::create_parent(out)?;
                }
                one(input, out, format, &opts, write_opts, &args.crs)
                    .map(|d| (d, (*out).clone(), (*input).clone()))
            })
            .collect()
    })?;
    let (mut ok, mut warnings, mut polys) = (0, 0, (0, 0));
    let (mut parts, mut names) = (Vec::new(), Vec::new());
    for r in results {
        match r {
            Ok((d, out, input)) => {
                parts.push(out);
                names.push(input);
                if let Some(line) = d.line.filter(|_| staging.is_none()) {
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
    if let (Some(st), crate::outputs::Plan::Merge(t)) = (&staging, &plan) {
        if parts.is_empty() {
            crate::log::error!("no input could be read; {} not written", t.display());
        } else {
            match st.merge(&parts, &names, t, &wopts) {
                Ok(s) => crate::log::summary!("{}", crate::outputs::merge_line(&s, t)),
                Err(e) => {
                    crate::log::error!("{e:#}");
                    failed += ok;
                    ok = 0;
                }
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
    let rough_local = rough_model(&local, opts);
    let rough = frame.rough_to_source(&local, &model, &rough_local, None);
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
