//! `--rays`, `--seed` and the silhouette test (`--threshold`, `--roof-tolerance`): the
//! selection.

use super::{non_negative, positive};
use skylod::lod::SelectOptions;

/// The silhouette test of the selection (`lod`, `evaluate`, `fisheye --colour-by level`).
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct SilhouetteArgs {
    /// Silhouette threshold in degrees (default: 1.5 x the cell's angular size).
    #[arg(long, value_name = "DEG", value_parser = positive, allow_hyphen_values = true)]
    pub threshold: Option<f64>,
    /// How far (m) below the lowest roof edge an installation may start and still count as
    /// standing on the roof.
    #[arg(long, default_value_t = SelectOptions::default().roof_tolerance_m, value_name = "M", value_parser = non_negative, allow_hyphen_values = true)]
    pub roof_tolerance: f64,
}

/// The selection bundle and silhouette test (`lod`, `evaluate`).
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct SelectArgs {
    /// Rays per POI of the selection bundle (cells of the equal-solid-angle hemisphere
    /// partition).
    #[arg(long, default_value_t = SelectOptions::default().rays)]
    pub rays: usize,
    /// Seed of the ray jitter inside each cell (same seed, same output).
    #[arg(long, default_value_t = SelectOptions::default().seed)]
    pub seed: u64,
    #[command(flatten)]
    pub silhouette: SilhouetteArgs,
}

impl SelectArgs {
    /// The library's options.
    pub fn options(&self) -> SelectOptions {
        self.silhouette.options(self.rays, self.seed)
    }
}

impl SilhouetteArgs {
    /// The library's options with this bundle.
    pub fn options(&self, rays: usize, seed: u64) -> SelectOptions {
        SelectOptions {
            rays,
            seed,
            threshold_deg: self.threshold,
            roof_tolerance_m: self.roof_tolerance,
        }
    }
}
