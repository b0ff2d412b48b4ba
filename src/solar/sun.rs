//! Sun position (NREL SPA through the `solar-positioning` crate) and a precomputed table
//! of sun directions for a calendar year.
//!
//! Positions are topocentric and apparent: SPA's atmospheric refraction correction is
//! applied with the site's pressure and temperature (only while the geometric sun is above
//! SPA's cut-off of -0.83337 degrees elevation, as SPA does). A step is "above the horizon"
//! when the apparent zenith angle is below 90 degrees.
//!
//! # Example
//! ```rust
//! use chrono::{TimeZone, Utc};
//! use skylod::solar::{Site, sun_position};
//! let site = Site::new(41.39, 2.17); // Barcelona
//! let noon = Utc.with_ymd_and_hms(2025, 6, 21, 11, 50, 0).unwrap();
//! let p = sun_position(noon, &site)?;
//! assert!(p.zenith_deg > 17.0 && p.zenith_deg < 19.0);
//! assert!(p.direction.y < 0.0); // the sun stands to the south at noon
//! # Ok::<(), skylod::solar::SolarError>(())
//! ```

use super::ephemeris::SunEphemeris;
use super::SolarError;
use crate::model::runtime::progress::{check, stage, Progress, Silent, Stage};
use chrono::{DateTime, Datelike, Duration, FixedOffset, NaiveDate, Offset, TimeZone, Utc};
use glam::DVec3;
use rayon::prelude::*;
use solar_positioning::{Location, PreparedPositions, RefractionCorrection, SolarPositions};

/// Time zone used to attribute steps to local months: an IANA zone (with daylight saving)
/// or a fixed offset from UTC.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SiteTimeZone {
    /// A fixed offset from UTC (`"UTC"`, `"+01:00"`, `"-0700"`, `"+05"`).
    Fixed(FixedOffset),
    /// A named IANA zone such as `"Europe/Madrid"`.
    Named(chrono_tz::Tz),
}

impl SiteTimeZone {
    /// Parses `"UTC"`, `"Z"`, `"GMT"`, a fixed offset `±HH`, `±HHMM`, `±HH:MM` (optionally
    /// prefixed with `UTC`), or an IANA zone name.
    ///
    /// # Errors
    /// [`SolarError::TimeZone`] if the text is none of these.
    pub fn parse(text: &str) -> Result<Self, SolarError> {
        let t = text.trim();
        let bad = || SolarError::TimeZone(text.to_string());
        let upper = t.to_ascii_uppercase();
        if matches!(upper.as_str(), "UTC" | "Z" | "GMT") {
            return Ok(SiteTimeZone::Fixed(Utc.fix()));
        }
        let offset = upper
            .strip_prefix("UTC")
            .or_else(|| upper.strip_prefix("GMT"))
            .unwrap_or(&upper);
        if let Some(rest) = offset.strip_prefix(['+', '-']) {
            let sign = if offset.starts_with('-') { -1 } else { 1 };
            let digits: String = rest.chars().filter(|c| *c != ':').collect();
            if !digits.chars().all(|c| c.is_ascii_digit()) || rest.matches(':').count() > 1 {
                return Err(bad());
            }
            let (h, m) = match digits.len() {
                1 | 2 => (digits.parse::<i32>().map_err(|_| bad())?, 0),
                4 => (
                    digits
                        .get(..2)
                        .and_then(|s| s.parse::<i32>().ok())
                        .ok_or_else(bad)?,
                    digits
                        .get(2..)
                        .and_then(|s| s.parse::<i32>().ok())
                        .ok_or_else(bad)?,
                ),
                _ => return Err(bad()),
            };
            if h > 14 || m > 59 {
                return Err(bad());
            }
            let secs = sign * (h * 3600 + m * 60);
            return FixedOffset::east_opt(secs)
                .map(SiteTimeZone::Fixed)
                .ok_or_else(bad);
        }
        t.parse::<chrono_tz::Tz>()
            .map(SiteTimeZone::Named)
            .map_err(|_| bad())
    }

    /// Local calendar month (1..=12) of a UTC instant.
    pub fn local_month(&self, utc: DateTime<Utc>) -> u32 {
        match self {
            SiteTimeZone::Fixed(o) => utc.with_timezone(o).month(),
            SiteTimeZone::Named(z) => utc.with_timezone(z).month(),
        }
    }
}

/// Observer site and atmosphere for SPA.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Site {
    /// Geodetic latitude in degrees, north positive.
    pub latitude: f64,
    /// Longitude in degrees, east positive.
    pub longitude: f64,
    /// Elevation above sea level in metres (parallax only).
    pub elevation_m: f64,
    /// Annual mean local pressure in millibars (hPa), for refraction.
    pub pressure_mbar: f64,
    /// Annual mean local temperature in degrees Celsius, for refraction.
    pub temperature_c: f64,
    /// Delta T = TT - UT1 in seconds.
    pub delta_t_s: f64,
    /// Time zone used to attribute table steps to local months.
    pub time_zone: SiteTimeZone,
}

impl Site {
    /// A site at sea level with the standard atmosphere (1013.25 mbar, 15 C), delta T of
    /// 69 s (its value in the early 2020s) and month attribution in UTC.
    pub fn new(latitude: f64, longitude: f64) -> Site {
        Site {
            latitude,
            longitude,
            elevation_m: 0.0,
            pressure_mbar: 1013.25,
            temperature_c: 15.0,
            delta_t_s: 69.0,
            time_zone: SiteTimeZone::Fixed(Utc.fix()),
        }
    }

    /// The same site with the time zone parsed by [`SiteTimeZone::parse`].
    ///
    /// # Errors
    /// [`SolarError::TimeZone`] for an unknown zone or malformed offset.
    pub fn with_time_zone(mut self, zone: &str) -> Result<Site, SolarError> {
        self.time_zone = SiteTimeZone::parse(zone)?;
        Ok(self)
    }

    fn location(&self) -> Location {
        Location {
            latitude: self.latitude,
            longitude: self.longitude,
        }
    }
}

/// Apparent topocentric sun position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SunPosition {
    /// Topocentric zenith angle with refraction, degrees.
    pub zenith_deg: f64,
    /// Topocentric azimuth, degrees clockwise from north, in `[0, 360)`.
    pub azimuth_deg: f64,
    /// Unit vector towards the sun: x east, y north, z up.
    pub direction: DVec3,
}

/// Unit direction (x east, y north, z up) of zenith angle and azimuth (clockwise from
/// north), both in degrees.
pub fn direction_from_angles(zenith_deg: f64, azimuth_deg: f64) -> DVec3 {
    let (sz, cz) = zenith_deg.to_radians().sin_cos();
    let (sa, ca) = azimuth_deg.to_radians().sin_cos();
    DVec3::new(sz * sa, sz * ca, cz)
}

/// Sun position at a UTC instant for `site`, with SPA's refraction correction.
///
/// # Errors
/// [`SolarError::Spa`] for invalid coordinates, atmosphere, elevation or a date outside
/// SPA's range (years -2000..6000).
pub fn sun_position(utc: DateTime<Utc>, site: &Site) -> Result<SunPosition, SolarError> {
    let refraction = RefractionCorrection::new(site.pressure_mbar, site.temperature_c)?;
    let p = SolarPositions::new().at(
        &utc,
        site.location(),
        site.elevation_m,
        site.delta_t_s,
        Some(refraction),
    )?;
    Ok(SunPosition {
        zenith_deg: p.zenith_angle(),
        azimuth_deg: p.azimuth(),
        direction: direction_from_angles(p.zenith_angle(), p.azimuth()),
    })
}

/// One time step of a [`SunTable`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SunStep {
    /// Unit direction towards the sun at the middle of the step (x east, y north, z up):
    /// SPA's, but for the steps with the sun more than 2 degrees below the horizon (see
    /// [`SunTable`]), where it is a quick position's, within 0.05 degrees of SPA's.
    pub direction: DVec3,
    /// Whether the sun is above the horizon (apparent zenith < 90 degrees).
    pub above_horizon: bool,
    /// Local calendar month of the middle of the step, 0 = January .. 11 = December.
    pub month: u8,
}

/// Sun directions for consecutive equal time steps, precomputed once.
///
/// Step `k` stands for the interval `[start + k*step, start + (k+1)*step)`; the sun is
/// evaluated at the middle of the interval (midpoint rule), and the interval is attributed
/// to the local month (site time zone) of that middle instant. For [`SunTable::year`] the
/// steps cover a UTC calendar year, so with a non-UTC zone the first/last few hours of the
/// table fall into the neighbouring local year and are counted in its month (January or
/// December) — a year of steps always yields one full year of hours.
///
/// SPA is skipped at night: in the years 1800-2200, a step that a quick solar position
/// (Meeus' low-accuracy solar coordinates, within 0.05 degrees of SPA) puts more than 2 degrees below the
/// horizon is below it for SPA too; it gets `above_horizon: false` and the quick position's
/// direction without SPA (about half the steps of a year, half the table's cost). Every
/// step with the sun up, and every flag, is SPA's to the bit; the first and the last step
/// always go through SPA, so that a site or a date SPA refuses is refused as before.
#[derive(Debug, Clone, PartialEq)]
pub struct SunTable {
    start: DateTime<Utc>,
    step_minutes: u32,
    steps: Vec<SunStep>,
}

/// Sun elevation (geometric, degrees) below which [`quick_direction`] proves the sun is
/// under the horizon for SPA: SPA refracts only above its cut-off of -0.83337 degrees, and
/// the quick position is within 0.05 degrees of SPA's (tested); the rest is margin.
const NIGHT_DEG: f64 = -2.0;

/// Years (of every step) in which [`quick_direction`] is trusted; outside, every step goes
/// through SPA.
const QUICK_YEARS: std::ops::RangeInclusive<i32> = 1800..=2200;

/// Geometric sun direction (x east, y north, z up; no refraction, no parallax) at `utc`
/// seen from `site`: the low-accuracy solar coordinates of Meeus, *Astronomical
/// Algorithms* ch. 25 (about 0.01 degrees) with delta T, and the mean sidereal time of
/// ch. 12. Only used for the steps far below the horizon ([`NIGHT_DEG`]).
fn quick_direction(utc: DateTime<Utc>, site: &Site) -> DVec3 {
    let jd = utc.timestamp_millis() as f64 / 86_400_000.0 + 2_440_587.5;
    let d = jd - 2_451_545.0;
    // Julian centuries of dynamical time for the sun, of universal time for the Earth's spin
    let t = (d + site.delta_t_s / 86_400.0) / 36_525.0;
    let l0 = 280.46646 + t * (36_000.769_83 + t * 0.0003032);
    let m = (357.52911 + t * (35_999.050_29 - t * 0.0001537)).to_radians();
    let c = (1.914602 - t * (0.004817 + t * 0.000014)) * m.sin()
        + (0.019993 - t * 0.000101) * (2.0 * m).sin()
        + 0.000289 * (3.0 * m).sin();
    let omega = (125.04 - 1934.136 * t).to_radians();
    let lambda = (l0 + c - 0.00569 - 0.00478 * omega.sin()).to_radians();
    let eps = (23.0
        + (26.0 + (21.448 - t * (46.815 + t * (0.00059 - t * 0.001813))) / 60.0) / 60.0
        + 0.00256 * omega.cos())
    .to_radians();
    let alpha = (eps.cos() * lambda.sin()).atan2(lambda.cos());
    let delta = (eps.sin() * lambda.sin()).clamp(-1.0, 1.0).asin();
    let tu = d / 36_525.0;
    let gmst =
        280.460_618_37 + 360.985_647_366_29 * d + tu * tu * (0.000_387_933 - tu / 38_710_000.0);
    let h = (gmst + site.longitude).to_radians() - alpha;
    let (sp, cp) = site.latitude.to_radians().sin_cos();
    let (sd, cd) = delta.sin_cos();
    let (sh, ch) = h.sin_cos();
    DVec3::new(-cd * sh, sd * cp - cd * ch * sp, sd * sp + cd * ch * cp).normalize_or_zero()
}

/// Whether the sun at `utc` is more than `margin_deg` below the elevation under which the
/// table skips SPA ([`NIGHT_DEG`]) for a site near `site`, by the quick position, in the
/// years it is trusted for ([`QUICK_YEARS`]). For work ahead of the table
/// ([`super::ephemeris`]) that need not be done for such steps; the table decides itself.
pub(super) fn night_by_far(utc: DateTime<Utc>, site: &Site, margin_deg: f64) -> bool {
    QUICK_YEARS.contains(&utc.year()) && quick_elevation(utc, site) < NIGHT_DEG - margin_deg
}

/// Start and number of steps of the UTC calendar year `year` at `step_minutes` (the
/// remainder shorter than a step at the end of the year left out).
pub(super) fn year_span(
    year: i32,
    step_minutes: u32,
) -> Result<(DateTime<Utc>, usize), SolarError> {
    let start = Utc
        .with_ymd_and_hms(year, 1, 1, 0, 0, 0)
        .single()
        .ok_or(SolarError::Year(year))?;
    let end =
        NaiveDate::from_ymd_opt(year.saturating_add(1), 1, 1).ok_or(SolarError::Year(year))?;
    let minutes = (end - start.date_naive()).num_minutes();
    if step_minutes == 0 || step_minutes > 1440 {
        return Err(SolarError::Step(step_minutes));
    }
    let steps = usize::try_from(minutes / i64::from(step_minutes)).unwrap_or(0);
    Ok((start, steps))
}

/// The middle of step `k` of `step_s` seconds from `start`, where the sun is evaluated
/// (`None` past the representable range).
pub(super) fn step_mid(start: DateTime<Utc>, step_s: i64, k: usize) -> Option<DateTime<Utc>> {
    let offset = Duration::try_seconds(i64::try_from(k).ok()?.checked_mul(step_s)?)?;
    let half = Duration::milliseconds(step_s * 500);
    start.checked_add_signed(offset)?.checked_add_signed(half)
}

/// Geometric sun elevation in degrees of [`quick_direction`].
fn quick_elevation(utc: DateTime<Utc>, site: &Site) -> f64 {
    quick_direction(utc, site)
        .z
        .clamp(-1.0, 1.0)
        .asin()
        .to_degrees()
}

impl SunTable {
    /// All steps of the UTC calendar year `year` (35,040 steps at 15 minutes; 35,136 in a
    /// leap year). When `step_minutes` does not divide the year, the remainder shorter than
    /// one step at the end of the year is left out.
    ///
    /// # Errors
    /// [`SolarError::Step`] for a step of 0 or more than 1440 minutes,
    /// [`SolarError::Year`] for a year chrono cannot represent, [`SolarError::Spa`] for
    /// invalid site parameters.
    pub fn year(year: i32, step_minutes: u32, site: &Site) -> Result<SunTable, SolarError> {
        SunTable::year_with(year, step_minutes, site, &Silent)
    }

    /// [`SunTable::year`] as a progress stage ([`Stage::Sun`]: items are steps, advanced a
    /// day of steps at a time), cancellable between days.
    ///
    /// # Errors
    /// As [`SunTable::year`]; [`SolarError::Cancelled`] when `progress` asks to stop.
    pub fn year_with(
        year: i32,
        step_minutes: u32,
        site: &Site,
        progress: &dyn Progress,
    ) -> Result<SunTable, SolarError> {
        SunTable::year_ahead(year, step_minutes, site, None, progress)
    }

    /// [`SunTable::year_with`], taking SPA's site-independent half of the steps from `ahead`
    /// where it has them ready (and asking its thread to stop): the same table to the bit
    /// (`super::ephemeris`). An ephemeris of another year, step or delta T is not used.
    ///
    /// # Errors
    /// As [`SunTable::year_with`].
    pub fn year_ahead(
        year: i32,
        step_minutes: u32,
        site: &Site,
        ahead: Option<&SunEphemeris>,
        progress: &dyn Progress,
    ) -> Result<SunTable, SolarError> {
        let (start, steps) = year_span(year, step_minutes)?;
        SunTable::build((start, steps, step_minutes), site, ahead, progress)
    }

    /// `steps` consecutive steps of `step_minutes` from `start` (computed in parallel;
    /// the result does not depend on the thread count).
    ///
    /// # Errors
    /// As [`SunTable::year`].
    pub fn range(
        start: DateTime<Utc>,
        steps: usize,
        step_minutes: u32,
        site: &Site,
    ) -> Result<SunTable, SolarError> {
        SunTable::range_with(start, steps, step_minutes, site, &Silent)
    }

    /// [`SunTable::range`] as a progress stage ([`Stage::Sun`], see [`SunTable::year_with`]).
    ///
    /// # Errors
    /// As [`SunTable::range`]; [`SolarError::Cancelled`] when `progress` asks to stop.
    pub fn range_with(
        start: DateTime<Utc>,
        steps: usize,
        step_minutes: u32,
        site: &Site,
        progress: &dyn Progress,
    ) -> Result<SunTable, SolarError> {
        SunTable::build((start, steps, step_minutes), site, None, progress)
    }

    /// The table of `steps` steps of `step_minutes` from `start`, with SPA's
    /// site-independent half from `ahead` where ready.
    fn build(
        (start, steps, step_minutes): (DateTime<Utc>, usize, u32),
        site: &Site,
        ahead: Option<&SunEphemeris>,
        progress: &dyn Progress,
    ) -> Result<SunTable, SolarError> {
        if step_minutes == 0 || step_minutes > 1440 {
            return Err(SolarError::Step(step_minutes));
        }
        if let Some(a) = ahead {
            a.stop();
        }
        let refraction = RefractionCorrection::new(site.pressure_mbar, site.temperature_c)?;
        let spa = SolarPositions::new();
        let location = site.location();
        let step_s = i64::from(step_minutes) * 60;
        let in_years =
            |k: usize| step_mid(start, step_s, k).is_some_and(|t| QUICK_YEARS.contains(&t.year()));
        let quick = steps > 2
            && in_years(0)
            && in_years(steps - 1)
            && site.delta_t_s.abs() <= 86_400.0
            && (-90.0..=90.0).contains(&site.latitude)
            && (-180.0..=180.0).contains(&site.longitude);
        let one = |k: usize, prepared: Option<&PreparedPositions>| {
            let mid = step_mid(start, step_s, k).ok_or(SolarError::Step(step_minutes))?;
            let month = u8::try_from(site.time_zone.local_month(mid).saturating_sub(1))
                .unwrap_or(0)
                .min(11);
            if quick && k != 0 && k + 1 != steps {
                let q = quick_direction(mid, site);
                if q.z.clamp(-1.0, 1.0).asin().to_degrees() < NIGHT_DEG {
                    return Ok(SunStep {
                        direction: q,
                        above_horizon: false,
                        month,
                    });
                }
            }
            // `spa.at` is `for_time` then `at`: the same operations with the half ahead
            let p = match prepared {
                Some(p) => p.at(location, site.elevation_m, Some(refraction))?,
                None => spa.at(
                    &mid,
                    location,
                    site.elevation_m,
                    site.delta_t_s,
                    Some(refraction),
                )?,
            };
            Ok(SunStep {
                direction: direction_from_angles(p.zenith_angle(), p.azimuth()),
                above_horizon: p.zenith_angle() < 90.0,
                month,
            })
        };
        // A day of steps per task: the check between days, the order of the steps kept.
        let per_day = SunEphemeris::per_day(step_minutes);
        let table = (start, steps, step_minutes, site.delta_t_s);
        let steps = stage(progress, Stage::Sun, steps as u64, 0, || {
            let days: Vec<Vec<SunStep>> = (0..steps.div_ceil(per_day))
                .into_par_iter()
                .map(|d| {
                    check(progress, Stage::Sun)?;
                    let ks = d * per_day..((d + 1) * per_day).min(steps);
                    let n = ks.len() as u64;
                    let ready = ahead.and_then(|a| a.day(table, d));
                    let day = (ks.enumerate())
                        .map(|(i, k)| one(k, ready.and_then(|r| r.get(i)?.as_ref())))
                        .collect::<Result<Vec<_>, SolarError>>()?;
                    progress.advance(Stage::Sun, n, 0, None);
                    Ok(day)
                })
                .collect::<Result<_, SolarError>>()?;
            Ok::<_, SolarError>(days.concat())
        })?;
        Ok(SunTable {
            start,
            step_minutes,
            steps,
        })
    }

    /// The steps in time order.
    pub fn steps(&self) -> &[SunStep] {
        &self.steps
    }

    /// Number of steps.
    pub fn len(&self) -> usize {
        self.steps.len()
    }

    /// Whether the table has no steps.
    pub fn is_empty(&self) -> bool {
        self.steps.is_empty()
    }

    /// Step length in minutes.
    pub fn step_minutes(&self) -> u32 {
        self.step_minutes
    }

    /// Step length in hours.
    pub fn step_hours(&self) -> f64 {
        f64::from(self.step_minutes) / 60.0
    }

    /// Start of the first step (UTC).
    pub fn start(&self) -> DateTime<Utc> {
        self.start
    }

    /// Start of step `k` (UTC), or `None` past the representable range.
    pub fn step_start(&self, k: usize) -> Option<DateTime<Utc>> {
        let secs = i64::try_from(k)
            .ok()?
            .checked_mul(i64::from(self.step_minutes) * 60)?;
        self.start.checked_add_signed(Duration::try_seconds(secs)?)
    }

    /// The instant at which step `k` was evaluated (its middle), or `None`.
    pub fn step_mid(&self, k: usize) -> Option<DateTime<Utc>> {
        self.step_start(k)?
            .checked_add_signed(Duration::seconds(i64::from(self.step_minutes) * 30))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn nrel_site() -> Site {
        Site {
            latitude: 39.742476,
            longitude: -105.1786,
            elevation_m: 1830.14,
            pressure_mbar: 820.0,
            temperature_c: 11.0,
            delta_t_s: 67.0,
            time_zone: SiteTimeZone::parse("-07:00").unwrap(),
        }
    }

    #[test]
    fn nrel_reference_case() {
        let local = FixedOffset::west_opt(7 * 3600)
            .unwrap()
            .with_ymd_and_hms(2003, 10, 17, 12, 30, 30)
            .unwrap();
        let p = sun_position(local.with_timezone(&Utc), &nrel_site()).unwrap();
        assert!((p.zenith_deg - 50.111622).abs() < 3e-4, "{}", p.zenith_deg);
        assert!(
            (p.azimuth_deg - 194.340241).abs() < 3e-4,
            "{}",
            p.azimuth_deg
        );
        let d = p.direction;
        assert!((d.length() - 1.0).abs() < 1e-12);
        assert!((d.z - p.zenith_deg.to_radians().cos()).abs() < 1e-12);
        // Azimuth 194 deg: south, slightly west.
        assert!(d.y < 0.0 && d.x < 0.0);
    }

    #[test]
    fn invalid_site_is_an_error() {
        let t = Utc.with_ymd_and_hms(2020, 1, 1, 0, 0, 0).unwrap();
        assert!(sun_position(t, &Site::new(95.0, 0.0)).is_err());
        let mut s = Site::new(10.0, 0.0);
        s.pressure_mbar = -1.0;
        assert!(sun_position(t, &s).is_err());
        assert!(SunTable::year(2020, 0, &Site::new(10.0, 0.0)).is_err());
        assert!(SunTable::year(2020, 15, &Site::new(10.0, 200.0)).is_err());
    }

    #[test]
    fn time_zone_parsing() {
        let utc = SiteTimeZone::parse("UTC").unwrap();
        assert_eq!(utc, SiteTimeZone::Fixed(FixedOffset::east_opt(0).unwrap()));
        for (s, secs) in [
            ("+01:00", 3600),
            ("-07:00", -25200),
            ("+0530", 19800),
            ("UTC+02", 7200),
            ("-3", -10800),
        ] {
            assert_eq!(
                SiteTimeZone::parse(s).unwrap(),
                SiteTimeZone::Fixed(FixedOffset::east_opt(secs).unwrap()),
                "{s}"
            );
        }
        assert!(matches!(
            SiteTimeZone::parse("Europe/Madrid").unwrap(),
            SiteTimeZone::Named(chrono_tz::Tz::Europe__Madrid)
        ));
        for bad in ["Mars/Olympus", "+25:00", "+1:2:3", "+01:61", "", "+abc"] {
            assert!(SiteTimeZone::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn local_month_with_dst_zone() {
        let z = SiteTimeZone::parse("Europe/Madrid").unwrap();
        // 2025-05-31 22:30 UTC is 2025-06-01 00:30 CEST (UTC+2).
        let t = Utc.with_ymd_and_hms(2025, 5, 31, 22, 30, 0).unwrap();
        assert_eq!(z.local_month(t), 6);
        let f = SiteTimeZone::parse("+01:00").unwrap();
        assert_eq!(f.local_month(t), 5);
    }

    /// Counts the sun stage's steps; asks to stop once `stop_after` steps are done.
    struct Steps {
        started: std::sync::atomic::AtomicU64,
        done: std::sync::atomic::AtomicU64,
        finished: std::sync::atomic::AtomicBool,
        stop_after: u64,
    }

    impl Steps {
        fn new(stop_after: u64) -> Steps {
            Steps {
                started: 0.into(),
                done: 0.into(),
                finished: false.into(),
                stop_after,
            }
        }
    }

    impl Progress for Steps {
        fn start(&self, stage: Stage, items: u64, _: u64) {
            assert_eq!(stage, Stage::Sun);
            self.started
                .store(items, std::sync::atomic::Ordering::Relaxed);
        }
        fn advance(&self, stage: Stage, items: u64, _: u64, _: Option<&str>) {
            assert_eq!(stage, Stage::Sun);
            self.done
                .fetch_add(items, std::sync::atomic::Ordering::Relaxed);
        }
        fn finish(&self, _: Stage) {
            self.finished
                .store(true, std::sync::atomic::Ordering::Relaxed);
        }
        fn is_cancelled(&self) -> bool {
            self.done.load(std::sync::atomic::Ordering::Relaxed) >= self.stop_after
        }
    }

    #[test]
    fn the_sun_table_is_a_progress_stage_that_can_be_cancelled() {
        use std::sync::atomic::Ordering::Relaxed;
        let site = Site::new(48.76, 11.42);
        // Every step announced is done, the table is the one without progress.
        let p = Steps::new(u64::MAX);
        let t = SunTable::year_with(2025, 15, &site, &p).unwrap();
        assert_eq!(p.started.load(Relaxed), 35_040);
        assert_eq!(p.done.load(Relaxed), 35_040);
        assert!(p.finished.load(Relaxed));
        assert_eq!(t, SunTable::year(2025, 15, &site).unwrap());
        // A step that does not divide a day: the last day's steps are short, all counted.
        let p = Steps::new(u64::MAX);
        let t = SunTable::year_with(2025, 7, &site, &p).unwrap();
        assert_eq!(p.done.load(Relaxed), t.len() as u64);
        // Asked to stop after the first days: Cancelled, named by the stage, well before
        // the year is done (at most one day per thread goes on after the request).
        let p = Steps::new(96 * 3);
        let e = SunTable::year_with(2025, 15, &site, &p).unwrap_err();
        assert_eq!(
            e,
            SolarError::Cancelled(crate::model::runtime::progress::Cancelled { stage: Stage::Sun })
        );
        assert_eq!(
            e.to_string(),
            "cancelled while computing the sun's positions"
        );
        assert!(p.finished.load(Relaxed));
        let threads = rayon::current_num_threads() as u64;
        assert!(
            p.done.load(Relaxed) <= 96 * (3 + threads),
            "{}",
            p.done.load(Relaxed)
        );
        // Cancelled before it begins: no step is computed.
        let p = Steps::new(0);
        assert!(SunTable::year_with(2025, 15, &site, &p).is_err());
        assert_eq!(p.done.load(Relaxed), 0);
    }

    #[test]
    fn year_table_shape_and_months() {
        let site = Site::new(41.39, 2.17)
            .with_time_zone("Europe/Madrid")
            .unwrap();
        let t = SunTable::year(2025, 60, &site).unwrap();
        assert_eq!(t.len(), 8760);
        assert_eq!(t.step_hours(), 1.0);
        // 2025-01-01 00:30 UTC = 01:30 local: January. Last step 23:30 UTC Dec 31 =
        // 00:30 Jan 1 2026 local: attributed to January.
        assert_eq!(t.steps()[0].month, 0);
        assert_eq!(t.steps()[t.len() - 1].month, 0);
        assert_eq!(t.steps()[t.len() - 2].month, 11);
        let mut per_month = [0usize; 12];
        for s in t.steps() {
            per_month[usize::from(s.month)] += 1;
        }
        // June: 30 days * 24 h; October has 25 local hours more (DST ends).
        assert_eq!(per_month[5], 720);
        assert_eq!(per_month[9], 31 * 24 + 1);
        let above = t.steps().iter().filter(|s| s.above_horizon).count();
        // Roughly half the hours of the year are daytime (a bit more with refraction).
        assert!((4300..4600).contains(&above), "{above}");
        // Each step agrees with a direct evaluation at its middle.
        // (SPA's to the bit with the sun up; at night, within 0.05 degrees)
        for k in [0, 1000, 4321, 8759] {
            let p = sun_position(t.step_mid(k).unwrap(), &site).unwrap();
            let tol = if p.zenith_deg < 92.0 { 1e-12 } else { 1e-3 };
            assert!((p.direction - t.steps()[k].direction).length() < tol);
            assert_eq!(p.zenith_deg < 90.0, t.steps()[k].above_horizon);
        }
        let y15 = SunTable::year(2025, 15, &Site::new(0.0, 0.0)).unwrap();
        assert_eq!(y15.len(), 35_040);
        assert_eq!(SunTable::year(2024, 15, &site).unwrap().len(), 35_136);
    }

    #[test]
    fn table_is_deterministic_across_thread_counts() {
        let site = Site::new(-33.9, 18.4);
        let a = SunTable::year(2023, 180, &site).unwrap();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let b = pool.install(|| SunTable::year(2023, 180, &site).unwrap());
        assert_eq!(a, b);
    }

    /// The table as it was before SPA was skipped at night: every step by SPA.
    fn every_step_by_spa(year: i32, step_minutes: u32, site: &Site) -> Vec<SunStep> {
        let start = Utc.with_ymd_and_hms(year, 1, 1, 0, 0, 0).unwrap();
        let end = NaiveDate::from_ymd_opt(year + 1, 1, 1).unwrap();
        let steps = (end - start.date_naive()).num_minutes() / i64::from(step_minutes);
        let refraction = RefractionCorrection::new(site.pressure_mbar, site.temperature_c).unwrap();
        let step_s = i64::from(step_minutes) * 60;
        (0..steps)
            .map(|k| {
                let mid = start + Duration::seconds(k * step_s + step_s / 2);
                let p = SolarPositions::new()
                    .at(
                        &mid,
                        site.location(),
                        site.elevation_m,
                        site.delta_t_s,
                        Some(refraction),
                    )
                    .unwrap();
                SunStep {
                    direction: direction_from_angles(p.zenith_angle(), p.azimuth()),
                    above_horizon: p.zenith_angle() < 90.0,
                    month: (site.time_zone.local_month(mid) - 1) as u8,
                }
            })
            .collect()
    }

    /// Skipping SPA at night changes no flag, no month and no step with the sun up (to the
    /// bit), and moves the night directions by less than 0.05 degrees; outside 1800-2200
    /// every step is SPA's.
    #[test]
    fn night_steps_skip_spa_and_change_no_step_with_the_sun_up() {
        let mut high = Site::new(-22.9, -68.2).with_time_zone("-04:00").unwrap();
        (high.elevation_m, high.pressure_mbar, high.temperature_c) = (4000.0, 620.0, -5.0);
        let mut late = Site::new(35.0, 139.7);
        late.delta_t_s = 3000.0;
        let madrid = Site::new(41.39, 2.17)
            .with_time_zone("Europe/Madrid")
            .unwrap();
        let cases = [
            (2025, 15, Site::new(41.38, 2.17), true),
            (2024, 60, madrid, true),
            (2025, 30, Site::new(78.2, 15.6), true),
            (2023, 20, Site::new(-89.9, 0.0), true),
            (2026, 15, Site::new(0.0, -179.9), true),
            (2025, 45, high, true),
            (2030, 60, late, true),
            (1700, 180, Site::new(51.5, 0.0), false),
            (2300, 180, Site::new(-33.9, 18.4), false),
        ];
        for (year, step, site, quick) in cases {
            let want = every_step_by_spa(year, step, &site);
            let got = SunTable::year(year, step, &site).unwrap();
            assert_eq!(got.len(), want.len());
            let mut skipped = 0;
            for (k, (g, w)) in got.steps().iter().zip(&want).enumerate() {
                assert_eq!(g.above_horizon, w.above_horizon, "{year} {site:?} {k}");
                assert_eq!(g.month, w.month);
                if g.direction.to_array().map(f64::to_bits)
                    != w.direction.to_array().map(f64::to_bits)
                {
                    skipped += 1;
                    assert!(!w.above_horizon && w.direction.z < -0.03, "{year} {k}");
                    assert!(g.direction.angle_between(w.direction).to_degrees() < 0.05);
                }
            }
            // half the steps of a year, but at the poles
            if quick && site.latitude.abs() < 70.0 {
                assert!(skipped * 3 > want.len(), "{year} {site:?}: {skipped}");
            }
            if !quick {
                assert_eq!(skipped, 0);
            }
        }
    }

    /// The quick elevation is within 0.05 degrees of SPA's geometric elevation over the
    /// years it is trusted for (the margin to the night threshold is over a degree).
    #[test]
    fn quick_elevation_is_close_to_spa() {
        let mut worst: f64 = 0.0;
        for year in [1800, 1900, 2025, 2100, 2200] {
            for (lat, lon, dt) in [
                (41.38, 2.17, 69.0),
                (78.2, 15.6, 69.0),
                (-89.9, 0.0, 0.0),
                (0.0, -179.9, 69.0),
                (-33.9, 18.4, 300.0),
            ] {
                let mut site = Site::new(lat, lon);
                site.delta_t_s = dt;
                let start = Utc.with_ymd_and_hms(year, 1, 1, 0, 0, 0).unwrap();
                for k in 0..900 {
                    let t = start + Duration::minutes(k * 587);
                    let p = SolarPositions::new()
                        .at(&t, site.location(), 0.0, site.delta_t_s, None)
                        .unwrap();
                    let e = quick_elevation(t, &site) - (90.0 - p.zenith_angle());
                    worst = worst.max(e.abs());
                }
            }
        }
        assert!(worst < 0.05, "{worst}");
        const { assert!(NIGHT_DEG + 0.05 < -0.83337 - 1.0) };
    }
}
