//! `skylod evaluate`: full vs LoD vs all-boxes model, the paper's Tables 1 and 2.

use crate::args::rough::RoughArgs;
use crate::args::select::SelectArgs;
use crate::args::sun::SunArgs;
use crate::commands::out_err;
use crate::Outcome;
use skylod::export::report::write_table;
use skylod::export::report::SunSetting;
use skylod::lod::LodOptions;
use skylod::pipeline::session::EvaluateRequest;
use skylod::solar::{Site, SunTable};
use std::io::Write;
use std::time::Instant;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    on: crate::args::tracing::SunTracingArgs,
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
    #[command(flatten)]
    weather: crate::args::weather::WeatherArgs,
}

pub fn run(mut args: Args) -> anyhow::Result<Outcome> {
    args.on.site.check("evaluate", false)?;
    args.weather.check()?;
    let rough_opts = args.rough.options()?;
    let t_all = Instant::now();
    let Some(s) = args.on.tracing.study("evaluate", |_| Ok(()))? else {
        return Ok(Outcome::SomeFailed);
    };
    let lod = LodOptions {
        rough: rough_opts,
        select: args.select.options(),
    };
    let mut req = EvaluateRequest::new(lod, args.svf_rays);
    if !args.no_sun {
        let cmd = "evaluate (or give --no-sun)";
        let (lat, lon) = args.on.site.resolve(s.study.source(), cmd)?;
        let (year, step) = (args.sun.year, args.sun.step);
        let table = SunTable::year_with(year, step, &Site::new(lat, lon), &crate::log::reporter())?;
        req.sun = Some((SunSetting::new(lat, lon, year, step), table));
    }
    req.weather = (args.weather).year(&args.on.site, s.study.source(), "evaluate --weather")?;
    let a = s
        .study
        .evaluate_output(req, t_all, &crate::log::reporter())?;
    s.warn_flags(&a.flags);
    let mut out = std::io::stdout().lock();
    if args.json {
        out_err(writeln!(out, "{}", serde_json::to_string_pretty(&a.doc)?))?;
    } else {
        out_err(write_table(&mut out, &a.doc.pois, s.header()))?;
        for line in &a.summary {
            crate::log::summary!("{line}");
        }
    }
    Ok(s.outcome())
}
