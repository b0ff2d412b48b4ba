//! `--scene-radius M`: read only the inputs within reach of the POIs ([`skylod::batch::scene_radius`]).

use crate::args::poi::PoiArgs;
use anyhow::bail;
use skylod::batch::scene_radius::{within_reach, Reach};
use skylod::batch::shard::Shard;
use skylod::poi::Poi;

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
        let mine = match shard {
            Some(s) => {
                let at: Vec<glam::DVec3> = pois.iter().map(|p| p.position).collect();
                pois[s.pois(&at)].to_vec()
            }
            None => pois.to_vec(),
        };
        let at: Vec<glam::DVec3> = mine.iter().map(|p| p.position).collect();
        let total = args.inputs.len();
        // The pre-scan runs in rayon's global pool: size it (once) before it starts.
        args.jobs.global()?;
        let Reach { keep, scanned } = within_reach(&args.inputs, &at, radius);
        let inputs: Vec<_> = args
            .inputs
            .drain(..)
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(p, _)| p)
            .collect();
        let names: Vec<String> = inputs
            .iter()
            .map(|p| skylod::model::shown(p).to_string())
            .collect();
        crate::log::summary!(
            "{cmd}: scene radius {radius} m: {} of {total} input(s) within reach of {} POI(s) \
             ({} not read; {scanned} without an envelope, pre-scanned): {}",
            inputs.len(),
            mine.len(),
            total - inputs.len(),
            names.join(", ")
        );
        if inputs.is_empty() && !mine.is_empty() {
            bail!("no input comes within --scene-radius {radius} of a POI (are the POIs in the model's CRS?)");
        }
        args.inputs = inputs;
        Ok(())
    }
}
