//! `skylod sun-hours`.

use crate::args::sun::SunArgs;
use crate::commands::emit;
use crate::Outcome;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    on: crate::args::tracing::SunTracingArgs,
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
    let Some(s) = args.on.study("sun-hours")? else {
        return Ok(Outcome::SomeFailed);
    };
    let site = args.on.site.resolve(s.study.source(), "sun-hours")?;
    let (year, tz, progress) = (
        (args.sun.year, args.sun.step),
        &args.timezone,
        crate::log::reporter(),
    );
    let a = s.study.sun_hours_output(site, year, tz, &progress)?;
    s.warn_flags(&a.flags);
    emit(&a.doc, args.json, &s.text())?;
    Ok(s.outcome())
}
