//! `skylod horizon`: horizon profiles of POIs (PVGIS / pvlib convention) as CSV or JSON.

use crate::commands::{out_err, polygons, s_to_ms};
use crate::Outcome;
use anyhow::Context;
use skylod::citygml::write::{atomic_write_bytes, check_target, WriteOptions};
use skylod::output::horizon::{round_deg, write_csv, HorizonOutput, HorizonPoi};
use skylod::output::svf::TraceTimings;
use skylod::solar::HorizonOptions;
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    tracing: crate::args::tracing::TracingArgs,
    /// Azimuth step in degrees (0.01..=90); azimuths 0, step, 2 step, ... below 360.
    #[arg(long, default_value_t = 1.0)]
    step: f64,
    /// Output file (CSV `id,azimuth,elevation`, or JSON with --json); default: stdout.
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// JSON `{"pois":[{"id","poi","azimuth":[...],"elevation":[...]}],...}` instead of CSV.
    #[arg(long)]
    json: bool,
    /// Replace an existing output file.
    #[arg(long)]
    overwrite: bool,
}

pub fn run(mut args: Args) -> anyhow::Result<Outcome> {
    let opts = HorizonOptions::default().with_step(args.step);
    opts.validate().context("--step")?;
    let (output, overwrite) = (args.output.clone(), args.overwrite);
    let Some(s) = args.tracing.study("horizon", |poi_args| {
        if let Some(out) = &output {
            let w = WriteOptions {
                overwrite,
                ..Default::default()
            };
            check_target(out, &w, poi_args.inputs.iter().map(|p| p.as_path()))
                .with_context(|| format!("output {}", out.display()))?;
        }
        Ok(())
    })?
    else {
        return Ok(Outcome::SomeFailed);
    };
    // Traced in the local metric frame (y = north): azimuths are from north there.
    let traced = s.study.horizon(&opts, &crate::log::reporter())?;
    s.warn_flags(&traced.flags);
    let (bvh_ms, trace_ms) = (s_to_ms(traced.bvh_s), s_to_ms(traced.trace_s));
    let pois = s.study.pois();
    let rows = traced.rows(pois, |p, h, flags| {
        HorizonPoi::new(
            p,
            h.azimuth.iter().map(|a| round_deg(*a)).collect(),
            h.elevation.iter().map(|e| round_deg(*e)).collect(),
            flags,
        )
        .with_overhang(h.overhang.iter().map(|o| o.map(round_deg)).collect())
    });
    let profiles = traced.results;
    let text = if args.json {
        let doc = HorizonOutput::new(
            rows,
            args.step,
            opts.tolerance_deg,
            s.inputs.clone(),
            polygons(s.study.source()),
            TraceTimings {
                read: s.read_ms,
                bvh: bvh_ms,
                trace: trace_ms,
            },
        );
        serde_json::to_string_pretty(&doc)? + "\n"
    } else {
        // Shards after the first leave out the header line: concatenated in shard order,
        // the shards' files are the serial run's.
        write_csv(&rows, s.header())
    };
    match &args.output {
        Some(out) => {
            atomic_write_bytes(out, text.as_bytes())
                .with_context(|| format!("writing {}", out.display()))?;
        }
        None => out_err(std::io::stdout().lock().write_all(text.as_bytes()))?,
    }
    for (p, h) in pois.iter().zip(&profiles) {
        let (mut max, mut at) = (0.0, 0.0);
        for (a, e) in h.azimuth.iter().zip(&h.elevation) {
            if *e > max {
                (max, at) = (*e, *a);
            }
        }
        let mean = h.elevation.iter().sum::<f64>() / h.elevation.len().max(1) as f64;
        crate::log::summary!(
            "{}: mean elevation {mean:.2}°, highest {max:.2}° at azimuth {at}°",
            p.id
        );
    }
    crate::log::summary!(
        "{} POI(s), {} azimuths each (step {}°); {} from {} input(s); read {:.0} ms, bvh {:.0} ms, trace {:.0} ms",
        pois.len(),
        opts.azimuths().len(),
        args.step,
        crate::commands::polygons_traced(s.study.source()),
        s.inputs.len(),
        s.read_ms,
        bvh_ms,
        trace_ms
    );
    Ok(s.outcome())
}
