//! `--max-svf-error` / `--max-sun-hours-error` / `--no-bound` of `skylod lod`: the
//! error-bounded LoD ([`skylod::lod::bound`]) run between the selection and the writing. On by
//! default: SVF within 1 % at every POI, and sun hours within 1 % whenever the site is known;
//! with `--weather`, the annual irradiation within 1 % (`--max-irradiance-error`).

use crate::args::non_negative;
use crate::args::site::SiteArgs;
use crate::args::sun::SunArgs;
use crate::args::weather::WeatherArgs;
use crate::flags::site_text;
use anyhow::{anyhow, bail};
use skylod::export::report::Guarantee;
use skylod::pipeline::session::BoundRequest;
use skylod::pipeline::session::Study;
use skylod::pipeline::BoundSpec;
use skylod::solar::SunEphemeris;

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
        self.site.check("lod", true)?;
        self.weather.check()?;
        if self.max_irradiance_error.is_some() && self.weather.weather.is_none() {
            bail!(
                "lod --max-irradiance-error needs --weather FILE: the hourly weather year                  (EPW or TMY3) whose annual irradiation is bounded"
            );
        }
        Ok(())
    }

    /// The request these options make (the bound's seed comes with the selection's options).
    fn request(&self, seed: u64) -> BoundRequest {
        let mut r = BoundRequest::new(self.bound_rays, seed, ("--no-bound", "--lat/--lon"));
        r.bound = !self.no_bound;
        (r.max_svf_error, r.max_sun_hours_error) = (self.max_svf_error, self.max_sun_hours_error);
        r.max_irradiance_error = self.max_irradiance_error;
        (r.year, r.step_min) = (self.sun.year, self.sun.step);
        r
    }

    /// SPA's site-independent half of the sun-hours bound's table, computed while the model
    /// is read near the site of `first` ([`BoundRequest::ephemeris`]); `None` with `--no-bound`.
    pub fn ephemeris(&self, first: Option<&std::path::Path>) -> Option<SunEphemeris> {
        self.request(0)
            .ephemeris(self.site.lat, self.site.lon, first)
    }

    /// The bound to run after the selection ([`skylod::pipeline::session::bound_plan`]) and what it
    /// guarantees; `study`'s model as read gives the sun's site ([`Study::sun_site`]), `ahead`
    /// (from [`BoundArgs::ephemeris`]) the site-independent half of the sun's table.
    pub fn spec(
        &self,
        study: &Study,
        seed: u64,
        ahead: Option<&SunEphemeris>,
    ) -> anyhow::Result<(Option<BoundSpec>, Guarantee)> {
        let r = self.request(seed);
        let source = study.source();
        let site = study.sun_site(self.site.lat, self.site.lon);
        let plan = r
            .plan(site)
            .map_err(|e| anyhow!(site_text(&e, "lod --max-sun-hours-error")))?;
        if let Some(n) = plan.site.as_ref().and_then(|s| s.note("")) {
            if self.max_sun_hours_error.is_some() {
                crate::log::summary!("lod --max-sun-hours-error: {n}");
            }
            crate::log::summary!("lod: {n}");
        }
        let sun = plan.sun_table_ahead(ahead, &crate::log::reporter())?;
        let year = self.weather.year(&self.site, source, "lod")?;
        Ok(plan.finish(sun, year))
    }
}
