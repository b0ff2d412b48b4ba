//! NREL TMY3 CSV: a station line (USAF id, name, state, time zone, latitude, longitude,
//! elevation), a column header line, then one line per hour: `Date (MM/DD/YYYY)`,
//! `Time (HH:MM)` (01:00–24:00, ending), … `GHI`, `DNI`, `DHI` (Wh/m², whatever unit the
//! header prints), found by their column names.

use super::{format_error, number, weather, weather_hour, Weather, WeatherError};
use super::{WeatherFormat, WeatherSite};
use chrono::NaiveDate;

pub(super) fn parse(text: &str, name: &str) -> Result<Weather, WeatherError> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(text.as_bytes());
    let mut records = reader.records();
    let mut next = |what: &str| -> Result<csv::StringRecord, WeatherError> {
        match records.next() {
            Some(Ok(r)) => Ok(r),
            Some(Err(e)) => Err(format_error(
                name,
                e.position().map_or(0, |p| p.line()),
                e.to_string(),
            )),
            None => Err(format_error(name, 1, format!("no {what}: not a TMY3 file"))),
        }
    };
    let station = next("station line")?;
    if station.len() < 7 {
        return Err(format_error(
            name,
            1,
            "neither an EPW (LOCATION line) nor a TMY3 file (station line of 7 fields)",
        ));
    }
    let site = WeatherSite {
        name: station.get(1).unwrap_or("").trim().to_string(),
        utc_offset_hours: number(&station, 3, "time zone", (-12.0, 14.0), name)?,
        latitude: number(&station, 4, "latitude", (-90.0, 90.0), name)?,
        longitude: number(&station, 5, "longitude", (-180.0, 180.0), name)?,
        elevation_m: number(&station, 6, "elevation", (-1000.0, 9999.9), name)?,
    };
    let header = next("column header")?;
    let column = |key: &str| {
        header
            .iter()
            .position(|h| h.split(" (").next().map(str::trim) == Some(key))
            .ok_or_else(|| format_error(name, 2, format!("no {key} column in the header")))
    };
    let (date_c, time_c) = (column("Date")?, column("Time")?);
    let (ghi_c, dni_c, dhi_c) = (column("GHI")?, column("DNI")?, column("DHI")?);
    let mut hours = Vec::with_capacity(8760);
    for rec in records {
        let rec = rec
            .map_err(|e| format_error(name, e.position().map_or(0, |p| p.line()), e.to_string()))?;
        let line = rec.position().map_or(0, |p| p.line());
        let date_s = rec.get(date_c).unwrap_or("").trim();
        let date = NaiveDate::parse_from_str(date_s, "%m/%d/%Y")
            .map_err(|_| format_error(name, line, format!("date {date_s:?} is not MM/DD/YYYY")))?;
        let time_s = rec.get(time_c).unwrap_or("").trim();
        let hour = time_s
            .split_once(':')
            .and_then(|(h, m)| (m == "00").then_some(h))
            .and_then(|h| h.parse::<u32>().ok())
            .filter(|h| (1..=24).contains(h))
            .ok_or_else(|| {
                format_error(name, line, format!("time {time_s:?} is not 01:00..24:00"))
            })?;
        let irr = [(ghi_c, "GHI"), (dni_c, "DNI"), (dhi_c, "DHI")];
        hours.push(weather_hour(&rec, line, (date, hour), &site, irr, name)?);
    }
    weather(WeatherFormat::Tmy3, site, hours, name, 3)
}

#[cfg(test)]
mod tests {
    use super::super::parse_weather;

    const HEAD: &str = "723170,\"GREENSBORO\",NC,-5.0,36.100,-79.950,273\n\
        Date (MM/DD/YYYY),Time (HH:MM),ETR (W/m^2),GHI (W/m^2),DNI (W/m^2),DHI (W/m^2)\n";

    #[test]
    fn reads_columns_by_name() {
        let s = format!("{HEAD}06/21/1990,13:00,1300,900,800,120\n");
        let w = parse_weather(&s, "t.csv").unwrap();
        assert_eq!(w.site.name, "GREENSBORO");
        assert_eq!((w.site.latitude, w.site.longitude), (36.1, -79.95));
        let h = w.hours[0];
        assert_eq!((h.ghi, h.dni, h.dhi), (900.0, 800.0, 120.0));
        assert_eq!(h.mid_utc.to_rfc3339(), "1990-06-21T17:30:00+00:00");
    }

    #[test]
    fn errors_name_the_line() {
        let s = format!("{HEAD}06/21/1990,13:00,1300,900,800,120\n06/21/1990,13:30,0,0,0,0\n");
        let e = parse_weather(&s, "t.csv").unwrap_err().to_string();
        assert!(e.starts_with("t.csv:4: time \"13:30\""), "{e}");
        let e = parse_weather("a,b\n", "t.csv").unwrap_err().to_string();
        assert!(e.contains("neither an EPW"), "{e}");
    }
}
