//! Hourly weather for irradiance: EnergyPlus EPW and NREL TMY3 CSV files, read into one
//! [`Weather`] year of [`WeatherHour`]s.
//!
//! Both formats give, for each hour, the irradiation received over the hour *ending* at the
//! row's time stamp, in the site's local *standard* time (no daylight saving): EPW hour 1 is
//! 00:00–01:00, TMY3's `01:00` likewise. The values are Wh/m² over the hour, so numerically
//! the hour's mean irradiance in W/m². skylod keeps each row's own date (typical years mix
//! months of different years) and puts the sun at the **middle** of the hour (pvlib's
//! convention for hourly data): [`WeatherHour::mid_utc`] = the hour's end − 30 min − the
//! time zone.
//!
//! Readers use the `csv` crate; the format is told by content (an EPW starts with
//! `LOCATION,`), not by the file name.
//!
//! # Example
//! ```
//! use skylod::solar::parse_weather;
//! let mut epw = String::from("LOCATION,Somewhere,,XX,test,000000,41.39,2.17,1.0,12.0\n");
//! for l in ["DESIGN CONDITIONS,0", "TYPICAL/EXTREME PERIODS,0", "GROUND TEMPERATURES,0",
//!           "HOLIDAYS/DAYLIGHT SAVINGS,No,0,0,0", "COMMENTS 1,", "COMMENTS 2,",
//!           "DATA PERIODS,1,1,Data,Sunday, 1/ 1,12/31"] {
//!     epw.push_str(l);
//!     epw.push('\n');
//! }
//! // noon on 1 January: GHI 300, DNI 500, DHI 100 Wh/m²
//! epw.push_str("1999,1,1,13,0,?,10,5,70,101325,0,0,300,300,500,100,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0\n");
//! let w = parse_weather(&epw, "x.epw").unwrap();
//! assert_eq!((w.site.latitude, w.site.utc_offset_hours), (41.39, 1.0));
//! let h = &w.hours[0];
//! assert_eq!((h.ghi, h.dni, h.dhi), (300.0, 500.0, 100.0));
//! assert_eq!(h.mid_utc.to_rfc3339(), "1999-01-01T11:30:00+00:00");
//! ```

mod epw;
mod tmy3;

use chrono::{DateTime, Datelike, Duration, NaiveDate, Timelike, Utc};
use std::path::Path;

/// The weather file's site, as its header gives it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct WeatherSite {
    /// The station's name.
    pub name: String,
    /// Latitude in degrees, north positive.
    pub latitude: f64,
    /// Longitude in degrees, east positive.
    pub longitude: f64,
    /// Hours from UTC of the file's local standard time (e.g. -5 for US Eastern).
    pub utc_offset_hours: f64,
    /// Elevation in metres.
    pub elevation_m: f64,
}

impl WeatherSite {
    /// Great-circle distance (km, a sphere of 6,371 km) from the station to (`lat`, `lon`).
    pub fn distance_km(&self, lat: f64, lon: f64) -> f64 {
        let (p1, p2) = (self.latitude.to_radians(), lat.to_radians());
        let dl = (lon - self.longitude).to_radians();
        let h = ((p2 - p1) / 2.0).sin().powi(2) + p1.cos() * p2.cos() * (dl / 2.0).sin().powi(2);
        2.0 * 6371.0 * h.sqrt().min(1.0).asin()
    }
}

/// One hour of weather: irradiation over the hour in Wh/m² (= mean W/m²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WeatherHour {
    /// The middle of the hour, in UTC (where the sun is put).
    pub mid_utc: DateTime<Utc>,
    /// Global horizontal irradiation.
    pub ghi: f64,
    /// Direct normal irradiation.
    pub dni: f64,
    /// Diffuse horizontal irradiation.
    pub dhi: f64,
}

/// The formats [`read_weather`] reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum WeatherFormat {
    /// EnergyPlus weather (`.epw`).
    Epw,
    /// NREL Typical Meteorological Year 3 CSV.
    Tmy3,
}

/// A weather year: its site and its hours in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct Weather {
    /// The format the file was in.
    pub format: WeatherFormat,
    /// The site of the header.
    pub site: WeatherSite,
    /// The hours, in file order.
    pub hours: Vec<WeatherHour>,
}

/// Why a weather file could not be read: the file and, where known, its line.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WeatherError {
    /// The file could not be read.
    #[error("{file}: {source}")]
    Io {
        /// The file.
        file: String,
        /// The cause.
        source: std::io::Error,
    },
    /// The content is not what the format says.
    #[error("{file}:{line}: {message}")]
    Format {
        /// The file.
        file: String,
        /// The line (1-based).
        line: u64,
        /// What is wrong.
        message: String,
    },
}

/// Read an EPW or TMY3 file (told by content).
///
/// # Errors
/// `WeatherError` naming the file and line.
pub fn read_weather(path: &Path) -> Result<Weather, WeatherError> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| WeatherError::Io {
        file: name.clone(),
        source,
    })?;
    // Weather files are ASCII or Latin-1 (station names): decode bytes as Latin-1.
    let text: String = match String::from_utf8(bytes) {
        Ok(t) => t,
        Err(e) => e.into_bytes().iter().map(|&b| char::from(b)).collect(),
    };
    parse_weather(&text, &name)
}

/// Parse the text of an EPW or TMY3 file; `name` is used in errors.
///
/// # Errors
/// `WeatherError::Format` naming `name` and the line.
pub fn parse_weather(text: &str, name: &str) -> Result<Weather, WeatherError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    if text.starts_with("LOCATION,") {
        epw::parse(text, name)
    } else {
        tmy3::parse(text, name)
    }
}

impl Weather {
    /// Whether the hours are one whole year, as an annual figure needs: 8,760 hours (8,784 in
    /// a leap year, summed as they are), each hour of the local calendar once (a TMY's months
    /// may come from different years). `file` names the file in the error.
    ///
    /// # Errors
    /// `WeatherError::Format` naming the line of the first hour seen twice, or the number of
    /// hours when it is not a year's.
    pub fn check_year(&self, file: &str) -> Result<(), WeatherError> {
        let first_line = match self.format {
            WeatherFormat::Epw => 9,
            WeatherFormat::Tmy3 => 3,
        };
        let offset = Duration::seconds((self.site.utc_offset_hours * 3600.0) as i64);
        let mut seen = std::collections::HashSet::new();
        for (k, h) in self.hours.iter().enumerate() {
            let t = h.mid_utc + offset;
            if !seen.insert((t.month(), t.day(), t.hour())) {
                return Err(format_error(
                    file,
                    first_line + k as u64,
                    format!(
                        "{:02}-{:02} {:02}:30 is given twice: an annual figure needs each hour of one year once",
                        t.month(),
                        t.day(),
                        t.hour()
                    ),
                ));
            }
        }
        let n = self.hours.len();
        if n != 8760 && n != 8784 {
            return Err(format_error(
                file,
                first_line + n as u64 - 1,
                format!(
                    "{n} hours: an annual figure needs one year, 8760 hours (8784 in a leap year)"
                ),
            ));
        }
        Ok(())
    }

    /// Annual sums (kWh/m²) of GHI, DNI and DHI over every hour.
    pub fn totals_kwh_m2(&self) -> (f64, f64, f64) {
        let (g, n, d) = self.hours.iter().fold((0.0, 0.0, 0.0), |a, h| {
            (a.0 + h.ghi, a.1 + h.dni, a.2 + h.dhi)
        });
        (g / 1000.0, n / 1000.0, d / 1000.0)
    }
}

/// The middle of the hour that ends at `hour_end` (0..=24) of `date`, local standard time at
/// `utc_offset_hours`, in UTC.
fn mid_hour_utc(date: NaiveDate, hour_end: u32, utc_offset_hours: f64) -> Option<DateTime<Utc>> {
    let midnight = date.and_hms_opt(0, 0, 0)?.and_utc();
    let offset_s = (utc_offset_hours * 3600.0).round() as i64;
    Some(
        midnight + Duration::hours(i64::from(hour_end))
            - Duration::minutes(30)
            - Duration::seconds(offset_s),
    )
}

/// The hour of `rec` (line `line`) that ends at `hour_end` of `date` (local standard time of
/// `site`), its GHI, DNI and DHI read from the columns `irr` (index, name for errors).
fn weather_hour(
    rec: &csv::StringRecord,
    line: u64,
    (date, hour_end): (NaiveDate, u32),
    site: &WeatherSite,
    irr: [(usize, &str); 3],
    name: &str,
) -> Result<WeatherHour, WeatherError> {
    let mid_utc = mid_hour_utc(date, hour_end, site.utc_offset_hours)
        .ok_or_else(|| format_error(name, line, "the hour is out of range"))?;
    let [ghi, dni, dhi] = irr;
    Ok(WeatherHour {
        mid_utc,
        ghi: irradiation(rec, ghi.0, ghi.1, name)?,
        dni: irradiation(rec, dni.0, dni.1, name)?,
        dhi: irradiation(rec, dhi.0, dhi.1, name)?,
    })
}

/// The weather year read, or a format error at `first_data_line` when it has no hour.
fn weather(
    format: WeatherFormat,
    site: WeatherSite,
    hours: Vec<WeatherHour>,
    name: &str,
    first_data_line: u64,
) -> Result<Weather, WeatherError> {
    if hours.is_empty() {
        return Err(format_error(name, first_data_line, "no hourly data"));
    }
    Ok(Weather {
        format,
        site,
        hours,
    })
}

/// A field of a record as a finite number in `lo..=hi`, or a format error naming the line.
fn number(
    rec: &csv::StringRecord,
    i: usize,
    what: &str,
    (lo, hi): (f64, f64),
    name: &str,
) -> Result<f64, WeatherError> {
    let line = rec.position().map_or(0, |p| p.line());
    let field = rec.get(i).unwrap_or("").trim();
    match field.parse::<f64>() {
        Ok(v) if v.is_finite() && (lo..=hi).contains(&v) => Ok(v),
        _ => Err(WeatherError::Format {
            file: name.to_string(),
            line,
            message: format!(
                "{what} (field {}) is {field:?}, not a number in {lo}..{hi}",
                i + 1
            ),
        }),
    }
}

/// An irradiation field (Wh/m²): 0..=1,500; EPW's and TMY3's missing value 9999 refused.
fn irradiation(
    rec: &csv::StringRecord,
    i: usize,
    what: &str,
    name: &str,
) -> Result<f64, WeatherError> {
    number(rec, i, what, (0.0, 1500.0), name)
}

fn format_error(name: &str, line: u64, message: impl Into<String>) -> WeatherError {
    WeatherError::Format {
        file: name.to_string(),
        line,
        message: message.into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_year_is_each_hour_once() {
        let site = WeatherSite {
            name: "x".into(),
            latitude: 0.0,
            longitude: 0.0,
            utc_offset_hours: 1.0,
            elevation_m: 0.0,
        };
        let year = |n: i64| {
            let start = chrono::TimeZone::with_ymd_and_hms(&Utc, 2021, 1, 1, 0, 30, 0).unwrap();
            let hours = (0..n)
                .map(|k| WeatherHour {
                    mid_utc: start + Duration::hours(k) - Duration::hours(1),
                    ghi: 0.0,
                    dni: 0.0,
                    dhi: 0.0,
                })
                .collect();
            Weather {
                format: WeatherFormat::Epw,
                site: site.clone(),
                hours,
            }
        };
        assert!(year(8760).check_year("w.epw").is_ok());
        let e = year(8759).check_year("w.epw").unwrap_err().to_string();
        assert_eq!(
            e,
            "w.epw:8767: 8759 hours: an annual figure needs one year, 8760 hours (8784 in a leap year)"
        );
        // a second year's first hour is the first hour again
        let e = year(8761).check_year("w.epw").unwrap_err().to_string();
        assert!(
            e.starts_with("w.epw:8769: 01-01 00:30 is given twice"),
            "{e}"
        );
    }

    #[test]
    fn station_distance() {
        let s = WeatherSite {
            name: "Greensboro".into(),
            latitude: 36.1,
            longitude: -79.95,
            utc_offset_hours: -5.0,
            elevation_m: 273.0,
        };
        assert_eq!(s.distance_km(36.1, -79.95), 0.0);
        // one degree of latitude: 111.19 km on the sphere
        assert!((s.distance_km(37.1, -79.95) - 111.195).abs() < 0.01);
        // to Barcelona's synth district: 6,871 km
        assert!((s.distance_km(41.3777, 2.1632) - 6871.0).abs() < 1.0);
    }

    #[test]
    fn mid_hour_in_utc() {
        let d = NaiveDate::from_ymd_opt(2001, 6, 1).unwrap();
        // hour ending 13:00 at UTC-5 -> 12:30 local -> 17:30 UTC
        assert_eq!(
            mid_hour_utc(d, 13, -5.0).unwrap().to_rfc3339(),
            "2001-06-01T17:30:00+00:00"
        );
        // hour 24 ends at midnight of the next day
        assert_eq!(
            mid_hour_utc(d, 24, 0.0).unwrap().to_rfc3339(),
            "2001-06-01T23:30:00+00:00"
        );
        // India: +5:30
        assert_eq!(
            mid_hour_utc(d, 1, 5.5).unwrap().to_rfc3339(),
            "2001-05-31T19:00:00+00:00"
        );
    }
}
