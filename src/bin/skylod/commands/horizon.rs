//! `skylod horizon`: horizon profiles of POIs (PVGIS / pvlib convention) as CSV or JSON.

use crate::commands::out_err;
use crate::Outcome;
use anyhow::Context;
use skylod::export::report::Document;
use skylod::io::citygml::{atomic_write_bytes, check_target, WriteOptions};
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
    let a = s.study.horizon_output(&opts, &crate::log::reporter())?;
    s.warn_flags(&a.flags);
    let (cx, mut text) = (s.text(), Vec::new());
    if args.json {
        text = (serde_json::to_string_pretty(&a.doc)? + "\n").into_bytes();
    } else {
        // Shards after the first leave out the header line: concatenated in shard order,
        // the shards' files are the serial run's.
        a.doc.write_table(&mut text, &cx)?;
    }
    match &args.output {
        Some(out) => {
            atomic_write_bytes(out, &text).with_context(|| format!("writing {}", out.display()))?;
        }
        None => out_err(std::io::stdout().lock().write_all(&text))?,
    }
    for line in a.summary.iter().chain(&a.doc.summary(&cx)) {
        crate::log::summary!("{line}");
    }
    Ok(s.outcome())
}
