//! `skylod`: the command-line front end. The library does the work; this binary owns the
//! terminal, the exit codes (0 ok, 1 some inputs failed, 2 usage or fatal) and progress.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod cmd_convert;
mod cmd_evaluate;
mod cmd_fisheye;
mod cmd_horizon;
mod cmd_lod;
mod cmd_reproject;
mod cmd_rough;
mod cmd_stats;
mod cmd_sun_hours;
mod cmd_svf;
mod cmd_synth;
mod common;

/// Skyline-controlled mixed level-of-detail CityGML for solar analysis.
#[derive(Parser, Debug)]
#[command(name = "skylod", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Count buildings, surfaces, installations, openings and polygons per file and in total.
    Stats(cmd_stats::Args),
    /// Read a CityGML file and write it back (identity of the pipeline; envelopes recomputed).
    Convert(cmd_convert::Args),
    /// Write the rough model (every asset generalised: planes, boxes) as CityGML.
    Rough(cmd_rough::Args),
    /// Generate a procedural Barcelona-Eixample LoD3 district (CityGML 2.0) and facade POIs.
    Synth(cmd_synth::Args),
    /// Skyline-controlled mixed-LoD CityGML for a set of POIs (rough model, sky bundle, BVH, silhouette selection).
    Lod(cmd_lod::Args),
    /// SVF and sun hours on the full, the LoD and the all-boxes model per POI (paper Tables 1-2).
    Evaluate(cmd_evaluate::Args),
    /// Sky view factor and sky exposure of points of interest against the full model.
    Svf(cmd_svf::Args),
    /// Direct-sun hours per year and per month of points of interest.
    SunHours(cmd_sun_hours::Args),
    /// Fisheye picture (SVG) of the sky hemisphere seen from a point, with sun paths.
    Fisheye(cmd_fisheye::Args),
    /// Horizon profile (skyline elevation per azimuth) of points, as CSV or JSON (PVGIS/pvlib).
    Horizon(cmd_horizon::Args),
    /// Transform every coordinate into another CRS through PROJ (needs the cargo feature `proj`).
    Reproject(cmd_reproject::Args),
}

/// Outcome of a command: success, some inputs failed (exit 1), or fatal (exit 2).
pub enum Outcome {
    Ok,
    SomeFailed,
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return match e.kind() {
                clap::error::ErrorKind::DisplayHelp | clap::error::ErrorKind::DisplayVersion => {
                    ExitCode::SUCCESS
                }
                _ => ExitCode::from(2),
            };
        }
    };
    let result = match cli.command {
        Command::Stats(a) => cmd_stats::run(a),
        Command::Convert(a) => cmd_convert::run(a),
        Command::Rough(a) => cmd_rough::run(a),
        Command::Synth(a) => cmd_synth::run(a),
        Command::Lod(a) => cmd_lod::run(a),
        Command::Evaluate(a) => cmd_evaluate::run(a),
        Command::Svf(a) => cmd_svf::run(a),
        Command::SunHours(a) => cmd_sun_hours::run(a),
        Command::Fisheye(a) => cmd_fisheye::run(a),
        Command::Horizon(a) => cmd_horizon::run(a),
        Command::Reproject(a) => cmd_reproject::run(a),
    };
    match result {
        Ok(Outcome::Ok) => ExitCode::SUCCESS,
        Ok(Outcome::SomeFailed) => ExitCode::from(1),
        Err(e) => {
            eprintln!("skylod: error: {e:#}");
            ExitCode::from(2)
        }
    }
}
