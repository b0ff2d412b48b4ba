//! `skylod rough`: the rough model (every asset at level 1) written as CityGML.

use crate::Outcome;
use anyhow::bail;
use skylod::citygml::mixed::write_mixed;
use skylod::citygml::read_file;
use skylod::citygml::write::WriteOptions;
use skylod::rough::{rough_model, RoughOptions};
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// CityGML files (.gml, .xml, .gz).
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// Output file for one input (.gz to compress); a directory for several inputs
    /// (created if missing; one output per input, with the input's file name).
    #[arg(short, long)]
    output: PathBuf,
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
    let opts = RoughOptions {
        angle_deg: args.angle,
        thickness_m: args.thickness,
        prefer_lod2: !args.no_lod2,
    };
    let targets = crate::common::outputs_per_input(&args.inputs, &args.output)?;
    let wopts = WriteOptions {
        overwrite: args.overwrite,
        protect: args.inputs.clone(),
        keep_envelopes: false,
    };
    let mut failed = 0usize;
    for (input, out) in &targets {
        if let Err(e) = one(input, out, &opts, &wopts) {
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

fn one(input: &Path, out: &Path, opts: &RoughOptions, wopts: &WriteOptions) -> anyhow::Result<()> {
    let model = read_file(input)?;
    let rough = rough_model(&model, opts);
    let levels = vec![1u8; model.assets.len()];
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
