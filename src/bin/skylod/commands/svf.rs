//! `skylod svf`.

use crate::args::tracing::Prepared;
use crate::commands::{out_err, polygons, s_to_ms, warn_flags};
use crate::Outcome;
use skylod::output::svf::{write_table, SvfOutput, SvfPoi, TraceTimings};
use skylod::solar::SkyBundles;
use std::io::Write;

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
    let Some(Prepared {
        mut loaded,
        pois,
        shard,
        ..
    }) = args.tracing.prepare("svf", |_| Ok(()))?
    else {
        return Ok(Outcome::SomeFailed);
    };
    let framed = (args.tracing.pois).frame_checked(&mut loaded.model, pois, "svf")?;
    let traced = skylod::pipeline::svf(&framed, &bundles, &crate::log::reporter())?;
    warn_flags(&framed.pois, &traced.flags);
    let (bvh_ms, trace_ms) = (s_to_ms(traced.bvh_s), s_to_ms(traced.trace_s));
    let pois = &framed.pois;
    let rows = traced.rows(pois, SvfPoi::new);
    let mut out = std::io::stdout().lock();
    if args.json {
        let doc = SvfOutput::new(
            rows,
            args.rays,
            args.seed,
            loaded.inputs.clone(),
            polygons(framed.source),
            TraceTimings {
                read: loaded.read_ms,
                bvh: bvh_ms,
                trace: trace_ms,
            },
        );
        out_err(writeln!(out, "{}", serde_json::to_string_pretty(&doc)?))?;
    } else {
        let (dp, header) = (
            framed.crs.plan_decimals(),
            crate::args::shard::header(shard),
        );
        out_err(write_table(&mut out, &rows, dp, header))?;
        crate::log::summary!(
            "{} POI(s), {} rays per bundle, seed {}; {} from {} input(s); read {:.0} ms, bvh {:.0} ms, trace {:.0} ms",
            pois.len(),
            args.rays,
            args.seed,
            crate::commands::polygons_traced(framed.source),
            loaded.inputs.len(),
            loaded.read_ms,
            bvh_ms,
            trace_ms
        );
    }
    Ok(loaded.outcome())
}
