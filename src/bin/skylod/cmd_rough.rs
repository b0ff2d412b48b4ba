//! `skylod rough`: the rough model (every asset at level 1) written as CityGML.

use crate::Outcome;
use anyhow::bail;
use skylod::citygml::mixed::write_mixed;
use skylod::citygml::read_file;
use skylod::citygml::write::WriteOptions;
use skylod::export::{Content, Format};
use skylod::rough::{rough_model, RoughOptions};
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// CityGML files (.gml, .xml, .gz).
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// Output file for one input (.gz to compress); a directory for several inputs
    /// (created if missing; one output per input, with the input's file name). The format
    /// follows the name: .gml/.xml CityGML, .obj OBJ, .city.json CityJSON, .city.jsonl CityJSONSeq.
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
}

pub fn run(args: Args) -> anyhow::Result<Outcome> {
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
        std::fs::create_dir_all(&args.output)
            .map_err(|e| anyhow::anyhow!("{}: cannot create: {e}", args.output.display()))?;
        v
    };
    let wopts = WriteOptions {
        overwrite: args.overwrite,
        protect: args.inputs.clone(),
        keep_envelopes: false,
    };
    let mut failed = 0usize;
    for (input, out) in &targets {
        if let Err(e) = one(input, out, format, &opts, &wopts) {
            eprintln!("error: {e}");
            failed += 1;
        }
    }
    if failed > 0 {
        eprintln!("{failed} of {} input(s) failed", targets.len());
        Ok(Outcome::SomeFailed)
    } else {
        Ok(Outcome::Ok)
    }
}

fn one(
    input: &Path,
    out: &Path,
    format: Format,
    opts: &RoughOptions,
    wopts: &WriteOptions,
) -> anyhow::Result<()> {
    let model = read_file(input)?;
    let rough = rough_model(&model, opts);
    let levels = vec![1u8; model.assets.len()];
    if format != Format::CityGml {
        let content = Content::Levels {
            rough: &rough,
            levels: &levels,
        };
        return crate::export::write(format, &model, 0, content, out, wopts);
    }
    let s = write_mixed(&model, 0, &rough, &levels, out, wopts)?;
    let pct = if s.polygons_in > 0 {
        100.0 * s.polygons_out as f64 / s.polygons_in as f64
    } else {
        100.0
    };
    eprintln!(
        "{} -> {}: {} assets, polygons {} -> {} ({pct:.1}%), {} href(s) and {} appearance target(s) pruned",
        input.display(),
        out.display(),
        s.levels[1],
        s.polygons_in,
        s.polygons_out,
        s.hrefs_pruned,
        s.appearance_targets_pruned,
    );
    Ok(())
}
