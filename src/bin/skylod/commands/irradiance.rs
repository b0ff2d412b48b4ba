//! `skylod irradiance`.

use crate::args::site::SiteArgs;
use crate::args::weather::weather_site;
use crate::commands::emit;
use crate::Outcome;
use anyhow::Context;
use skylod::export::report::write_csv;
use skylod::pipeline::session::ms_since;
use skylod::pipeline::session::IrradianceRequest;
use skylod::solar::irradiance::SkyModel;
use skylod::solar::read_weather;
use skylod::solar::SkyBundles;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    tracing: crate::args::tracing::TracingArgs,
    /// Hourly weather: EnergyPlus EPW or NREL TMY3 CSV (told by content).
    #[arg(long, value_name = "FILE")]
    weather: PathBuf,
    #[command(flatten)]
    site: SiteArgs,
    /// Diffuse sky model: all-weather (the Perez all-weather sky by daylight coefficients, as
    /// Radiance), perez (the Perez 1990 transposition, as pvlib on open planes) or isotropic.
    #[arg(long, value_enum, default_value = "all-weather")]
    sky: SkyModel,
    /// Reflectance of the ground and obstructions (0 turns reflection off).
    #[arg(long, default_value_t = 0.2)]
    albedo: f64,
    /// Rays per sky bundle.
    #[arg(long, default_value_t = 10_000)]
    rays: usize,
    /// Seed of the ray jitter inside each cell.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print JSON instead of a table.
    #[arg(long, conflicts_with = "csv")]
    json: bool,
    /// Print CSV (one row per POI) instead of a table.
    #[arg(long)]
    csv: bool,
    /// Also write every hour's global irradiation (Wh/m²) per POI to this CSV file.
    #[arg(long, value_name = "FILE")]
    hourly: Option<PathBuf>,
    /// Overwrite the --hourly (or -o) file if it exists.
    #[arg(long)]
    overwrite: bool,
    #[command(flatten)]
    attributes: crate::args::attributes::AttributeArgs,
}

pub fn run(mut args: Args) -> anyhow::Result<Outcome> {
    args.site.check("irradiance", true)?;
    crate::args::weather::albedo(args.albedo)?;
    if let Some(h) = &args.hourly {
        skylod::io::check_target(h, [], args.overwrite)?;
    }
    let region = args.tracing.region.active();
    args.attributes.check(region, args.overwrite)?;
    let t = Instant::now();
    let weather = read_weather(&args.weather)?;
    let weather_ms = ms_since(t);
    let bundles = SkyBundles::new(args.rays, args.seed)?;
    let Some(s) = args.tracing.study("irradiance", |_| Ok(()))? else {
        return Ok(Outcome::SomeFailed);
    };
    let (lat, lon) = weather_site(&args.site, s.study.source(), &weather, "irradiance")?;
    let req = IrradianceRequest {
        path: &args.weather,
        weather: &weather,
        weather_ms,
        site: [lat, lon],
        sky: args.sky,
        albedo: args.albedo,
        bundles: &bundles,
        rays: args.rays,
        hourly: args.hourly.is_some(),
    };
    let run = s.study.irradiance_output(&req, &crate::log::reporter())?;
    s.warn_flags(&run.doc.flags);
    let values = run.annual_global();
    if let Some(n) = (args.attributes).write(&s.study.framed(), &values, args.overwrite)? {
        crate::log::summary!("irradiance: {n} surface(s) given skylodAnnualIrradiation");
    }
    if let Some(path) = &args.hourly {
        skylod::io::atomic_write(path, |w: &mut dyn Write| -> anyhow::Result<u64> {
            run.write_hourly(w, &weather)?;
            Ok(0)
        })
        .with_context(|| format!("writing {}", path.display()))?;
    }
    if args.csv {
        write_csv(std::io::stdout().lock(), &run.doc.doc.pois).context("writing to stdout")?;
    } else {
        emit(&run.doc.doc, args.json, &s.text())?;
    }
    Ok(s.outcome())
}
