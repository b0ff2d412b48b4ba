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
    /// Output file for one input (.gz to compress; `-` for standard output); a directory for
    /// several inputs (created if missing; one output per input, with the input's file name).
    /// The format follows the name: .gml/.xml CityGML, .obj OBJ, .city.json CityJSON,
    /// .city.jsonl CityJSONSeq.
    #[arg(short, long)]
    output: PathBuf,
    /// Output format when the output's name does not tell it (in a directory: the format of
    /// every output, named after its input with the format's ending).
    #[arg(long, value_name = "citygml|obj|cityjson|cityjsonseq", value_parser = crate::export::parse_format)]
    format: Option<Format>,
    /// Largest angle (degrees) between the normals of polygons merged into one plane.
    #[arg(long, default_value_t = RoughOptions::default().angle_deg)]
    angle: f64,
    /// Largest distance (m) of a polygon from its plane to be merged or absorbed.
    #[arg(long, default_value_t = RoughOptions::default().thickness_m)]
    thickness: f64,
    /// Do not use an asset's LoD2 geometry in place of its higher LoD.
    #[arg(long)]
    no_lod2: bool,
    /// Replace existing output files.
    #[arg(long)]
    overwrite: bool,
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
    if !(args.angle.is_finite() && (0.0..=90.0).contains(&args.angle)) {
        bail!("--angle must be between 0 and 90 degrees");
    }
    if !(args.thickness.is_finite() && args.thickness >= 0.0) {
        bail!("--thickness must be a non-negative number of metres");
    }
    let format = crate::export::resolve(args.inputs.len(), &args.output, args.format)?;
    let opts = RoughOptions {
        angle_deg: args.angle,
        thickness_m: args.thickness,
        prefer_lod2: !args.no_lod2,
    };
    let targets: Vec<(PathBuf, PathBuf)> = if args.inputs.len() == 1 {
        if args.output.is_dir() {
            bail!(
                "{}: is a directory; with one input, -o names the output file",
                args.output.display()
            );
        }
        vec![(args.inputs[0].clone(), args.output.clone())]
    } else {
        if is_stdout(&args.output) {
            bail!("several inputs cannot be written to standard output: give -o DIR");
        }
        if args.output.exists() && !args.output.is_dir() {
            bail!(
                "{}: with several inputs, -o must be a directory",
                args.output.display()
            );
        }
        let mut seen = std::collections::HashSet::new();
        let mut v = Vec::new();
        for i in &args.inputs {
            let Some(out) = crate::export::in_dir(&args.output, i, format) else {
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
        overwrite: args.overwrite,
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
                eprintln!("error: {e}");
                failed += 1;
            }
        }
    }
    if args.inputs.len() > 1 {
        std::fs::create_dir_all(&args.output)
            .map_err(|e| anyhow::anyhow!("{}: cannot create: {e}", args.output.display()))?;
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
                    eprintln!("{line}");
                }
                ok += 1;
                warnings += d.warnings;
                polys.0 += d.polygons.0;
                polys.1 += d.polygons.1;
            }
            Err(e) => {
                eprintln!("error: {e}");
                failed += 1;
            }
        }
    }
    eprintln!(
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
        eprintln!("rough: warning: {}: {w}", input.display());
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
