//! `--weather`, `--sky`, `--albedo` of `evaluate` and `lod`: a weather year for the annual
//! irradiation ([`skylod::solar::irradiance`]), and the sun's site for it (shared with
//! `irradiance`).

use crate::args::site::SiteArgs;
use anyhow::{anyhow, bail, Context};
use skylod::model::CityModel;
use skylod::pipeline::session::{weather_site as sun_site, WeatherYear};
use skylod::solar::irradiance::SkyModel;
use skylod::solar::{read_weather, Weather};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct WeatherArgs {
    /// Hourly weather year (EnergyPlus EPW or NREL TMY3 CSV, told by content): adds each
    /// POI's annual global irradiation (kWh/m²) on its plane.
    #[arg(long, value_name = "FILE")]
    pub weather: Option<PathBuf>,
    /// Diffuse sky model of --weather: all-weather (the Perez all-weather sky by daylight coefficients, as
    /// Radiance), perez (the Perez 1990 transposition, as pvlib on open planes) or isotropic.
    #[arg(long, value_enum, default_value = "all-weather", requires = "weather")]
    pub sky: SkyModel,
    /// Reflectance of the ground and obstructions with --weather (0 turns reflection off).
    #[arg(long, default_value_t = 0.2, requires = "weather")]
    pub albedo: f64,
}

impl WeatherArgs {
    /// Usage checks before any input is read.
    pub fn check(&self) -> anyhow::Result<()> {
        albedo(self.albedo)
    }

    /// The weather year of `--weather` (`None` without it), the sun placed at `site`'s
    /// flags, else the model's centre, else the station ([`weather_site`]).
    pub fn year(
        &self,
        site: &SiteArgs,
        model: &CityModel,
        cmd: &str,
    ) -> anyhow::Result<Option<WeatherYear>> {
        let Some(path) = &self.weather else {
            return Ok(None);
        };
        let weather = read_weather(path)?;
        let at = weather_site(site, model, &weather, cmd)?;
        let year = WeatherYear::new(path, &weather, at, self.sky, self.albedo)
            .with_context(|| format!("{cmd}: placing the sun for {}", path.display()))?;
        Ok(Some(year))
    }
}

/// `--albedo` in range.
pub fn albedo(a: f64) -> anyhow::Result<()> {
    if !(0.0..=1.0).contains(&a) {
        bail!("--albedo must be in 0..1 (got {a})");
    }
    Ok(())
}

/// The sun's site for a weather year ([`skylod::pipeline::session::weather_site`]: --lat/--lon,
/// else the model's centre, else the station's), said on stderr.
pub fn weather_site(
    args: &SiteArgs,
    model: &CityModel,
    weather: &Weather,
    cmd: &str,
) -> anyhow::Result<(f64, f64)> {
    let site = skylod::model::crs::model_site(model, &skylod::model::crs::model_crs(model, None));
    let s = sun_site(args.given(), site, weather)
        .map_err(|e| anyhow!("{cmd}: {e}; give --lat/--lon to use this weather anyway"))?;
    if let Some(n) = s.note(&weather.site.name) {
        crate::log::summary!("{cmd}: {n}");
    }
    Ok(s.lat_lon())
}
