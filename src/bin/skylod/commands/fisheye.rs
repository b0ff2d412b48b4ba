//! `skylod fisheye`.

use crate::args::poi::PoiArgs;
use crate::args::rough::RoughArgs;
use crate::args::site::SiteArgs;
use crate::Outcome;
use anyhow::{bail, Context};
use skylod::io::citygml::{atomic_write_bytes, check_target, is_stdout, WriteOptions};
use skylod::lod::LodOptions;
use skylod::pipeline::batch::per_poi;
use skylod::pipeline::session::{PictureSvg, Pictures};
use skylod::solar::Projection;
use std::path::PathBuf;

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum ProjectionArg {
    EqualArea,
    Stereographic,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq)]
enum ColourBy {
    /// The level `skylod lod` gives the asset hit for this POI (0 dropped, 1 rough, 2 full
    /// detail; level-2 assets, the silhouette, are outlined).
    Level,
    /// The kind of the asset hit (roof, wall, installation, ...).
    Kind,
}

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pois: PoiArgs,
    #[command(flatten)]
    shard: crate::args::shard::ShardArgs,
    #[command(flatten)]
    scene: crate::args::scene::SceneArgs,
    /// Output SVG (`-` for standard output, one POI only). With several POIs, one file per
    /// POI: `<stem>-<id>.svg`.
    #[arg(short, long)]
    output: PathBuf,
    /// Replace existing output files.
    #[arg(long)]
    overwrite: bool,
    /// Cells of the equal solid-angle sky partition (one ray through each centre).
    #[arg(long, default_value_t = 2_000)]
    rays: usize,
    /// Projection of the hemisphere.
    #[arg(long, value_enum, default_value = "equal-area")]
    projection: ProjectionArg,
    /// `--lat`/`--lon` of the sun paths (default: the centre of the model from its CRS, as
    /// sun-hours; no sun paths when the CRS cannot be converted).
    #[command(flatten)]
    site: SiteArgs,
    /// Year of the sun paths.
    #[arg(long, default_value_t = skylod::solar::DEFAULT_YEAR)]
    year: i32,
    /// What hit cells are coloured by.
    #[arg(long, value_enum, default_value = "level")]
    colour_by: ColourBy,
    /// Rays of the selection bundle (with --colour-by level), as `skylod lod --rays`.
    #[arg(long, default_value_t = 10_000)]
    select_rays: usize,
    /// Seed of the selection bundle, as `skylod lod --seed`.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// `--threshold`, `--roof-tolerance` of the selection, as `skylod lod`.
    #[command(flatten)]
    silhouette: crate::args::select::SilhouetteArgs,
    /// The rough model of the selection, as `skylod lod`.
    #[command(flatten)]
    rough: RoughArgs,
}

pub fn run(mut args: Args) -> anyhow::Result<Outcome> {
    let spool = crate::inputs::expand_inputs(&mut args.pois.inputs)?;
    let shard = args.shard.resolve()?;
    let pois = args.pois.points()?;
    let projection = match args.projection {
        ProjectionArg::EqualArea => Projection::EqualArea,
        ProjectionArg::Stereographic => Projection::Stereographic,
    };
    let pictures = Pictures::new(args.rays, projection)?;
    args.site.check("fisheye", true)?;
    let lod_opts = LodOptions {
        rough: args.rough.options()?,
        select: args.silhouette.options(args.select_rays, args.seed),
    };
    let pictures = pictures.with_levels((args.colour_by == ColourBy::Level).then_some(lod_opts));
    // Named from all POIs, so a shard writes the files the serial run would.
    let many = pois.len() > 1;
    args.scene
        .filter(&mut args.pois, &pois, shard, false, "fisheye")?;
    let pois = crate::args::shard::pois(shard, pois, "fisheye");
    let outputs: Vec<PathBuf> = pois
        .iter()
        .map(|p| per_poi(&args.output, &p.id, many))
        .collect();
    if many && is_stdout(&args.output) {
        bail!(
            "{} POIs give one picture each: -o - (standard output) takes one POI",
            pois.len()
        );
    }
    // Every target is checked before any work: never over an input, never over an existing
    // file without --overwrite.
    let wopts = WriteOptions {
        overwrite: args.overwrite,
        ..Default::default()
    };
    for o in &outputs {
        check_target(o, &wopts, args.pois.inputs.iter().map(PathBuf::as_path))?;
    }
    let Some(scene) = args.pois.scene()? else {
        return Ok(Outcome::SomeFailed);
    };
    let s = args.pois.study(scene, pois, shard, spool, "fisheye")?;
    let pictures = match s.study.sun_paths_site(args.site.given()) {
        Ok(site) => {
            if let Some(n) = site.note("") {
                crate::log::summary!("fisheye: {n}");
            }
            pictures.with_sun_paths(site.lat_lon(), args.year)?
        }
        Err(_) => {
            let crs = s.study.crs();
            crate::log::summary!("fisheye: no sun paths: the CRS ({crs}) is not one skylod converts; give --lat/--lon");
            pictures
        }
    };
    let (pois, inputs) = (s.study.pois(), s.study.input_names().join(", "));
    let each = |k: usize, pic: PictureSvg| -> anyhow::Result<()> {
        let (poi, out) = (&pois[k], &outputs[k]);
        crate::commands::warn_flags(std::slice::from_ref(poi), std::slice::from_ref(&pic.flags));
        atomic_write_bytes(out, pic.svg.as_bytes()).context("writing the picture")?;
        crate::log::summary!("{}", pic.line(&poi.id, &inputs, out, pictures.cells()));
        Ok(())
    };
    s.study
        .fisheye_svgs(&pictures, &crate::log::reporter(), each)?;
    Ok(s.outcome())
}
