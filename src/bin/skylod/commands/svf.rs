//! `skylod svf`.

use crate::commands::emit;
use crate::Outcome;
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
    let rays = (args.rays, args.seed);
    let a = s
        .study
        .svf_output(&bundles, rays, &crate::log::reporter())?;
    s.warn_flags(&a.flags);
    emit(&a.doc, args.json, &s.text())?;
    Ok(s.outcome())
}
