//! `skylod`: the command-line front end. The library does the work; this binary owns the
//! terminal, the exit codes (0 ok, 1 some inputs failed, 2 usage or fatal, 143 / 129 stopped
//! by SIGTERM / SIGHUP) and progress.

use crate::flags::cli_text;
use clap::{Parser, Subcommand};
use skylod::io::{chain_message, is_broken_pipe};
use std::process::ExitCode;

mod args;
mod commands;
mod flags;
mod inputs;
mod log;
mod outputs;

/// Skyline-controlled mixed level-of-detail CityGML for solar analysis.
#[derive(Parser, Debug)]
#[command(name = "skylod", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// `--quiet`, `--log-level` (global: after any subcommand too).
    #[command(flatten)]
    log: log::LogArgs,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Count buildings, surfaces, installations, openings and polygons per file and in total.
    Stats(commands::stats::Args),
    /// Read a CityGML file and write it back (identity of the pipeline; envelopes recomputed).
    Convert(commands::convert::Args),
    /// Write the rough model (every asset generalised: planes, boxes) as CityGML.
    Rough(commands::rough::Args),
    /// Generate a procedural Barcelona-Eixample LoD3 district (CityGML 2.0) and facade POIs.
    Synth(commands::synth::Args),
    /// Skyline-controlled mixed-LoD CityGML for a set of POIs (rough model, sky bundle, BVH, silhouette selection).
    Lod(commands::lod::Args),
    /// SVF and sun hours on the full, the LoD and the all-boxes model per POI (paper Tables 1-2).
    Evaluate(commands::evaluate::Args),
    /// Sky view factor and sky exposure of points of interest against the full model.
    Svf(commands::svf::Args),
    /// Direct-sun hours per year and per month of points of interest.
    SunHours(commands::sun_hours::Args),
    /// Annual irradiation (kWh/m²) on the plane of points from EPW or TMY3 weather (direct, diffuse, reflected).
    Irradiance(commands::irradiance::Args),
    /// Fisheye picture (SVG) of the sky hemisphere seen from a point, with sun paths.
    Fisheye(commands::fisheye::Args),
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell).
    Completions(commands::completions::CompletionArgs),
    /// Print the manual page (roff; `skylod man | man -l -`).
    Man(commands::completions::ManArgs),
    /// Horizon profile (skyline elevation per azimuth) of points, as CSV or JSON (PVGIS/pvlib).
    Horizon(commands::horizon::Args),
    /// Transform every coordinate into another CRS through PROJ (needs the cargo feature `proj`).
    Reproject(commands::reproject::Args),
    /// Keep the city objects that match a box, ids or types (streamed).
    Subset(commands::subset::Args),
    /// Keep or remove LoD representations of city objects (streamed).
    FilterLods(commands::filter_lods::Args),
    /// Upgrade CityGML 1.0 / 2.0 to CityGML 3.0 (streamed).
    Upgrade(commands::upgrade::Args),
}

/// Outcome of a command: success, some inputs failed (exit 1), or fatal (exit 2).
pub enum Outcome {
    Ok,
    SomeFailed,
}

impl Outcome {
    /// Some inputs failed when `failed`, else all went well.
    pub fn failed_if(failed: bool) -> Outcome {
        if failed {
            Outcome::SomeFailed
        } else {
            Outcome::Ok
        }
    }
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
    log::init(&cli.log);
    log::on_interrupt();
    let result = match cli.command {
        Command::Stats(a) => commands::stats::run(a),
        Command::Convert(a) => commands::convert::run(a),
        Command::Rough(a) => commands::rough::run(a),
        Command::Synth(a) => commands::synth::run(a),
        Command::Lod(a) => commands::lod::run(a),
        Command::Evaluate(a) => commands::evaluate::run(a),
        Command::Svf(a) => commands::svf::run(a),
        Command::SunHours(a) => commands::sun_hours::run(a),
        Command::Irradiance(a) => commands::irradiance::run(a),
        Command::Fisheye(a) => commands::fisheye::run(a),
        Command::Completions(a) => commands::completions::completions(a),
        Command::Man(a) => commands::completions::man(a),
        Command::Horizon(a) => commands::horizon::run(a),
        Command::Reproject(a) => commands::reproject::run(a),
        Command::Subset(a) => commands::subset::run(a),
        Command::FilterLods(a) => commands::filter_lods::run(a),
        Command::Upgrade(a) => commands::upgrade::run(a),
    };
    // SIGTERM or SIGHUP: the command stopped at its next file or POI (or had finished);
    // every output in place is complete. The exit code says which signal (143, 129).
    if let Some(code) = log::signal_exit_code() {
        if let Err(e) = &result {
            log::line(log::Level::Error, &format!("skylod: error: {}", message(e)));
        }
        return ExitCode::from(code);
    }
    match result {
        Ok(Outcome::Ok) => ExitCode::SUCCESS,
        Ok(Outcome::SomeFailed) => ExitCode::from(1),
        // The reader of our standard output went away (`skylod stats … | head`): nothing
        // is wrong with the work, so end quietly and successfully, as ripgrep does.
        Err(e) if is_broken_pipe(e.as_ref()) => ExitCode::SUCCESS,
        Err(e) => {
            let text = format!("skylod: error: {}", message(&e));
            log::line(log::Level::Error, &text);
            ExitCode::from(2)
        }
    }
}

/// The error and its causes joined by ": ", each thing said once, in the CLI's words
/// ([`skylod::io::chain_message`], [`crate::flags::cli_text`]).
fn message(e: &anyhow::Error) -> String {
    chain_message(e.as_ref(), cli_text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arguments_are_consistent() {
        use clap::CommandFactory;
        Cli::command().debug_assert();
    }
}
