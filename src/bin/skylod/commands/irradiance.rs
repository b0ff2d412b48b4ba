//! `skylod irradiance`.

use crate::args::site::SiteArgs;
use crate::args::tracing::Prepared;
use crate::args::weather::weather_site;
use crate::commands::{ms, out_err, polygons, s_to_ms, warn_flags};
use crate::Outcome;
use anyhow::{bail, Context};
use skylod::output::irradiance::{
    write_csv, write_hourly_csv, write_table, IrradianceOutput, IrradiancePoi, IrradianceTimings,
    WeatherSummary,
};
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
    let Some(Prepared {
        mut loaded,
        pois,
        shard,
        ..
    }) = args.tracing.prepare("irradiance", |_| Ok(()))?
    else {
        return Ok(Outcome::SomeFailed);
    };
    let framed = (args.tracing.pois).frame_checked(&mut loaded.model, pois, "irradiance")?;
    let (lat, lon) = weather_site(&args.site, framed.source, &weather, "irradiance")?;
    let (sky, albedo) = (args.sky, args.albedo);
    let opts = IrradianceOptions { sky, albedo };
    let t = Instant::now();
    let table = IrradianceTable::new(&weather, &Site::new(lat, lon), sky)?;
    let sun_ms = weather_ms + ms(t);
    let traced = skylod::pipeline::irradiance(
        &framed,
        &bundles,
        &table,
        &opts,
        args.hourly.is_some(),
        &crate::log::reporter(),
    )?;
    warn_flags(&framed.pois, &traced.flags);
    let pois = &framed.pois;
    let rows = traced.rows(pois, |p, r, f| IrradiancePoi::new(p, &r.annual, f));
    let values: Vec<f64> = traced
        .results
        .iter()
        .map(|r| r.annual.global_kwh_m2)
        .collect();
    if let Some(n) = args.attributes.write(&framed, &values, args.overwrite)? {
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
    let summary = WeatherSummary::new(
        args.weather.display().to_string(),
        weather.format,
        &weather.site,
        weather.hours.len(),
        weather.totals_kwh_m2(),
    );
    let timings = IrradianceTimings {
        read: loaded.read_ms,
        sun: sun_ms,
        bvh: s_to_ms(traced.bvh_s),
        trace: s_to_ms(traced.trace_s),
    };
    let mut out = std::io::stdout().lock();
    if args.json {
        let doc = IrradianceOutput::new(
            rows,
            summary,
            [lat, lon],
            sky,
            args.albedo,
            args.rays,
            loaded.inputs.clone(),
            polygons(framed.source),
            timings,
        );
        out_err(writeln!(out, "{}", serde_json::to_string_pretty(&doc)?))?;
    } else if args.csv {
        write_csv(&mut out, &rows).context("writing to stdout")?;
    } else {
        out_err(write_table(
            &mut out,
            &rows,
            crate::args::shard::header(shard),
        ))?;
        crate::log::summary!(
            "{} POI(s); {} hours of {} ({}, GHI {:.0} kWh/m²) at ({lat:.4}, {lon:.4}), {sky:?} sky, albedo {}; {} from {} input(s); read {:.0} ms, weather and sun {:.0} ms, bvh {:.0} ms, trace {:.0} ms",
            pois.len(),
            weather.hours.len(),
            summary.station,
            summary.format,
            summary.ghi_kwh_m2,
            args.albedo,
            crate::commands::polygons_traced(framed.source),
            loaded.inputs.len(),
            timings.read,
            timings.sun,
            timings.bvh,
            timings.trace
        );
    }
    Ok(loaded.outcome())
}
