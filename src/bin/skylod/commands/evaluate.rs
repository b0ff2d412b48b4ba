//! `skylod evaluate`: full vs LoD vs all-boxes model, the paper's Tables 1 and 2.

use crate::args::rough::RoughArgs;
use crate::args::select::SelectArgs;
use crate::args::site::SiteArgs;
use crate::args::sun::SunArgs;
use crate::args::tracing::Prepared;
use crate::commands::{ms, out_err, warn_flags};
use crate::Outcome;
use skylod::lod::LodOptions;
use skylod::output::evaluate::{EvaluateOutput, EvaluateTimings};
use skylod::output::sun_hours::SunSetting;
use skylod::pipeline::evaluation::EvalOptions;
use skylod::pipeline::EvaluateOptions;
use skylod::solar::{Site, SunTable};
use std::io::Write;
use std::time::Instant;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    tracing: crate::args::tracing::TracingArgs,
    #[command(flatten)]
    site: SiteArgs,
    /// Skip sun hours (then --lat/--lon are not needed).
    #[arg(long)]
    no_sun: bool,
    #[command(flatten)]
    sun: SunArgs,
    #[command(flatten)]
    select: SelectArgs,
    #[command(flatten)]
    rough: RoughArgs,
    /// Rays of each SVF bundle (the same bundle for the three models).
    #[arg(long, default_value_t = 20_000)]
    svf_rays: usize,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

pub fn run(mut args: Args) -> anyhow::Result<Outcome> {
    args.site.check("evaluate")?;
    let rough_opts = args.rough.options()?;
    let t_all = Instant::now();
    let Some(Prepared {
        mut loaded,
        pois,
        shard,
        ..
    }) = args.tracing.prepare("evaluate", |_| Ok(()))?
    else {
        return Ok(Outcome::SomeFailed);
    };
    let framed = (args.tracing.pois).frame_checked(&mut loaded.model, pois, "evaluate")?;
    let site = if args.no_sun {
        None
    } else {
        let (lat, lon) = args
            .site
            .resolve(framed.source, "evaluate (or give --no-sun)")?;
        Some(Site::new(lat, lon))
    };
    let table = match &site {
        Some(s) => Some(SunTable::year_with(
            args.sun.year,
            args.sun.step,
            s,
            &crate::log::reporter(),
        )?),
        None => None,
    };
    let opts = EvaluateOptions {
        eval: EvalOptions {
            lod: LodOptions {
                rough: rough_opts,
                select: args.select.options(),
            },
            svf_rays: args.svf_rays,
            ..Default::default()
        },
        sun: table,
    };
    let e = skylod::pipeline::evaluate(&framed, &opts, &crate::log::reporter())?;
    let flags: Vec<_> = e.pois.iter().map(|p| p.flags.clone()).collect();
    warn_flags(&framed.pois, &flags);
    let mut out = std::io::stdout().lock();
    if args.json {
        let doc = EvaluateOutput::new(
            loaded.inputs.clone(),
            args.select.rays,
            args.svf_rays,
            args.select.seed,
            site.map(|s| SunSetting::new(s.latitude, s.longitude, args.sun.year, args.sun.step)),
            e.pois.clone(),
            EvaluateTimings {
                read: loaded.read_ms,
                rough: e.rough_ms,
                selection_bvh: e.selection_bvh_ms,
                total: ms(t_all),
            },
        );
        out_err(writeln!(out, "{}", serde_json::to_string_pretty(&doc)?))?;
    } else {
        let header = crate::args::shard::header(shard);
        out_err(skylod::output::evaluate::write_table(
            &mut out, &e.pois, header,
        ))?;
        crate::log::summary!(
            "{} POI(s); selection {} rays, SVF {} rays; read {:.0} ms, rough {:.0} ms (shared), selection BVH {:.0} ms (shared), total {:.0} ms",
            e.pois.len(),
            args.select.rays,
            args.svf_rays,
            loaded.read_ms,
            e.rough_ms,
            e.selection_bvh_ms,
            ms(t_all)
        );
    }
    Ok(loaded.outcome())
}
