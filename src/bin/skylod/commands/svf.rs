//! `skylod svf`.

use crate::commands::{out_err, polygons, s_to_ms};
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
    let Some(s) = args.tracing.study("svf", |_| Ok(()))? else {
        return Ok(Outcome::SomeFailed);
    };
    let traced = s.study.svf(&bundles, &crate::log::reporter())?;
    s.warn_flags(&traced.flags);
    let (bvh_ms, trace_ms) = (s_to_ms(traced.bvh_s), s_to_ms(traced.trace_s));
    let pois = s.study.pois();
    let rows = traced.rows(pois, SvfPoi::new);
    let mut out = std::io::stdout().lock();
    if args.json {
        let doc = SvfOutput::new(
            rows,
            args.rays,
            args.seed,
            s.inputs.clone(),
            polygons(s.study.source()),
            TraceTimings {
                read: s.read_ms,
                bvh: bvh_ms,
                trace: trace_ms,
            },
        );
        out_err(writeln!(out, "{}", serde_json::to_string_pretty(&doc)?))?;
    } else {
        let dp = s.study.crs().plan_decimals();
        out_err(write_table(&mut out, &rows, dp, s.header()))?;
        crate::log::summary!(
            "{} POI(s), {} rays per bundle, seed {}; {} from {} input(s); read {:.0} ms, bvh {:.0} ms, trace {:.0} ms",
            pois.len(),
            args.rays,
            args.seed,
            crate::commands::polygons_traced(s.study.source()),
            s.inputs.len(),
            s.read_ms,
            bvh_ms,
            trace_ms
        );
    }
    Ok(s.outcome())
}
