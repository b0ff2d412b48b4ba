//! The arguments every tracing command (svf, sun-hours, horizon, evaluate) shares — inputs
//! and POIs, region, shard, scene radius — and the steps they take before tracing.

use crate::args::poi::PoiArgs;
use crate::args::region::RegionArgs;
use crate::args::scene::SceneArgs;
use crate::args::shard::ShardArgs;
use crate::inputs::{expand_inputs, Loaded, Spool};
use skylod::batch::shard::Shard;
use skylod::poi::Poi;

#[derive(clap::Args, Debug)]
pub struct TracingArgs {
    #[command(flatten)]
    pub pois: PoiArgs,
    #[command(flatten)]
    pub region: RegionArgs,
    #[command(flatten)]
    pub shard: ShardArgs,
    #[command(flatten)]
    pub scene: SceneArgs,
}

/// What a tracing command has once its inputs are read: the model (checked), this shard's
/// POIs (not yet in the local frame: [`PoiArgs::frame_checked`]) and the shard.
pub struct Prepared {
    pub loaded: Loaded,
    pub pois: Vec<Poi>,
    pub shard: Option<Shard>,
    /// Standard input spooled to a file lives as long as the command needs its inputs.
    _spool: Spool,
}

impl TracingArgs {
    /// Inputs expanded (directories, lists, `-`), the shard resolved, the POIs made (a
    /// region's grid too), inputs beyond `--scene-radius` left out, `before_read` (checks
    /// that must refuse before any work, e.g. an output target), then the inputs read and
    /// checked and this shard's POIs kept. `None` when no input could be read (each failure
    /// was reported).
    pub fn prepare(
        &mut self,
        cmd: &str,
        before_read: impl FnOnce(&PoiArgs) -> anyhow::Result<()>,
    ) -> anyhow::Result<Option<Prepared>> {
        let spool = expand_inputs(&mut self.pois.inputs)?;
        let shard = self.shard.resolve()?;
        let pois = self.region.points(&self.pois)?;
        let region = self.region.active();
        self.scene
            .filter(&mut self.pois, &pois, shard, region, cmd)?;
        before_read(&self.pois)?;
        let loaded = self.pois.load_checked()?;
        if loaded.inputs.is_empty() {
            return Ok(None);
        }
        let pois = self.region.extend(pois, &loaded.model)?;
        let pois = crate::args::shard::pois(shard, pois, cmd);
        Ok(Some(Prepared {
            loaded,
            pois,
            shard,
            _spool: spool,
        }))
    }
}
