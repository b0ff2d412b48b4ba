//! Step 5 for irradiance: every POI's annual irradiation against the full-detail scene.

use super::analyse::{trace_with, Scenes, Traced};
use super::Framed;
use crate::model::runtime::progress::{Cancelled, Progress};
use crate::solar::irradiance::{Irradiance, IrradianceOptions, IrradianceTable};
use crate::solar::{poi_irradiance, SkyBundles};

/// One POI's [`Irradiance`], with its hourly global irradiation (Wh/m², in the weather's
/// order) when asked for.
#[derive(Debug, Clone, PartialEq, Default)]
#[non_exhaustive]
pub struct PoiIrradiance {
    /// Annual sums.
    pub annual: Irradiance,
    /// Hourly global irradiation; empty unless asked for.
    pub hourly: Vec<f64>,
}

impl AsRef<Irradiance> for PoiIrradiance {
    fn as_ref(&self) -> &Irradiance {
        &self.annual
    }
}

/// Annual irradiation of every POI ([`poi_irradiance`]), through [`trace_with`] in `scenes`:
/// `table` holds the weather's hours with the sun placed, `bundles` the sky rays; `hourly`
/// keeps each hour's value.
///
/// # Errors
/// [`Cancelled`] when `progress` asks to stop.
pub fn irradiance(
    framed: &Framed<'_>,
    bundles: &SkyBundles,
    table: &IrradianceTable,
    opts: &IrradianceOptions,
    hourly: bool,
    scenes: Scenes,
    progress: &dyn Progress,
) -> Result<Traced<PoiIrradiance>, Cancelled> {
    trace_with(
        framed,
        scenes,
        |s, p| {
            let mut values = Vec::new();
            let h = hourly.then_some(&mut values);
            let annual = poi_irradiance(s, p, bundles, table, opts, h);
            PoiIrradiance {
                annual,
                hourly: values,
            }
        },
        |r| (r.annual.svf == 0.0 && r.annual.sun_hours == 0).then_some(0),
        progress,
    )
}
