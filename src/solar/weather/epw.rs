//! EnergyPlus weather files: a `LOCATION` line (city, state, country, source, WMO, latitude,
//! longitude, time zone, elevation), seven more header lines, then one line per hour:
//! year, month, day, hour (1–24, ending), minute, flags, …, GHI (field 14), DNI (15),
//! DHI (16), in Wh/m².

use super::{format_error, number, weather, weather_hour, Weather, WeatherError};
use super::{WeatherFormat, WeatherSite};
use chrono::NaiveDate;

pub(super) fn parse(text: &str, name: &str) -> Result<Weather, WeatherError> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(text.as_bytes());
    let mut site = None;
    let mut hours = Vec::with_capacity(8760);
    for rec in reader.records() {
        let rec = rec.map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            format_error(name, line, e.to_string())
        })?;
        let line = rec.position().map_or(0, |p| p.line());
        let first = rec.get(0).unwrap_or("").trim();
        if first == "LOCATION" {
            site = Some(WeatherSite {
                name: rec.get(1).unwrap_or("").trim().to_string(),
                latitude: number(&rec, 6, "latitude", (-90.0, 90.0), name)?,
                longitude: number(&rec, 7, "longitude", (-180.0, 180.0), name)?,
                utc_offset_hours: number(&rec, 8, "time zone", (-12.0, 14.0), name)?,
                elevation_m: number(&rec, 9, "elevation", (-1000.0, 9999.9), name)?,
            });
            continue;
        }
        if first.parse::<i32>().is_err() {
            continue; // the other header lines
        }
        let Some(site) = site.as_ref() else {
            return Err(format_error(name, line, "data before the LOCATION line"));
        };
        let year = number(&rec, 0, "year", (1.0, 9999.0), name)? as i32;
        let month = number(&rec, 1, "month", (1.0, 12.0), name)? as u32;
        let day = number(&rec, 2, "day", (1.0, 31.0), name)? as u32;
        let hour = number(&rec, 3, "hour", (1.0, 24.0), name)? as u32;
        let date = NaiveDate::from_ymd_opt(year, month, day)
            .ok_or_else(|| format_error(name, line, format!("no date {year}-{month}-{day}")))?;
        hours.push(weather_hour(
            &rec,
            line,
            (date, hour),
            site,
            [
                (13, "global horizontal radiation"),
                (14, "direct normal radiation"),
                (15, "diffuse horizontal radiation"),
            ],
            name,
        )?);
    }
    let site = site.ok_or_else(|| format_error(name, 1, "no LOCATION line: not an EPW file"))?;
    weather(WeatherFormat::Epw, site, hours, name, 9)
}

#[cfg(test)]
mod tests {
    use super::super::parse_weather;

    fn header() -> String {
        let mut s = String::from("LOCATION,Greensboro,NC,USA,TMY3,723170,36.1,-79.95,-5.0,273.0\n");
        for _ in 0..7 {
            s.push_str("COMMENTS,\n");
        }
        s
    }

    #[test]
    fn missing_value_is_refused_with_its_line() {
        let mut s = header();
        s.push_str("1990,1,1,1,60,?,0,0,0,0,0,0,0,0,0,0\n");
        s.push_str("1990,1,1,2,60,?,0,0,0,0,0,0,0,0,9999,0\n");
        let e = parse_weather(&s, "g.epw").unwrap_err().to_string();
        assert!(
            e.starts_with("g.epw:10: direct normal radiation (field 15)"),
            "{e}"
        );
    }

    #[test]
    fn no_data_and_bad_date() {
        let e = parse_weather(&header(), "g.epw").unwrap_err().to_string();
        assert!(e.contains("no hourly data"), "{e}");
        let mut s = header();
        s.push_str("1990,2,30,1,60,?,0,0,0,0,0,0,0,0,0,0\n");
        let e = parse_weather(&s, "g.epw").unwrap_err().to_string();
        assert!(e.contains("g.epw:9: no date 1990-2-30"), "{e}");
    }
}
