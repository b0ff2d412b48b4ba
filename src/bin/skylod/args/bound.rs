//! `--max-svf-error` / `--max-sun-hours-error` of `skylod lod`: the error-bounded LoD
//! ([`skylod::lod::bound`]) run between the selection and the writing.

use crate::args::non_negative;
use crate::args::site::SiteArgs;
use crate::args::sun::SunArgs;
use skylod::lod::bound::BoundOptions;
use skylod::model::CityModel;
use skylod::pipeline::BoundSpec;
use skylod::solar::{Site, SunTable};

#[derive(clap::Args, Debug)]
pub struct BoundArgs {
    /// Largest relative SVF error allowed at any POI (e.g. 0.01): after the selection, the LoD
    /// model is traced against the full model with the same rays and assets are promoted
    /// (0 -> 1, 1 -> 2) until every POI holds; exit 1 naming the POIs when it cannot.
    #[arg(long, value_name = "E", value_parser = non_negative, allow_hyphen_values = true)]
    max_svf_error: Option<f64>,
    /// Largest relative error of yearly sun hours allowed at any POI (as --max-svf-error; the
    /// site comes from --lat/--lon or the model's CRS).
    #[arg(long, value_name = "E", value_parser = non_negative, allow_hyphen_values = true)]
    max_sun_hours_error: Option<f64>,
    /// Rays of the SVF bundle of the bound check.
    #[arg(long, default_value_t = 20_000, value_name = "N")]
    bound_rays: usize,
    #[command(flatten)]
    site: SiteArgs,
    /// `--year`, `--step` of the sun-hours bound.
    #[command(flatten)]
    sun: SunArgs,
}

impl BoundArgs {
    /// Whether a bound was asked for.
    pub fn active(&self) -> bool {
        self.max_svf_error.is_some() || self.max_sun_hours_error.is_some()
    }

    /// Usage checks before any input is read.
    pub fn check(&self) -> anyhow::Result<()> {
        self.site.check("lod")
    }

    /// The bound to run after the selection ([`skylod::pipeline::levels`]), if one was
    /// asked for; `source` (the model as read) gives the sun's site.
    pub fn spec(&self, source: &CityModel, seed: u64) -> anyhow::Result<Option<BoundSpec>> {
        if !self.active() {
            return Ok(None);
        }
        let sun = match self.max_sun_hours_error {
            Some(_) => {
                let (lat, lon) = self.site.resolve(source, "lod --max-sun-hours-error")?;
                Some(SunTable::year(
                    self.sun.year,
                    self.sun.step,
                    &Site::new(lat, lon),
                )?)
            }
            None => None,
        };
        let options = BoundOptions {
            max_svf_error: self.max_svf_error,
            max_sun_error: self.max_sun_hours_error,
            svf_rays: self.bound_rays,
            svf_seed: seed,
            ..Default::default()
        };
        Ok(Some(BoundSpec { options, sun }))
    }
}
