//! `--weather`, `--sky`, `--albedo` of `evaluate` and `lod`: a weather year for the annual
//! irradiation ([`skylod::solar::irradiance`]), and the sun's site for it (shared with
//! `irradiance`).

use crate::args::site::{model_site, SiteArgs};
use anyhow::{bail, Context};
use skylod::model::CityModel;
use skylod::output::irradiance::{SkyName, WeatherSummary};
use skylod::solar::irradiance::{IrradianceOptions, IrradianceSetting, IrradianceTable, SkyModel};
use skylod::solar::weather::{read_weather, Weather};
use skylod::solar::Site;
use std::path::PathBuf;

/// Farthest a weather station may be from the model's site (km) unless --lat/--lon are given.
pub const MAX_STATION_KM: f64 = 50.0;

#[derive(clap::Args, Debug)]
pub struct WeatherArgs {
    /// Hourly weather year (EnergyPlus EPW or NREL TMY3 CSV, told by content): adds each
    /// POI's annual global irradiation (kWh/m²) on its plane.
    #[arg(long, value_name = "FILE")]
    pub weather: Option<PathBuf>,
    /// Diffuse sky model of --weather: perez (Perez 1990 anisotropic) or isotropic.
    #[arg(long, value_enum, default_value = "perez", requires = "weather")]
    pub sky: SkyModel,
    /// Reflectance of the ground and obstructions with --weather (0 turns reflection off).
    #[arg(long, default_value_t = 0.2, requires = "weather")]
    pub albedo: f64,
}

/// A weather year read and placed: what to trace and what to report.
pub struct WeatherYear {
    /// The table and options to trace with.
    pub setting: IrradianceSetting,
    /// The file and its totals.
    pub summary: WeatherSummary,
    /// The sun's site (latitude, longitude).
    pub site: [f64; 2],
}

impl WeatherArgs {
    /// Usage checks before any input is read.
    pub fn check(&self) -> anyhow::Result<()> {
        if !(0.0..=1.0).contains(&self.albedo) {
            bail!("--albedo must be in 0..1 (got {})", self.albedo);
        }
        Ok(())
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
        let (lat, lon) = weather_site(site, model, &weather, cmd)?;
        let table = IrradianceTable::new(&weather, &Site::new(lat, lon), self.sky)
            .with_context(|| format!("{cmd}: placing the sun for {}", path.display()))?;
        let summary = WeatherSummary::new(
            path.display().to_string(),
            weather.format,
            &weather.site,
            weather.hours.len(),
            weather.totals_kwh_m2(),
        );
        let opts = IrradianceOptions {
            sky: self.sky,
            albedo: self.albedo,
        };
        Ok(Some(WeatherYear {
            setting: IrradianceSetting { table, opts },
            summary,
            site: [lat, lon],
        }))
    }
}

impl WeatherYear {
    /// The sky model's name in the JSON.
    pub fn sky(&self) -> SkyName {
        self.setting.opts.sky.into()
    }
}

/// The sun's site for a weather year: --lat/--lon; else the model's centre (refused when
/// the weather station is farther than [`MAX_STATION_KM`]); else the weather station's.
pub fn weather_site(
    args: &SiteArgs,
    model: &CityModel,
    weather: &Weather,
    cmd: &str,
) -> anyhow::Result<(f64, f64)> {
    if let Some(s) = args.given() {
        return Ok(s);
    }
    let w = &weather.site;
    match model_site(model) {
        Ok((a, o, srs)) => {
            let km = w.distance_km(a, o);
            if km > MAX_STATION_KM {
                bail!(
                    "{cmd}: the model (lat {a:.4}, lon {o:.4} in {srs}) is {km:.0} km from \
                     the weather station {:?} (lat {}, lon {}); give --lat/--lon to use this \
                     weather anyway",
                    w.name,
                    w.latitude,
                    w.longitude
                );
            }
            crate::log::summary!(
                "{cmd}: site lat {a:.5}, lon {o:.5}: the centre of the model in {srs}"
            );
            Ok((a, o))
        }
        Err(why) => {
            crate::log::summary!(
                "{cmd}: site of the weather station {:?} (lat {}, lon {}): {why}",
                w.name,
                w.latitude,
                w.longitude
            );
            Ok((w.latitude, w.longitude))
        }
    }
}
