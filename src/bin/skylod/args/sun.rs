//! `--year`, `--step`: the simulated year of the sun.

/// Default year of `--year`: a fixed year so that results are reproducible.
pub const DEFAULT_YEAR: i32 = 2025;

/// The simulated year of the sun (`sun-hours`, `evaluate`, `lod --max-sun-hours-error`).
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct SunArgs {
    /// Calendar year (UTC) simulated.
    #[arg(long, default_value_t = DEFAULT_YEAR)]
    pub year: i32,
    /// Time step in minutes (the sun is evaluated at the middle of each step).
    #[arg(long, default_value_t = 15)]
    pub step: u32,
}
