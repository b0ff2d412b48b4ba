//! `skylod irradiance`.

use crate::args::site::SiteArgs;
use crate::args::weather::weather_site;
use crate::commands::{emit, ms, polygons};
use crate::Outcome;
use anyhow::{bail, Context};
use skylod::output::irradiance::{
    write_csv, write_hourly_csv, IrradianceOutput, IrradiancePoi, IrradianceTimings,
};
use skylod::session::weather::weather_summary;
use skylod::solar::irradiance::{IrradianceOptions, IrradianceTable, SkyModel};
use skylod::solar::weather::read_weather;
use skylod::solar::{Site, SkyBundles};
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
    /// Diffuse sky model: perez (Perez 1990 anisotropic) or isotropic.
    #[arg(long, value_enum, default_value = "perez")]
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
    args.site.check_given("irradiance")?;
    if !(0.0..=1.0).contains(&args.albedo) {
        bail!("--albedo must be in 0..1 (got {})", args.albedo);
    }
    if let Some(h) = &args.hourly {
        skylod::io::check_target(h, [], args.overwrite)?;
    }
    let region = args.tracing.region.active();
    args.attributes.check(region, args.overwrite)?;
    let t = Instant::now();
    let weather = read_weather(&args.weather)?;
    let weather_ms = ms(t);
    let bundles = SkyBundles::new(args.rays, args.seed)?;
    let Some(s) = args.tracing.study("irradiance", |_| Ok(()))? else {
        return Ok(Outcome::SomeFailed);
    };
    let (lat, lon) = weather_site(&args.site, s.study.source(), &weather, "irradiance")?;
    let (sky, albedo) = (args.sky, args.albedo);
    let opts = IrradianceOptions { sky, albedo };
    let t = Instant::now();
    let table = IrradianceTable::new(&weather, &Site::new(lat, lon), sky)?;
    let sun_ms = weather_ms + ms(t);
    let traced = s.study.irradiance(
        &bundles,
        &table,
        &opts,
        args.hourly.is_some(),
        &crate::log::reporter(),
    )?;
    s.warn_flags(&traced.flags);
    let pois = s.study.pois();
    let rows = traced.rows(pois, |p, r, f| IrradiancePoi::new(p, &r.annual, f));
    let values: Vec<f64> = traced
        .results
        .iter()
        .map(|r| r.annual.global_kwh_m2)
        .collect();
    if let Some(n) = args
        .attributes
        .write(&s.study.framed(), &values, args.overwrite)?
    {
        crate::log::summary!("irradiance: {n} surface(s) given skylodAnnualIrradiation");
    }
    if let Some(path) = &args.hourly {
        let ids: Vec<&str> = pois.iter().map(|p| p.id.as_str()).collect();
        let series: Vec<&[f64]> = traced.results.iter().map(|r| r.hourly.as_slice()).collect();
        skylod::io::atomic_write(path, |w: &mut dyn Write| -> anyhow::Result<u64> {
            write_hourly_csv(w, &weather, &ids, &series)?;
            Ok(0)
        })
        .with_context(|| format!("writing {}", path.display()))?;
    }
    let summary = weather_summary(&args.weather, &weather);
    let timings = IrradianceTimings::new(s.timings(&traced), sun_ms);
    let doc = IrradianceOutput::new(
        rows,
        summary,
        [lat, lon],
        sky,
        args.albedo,
        args.rays,
        s.inputs.clone(),
        polygons(s.study.source()),
        timings,
    );
    if args.csv {
        write_csv(std::io::stdout().lock(), &doc.pois).context("writing to stdout")?;
    } else {
        emit(&doc, args.json, &s.text())?;
    }
    Ok(s.outcome())
}
