//! Solar analysis beside the LoD pipeline (paper 3, 5): sun positions ([`sun`]), sky view
//! factor and sky exposure ([`mod@svf`]) and sun hours ([`mod@sun_hours`]).
//!
//! All three take the scene only through an occlusion predicate (`true` = blocked), so
//! they work with any ray caster; parallelism over points of interest is the caller's.

pub mod sun;
pub mod sun_hours;
pub mod svf;

pub use sun::{sun_position, Site, SiteTimeZone, SunPosition, SunStep, SunTable};
pub use sun_hours::{sun_hours, visible_steps, SunHours};
pub use svf::{sky_view, SkyBundles, SkyView};

/// Errors of the solar analysis.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
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
    /// A year the calendar cannot represent.
    #[error("invalid year {0}")]
    Year(i32),
}
