//! `skylod evaluate`: full vs LoD vs all-boxes model, the paper's Tables 1 and 2.

use crate::args::rough::RoughArgs;
use crate::args::select::SelectArgs;
use crate::args::site::SiteArgs;
use crate::args::sun::SunArgs;
use crate::commands::{ms, out_err};
use crate::Outcome;
use skylod::lod::LodOptions;
use skylod::output::evaluate::{EvaluateOutput, EvaluateTimings, EvaluateWeather};
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
    #[command(flatten)]
    weather: crate::args::weather::WeatherArgs,
}

pub fn run(mut args: Args) -> anyhow::Result<Outcome> {
    args.site.check("evaluate")?;
    args.weather.check()?;
    let rough_opts = args.rough.options()?;
    let t_all = Instant::now();
    let Some(s) = args.tracing.study("evaluate", |_| Ok(()))? else {
        return Ok(Outcome::SomeFailed);
    };
    let site = if args.no_sun {
        None
    } else {
        let (lat, lon) = args
            .site
            .resolve(s.study.source(), "evaluate (or give --no-sun)")?;
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
        irradiance: None,
    };
    let year = (args.weather).year(&args.site, s.study.source(), "evaluate --weather")?;
    let opts = EvaluateOptions {
        irradiance: year.as_ref().map(|y| y.setting.clone()),
        ..opts
    };
    let e = s.study.evaluate(&opts, &crate::log::reporter())?;
    let flags: Vec<_> = e.pois.iter().map(|p| p.flags.clone()).collect();
    s.warn_flags(&flags);
    let mut out = std::io::stdout().lock();
    if args.json {
        let doc = EvaluateOutput::new(
            s.inputs.clone(),
            args.select.rays,
            args.svf_rays,
            args.select.seed,
            site.map(|s| SunSetting::new(s.latitude, s.longitude, args.sun.year, args.sun.step)),
            e.pois.clone(),
            EvaluateTimings {
                read: s.read_ms,
                rough: e.rough_ms,
                selection_bvh: e.selection_bvh_ms,
                total: ms(t_all),
            },
        );
        let doc = match &year {
            Some(y) => doc.with_weather(EvaluateWeather {
                weather: y.summary.clone(),
                sky: y.sky(),
                albedo: y.setting.opts.albedo,
                site: y.site,
            }),
            None => doc,
        };
        out_err(writeln!(out, "{}", serde_json::to_string_pretty(&doc)?))?;
    } else {
        out_err(skylod::output::evaluate::write_table(
            &mut out,
            &e.pois,
            s.header(),
        ))?;
        crate::log::summary!(
            "{} POI(s); selection {} rays, SVF {} rays; read {:.0} ms, rough {:.0} ms (shared), selection BVH {:.0} ms (shared), total {:.0} ms",
            e.pois.len(),
            args.select.rays,
            args.svf_rays,
            s.read_ms,
            e.rough_ms,
            e.selection_bvh_ms,
            ms(t_all)
        );
        if let Some(y) = &year {
            crate::log::summary!(
                "irradiance: {} hours of {} (GHI {:.0} kWh/m²) at ({:.4}, {:.4}), {:?} sky, albedo {}; largest LoD error {}",
                y.setting.table.len(),
                y.summary.station,
                y.summary.ghi_kwh_m2,
                y.site[0],
                y.site[1],
                y.setting.opts.sky,
                y.setting.opts.albedo,
                largest_irradiance_error(&e.pois)
            );
        }
    }
    Ok(s.outcome())
}

/// The largest relative irradiance error of the LoD model over the POIs, as a percentage.
fn largest_irradiance_error(pois: &[skylod::pipeline::evaluation::PoiEval]) -> String {
    let e = pois
        .iter()
        .filter_map(|p| p.lod_irradiance_error)
        .fold(0.0, f64::max);
    format!("{:.3}%", 100.0 * e)
}
