//! The arguments every tracing command (svf, sun-hours, horizon, evaluate, irradiance)
//! shares — inputs and POIs, region, shard, scene radius — and the steps they take before
//! tracing: the library's [`skylod::pipeline::session`] (`Scene` → `Study`) with what stays CLI-only
//! (failures and warnings on stderr, the shard said, the spooled standard input kept).

use crate::args::poi::PoiArgs;
use crate::args::region::RegionArgs;
use crate::args::scene::SceneArgs;
use crate::args::shard::ShardArgs;
use crate::inputs::{expand_inputs, Spool};
use crate::Outcome;
use skylod::export::report::TextContext;
use skylod::lod::poi::PoiFlag;
use skylod::pipeline::batch::Shard;
use skylod::pipeline::session::Study;

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

/// The inputs and POIs of a command that needs the sun's site (`sun-hours`, `evaluate`).
#[derive(clap::Args, Debug)]
pub struct SunTracingArgs {
    #[command(flatten)]
    pub tracing: TracingArgs,
    #[command(flatten)]
    pub site: crate::args::site::SiteArgs,
}

impl SunTracingArgs {
    /// `--lat`/`--lon` checked (both or neither), then [`TracingArgs::study`].
    pub fn study(&mut self, cmd: &str) -> anyhow::Result<Option<Session>> {
        self.site.check(cmd, false)?;
        self.tracing.study(cmd, |_| Ok(()))
    }
}

/// A tracing command's [`Study`] (model read and checked, this shard's POIs framed) with
/// what the CLI says about it.
pub struct Session {
    pub study: Study,
    pub shard: Option<Shard>,
    /// Milliseconds reading, rounded to 0.1.
    pub read_ms: f64,
    /// Some input could not be read (each was reported).
    pub failed: bool,
    /// Standard input spooled to a file lives as long as the command needs its inputs.
    pub _spool: Spool,
}

impl Session {
    /// Exit outcome: some inputs failed, or all were read.
    pub fn outcome(&self) -> Outcome {
        Outcome::failed_if(self.failed)
    }

    /// Whether this run prints a table's header ([`crate::args::shard::header`]).
    pub fn header(&self) -> bool {
        crate::args::shard::header(self.shard)
    }

    /// What the text of the command's document says beyond its JSON.
    pub fn text(&self) -> TextContext {
        self.study.text_context(self.header())
    }

    /// Say each POI's flags as a warning on stderr.
    pub fn warn_flags(&self, flags: &[Vec<PoiFlag>]) {
        crate::commands::warn_flags(self.study.pois(), flags);
    }
}

impl TracingArgs {
    /// Inputs expanded (directories, lists, `-`), the shard resolved, the POIs made (a
    /// region's grid too), inputs beyond `--scene-radius` left out, `before_read` (checks
    /// that must refuse before any work, e.g. an output target), then the inputs read and
    /// checked, this shard's POIs kept and framed. `None` when no input could be read (each
    /// failure was reported).
    pub fn study(
        &mut self,
        cmd: &str,
        before_read: impl FnOnce(&PoiArgs) -> anyhow::Result<()>,
    ) -> anyhow::Result<Option<Session>> {
        let spool = expand_inputs(&mut self.pois.inputs)?;
        let shard = self.shard.resolve()?;
        let pois = self.region.points(&self.pois)?;
        let region = self.region.active();
        self.scene
            .filter(&mut self.pois, &pois, shard, region, cmd)?;
        before_read(&self.pois)?;
        let Some(scene) = self.pois.scene()? else {
            return Ok(None);
        };
        let pois = self.region.extend(pois, scene.model())?;
        let pois = self.region.shard_pois(pois, scene.model(), shard, cmd);
        self.pois.study(scene, pois, shard, spool, cmd).map(Some)
    }
}
