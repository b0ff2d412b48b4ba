//! What [`bound`](super::bound::bound) achieved, as the `bound` section of the `lod` report
//! (`schemas/report.schema.json`): figures per POI, promotions, the bounds asked for.

use super::bound::{BoundOptions, Bounded};
use serde::Serialize;

/// Achieved figures at one POI.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
#[schemars(deny_unknown_fields)]
pub struct PoiBound {
    /// POI id.
    pub id: String,
    /// SVF of the full model.
    #[schemars(range(min = 0, max = 1))]
    pub svf_full: f64,
    /// SVF of the LoD model.
    #[schemars(range(min = 0, max = 1))]
    pub svf_lod: f64,
    /// Relative SVF error (0 when both are 0); infinite (written `null`) when the full SVF
    /// is 0 and the LoD SVF is not.
    #[schemars(with = "Option<f64>", range(min = 0))]
    pub svf_error: f64,
    /// Sun hours of the full model (with a sun table).
    #[schemars(range(min = 0))]
    pub sun_hours_full: Option<f64>,
    /// Sun hours of the LoD model.
    #[schemars(range(min = 0))]
    pub sun_hours_lod: Option<f64>,
    /// Relative sun-hours error.
    #[schemars(range(min = 0))]
    pub sun_hours_error: Option<f64>,
    /// Annual global irradiation of the full model, kWh/m² (with an irradiance bound).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = 0))]
    pub irradiance_full_kwh_m2: Option<f64>,
    /// Annual global irradiation of the LoD model, kWh/m² (with an irradiance bound).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = 0))]
    pub irradiance_lod_kwh_m2: Option<f64>,
    /// Relative error of the annual irradiation (with an irradiance bound).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = 0))]
    pub irradiance_error: Option<f64>,
    /// Whether the POI is within every bound.
    pub holds: bool,
}

/// One promotion.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
#[schemars(deny_unknown_fields)]
pub struct Promotion {
    /// Round (1-based) in which it was made.
    #[schemars(range(min = 1))]
    pub round: usize,
    /// Index of the asset in the model.
    pub asset: usize,
    /// `gml:id` of the asset, if any.
    pub id: Option<String>,
    /// Level before.
    #[schemars(range(max = 1))]
    pub from: u8,
    /// Level after.
    #[schemars(range(min = 1, max = 2))]
    pub to: u8,
    /// The POI whose error asked for it.
    pub poi: String,
    /// Rays of that POI whose answer differed on this asset.
    pub rays: usize,
}

/// The `bound` section of the `lod` report (`schemas/report.schema.json`).
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
#[schemars(deny_unknown_fields)]
pub struct BoundReport {
    /// The SVF bound asked for (relative).
    #[schemars(range(min = 0))]
    pub max_svf_error: Option<f64>,
    /// The sun-hours bound asked for (relative).
    #[schemars(range(min = 0))]
    pub max_sun_hours_error: Option<f64>,
    /// The annual-irradiation bound asked for (relative; absent when not asked for).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = 0))]
    pub max_irradiance_error: Option<f64>,
    /// Rays of the SVF bundle.
    #[schemars(range(min = 1))]
    pub rays: usize,
    /// Seed of the SVF bundle.
    pub seed: u64,
    /// Rounds of tracing the LoD model (1: nothing promoted).
    #[schemars(range(min = 1))]
    pub rounds: usize,
    /// Whether every POI holds.
    pub met: bool,
    /// Achieved figures per POI.
    pub pois: Vec<PoiBound>,
    /// Promotions in the order made.
    pub promotions: Vec<Promotion>,
}

impl BoundReport {
    /// One line per POI over the bound (id, SVF of both models, the errors), for the
    /// error message of a bound that cannot be met.
    pub fn failing_lines(&self) -> String {
        self.pois
            .iter()
            .filter(|p| !p.holds)
            .map(|p| {
                let mut sun = p.sun_hours_error.map_or(String::new(), |e| {
                    format!(", sun hours error {:.2}%", 100.0 * e)
                });
                if let (Some(e), Some(f), Some(l)) = (
                    p.irradiance_error,
                    p.irradiance_full_kwh_m2,
                    p.irradiance_lod_kwh_m2,
                ) {
                    sun.push_str(&format!(
                        ", irradiation {l:.1} kWh/m² (full {f:.1}), error {:.2}%",
                        100.0 * e
                    ));
                }
                format!(
                    "  {}: SVF {:.4} (full {:.4}), error {:.2}%{sun}",
                    p.id,
                    p.svf_lod,
                    p.svf_full,
                    100.0 * p.svf_error
                )
            })
            .collect::<Vec<_>>()
            .join("\n")
    }

    /// The report section of a result made with `opts`.
    pub fn new(b: &Bounded, opts: &BoundOptions) -> BoundReport {
        BoundReport {
            max_svf_error: opts.max_svf_error,
            max_sun_hours_error: opts.max_sun_error,
            max_irradiance_error: opts.max_irradiance_error,
            rays: opts.svf_rays,
            seed: opts.svf_seed,
            rounds: b.rounds,
            met: b.met,
            pois: b.pois.clone(),
            promotions: b.promotions.clone(),
        }
    }
}
