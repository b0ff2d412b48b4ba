//! The JSON of `skylod evaluate --json`: per POI the full, LoD and all-boxes models' solar
//! figures and their errors ([`PoiEval`]), the rays, the sun table and the timings.

use super::sun_hours::SunSetting;
use crate::lod::evaluation::PoiEval;
use schemars::JsonSchema;
use serde::Serialize;
use std::io::Write;

/// The whole `evaluate --json` document.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
#[non_exhaustive]
pub struct EvaluateOutput {
    /// Paths read.
    pub inputs: Vec<String>,
    /// Rays per POI of the selection.
    pub rays: usize,
    /// Rays of each SVF bundle.
    pub svf_rays: usize,
    /// Seed of the selection's ray jitter.
    pub seed: u64,
    /// The sun table, `null` without sun hours (`--no-sun`).
    pub sun: Option<SunSetting>,
    /// The weather year of the irradiance columns (`--weather`); absent without it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub weather: Option<EvaluateWeather>,
    /// One entry per POI, in input order.
    pub pois: Vec<PoiEval>,
    /// Wall-clock milliseconds per stage.
    pub timings_ms: EvaluateTimings,
}

impl EvaluateOutput {
    /// The document of an evaluation with `rays` selection rays, `svf_rays` SVF rays and
    /// seed `seed`.
    pub fn new(
        inputs: Vec<String>,
        rays: usize,
        svf_rays: usize,
        seed: u64,
        sun: Option<SunSetting>,
        pois: Vec<PoiEval>,
        timings_ms: EvaluateTimings,
    ) -> Self {
        EvaluateOutput {
            inputs,
            rays,
            svf_rays,
            seed,
            sun,
            weather: None,
            pois,
            timings_ms,
        }
    }

    /// The same document naming the weather year of its irradiance figures.
    pub fn with_weather(mut self, weather: EvaluateWeather) -> Self {
        self.weather = Some(weather);
        self
    }
}

/// The weather year of `evaluate --weather`: where it came from and how it was used.
#[derive(Debug, Clone, PartialEq, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
pub struct EvaluateWeather {
    /// The station and its yearly totals.
    pub weather: super::irradiance::WeatherSummary,
    /// Diffuse sky model.
    pub sky: super::irradiance::SkyName,
    /// Reflectance of the ground and obstructions.
    #[schemars(range(min = 0, max = 1))]
    pub albedo: f64,
    /// Where the sun was placed (latitude, longitude, degrees).
    pub site: [f64; 2],
}

/// Milliseconds per stage of `evaluate`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, JsonSchema)]
#[schemars(deny_unknown_fields)]
pub struct EvaluateTimings {
    /// Reading the inputs.
    #[schemars(range(min = 0))]
    pub read: f64,
    /// The rough model (shared by all POIs).
    #[schemars(range(min = 0))]
    pub rough: f64,
    /// The selection scene (shared by all POIs).
    #[schemars(range(min = 0))]
    pub selection_bvh: f64,
    /// The whole command.
    #[schemars(range(min = 0))]
    pub total: f64,
}

/// A relative error as a percentage with two decimals, `inf` if not finite, `-` if none.
fn pct(x: Option<f64>) -> String {
    match x {
        Some(v) if v.is_finite() => format!("{:.2}%", 100.0 * v),
        Some(_) => "inf".into(),
        None => "-".into(),
    }
}

/// Hours with one decimal, `-` if none.
fn hours(x: Option<f64>) -> String {
    x.map_or("-".into(), |h| format!("{h:.1}"))
}

/// The table of `skylod evaluate` (the paper's Tables 1 and 2): a header line (if
/// `header`), then per POI one line for each model (full, lod, boxes) with its polygons,
/// reduction, sky view factor, sun hours, their errors against the full model and timings;
/// with a weather year (`--weather`: any POI with `crate::lod::evaluation::ModelFigures::global_kwh_m2`) three
/// more columns, the annual global irradiation and its error (kWh/m² and relative).
pub fn write_table(out: &mut impl Write, pois: &[PoiEval], header: bool) -> std::io::Result<()> {
    let irr = pois.iter().any(|p| p.full.global_kwh_m2.is_some());
    if header {
        write!(
            out,
            "{:<18} {:>7} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9}",
            "poi",
            "model",
            "polygons",
            "reduction",
            "svf",
            "svf err",
            "sky exp",
            "sun h",
            "sun err",
            "bvh ms",
            "trace ms",
            "select ms"
        )?;
        if irr {
            write!(out, " {:>9} {:>9} {:>9}", "kWh/m2", "irr abs", "irr err")?;
        }
        writeln!(out)?;
    }
    for p in pois {
        let full_irr = p.full.global_kwh_m2.map(|_| 0.0);
        for (name, m, svf_err, sun_err, sel, irr_err) in [
            (
                "full",
                &p.full,
                Some(0.0),
                p.full.sun_hours.map(|_| 0.0),
                None,
                (full_irr, full_irr),
            ),
            (
                "lod",
                &p.lod,
                Some(p.lod_svf_error),
                p.lod_sun_error,
                Some(p.select_ms),
                (p.lod_irradiance_abs_error_kwh_m2, p.lod_irradiance_error),
            ),
            (
                "boxes",
                &p.boxes,
                Some(p.boxes_svf_error),
                p.boxes_sun_error,
                None,
                (
                    p.boxes_irradiance_abs_error_kwh_m2,
                    p.boxes_irradiance_error,
                ),
            ),
        ] {
            let reduction = m.polygons as f64 / p.full.polygons.max(1) as f64;
            write!(
                out,
                "{:<18} {:>7} {:>9} {:>8.2}% {:>9.4} {:>9} {:>9.4} {:>9} {:>9} {:>9.1} {:>9.1} {:>9}",
                p.id,
                name,
                m.polygons,
                100.0 * reduction,
                m.svf,
                pct(svf_err),
                m.sky_exposure,
                hours(m.sun_hours),
                pct(sun_err),
                m.bvh_ms,
                m.trace_ms,
                sel.map_or("-".into(), |s: f64| format!("{s:.1}"))
            )?;
            if irr {
                let kwh = |x: Option<f64>| x.map_or("-".into(), |v| format!("{v:.1}"));
                write!(
                    out,
                    " {:>9} {:>9} {:>9}",
                    kwh(m.global_kwh_m2),
                    kwh(irr_err.0),
                    pct(irr_err.1)
                )?;
            }
            writeln!(out)?;
        }
    }
    Ok(())
}
