//! `skylod sun-hours`.

use crate::args::site::SiteArgs;
use crate::args::sun::SunArgs;
use crate::commands::{emit, ms, polygons};
use crate::Outcome;
use skylod::output::sun_hours::{SunHoursOutput, SunHoursPoi, SunHoursTimings, SunSetting};
use skylod::session::SunOptions;
use skylod::solar::Site;
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
    let Some(s) = args.tracing.study("sun-hours", |_| Ok(()))? else {
        return Ok(Outcome::SomeFailed);
    };
    let (lat, lon) = args.site.resolve(s.study.source(), "sun-hours")?;
    let site = Site::new(lat, lon).with_time_zone(&args.timezone)?;
    let sun = SunOptions::new(Some(site), args.sun.year, args.sun.step);
    let t = Instant::now();
    let table = s.study.sun_table_with(&sun, &crate::log::reporter())?;
    let sun_ms = ms(t);
    let traced = s.study.sun_hours(&sun, &crate::log::reporter())?;
    s.warn_flags(&traced.flags);
    let timings = SunHoursTimings::new(s.timings(&traced), sun_ms);
    let doc = SunHoursOutput::new(
        traced.rows(s.study.pois(), SunHoursPoi::new),
        SunSetting::new(lat, lon, args.sun.year, args.sun.step),
        args.timezone.clone(),
        table.len(),
        s.inputs.clone(),
        polygons(s.study.source()),
        timings,
    );
    emit(&doc, args.json, &s.text())?;
    Ok(s.outcome())
}
