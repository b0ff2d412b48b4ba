//! Solar analysis beside the LoD pipeline (paper 3, 5): the sky partition into ray bundles
//! (`sky`, shared with the selection), sun positions (`sun`, with the site-independent
//! half computed ahead: `ephemeris`), sky view factor and sky
//! exposure (`mod@svf`), sun hours (`mod@sun_hours`), horizon profiles (`horizon`) and
//! irradiation from hourly weather (`weather`, [`mod@irradiance`]).
//!
//! All three take the scene only through an occlusion predicate (`true` = blocked), so
//! they work with any ray caster; parallelism over points of interest is the caller's.

pub(crate) mod ephemeris;
pub(crate) mod fisheye;
pub(crate) mod horizon;
pub mod irradiance;
pub(crate) mod sky;
pub(crate) mod sun;
pub(crate) mod sun_hours;
pub(crate) mod svf;
// Ray tracing: triangles in a BVH, first hit and occlusion, exact reference tests.
pub mod trace;
pub(crate) mod weather;
pub use ephemeris::SunEphemeris;
pub use fisheye::{fisheye_svg, CellClass, FisheyeOptions, Projection};
pub use sky::{Frame, SkyError, SkyPartition, SkyVariant};
pub use weather::{parse_weather, read_weather, Weather, WeatherFormat, WeatherHour, WeatherSite};

pub use horizon::{horizon_profile, HorizonOptions, HorizonProfile};
pub use sun::{sun_position, Site, SiteTimeZone, SunPosition, SunStep, SunTable};
pub use sun_hours::{sun_hours, visible_steps, SunHours};
pub use svf::{sky_view, SkyBundles, SkyView, DEFAULT_SKY_RAYS, DEFAULT_SKY_SEED};

/// Default simulated year of the sun hours: a fixed year, so that results are reproducible.
pub const DEFAULT_YEAR: i32 = 2025;
/// Default time step (minutes) of the sun hours; the sun is evaluated at the middle of each.
pub const DEFAULT_STEP_MIN: u32 = 15;

use crate::model::Poi;
use crate::model::POI_OFFSET;
use crate::solar::trace::TraceScene;

/// [`sky_view()`] of a POI against a scene: rays start at [`Poi::ray_origin`] (moved
/// [`POI_OFFSET`] along the normal) and ignore hits closer than [`POI_OFFSET`]; the bundles
/// are jittered for this POI ([`SkyBundles::for_poi`]).
pub fn poi_sky_view(scene: &TraceScene, poi: &Poi, bundles: &SkyBundles) -> SkyView {
    sky_view(
        poi.ray_origin(),
        poi.normal,
        &bundles.for_poi(poi),
        |o, d| scene.occluded(o, d, POI_OFFSET, f64::INFINITY),
    )
}

/// [`sun_hours()`] of a POI against a scene, with the same ray origin and `tmin` as
/// [`poi_sky_view`].
pub fn poi_sun_hours(scene: &TraceScene, poi: &Poi, table: &SunTable) -> SunHours {
    let origin = poi.ray_origin();
    sun_hours(table, poi.normal, |d| {
        scene.occluded(origin, d, POI_OFFSET, f64::INFINITY)
    })
}

/// [`irradiance::irradiance_hourly`] of a POI against a scene: its plane view from the
/// POI's own bundle ([`SkyBundles::for_poi`], as [`poi_sky_view`]) and one ray per sunlit
/// hour, with the same ray origin and `tmin` as [`poi_sky_view`].
pub fn poi_irradiance(
    scene: &TraceScene,
    poi: &Poi,
    bundles: &SkyBundles,
    table: &irradiance::IrradianceTable,
    opts: &irradiance::IrradianceOptions,
    hourly: Option<&mut Vec<f64>>,
) -> irradiance::Irradiance {
    let origin = poi.ray_origin();
    let blocked = |d| scene.occluded(origin, d, POI_OFFSET, f64::INFINITY);
    let view = irradiance::plane_view(poi.normal, &bundles.for_poi(poi), blocked);
    irradiance::irradiance_hourly(table, poi.normal, view, blocked, opts, hourly)
}

/// [`horizon_profile()`] of a POI against a scene, with the same ray origin and `tmin` as
/// [`poi_sky_view`]; with a normal, the POI's own surface plane is part of the horizon.
pub fn poi_horizon(
    scene: &TraceScene,
    poi: &Poi,
    opts: &HorizonOptions,
) -> Result<HorizonProfile, SolarError> {
    let origin = poi.ray_origin();
    horizon_profile(opts, poi.normal, |d| {
        scene.occluded(origin, d, POI_OFFSET, f64::INFINITY)
    })
}

/// Errors of the solar analysis.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SolarError {
    /// The solar position algorithm rejected its input (coordinates, atmosphere, date).
    #[error("solar position: {0}")]
    Spa(#[from] solar_positioning::Error),
    /// Unknown time zone name or malformed offset.
    #[error("unknown time zone or offset {0:?} (use an IANA name, \"UTC\" or \"+HH:MM\")")]
    TimeZone(String),
    /// Step length outside 1..=1440 minutes, or a step beyond the representable time range.
    #[error("invalid time step of {0} minutes")]
    Step(u32),
    /// Horizon sampling options out of range.
    #[error("invalid horizon options: {0}")]
    Horizon(String),
    /// A year the calendar cannot represent.
    #[error("invalid year {0}")]
    Year(i32),
    /// The caller asked to stop ([`crate::model::runtime::progress::Progress::is_cancelled`]).
    #[error(transparent)]
    Cancelled(#[from] crate::model::runtime::progress::Cancelled),
}
