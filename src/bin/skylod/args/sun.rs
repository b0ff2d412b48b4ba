//! `--year`, `--step`: the simulated year of the sun.

use skylod::solar::{DEFAULT_STEP_MIN, DEFAULT_YEAR};

/// The simulated year of the sun (`sun-hours`, `evaluate`, `lod --max-sun-hours-error`).
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct SunArgs {
    /// Calendar year (UTC) simulated.
    #[arg(long, default_value_t = DEFAULT_YEAR)]
    pub year: i32,
    /// Time step in minutes (the sun is evaluated at the middle of each step).
    #[arg(long, default_value_t = DEFAULT_STEP_MIN)]
    pub step: u32,
}
