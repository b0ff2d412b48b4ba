//! The JSON of `skylod horizon --json`: per POI its horizon profile (PVGIS / pvlib
//! convention: azimuths from north, elevations in degrees), the step, the inputs and the
//! timings.

use super::row::PoiRow;
use super::svf::TraceTimings;
use super::text::{run_part, TextContext};
use crate::lod::poi::checks::PoiFlag;
use crate::model::Poi;
use crate::solar::{HorizonOptions, HorizonProfile};
use schemars::JsonSchema;
use serde::Serialize;
use std::io::Write;

/// The whole `horizon --json` document.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
#[non_exhaustive]
pub struct HorizonOutput {
    /// One entry per POI, in input order.
    pub pois: Vec<HorizonPoi>,
    /// Azimuth step (degrees).
    #[schemars(range(min = 0.01, max = 90))]
    pub step_deg: f64,
    /// Resolution of each elevation (degrees).
    pub tolerance_deg: f64,
    /// Paths read.
    pub inputs: Vec<String>,
    /// Polygons of the model (all LoDs, as `stats` counts them: `CityModel::polygon_count`).
    pub polygons: usize,
    /// Wall-clock milliseconds per stage.
    pub timings_ms: TraceTimings,
}

impl HorizonOutput {
    /// The document of a run with azimuth step `step_deg` and tolerance `tolerance_deg`.
    pub fn new(
        pois: Vec<HorizonPoi>,
        step_deg: f64,
        tolerance_deg: f64,
        inputs: Vec<String>,
        polygons: usize,
        timings_ms: TraceTimings,
    ) -> Self {
        HorizonOutput {
            pois,
            step_deg,
            tolerance_deg,
            inputs,
            polygons,
            timings_ms,
        }
    }
}

/// One POI of `horizon --json`.
pub type HorizonPoi = PoiRow<HorizonValues>;

/// What `horizon` computed for one POI ([`HorizonPoi`]).
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
#[non_exhaustive]
pub struct HorizonValues {
    /// Azimuths (degrees from north, clockwise), as written.
    pub azimuth: Vec<f64>,
    /// Elevation of the horizon at each azimuth (degrees), as written: the lower edge of
    /// the visible sky (90: no sky at that azimuth). The column pvlib and PVGIS read.
    pub elevation: Vec<f64>,
    /// Per azimuth, where sky above the elevation is blocked again (an eave, a balcony, an
    /// arcade): the elevation (degrees) at which that blocking starts; null when the sky is
    /// open from the elevation to the zenith.
    pub overhang: Vec<Option<f64>>,
}

impl HorizonPoi {
    /// The entry of `poi` with its profile (`azimuth`, `elevation`, as they are to be
    /// written: the command rounds them) and flags; no overhangs (see [`Self::with_overhang`]).
    pub fn new(poi: &Poi, azimuth: Vec<f64>, elevation: Vec<f64>, flags: &[PoiFlag]) -> Self {
        let overhang = vec![None; azimuth.len()];
        let values = HorizonValues {
            azimuth,
            elevation,
            overhang,
        };
        PoiRow::of(poi, values, flags)
    }

    /// The entry of `poi` with its profile `h` as written (degrees rounded: [`round_deg`]).
    pub fn from_profile(poi: &Poi, h: &HorizonProfile, flags: &[PoiFlag]) -> Self {
        let azimuth = h.azimuth.iter().map(|a| round_deg(*a)).collect();
        let elevation = h.elevation.iter().map(|e| round_deg(*e)).collect();
        HorizonPoi::new(poi, azimuth, elevation, flags)
            .with_overhang(h.overhang.iter().map(|o| o.map(round_deg)).collect())
    }

    /// This entry with the overhang of each azimuth (as written).
    pub fn with_overhang(mut self, overhang: Vec<Option<f64>>) -> Self {
        self.values.overhang = overhang;
        self
    }
}

/// Degrees as written: three decimals (the profile is resolved to 0.01°), no trailing
/// zeros, no negative zero.
pub fn round_deg(x: f64) -> f64 {
    let r = (x * 1000.0).round() / 1000.0;
    if r == 0.0 {
        0.0
    } else {
        r
    }
}

/// The CSV of `skylod horizon`: `id,azimuth,elevation`, one row per POI and azimuth (the
/// header line only if `header`); ids with a comma, quote or line break are quoted.
pub fn write_csv(pois: &[HorizonPoi], header: bool) -> String {
    let mut s = String::new();
    if header {
        s.push_str("id,azimuth,elevation\n");
    }
    for p in pois {
        let id = if p.id.contains([',', '"', '\n', '\r']) {
            format!("\"{}\"", p.id.replace('"', "\"\""))
        } else {
            p.id.clone()
        };
        for (a, e) in p.azimuth.iter().zip(&p.elevation) {
            s.push_str(&format!("{id},{a},{e}\n"));
        }
    }
    s
}

impl super::text::Document for HorizonOutput {
    /// The CSV `id,azimuth,elevation` ([`write_csv`]).
    fn write_table(&self, out: &mut dyn Write, cx: &TextContext) -> std::io::Result<()> {
        out.write_all(write_csv(&self.pois, cx.header).as_bytes())
    }

    fn summary(&self, cx: &TextContext) -> Vec<String> {
        let azimuths = HorizonOptions::default()
            .with_step(self.step_deg)
            .azimuths();
        let t = self.timings_ms.stages();
        vec![format!(
            "{} POI(s), {} azimuths each (step {}°); {}",
            self.pois.len(),
            azimuths.len(),
            self.step_deg,
            run_part(self.polygons, cx, self.inputs.len(), &t)
        )]
    }
}

/// The summary line of one POI's profile (`id`): its mean elevation and its highest, with
/// the azimuth of the first highest.
pub fn profile_summary(id: &str, h: &HorizonProfile) -> String {
    let (mut max, mut at) = (0.0, 0.0);
    for (a, e) in h.azimuth.iter().zip(&h.elevation) {
        if *e > max {
            (max, at) = (*e, *a);
        }
    }
    let mean = h.elevation.iter().sum::<f64>() / h.elevation.len().max(1) as f64;
    format!("{id}: mean elevation {mean:.2}°, highest {max:.2}° at azimuth {at}°")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_rows_and_quoting() {
        // Built by the parser, not as literals: the struct may gain fields.
        let mut pois = [
            crate::lod::poi::parse_poi("0,0,0", 0).unwrap(),
            crate::lod::poi::parse_poi("0,0,0", 1).unwrap(),
        ];
        pois[0].id = "a".into();
        pois[1].id = "b,c".into();
        let (azimuth, elevation) = (vec![0.0, 180.0], vec![12.34567, 0.0]);
        let rows: Vec<_> = pois
            .iter()
            .map(|p| {
                HorizonPoi::new(
                    p,
                    azimuth.iter().map(|a| round_deg(*a)).collect(),
                    elevation.iter().map(|e| round_deg(*e)).collect(),
                    &[],
                )
            })
            .collect();
        assert_eq!(
            write_csv(&rows, true),
            "id,azimuth,elevation\na,0,12.346\na,180,0\n\"b,c\",0,12.346\n\"b,c\",180,0\n"
        );
        assert_eq!(write_csv(&rows[..1], false), "a,0,12.346\na,180,0\n");
    }
}
