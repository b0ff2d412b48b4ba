//! `skylod sun-hours`.

use crate::args::site::SiteArgs;
use crate::args::sun::SunArgs;
use crate::args::tracing::Prepared;
use crate::commands::{ms, out_err, polygons, s_to_ms, warn_flags};
use crate::Outcome;
use skylod::output::sun_hours::{
    write_table, SunHoursOutput, SunHoursPoi, SunHoursTimings, SunSetting,
};
use skylod::solar::{Site, SunTable};
use std::io::Write;
use std::time::Instant;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    tracing: crate::args::tracing::TracingArgs,
    #[command(flatten)]
    site: SiteArgs,
    #[command(flatten)]
    sun: SunArgs,
    /// Time zone for attributing steps to months: IANA name ("Europe/Madrid"), "UTC" or
    /// a fixed offset ("+01:00").
    #[arg(long, default_value = "UTC", allow_hyphen_values = true)]
    timezone: String,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

pub fn run(mut args: Args) -> anyhow::Result<Outcome> {
    args.site.check("sun-hours")?;
    let Some(Prepared {
        mut loaded,
        pois,
        shard,
        ..
    }) = args.tracing.prepare("sun-hours", |_| Ok(()))?
    else {
        return Ok(Outcome::SomeFailed);
    };
    let framed = (args.tracing.pois).frame_checked(&mut loaded.model, pois, "sun-hours")?;
    let (lat, lon) = args.site.resolve(framed.source, "sun-hours")?;
    let site = Site::new(lat, lon).with_time_zone(&args.timezone)?;
    let t = Instant::now();
    let table = SunTable::year_with(args.sun.year, args.sun.step, &site, &crate::log::reporter())?;
    let sun_ms = ms(t);
    let traced = skylod::pipeline::sun_hours(&framed, &table, &crate::log::reporter())?;
    warn_flags(&framed.pois, &traced.flags);
    let (bvh_ms, trace_ms) = (s_to_ms(traced.bvh_s), s_to_ms(traced.trace_s));
    let pois = &framed.pois;
    let rows = traced.rows(pois, SunHoursPoi::new);
    let mut out = std::io::stdout().lock();
    if args.json {
        let doc = SunHoursOutput::new(
            rows,
            SunSetting::new(lat, lon, args.sun.year, args.sun.step),
            args.timezone.clone(),
            table.len(),
            loaded.inputs.clone(),
            polygons(framed.source),
            SunHoursTimings {
                read: loaded.read_ms,
                sun: sun_ms,
                bvh: bvh_ms,
                trace: trace_ms,
            },
        );
        out_err(writeln!(out, "{}", serde_json::to_string_pretty(&doc)?))?;
    } else {
        let header = crate::args::shard::header(shard);
        out_err(write_table(&mut out, &rows, header))?;
        crate::log::summary!(
            "{} POI(s); {} steps of {} min in {} at ({lat}, {lon}), months in {}; {} from {} input(s); read {:.0} ms, sun {:.0} ms, bvh {:.0} ms, trace {:.0} ms",
            pois.len(),
            table.len(),
            args.sun.step,
            args.sun.year,
            args.timezone,
            crate::commands::polygons_traced(framed.source),
            loaded.inputs.len(),
            loaded.read_ms,
            sun_ms,
            bvh_ms,
            trace_ms
        );
    }
    Ok(loaded.outcome())
}
