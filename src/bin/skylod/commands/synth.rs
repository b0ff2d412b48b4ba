//! `skylod synth`: the files written by [`skylod::pipeline::batch::synth`].

use crate::Outcome;
use anyhow::{bail, Context};
use skylod::model::synth::{Preset, SynthOptions};
use skylod::pipeline::batch::write_synth;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum PresetArg {
    /// Three buildings at one corner (a committed fixture, ~800 polygons).
    Small,
    /// 8x5 blocks, ~300K polygons, like the paper's district.
    Paper,
    /// 16x16 blocks, ~2M polygons, streamed to disk.
    City,
}

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output CityGML 2.0 file (.gz to compress; `-` for standard output). POIs go beside
    /// it as `<name>.pois.csv` unless --pois-output says where.
    #[arg(short, long)]
    output: PathBuf,
    /// Where to write the POI CSV (default: beside the output; with `-o -`, none unless
    /// given).
    #[arg(long, value_name = "FILE.csv")]
    pois_output: Option<PathBuf>,
    /// Size preset.
    #[arg(long, value_enum, default_value = "paper")]
    preset: PresetArg,
    /// Blocks as WxH (default: the preset's).
    #[arg(long)]
    blocks: Option<String>,
    /// Random seed.
    #[arg(long, default_value_t = 7)]
    seed: u64,
    /// Level of detail: 3 (facades, windows, installations) or 2 (shells only).
    #[arg(long, default_value_t = 3)]
    lod: u8,
    /// Also give each building an LoD2 shell.
    #[arg(long)]
    with_lod2: bool,
    /// Replace existing output files.
    #[arg(long)]
    overwrite: bool,
}

pub fn run(args: Args) -> anyhow::Result<Outcome> {
    let preset = match args.preset {
        PresetArg::Small => Preset::Small,
        PresetArg::Paper => Preset::Paper,
        PresetArg::City => Preset::City,
    };
    let mut opts: SynthOptions = preset.defaults();
    opts.seed = args.seed;
    opts.lod = args.lod;
    opts.with_lod2 = args.with_lod2;
    if let Some(b) = &args.blocks {
        let Some((x, y)) = b.split_once(['x', 'X']) else {
            bail!("--blocks {b}: expected WxH, e.g. 4x4");
        };
        opts.blocks_x = x.trim().parse().with_context(|| format!("--blocks {b}"))?;
        opts.blocks_y = y.trim().parse().with_context(|| format!("--blocks {b}"))?;
    }
    let t = Instant::now();
    let w = write_synth(
        &opts,
        &args.output,
        args.pois_output.as_deref(),
        args.overwrite,
    )?;
    let csv = (w.csv.as_ref()).map_or("not written (give --pois-output)".into(), |c| {
        c.display().to_string()
    });
    let line = w.line(&args.output, t.elapsed().as_secs_f64());
    crate::log::summary!("{line}; {} POIs -> {csv}", w.pois);
    Ok(Outcome::Ok)
}
