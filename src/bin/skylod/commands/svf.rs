//! `skylod svf`.

use crate::commands::{emit, polygons};
use crate::Outcome;
use skylod::output::svf::{SvfOutput, SvfPoi};
use skylod::solar::SkyBundles;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    tracing: crate::args::tracing::TracingArgs,
    /// Rays per bundle (cells of each Beckers sky partition).
    #[arg(long, default_value_t = skylod::solar::DEFAULT_SKY_RAYS)]
    rays: usize,
    /// Seed of the ray jitter inside each cell.
    #[arg(long, default_value_t = skylod::solar::DEFAULT_SKY_SEED)]
    seed: u64,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

pub fn run(mut args: Args) -> anyhow::Result<Outcome> {
    let bundles = SkyBundles::new(args.rays, args.seed)?;
    let Some(s) = args.tracing.study("svf", |_| Ok(()))? else {
        return Ok(Outcome::SomeFailed);
    };
    let traced = s.study.svf(&bundles, &crate::log::reporter())?;
    s.warn_flags(&traced.flags);
    let timings = s.timings(&traced);
    let rows = traced.rows(s.study.pois(), SvfPoi::new);
    let polygons = polygons(s.study.source());
    let doc = SvfOutput::new(
        rows,
        args.rays,
        args.seed,
        s.inputs.clone(),
        polygons,
        timings,
    );
    emit(&doc, args.json, &s.text())?;
    Ok(s.outcome())
}
