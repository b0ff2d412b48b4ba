//! `skylod fisheye`.

use crate::args::poi::PoiArgs;
use crate::args::rough::RoughArgs;
use crate::args::site::SiteArgs;
use crate::Outcome;
use anyhow::{bail, Context};
use skylod::batch::outputs::per_poi;
use skylod::citygml::write::{atomic_write_bytes, check_target, is_stdout, WriteOptions};
use skylod::lod::LodOptions;
use skylod::model::AssetKind;
use skylod::pipeline::{sky_pictures, SkyPictureOptions};
use skylod::solar::fisheye::{cell_shares, fisheye_svg, sun_paths, FisheyeOptions, Projection};
use skylod::solar::sky::{SkyPartition, SkyVariant};
use skylod::solar::{Site, SkyBundles};
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
    let partition = SkyPartition::new(args.rays, SkyVariant::EqualSolidAngle)?;
    let bundles = SkyBundles::new(args.rays.max(10_000), 1)?;
    args.site.check_given("fisheye")?;
    let lod_opts = LodOptions {
        rough: args.rough.options()?,
        select: args.silhouette.options(args.select_rays, args.seed),
    };
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
    let framed = s.study.framed();
    let site = args
        .site
        .for_sun_paths(framed.source, &framed.crs, "fisheye");
    let paths = match site {
        Some((lat, lon)) => sun_paths(&Site::new(lat, lon), args.year)?,
        None => Vec::new(),
    };
    let kinds: Vec<AssetKind> = framed.model.assets.iter().map(|a| a.kind).collect();
    let projection = match args.projection {
        ProjectionArg::EqualArea => Projection::EqualArea,
        ProjectionArg::Stereographic => Projection::Stereographic,
    };
    let popts = SkyPictureOptions {
        partition: &partition,
        bundles: &bundles,
        levels: (args.colour_by == ColourBy::Level).then_some(lod_opts),
    };
    let degrees = framed.crs.plan_decimals() == 8;
    let dp = if degrees { 8 } else { 2 };
    sky_pictures(
        &framed,
        &popts,
        &crate::log::reporter(),
        |k, pic| -> anyhow::Result<()> {
            let (poi, out) = (&framed.pois[k], &outputs[k]);
            crate::commands::warn_flags(
                std::slice::from_ref(poi),
                std::slice::from_ref(&pic.flags),
            );
            let p = poi.position;
            let mut caption = vec![format!(
                "POI ({:.dp$}, {:.dp$}, {:.2}){}",
                p.x,
                p.y,
                p.z,
                poi.normal
                    .map_or(", no normal (horizontal)".to_string(), |n| format!(
                        ", normal ({:.2}, {:.2}, {:.2})",
                        n.x, n.y, n.z
                    ))
            )];
            caption.push(format!(
                "SVF {:.3}, sky exposure {:.3} ({} rays per bundle); input: {}",
                pic.view.svf,
                pic.view.sky_exposure,
                bundles.len(),
                s.inputs.join(", ")
            ));
            if let Some((lat, lon)) = site {
                caption.push(format!("sun paths {} at lat {lat}, lon {lon}", args.year));
            }
            let opts = FisheyeOptions {
                projection,
                title: format!("Sky from {}", poi.id),
                caption,
                sun_paths: paths.clone(),
                ..FisheyeOptions::default()
            };
            let levels = pic.levels.as_deref();
            let doc = fisheye_svg(&partition, &pic.cells, &kinds, levels, &opts);
            let text = doc.to_string();
            atomic_write_bytes(out, text.as_bytes()).context("writing the picture")?;
            let sky = cell_shares(&pic.cells, &kinds, levels)
                .into_iter()
                .find(|s| s.0 == "sky")
                .map_or(0.0, |s| s.1);
            crate::log::summary!(
                "{}: {} -> {} ({} cells, {:.1} % sky, SVF {:.3})",
                poi.id,
                s.inputs.join(", "),
                out.display(),
                partition.len(),
                sky * 100.0,
                pic.view.svf
            );
            Ok(())
        },
    )?;
    Ok(s.outcome())
}
