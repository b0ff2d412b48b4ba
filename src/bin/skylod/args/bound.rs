//! `--max-svf-error` / `--max-sun-hours-error` / `--no-bound` of `skylod lod`: the
//! error-bounded LoD ([`skylod::lod::bound`]) run between the selection and the writing. On by
//! default: SVF within 1 % at every POI, and sun hours within 1 % whenever the site is known;
//! with `--weather`, the annual irradiation within 1 % (`--max-irradiance-error`).

use crate::args::non_negative;
use crate::args::site::{model_site, SiteArgs};
use crate::args::sun::SunArgs;
use crate::args::weather::WeatherArgs;
use anyhow::bail;
use skylod::lod::bound::BoundOptions;
use skylod::model::CityModel;
use skylod::output::report::Guarantee;
use skylod::pipeline::BoundSpec;
use skylod::solar::{Site, SunTable};

/// The relative error `lod` bounds by default (SVF, and sun hours where the site is known).
pub const DEFAULT_MAX_ERROR: f64 = 0.01;

#[derive(clap::Args, Debug)]
pub struct BoundArgs {
    /// Largest relative SVF error allowed at any POI (default 0.01): after the selection, the
    /// LoD model is traced against the full model with the same rays and assets are promoted
    /// (0 -> 1, 1 -> 2) until every POI holds; exit 1 naming the POIs when it cannot.
    #[arg(long, value_name = "E", value_parser = non_negative, allow_hyphen_values = true)]
    max_svf_error: Option<f64>,
    /// Largest relative error of yearly sun hours allowed at any POI (default 0.01 when the
    /// site is known: --lat/--lon or the model's CRS; given without a site: an error).
    #[arg(long, value_name = "E", value_parser = non_negative, allow_hyphen_values = true)]
    max_sun_hours_error: Option<f64>,
    /// Largest relative error of the annual global irradiation on each POI's plane allowed
    /// at any POI (default 0.01 when --weather is given; needs --weather).
    #[arg(long, value_name = "E", value_parser = non_negative, allow_hyphen_values = true)]
    max_irradiance_error: Option<f64>,
    /// No error bound: the selection alone decides the levels (faster; nothing guaranteed).
    #[arg(long, conflicts_with_all = ["max_svf_error", "max_sun_hours_error", "max_irradiance_error", "weather"])]
    no_bound: bool,
    /// Rays of the SVF bundle of the bound check.
    #[arg(long, default_value_t = 20_000, value_name = "N")]
    bound_rays: usize,
    #[command(flatten)]
    site: SiteArgs,
    /// `--year`, `--step` of the sun-hours bound.
    #[command(flatten)]
    sun: SunArgs,
    /// `--weather`, `--sky`, `--albedo` of the irradiance bound.
    #[command(flatten)]
    weather: WeatherArgs,
}

impl BoundArgs {
    /// Whether a bound was asked for explicitly (`--max-svf-error`, `--max-sun-hours-error`).
    pub fn explicit(&self) -> bool {
        self.max_svf_error.is_some()
            || self.max_sun_hours_error.is_some()
            || self.max_irradiance_error.is_some()
            || self.weather.weather.is_some()
    }

    /// Usage checks before any input is read.
    pub fn check(&self) -> anyhow::Result<()> {
        self.site.check_given("lod")?;
        self.weather.check()?;
        if self.max_irradiance_error.is_some() && self.weather.weather.is_none() {
            bail!(
                "lod --max-irradiance-error needs --weather FILE: the hourly weather year                  (EPW or TMY3) whose annual irradiation is bounded"
            );
        }
        Ok(())
    }

    /// The bound to run after the selection ([`skylod::pipeline::levels`]) and what it
    /// guarantees; `source` (the model as read) gives the sun's site.
    pub fn spec(
        &self,
        source: &CityModel,
        seed: u64,
    ) -> anyhow::Result<(Option<BoundSpec>, Guarantee)> {
        let mut guarantee = Guarantee::default();
        if self.no_bound {
            guarantee
                .not_bounded
                .push("SVF and sun hours: no error bound (--no-bound)".into());
            return Ok((None, guarantee));
        }
        let svf = self.max_svf_error.unwrap_or(DEFAULT_MAX_ERROR);
        guarantee.svf_error = Some(svf);
        let sun_error = match (self.max_sun_hours_error, self.site.given()) {
            (Some(e), _) => {
                let _ = self.site.resolve(source, "lod --max-sun-hours-error")?;
                Some(e)
            }
            (None, Some(_)) => Some(DEFAULT_MAX_ERROR),
            (None, None) => match model_site(source) {
                Ok(_) => Some(DEFAULT_MAX_ERROR),
                Err(why) => {
                    guarantee
                        .not_bounded
                        .push(format!("sun hours: no site ({why}; give --lat/--lon)"));
                    None
                }
            },
        };
        let sun = match sun_error {
            Some(_) => {
                let (lat, lon) = self.site.resolve(source, "lod")?;
                Some(SunTable::year_with(
                    self.sun.year,
                    self.sun.step,
                    &Site::new(lat, lon),
                    &crate::log::reporter(),
                )?)
            }
            None => None,
        };
        guarantee.sun_hours_error = sun_error;
        let year = self.weather.year(&self.site, source, "lod")?;
        let irradiance_error =
            (year.as_ref()).map(|_| self.max_irradiance_error.unwrap_or(DEFAULT_MAX_ERROR));
        guarantee.irradiance_error = irradiance_error;
        let options = BoundOptions {
            max_svf_error: Some(svf),
            max_sun_error: sun_error,
            max_irradiance_error: irradiance_error,
            svf_rays: self.bound_rays,
            svf_seed: seed,
            ..Default::default()
        };
        let irradiance = year.map(|y| y.setting);
        let spec = BoundSpec {
            options,
            sun,
            irradiance,
        };
        Ok((Some(spec), guarantee))
    }
}
