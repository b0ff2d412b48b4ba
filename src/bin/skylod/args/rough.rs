//! `--angle`, `--thickness`, `--no-lod2`: the rough model.

use super::non_negative;
use anyhow::bail;
use skylod::lod::rough::RoughOptions;

/// Rough-model options, the same on every command that builds the rough model (`lod`,
/// `evaluate`, `rough`, `fisheye`), so that the commands cannot drift apart.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct RoughArgs {
    /// Rough model: largest angle (degrees, 0 to 90) between the normals of polygons merged
    /// into one plane.
    #[arg(long, default_value_t = RoughOptions::default().angle_deg, value_name = "DEG", value_parser = non_negative, allow_hyphen_values = true)]
    pub angle: f64,
    /// Rough model: largest distance (m) of a polygon from its plane to be merged or absorbed.
    #[arg(long, default_value_t = RoughOptions::default().thickness_m, value_name = "M", value_parser = non_negative, allow_hyphen_values = true)]
    pub thickness: f64,
    /// Rough model: do not use an asset's LoD2 geometry in place of its higher LoD.
    #[arg(long)]
    pub no_lod2: bool,
}

impl RoughArgs {
    /// The library's options; an angle over 90 degrees is a usage error.
    pub fn options(&self) -> anyhow::Result<RoughOptions> {
        if self.angle > 90.0 {
            bail!("--angle must be between 0 and 90 degrees");
        }
        Ok(RoughOptions {
            angle_deg: self.angle,
            thickness_m: self.thickness,
            prefer_lod2: !self.no_lod2,
        })
    }
}
