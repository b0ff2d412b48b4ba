//! `skylod synth`.

use crate::Outcome;
use anyhow::{bail, Context};
use skylod::citygml::write::{atomic_write, check_target, is_stdout, WriteOptions};
use skylod::citygml::WriteError;
use skylod::synth::{generate, pois, pois_path, write_pois_csv, Preset, SynthOptions};
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
    let wopts = WriteOptions {
        overwrite: args.overwrite,
        ..Default::default()
    };
    let csv = match &args.pois_output {
        Some(p) => Some(p.clone()),
        None if is_stdout(&args.output) => None,
        None => Some(pois_path(&args.output)),
    };
    if csv.as_deref().is_some_and(is_stdout) && is_stdout(&args.output) {
        bail!("the model and the POIs cannot both go to standard output");
    }
    check_target(&args.output, &wopts, std::iter::empty())?;
    if let Some(csv) = &csv {
        check_target(csv, &wopts, std::iter::empty())?;
    }
    let t = Instant::now();
    let mut summary = None;
    atomic_write(&args.output, |w| {
        let s = generate(&opts, w).map_err(|e| WriteError::Io {
            file: args.output.clone(),
            source: std::io::Error::other(e.to_string()),
        })?;
        let n = s.bytes;
        summary = Some(s);
        Ok(n)
    })?;
    let points = pois(&opts);
    if let Some(csv) = &csv {
        atomic_write(csv, |w| {
            write_pois_csv(&points, w).map_err(|e| WriteError::Io {
                file: csv.clone(),
                source: std::io::Error::other(e.to_string()),
            })?;
            Ok(0)
        })?;
    }
    let dt = t.elapsed().as_secs_f64();
    if let Some(s) = summary {
        crate::log::summary!(
            "{}: {} buildings, {} polygons, {} windows, {} installations, {:.1} MB{} in {:.2} s; {} POIs -> {}",
            args.output.display(),
            s.buildings,
            s.polygons,
            s.windows,
            s.installations_total(),
            std::fs::metadata(&args.output).map_or(s.bytes, |m| m.len()) as f64 / 1e6,
            if args.output.extension().is_some_and(|e| e == "gz") {
                " (compressed)"
            } else {
                ""
            },
            dt,
            points.len(),
            csv.as_ref()
                .map_or("not written (give --pois-output)".into(), |c| c.display().to_string())
        );
    }
    Ok(Outcome::Ok)
}
