//! `skylod irradiance`.

use crate::args::site::SiteArgs;
use crate::args::weather::weather_site;
use crate::commands::emit;
use crate::Outcome;
use anyhow::Context;
use skylod::export::report::{
    surface_rows, write_csv, write_point_table, write_surface_table, Document, TableLayout,
};
use skylod::lod::poi::cadastre_surfaces;
use skylod::model::crs::CrsKind;
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
    /// With --surfaces: write one row per roof or wall surface to this CSV file (area,
    /// points, mean, least and greatest kWh/m², the building's roof total in kWh/year).
    #[arg(long, value_name = "FILE")]
    table: Option<PathBuf>,
    /// With --surfaces: write every sample point (surface, position and normal in the
    /// model's CRS, global, direct, diffuse and reflected kWh/m²) to this CSV file.
    #[arg(long, value_name = "FILE")]
    points: Option<PathBuf>,
    /// With --table: add each surface's area whose points reach KWH kWh/m² a year.
    #[arg(long, value_name = "KWH", requires = "table")]
    threshold: Option<f64>,
    /// With --table or --points: add twelve columns, the global kWh/m² of each month of the
    /// weather's local time.
    #[arg(long)]
    monthly: bool,
}

pub fn run(mut args: Args) -> anyhow::Result<Outcome> {
    args.site.check("irradiance", true)?;
    crate::args::weather::albedo(args.albedo)?;
    for f in [&args.hourly, &args.table, &args.points]
        .into_iter()
        .flatten()
    {
        skylod::io::check_target(f, [], args.overwrite)?;
    }
    let surfaces = args.tracing.region.surfaces().to_vec();
    if args.monthly && args.table.is_none() && args.points.is_none() {
        anyhow::bail!("--monthly adds columns to --table and --points: give one of them");
    }
    if surfaces.is_empty() && (args.table.is_some() || args.points.is_some()) {
        anyhow::bail!("--table and --points list the surfaces of --surfaces: give --surfaces roof,wall (or one of them)");
    }
    let region = args.tracing.region.active();
    args.attributes.check(region, args.overwrite)?;
    let t = Instant::now();
    let weather = read_weather(&args.weather)?;
    if !surfaces.is_empty() {
        // a cadastre's figures are annual
        weather.check_year(&args.weather.display().to_string())?;
    }
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
        cadastre: !surfaces.is_empty(),
        // a cadastre's tables are its answer: the POI rows only when printed
        rows: args.csv || args.json || (args.table.is_none() && args.points.is_none()),
    };
    let run = s.study.irradiance_output(&req, &crate::log::reporter())?;
    s.warn_flags(&run.doc.flags);
    let values = run.annual_global();
    if let Some(n) = (args.attributes).write(&s.study.framed(), &values, args.overwrite)? {
        crate::log::summary!("irradiance: {n} surface(s) given skylodAnnualIrradiation");
    }
    let annual = &run.traced.results;
    let degrees = matches!(s.study.crs().kind, CrsKind::Geographic { .. });
    let layout = TableLayout {
        degrees,
        threshold: args.threshold,
        monthly: args.monthly,
        header: s.header(),
    };
    if let Some(path) = &args.table {
        // areas in metres: the model in its tracing frame (same surfaces as the source's)
        let mut list = cadastre_surfaces(s.study.local_model(), &surfaces);
        if let Some(r) = (args.tracing.region).surface_shard(s.study.source(), s.shard) {
            list = list.get(r).map(<[_]>::to_vec).unwrap_or_default();
        }
        let rows = surface_rows(&list, s.study.pois(), annual, args.threshold, args.monthly);
        skylod::io::atomic_write(path, |w: &mut dyn Write| -> anyhow::Result<u64> {
            write_surface_table(w, &rows, layout)?;
            Ok(0)
        })
        .with_context(|| format!("writing {}", path.display()))?;
        let sampled = rows.iter().filter(|r| r.points > 0).count();
        crate::log::summary!(
            "irradiance: {} surface(s) in {}, {sampled} with points",
            rows.len(),
            path.display()
        );
    }
    if let Some(path) = &args.points {
        skylod::io::atomic_write(path, |w: &mut dyn Write| -> anyhow::Result<u64> {
            write_point_table(w, s.study.pois(), annual, layout)?;
            Ok(0)
        })
        .with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = &args.hourly {
        skylod::io::atomic_write(path, |w: &mut dyn Write| -> anyhow::Result<u64> {
            run.write_hourly(w, &weather, s.study.pois())?;
            Ok(0)
        })
        .with_context(|| format!("writing {}", path.display()))?;
    }
    let tables = args.table.is_some() || args.points.is_some();
    if args.csv {
        write_csv(std::io::stdout().lock(), &run.doc.doc.pois).context("writing to stdout")?;
    } else if args.json || !tables {
        emit(&run.doc.doc, args.json, &s.text())?;
    } else {
        for line in run.doc.doc.summary(&s.text()) {
            crate::log::summary!("{line}");
        }
    }
    Ok(s.outcome())
}
