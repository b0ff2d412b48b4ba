//! `--scene-radius M`: read only the inputs within reach of the POIs ([`skylod::pipeline::batch::scene_radius`]).

use crate::args::poi::PoiArgs;
use anyhow::bail;
use skylod::lod::poi::Poi;
use skylod::pipeline::batch::keep_within;
use skylod::pipeline::batch::Shard;

/// The scene options of the commands that trace POIs.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct SceneArgs {
    /// Read only the inputs whose extent (their gml:boundedBy envelope, or a fast pre-scan
    /// of their coordinates) comes within M (CRS units, metres for projected CRSs,
    /// horizontally) of a POI of this run; the others are not parsed. Needs the POIs from
    /// --poi/--pois in the model's CRS.
    #[arg(long, value_name = "M", value_parser = crate::args::non_negative)]
    pub scene_radius: Option<f64>,
}

impl SceneArgs {
    /// Keep in `args.inputs` only the inputs within `--scene-radius` of the POIs of `shard`
    /// among `pois`, saying on stderr which are read. Nothing to do without the option.
    pub fn filter(
        &self,
        args: &mut PoiArgs,
        pois: &[Poi],
        shard: Option<Shard>,
        region_active: bool,
        cmd: &str,
    ) -> anyhow::Result<()> {
        let Some(radius) = self.scene_radius else {
            return Ok(());
        };
        if region_active {
            bail!("--scene-radius needs the POIs before reading: give them with --poi/--pois, not --facade/--region");
        }
        if args.crs.poi_crs.is_some() {
            bail!("--scene-radius compares POIs with the inputs in the model's CRS: leave out --poi-crs");
        }
        // The pre-scan runs in rayon's global pool: size it (once) before it starts.
        args.jobs.global()?;
        let kept = keep_within(std::mem::take(&mut args.inputs), pois, shard, radius);
        crate::log::summary!("{cmd}: {}", kept.line(radius));
        if kept.inputs.is_empty() && kept.pois > 0 {
            bail!("no input comes within --scene-radius {radius} of a POI (are the POIs in the model's CRS?)");
        }
        args.inputs = kept.inputs;
        Ok(())
    }
}
