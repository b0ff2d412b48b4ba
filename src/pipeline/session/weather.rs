//! A weather year placed for the annual irradiation (`irradiance`, `evaluate --weather`,
//! `lod --weather`): where its sun stands ([`weather_site`]: the site given, else the model's
//! centre unless the station is too far, else the station's) and the year read and placed
//! with what the documents report of it ([`WeatherYear`]).

use crate::export::report::irradiance::{SkyName, WeatherSummary};
use crate::model::crs::{ModelSite, NoSite};
use crate::solar::irradiance::{IrradianceOptions, IrradianceSetting, IrradianceTable, SkyModel};
use crate::solar::weather::Weather;
use crate::solar::{Site, SolarError};
use std::path::Path;

/// Farthest a weather station may be from the model's site (km) unless the site is given.
pub const MAX_STATION_KM: f64 = 50.0;

/// Where the sun of a weather year stands, and why there.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum SunSite {
    /// The site the caller gave (latitude, longitude).
    Given(f64, f64),
    /// The centre of the model, converted from its CRS (named).
    Model(f64, f64, String),
    /// The weather station's, since the model gives none (why).
    Station(f64, f64, NoSite),
}

impl SunSite {
    /// Latitude and longitude, degrees.
    pub fn lat_lon(&self) -> (f64, f64) {
        match self {
            SunSite::Given(a, o) | SunSite::Model(a, o, _) | SunSite::Station(a, o, _) => (*a, *o),
        }
    }
}

/// The model's centre is too far from the weather station for its weather to be the
/// model's ([`MAX_STATION_KM`]); the caller says how to give the site anyway.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "the model (lat {lat:.4}, lon {lon:.4} in {srs}) is {km:.0} km from the weather station \
     {station:?} (lat {station_lat}, lon {station_lon})"
)]
pub struct StationTooFar {
    /// The model's centre, degrees.
    pub lat: f64,
    /// The model's centre, degrees.
    pub lon: f64,
    /// The CRS the centre was converted from.
    pub srs: String,
    /// Distance to the station (km).
    pub km: f64,
    /// The station's name.
    pub station: String,
    /// The station's latitude.
    pub station_lat: f64,
    /// The station's longitude.
    pub station_lon: f64,
}

/// The sun's site for `weather`: `given`; else the model's centre `model` (refused when the
/// station is farther than `MAX_STATION_KM`); else the station's.
///
/// # Errors
/// `StationTooFar`.
pub fn weather_site(
    given: Option<(f64, f64)>,
    model: Result<ModelSite, NoSite>,
    weather: &Weather,
) -> Result<SunSite, StationTooFar> {
    if let Some((a, o)) = given {
        return Ok(SunSite::Given(a, o));
    }
    let w = &weather.site;
    match model {
        Ok(s) => {
            let km = w.distance_km(s.lat, s.lon);
            if km > MAX_STATION_KM {
                return Err(StationTooFar {
                    lat: s.lat,
                    lon: s.lon,
                    srs: s.crs.name,
                    km,
                    station: w.name.clone(),
                    station_lat: w.latitude,
                    station_lon: w.longitude,
                });
            }
            Ok(SunSite::Model(s.lat, s.lon, s.crs.name))
        }
        Err(why) => Ok(SunSite::Station(w.latitude, w.longitude, why)),
    }
}

/// What the documents say of the weather file read from `path`.
pub fn weather_summary(path: &Path, weather: &Weather) -> WeatherSummary {
    WeatherSummary::new(
        path.display().to_string(),
        weather.format,
        &weather.site,
        weather.hours.len(),
        weather.totals_kwh_m2(),
    )
}

/// A weather year read and placed: what to trace and what to report.
#[derive(Debug, Clone)]
pub struct WeatherYear {
    /// The table and options to trace with.
    pub setting: IrradianceSetting,
    /// The file and its totals.
    pub summary: WeatherSummary,
    /// The sun's site (latitude, longitude).
    pub site: [f64; 2],
}

impl WeatherYear {
    /// `weather` (read from `path`) with its sun at `(lat, lon)`, the diffuse sky `sky` and
    /// the ground's `albedo`.
    ///
    /// # Errors
    /// [`SolarError`] when the sun cannot be placed.
    pub fn new(
        path: &Path,
        weather: &Weather,
        (lat, lon): (f64, f64),
        sky: SkyModel,
        albedo: f64,
    ) -> Result<WeatherYear, SolarError> {
        let table = IrradianceTable::new(weather, &Site::new(lat, lon), sky)?;
        Ok(WeatherYear {
            setting: IrradianceSetting {
                table,
                opts: IrradianceOptions { sky, albedo },
            },
            summary: weather_summary(path, weather),
            site: [lat, lon],
        })
    }

    /// The sky model's name in the JSON.
    pub fn sky(&self) -> SkyName {
        self.setting.opts.sky.into()
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::model::crs::Crs;

    /// Noon on 1 January at a station in Barcelona (as `solar::weather`'s example).
    pub(crate) fn weather() -> Weather {
        let mut epw = String::from("LOCATION,Somewhere,,XX,test,000000,41.39,2.17,1.0,12.0\n");
        for l in [
            "DESIGN CONDITIONS,0",
            "TYPICAL/EXTREME PERIODS,0",
            "GROUND TEMPERATURES,0",
            "HOLIDAYS/DAYLIGHT SAVINGS,No,0,0,0",
            "COMMENTS 1,",
            "COMMENTS 2,",
            "DATA PERIODS,1,1,Data,Sunday, 1/ 1,12/31",
        ] {
            epw.push_str(l);
            epw.push('\n');
        }
        epw.push_str("1999,1,1,13,0,?,10,5,70,101325,0,0,300,300,500,100,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0\n");
        crate::solar::weather::parse_weather(&epw, "x.epw").unwrap()
    }

    fn site(lat: f64, lon: f64) -> ModelSite {
        ModelSite {
            lat,
            lon,
            crs: Crs::parse("EPSG:25831"),
        }
    }

    #[test]
    fn the_sun_stands_at_the_site_given_the_model_or_the_station() {
        let w = weather();
        let (sl, so) = (w.site.latitude, w.site.longitude);
        let given = weather_site(Some((1.0, 2.0)), Ok(site(sl, so)), &w).unwrap();
        assert_eq!(given, SunSite::Given(1.0, 2.0));
        let near = weather_site(None, Ok(site(sl + 0.1, so)), &w).unwrap();
        assert_eq!(near.lat_lon(), (sl + 0.1, so));
        assert!(matches!(near, SunSite::Model(_, _, ref n) if n.contains("25831")));
        // One degree of latitude is ~111 km: too far from the station.
        let far = weather_site(None, Ok(site(sl + 1.0, so)), &w).unwrap_err();
        assert!((far.km - 111.0).abs() < 2.0, "{far:?}");
        assert!(
            far.to_string().contains("km from the weather station"),
            "{far}"
        );
        let none = NoSite { crs: None };
        let station = weather_site(None, Err(none), &w).unwrap();
        assert!(matches!(station, SunSite::Station(a, o, _) if a == sl && o == so));
    }

    #[test]
    fn a_year_is_placed_and_summarised() {
        let w = weather();
        let path = Path::new("tiny.epw");
        let at = (w.site.latitude, w.site.longitude);
        let y = WeatherYear::new(path, &w, at, SkyModel::Isotropic, 0.3).unwrap();
        assert_eq!(y.site, [at.0, at.1]);
        assert_eq!(y.setting.table.len(), w.hours.len());
        assert_eq!(y.setting.opts.albedo, 0.3);
        assert_eq!(y.summary.file, "tiny.epw");
        assert_eq!(
            (y.summary.station.as_str(), y.summary.ghi_kwh_m2),
            ("Somewhere", 0.3)
        );
        assert_eq!(y.summary.hours, w.hours.len());
    }
}
