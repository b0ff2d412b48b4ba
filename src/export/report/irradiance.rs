//! The JSON, table and CSV of `skylod irradiance`: per POI the annual irradiation on its
//! plane (global, direct, diffuse, reflected, kWh/m²), the weather and sky model, the inputs
//! and the timings.

use super::row::PoiRow;
use super::text::{run_part, TextContext};
use crate::lod::poi::checks::PoiFlag;
use crate::model::Poi;
use crate::solar::irradiance::{Irradiance, SkyModel};
use crate::solar::weather::{Weather, WeatherFormat, WeatherSite};
use schemars::JsonSchema;
use serde::Serialize;
use std::io::Write;

/// The whole `irradiance --json` document.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
#[non_exhaustive]
pub struct IrradianceOutput {
    /// One entry per POI, in input order.
    pub pois: Vec<IrradiancePoi>,
    /// The weather file and what it holds.
    pub weather: WeatherSummary,
    /// Where the sun was placed (latitude, longitude, degrees).
    pub site: [f64; 2],
    /// The diffuse sky model.
    pub sky: SkyName,
    /// Ground reflectance.
    #[schemars(range(min = 0, max = 1))]
    pub albedo: f64,
    /// Rays of the sky bundle per POI.
    pub rays: usize,
    /// Paths read.
    pub inputs: Vec<String>,
    /// Polygons of the scene at full detail.
    pub polygons: usize,
    /// Wall-clock milliseconds per stage.
    pub timings_ms: IrradianceTimings,
    /// The POIs computed, also where their rows are left out of [`IrradianceOutput::pois`].
    #[serde(skip)]
    #[schemars(skip)]
    pub(crate) points: usize,
}

impl IrradianceOutput {
    /// The document of one run.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        pois: Vec<IrradiancePoi>,
        weather: WeatherSummary,
        site: [f64; 2],
        sky: SkyModel,
        albedo: f64,
        rays: usize,
        inputs: Vec<String>,
        polygons: usize,
        timings_ms: IrradianceTimings,
    ) -> Self {
        IrradianceOutput {
            points: pois.len(),
            pois,
            weather,
            site,
            sky: sky.into(),
            albedo,
            rays,
            inputs,
            polygons,
            timings_ms,
        }
    }
}

/// The sky model's name in the JSON (`all-weather`, `perez` or `isotropic`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum SkyName {
    /// The Perez all-weather sky by daylight coefficients.
    #[serde(rename = "all-weather")]
    AllWeather,
    /// Perez 1990 anisotropic.
    Perez,
    /// Uniform radiance.
    Isotropic,
}

impl SkyName {
    /// Its name in the JSON.
    pub fn name(self) -> &'static str {
        match self {
            SkyName::AllWeather => "all-weather",
            SkyName::Perez => "perez",
            SkyName::Isotropic => "isotropic",
        }
    }
}

impl From<SkyModel> for SkyName {
    fn from(s: SkyModel) -> Self {
        match s {
            SkyModel::AllWeather => SkyName::AllWeather,
            SkyModel::Perez => SkyName::Perez,
            SkyModel::Isotropic => SkyName::Isotropic,
        }
    }
}

/// The weather file of a run.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
#[non_exhaustive]
pub struct WeatherSummary {
    /// The file as given.
    pub file: String,
    /// `epw` or `tmy3`.
    pub format: String,
    /// The station's name.
    pub station: String,
    /// Its latitude and longitude (degrees).
    pub lat_lon: [f64; 2],
    /// Hours read.
    pub hours: usize,
    /// Annual global horizontal irradiation (kWh/m²).
    pub ghi_kwh_m2: f64,
    /// Annual direct normal irradiation (kWh/m²).
    pub dni_kwh_m2: f64,
    /// Annual diffuse horizontal irradiation (kWh/m²).
    pub dhi_kwh_m2: f64,
}

impl WeatherSummary {
    /// The summary of a weather file read from `file`.
    pub fn new(
        file: String,
        format: WeatherFormat,
        site: &WeatherSite,
        hours: usize,
        (ghi, dni, dhi): (f64, f64, f64),
    ) -> Self {
        WeatherSummary {
            file,
            format: match format {
                WeatherFormat::Epw => "epw".into(),
                WeatherFormat::Tmy3 => "tmy3".into(),
            },
            station: site.name.clone(),
            lat_lon: [site.latitude, site.longitude],
            hours,
            ghi_kwh_m2: ghi,
            dni_kwh_m2: dni,
            dhi_kwh_m2: dhi,
        }
    }
}

/// One POI of `irradiance --json`.
pub type IrradiancePoi = PoiRow<IrradianceValues>;

/// What `irradiance` computed for one POI ([`IrradiancePoi`]).
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
#[non_exhaustive]
pub struct IrradianceValues {
    /// Direct + diffuse + reflected, kWh/m² over the weather's hours.
    #[schemars(range(min = 0))]
    pub global_kwh_m2: f64,
    /// From the sun's disc.
    #[schemars(range(min = 0))]
    pub direct_kwh_m2: f64,
    /// From the sky.
    #[schemars(range(min = 0))]
    pub diffuse_kwh_m2: f64,
    /// From the ground and obstructions.
    #[schemars(range(min = 0))]
    pub reflected_kwh_m2: f64,
    /// Cosine-weighted sky view factor of the plane.
    #[schemars(range(min = 0, max = 1))]
    pub svf: f64,
    /// Hours with the sun's ray free.
    pub sun_hours: u32,
    /// Hours the sun was above the horizon and in front of the plane.
    pub possible_sun_hours: u32,
}

impl IrradiancePoi {
    /// The entry of `poi`.
    pub fn new(poi: &Poi, r: &Irradiance, flags: &[PoiFlag]) -> Self {
        let values = IrradianceValues {
            global_kwh_m2: r.global_kwh_m2,
            direct_kwh_m2: r.direct_kwh_m2,
            diffuse_kwh_m2: r.diffuse_kwh_m2,
            reflected_kwh_m2: r.reflected_kwh_m2,
            svf: r.svf,
            sun_hours: r.sun_hours,
            possible_sun_hours: r.sun_hours_possible,
        };
        PoiRow::of(poi, values, flags)
    }
}

/// The table of `skylod irradiance`: a header line (if `header`), then one line per POI.
pub fn write_table(
    out: &mut impl Write,
    pois: &[IrradiancePoi],
    header: bool,
) -> std::io::Result<()> {
    if header {
        writeln!(
            out,
            "{:<20} {:>10} {:>10} {:>10} {:>10} {:>6}",
            "id", "global", "direct", "diffuse", "reflected", "svf"
        )?;
    }
    for p in pois {
        writeln!(
            out,
            "{:<20} {:>10.1} {:>10.1} {:>10.1} {:>10.1} {:>6.3}",
            p.id, p.global_kwh_m2, p.direct_kwh_m2, p.diffuse_kwh_m2, p.reflected_kwh_m2, p.svf
        )?;
    }
    Ok(())
}

/// The CSV of `skylod irradiance --csv`: one row per POI (kWh/m²).
pub fn write_csv(out: impl Write, pois: &[IrradiancePoi]) -> csv::Result<()> {
    let mut w = csv::Writer::from_writer(out);
    w.write_record([
        "id",
        "x",
        "y",
        "z",
        "global_kwh_m2",
        "direct_kwh_m2",
        "diffuse_kwh_m2",
        "reflected_kwh_m2",
        "svf",
        "sun_hours",
        "flags",
    ])?;
    for p in pois {
        let flags: Vec<String> = p
            .flags
            .iter()
            .map(|f| {
                serde_json::to_value(f)
                    .ok()
                    .and_then(|v| v.get("flag").and_then(|k| k.as_str()).map(String::from))
                    .unwrap_or_default()
            })
            .collect();
        w.write_record([
            p.id.clone(),
            p.poi[0].to_string(),
            p.poi[1].to_string(),
            p.poi[2].to_string(),
            format!("{:.3}", p.global_kwh_m2),
            format!("{:.3}", p.direct_kwh_m2),
            format!("{:.3}", p.diffuse_kwh_m2),
            format!("{:.3}", p.reflected_kwh_m2),
            format!("{:.4}", p.svf),
            p.sun_hours.to_string(),
            flags.join(";"),
        ])?;
    }
    w.flush()?;
    Ok(())
}

/// The CSV of `irradiance --hourly`: `time_utc` (the middle of each hour of `weather`) and
/// one column per POI (`ids`) of its hourly global irradiation (`series`, Wh/m²).
pub fn write_hourly_csv(
    out: impl Write,
    weather: &Weather,
    ids: &[&str],
    series: &[&[f64]],
) -> csv::Result<()> {
    let mut csv = csv::Writer::from_writer(out);
    let mut head = vec!["time_utc"];
    head.extend(ids);
    csv.write_record(&head)?;
    for (k, h) in weather.hours.iter().enumerate() {
        let mut row = vec![h.mid_utc.format("%Y-%m-%dT%H:%M:%SZ").to_string()];
        row.extend(
            series
                .iter()
                .map(|s| s.get(k).map_or(String::new(), |v| format!("{v:.2}"))),
        );
        csv.write_record(&row)?;
    }
    csv.flush()?;
    Ok(())
}

/// Milliseconds per stage of `irradiance` (`sun`: reading the weather and placing the sun).
pub type IrradianceTimings = super::sun_hours::SunHoursTimings;

impl super::text::Document for IrradianceOutput {
    fn write_table(&self, mut out: &mut dyn Write, cx: &TextContext) -> std::io::Result<()> {
        write_table(&mut out, &self.pois, cx.header)
    }

    fn summary(&self, cx: &TextContext) -> Vec<String> {
        let (w, t) = (&self.weather, self.timings_ms.stages("weather and sun"));
        vec![format!(
            "{} POI(s); {} hours of {} ({}, GHI {:.0} kWh/m²) at ({:.4}, {:.4}), {} sky, albedo {}; {}",
            self.points,
            w.hours,
            w.station,
            w.format,
            w.ghi_kwh_m2,
            self.site[0],
            self.site[1],
            self.sky.name(),
            self.albedo,
            run_part(self.polygons, cx, self.inputs.len(), &t)
        )]
    }
}
