//! The JSON of `skylod sun-hours --json`: per POI its hours of direct sun (over the year and
//! per month), the sun table, the inputs and the timings.

use super::row::PoiRow;
use super::text::{run_part, TextContext};
use crate::lod::poi::checks::PoiFlag;
use crate::model::Poi;
use crate::solar::SunHours;
use schemars::JsonSchema;
use serde::Serialize;
use std::io::Write;

/// The whole `sun-hours --json` document.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
#[non_exhaustive]
pub struct SunHoursOutput {
    /// One entry per POI, in input order.
    pub pois: Vec<SunHoursPoi>,
    /// Site, year and step of the sun table.
    #[serde(flatten)]
    pub sun: SunSetting,
    /// Time zone the steps were attributed to months in, as given.
    pub timezone: String,
    /// Steps of the sun table.
    pub steps: usize,
    /// Paths read.
    pub inputs: Vec<String>,
    /// Polygons of the model (all LoDs, as `stats` counts them: `CityModel::polygon_count`).
    pub polygons: usize,
    /// Wall-clock milliseconds per stage.
    pub timings_ms: SunHoursTimings,
}

impl SunHoursOutput {
    /// The document of a run over the sun table `sun` (`steps` steps, months in `timezone`).
    pub fn new(
        pois: Vec<SunHoursPoi>,
        sun: SunSetting,
        timezone: String,
        steps: usize,
        inputs: Vec<String>,
        polygons: usize,
        timings_ms: SunHoursTimings,
    ) -> Self {
        SunHoursOutput {
            pois,
            sun,
            timezone,
            steps,
            inputs,
            polygons,
            timings_ms,
        }
    }
}

/// Where and over which year a sun table was made: `sun-hours` writes it at the top level,
/// `evaluate` as its `sun` object.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
#[non_exhaustive]
pub struct SunSetting {
    /// Latitude (degrees).
    #[schemars(range(min = -90, max = 90))]
    pub lat: f64,
    /// Longitude (degrees).
    #[schemars(range(min = -180, max = 180))]
    pub lon: f64,
    /// Year.
    pub year: i32,
    /// Step of the table (minutes).
    #[schemars(range(min = 1))]
    pub step_minutes: u32,
}

impl SunSetting {
    /// A table at (`lat`, `lon`) over `year` every `step_minutes` minutes.
    pub fn new(lat: f64, lon: f64, year: i32, step_minutes: u32) -> Self {
        SunSetting {
            lat,
            lon,
            year,
            step_minutes,
        }
    }
}

/// One POI of `sun-hours --json`.
pub type SunHoursPoi = PoiRow<SunHoursValues>;

/// What `sun-hours` computed for one POI ([`SunHoursPoi`]).
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
#[non_exhaustive]
pub struct SunHoursValues {
    /// Hours of direct sun over the table.
    #[schemars(range(min = 0))]
    pub sun_hours: f64,
    /// The same per local month (January first).
    pub monthly: [f64; 12],
    /// Hours the sun is above the horizon and in front of the surface, blocked or not.
    #[schemars(range(min = 0))]
    pub possible_hours: f64,
}

impl SunHoursPoi {
    /// The entry of `poi` with its sun hours and flags.
    pub fn new(poi: &Poi, hours: &SunHours, flags: &[PoiFlag]) -> Self {
        let values = SunHoursValues {
            sun_hours: hours.hours,
            monthly: hours.monthly,
            possible_hours: hours.possible_hours,
        };
        PoiRow::of(poi, values, flags)
    }
}

const MONTHS: [&str; 12] = [
    "Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec",
];

/// The table of `skylod sun-hours`: a header line (if `header`), then one line per POI with
/// its sun hours, the possible hours and the hours of each month.
pub fn write_table(
    out: &mut impl Write,
    pois: &[SunHoursPoi],
    header: bool,
) -> std::io::Result<()> {
    if header {
        let mut head = format!("{:<20} {:>9} {:>9}", "id", "sun_h", "possible");
        for m in MONTHS {
            head.push_str(&format!(" {m:>6}"));
        }
        writeln!(out, "{head}")?;
    }
    for p in pois {
        let mut line = format!(
            "{:<20} {:>9.2} {:>9.2}",
            p.id, p.sun_hours, p.possible_hours
        );
        for m in p.monthly {
            line.push_str(&format!(" {m:>6.1}"));
        }
        writeln!(out, "{line}")?;
    }
    Ok(())
}

/// Milliseconds per stage of `sun-hours` and `irradiance`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
pub struct SunHoursTimings {
    /// Reading the inputs.
    #[schemars(range(min = 0))]
    pub read: f64,
    /// The sun table (`irradiance`: reading the weather and placing the sun).
    #[schemars(range(min = 0))]
    pub sun: f64,
    /// Triangulation and BVH build of the scene.
    #[schemars(range(min = 0))]
    pub bvh: f64,
    /// Tracing.
    #[schemars(range(min = 0))]
    pub trace: f64,
}

impl SunHoursTimings {
    /// `(stage, ms)` in the order the summary line names them ([`run_part`]), the sun's
    /// stage named `sun`.
    pub(crate) fn stages(&self, sun: &'static str) -> [(&'static str, f64); 4] {
        [
            ("read", self.read),
            (sun, self.sun),
            ("bvh", self.bvh),
            ("trace", self.trace),
        ]
    }

    /// The timings `t` of a traced command with `sun` milliseconds placing the sun.
    pub fn new(t: super::svf::TraceTimings, sun: f64) -> Self {
        let super::svf::TraceTimings { read, bvh, trace } = t;
        SunHoursTimings {
            read,
            sun,
            bvh,
            trace,
        }
    }
}

impl super::text::Document for SunHoursOutput {
    fn write_table(&self, mut out: &mut dyn Write, cx: &TextContext) -> std::io::Result<()> {
        write_table(&mut out, &self.pois, cx.header)
    }

    fn summary(&self, cx: &TextContext) -> Vec<String> {
        let (s, t) = (&self.sun, self.timings_ms.stages("sun"));
        vec![format!(
            "{} POI(s); {} steps of {} min in {} at ({}, {}), months in {}; {}",
            self.pois.len(),
            self.steps,
            s.step_minutes,
            s.year,
            s.lat,
            s.lon,
            self.timezone,
            run_part(self.polygons, cx, self.inputs.len(), &t)
        )]
    }
}
