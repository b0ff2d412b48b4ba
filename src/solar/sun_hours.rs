//! Sun hours of a point over a precomputed [`SunTable`] (paper 3, 5).
//!
//! A step counts when the sun is above the horizon, in front of the surface
//! (`dot(n, s) > 0`) and the ray towards it is not blocked; hours = counted steps x step
//! length. `normal = None`, or a zero / non-finite normal, means a horizontal surface
//! facing up (then "in front" is the same as "above the horizon").
//!
//! # Example
//! ```rust
//! use glam::DVec3;
//! use skylod::solar::{sun_hours, Site, SunTable};
//! let table = SunTable::year(2025, 60, &Site::new(41.39, 2.17))?;
//! let open = sun_hours(&table, None, |_| false);
//! assert_eq!(open.hours, open.possible_hours);
//! assert!(open.hours > 4300.0 && open.hours < 4600.0);
//! // A north-facing wall in Barcelona sees the sun only on summer mornings and evenings.
//! let north = sun_hours(&table, Some(DVec3::Y), |_| false);
//! assert!(north.hours < 0.3 * open.hours && north.monthly[0] == 0.0);
//! # Ok::<(), skylod::solar::SolarError>(())
//! ```

use super::sun::SunTable;
use glam::DVec3;

/// Result of [`sun_hours`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SunHours {
    /// Hours of direct sun over the table.
    pub hours: f64,
    /// The same per local month (index 0 = January), see [`SunTable`] for attribution.
    pub monthly: [f64; 12],
    /// Hours the sun is above the horizon and in front of the surface, blocked or not.
    pub possible_hours: f64,
    /// Number of counted steps (`hours / step length`).
    pub steps: usize,
}

/// Indices of the steps in which the sun is above the horizon, in front of the surface
/// and `blocked(sun_direction)` is false, in time order.
pub fn visible_steps<'a>(
    table: &'a SunTable,
    normal: Option<DVec3>,
    blocked: impl Fn(DVec3) -> bool + 'a,
) -> impl Iterator<Item = usize> + 'a {
    let n = normal.and_then(|n| n.try_normalize()).unwrap_or(DVec3::Z);
    table
        .steps()
        .iter()
        .enumerate()
        .filter(move |(_, s)| s.above_horizon && n.dot(s.direction) > 0.0)
        .filter(move |(_, s)| !blocked(s.direction))
        .map(|(k, _)| k)
}

/// Sun hours of a surface with `normal` over `table`; `blocked(dir)` tells whether the ray
/// from the point towards the sun direction `dir` is obstructed.
pub fn sun_hours(
    table: &SunTable,
    normal: Option<DVec3>,
    blocked: impl Fn(DVec3) -> bool,
) -> SunHours {
    let n = normal.and_then(|n| n.try_normalize()).unwrap_or(DVec3::Z);
    let mut monthly_steps = [0usize; 12];
    let mut possible = 0usize;
    let mut counted = 0usize;
    for s in table.steps() {
        if !(s.above_horizon && n.dot(s.direction) > 0.0) {
            continue;
        }
        possible += 1;
        if !blocked(s.direction) {
            counted += 1;
            if let Some(m) = monthly_steps.get_mut(usize::from(s.month)) {
                *m += 1;
            }
        }
    }
    let h = table.step_hours();
    SunHours {
        hours: counted as f64 * h,
        monthly: monthly_steps.map(|c| c as f64 * h),
        possible_hours: possible as f64 * h,
        steps: counted,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solar::sun::Site;
    use chrono::{Duration, NaiveDate, TimeZone, Utc};
    use solar_positioning::{
        ElevationTarget, Horizon, Location, RefractionCorrection, SolarEvents, SolarPositions,
    };

    const BCN: (f64, f64) = (41.39, 2.17);

    #[test]
    fn barcelona_open_sky_matches_day_length() {
        let site = Site::new(BCN.0, BCN.1);
        let step = 15u32;
        let table = SunTable::year(2025, step, &site).unwrap();
        let steps_per_day = (24 * 60 / step) as usize;
        assert_eq!(table.len(), 365 * steps_per_day);
        let spa = SolarPositions::new();
        let loc = Location {
            latitude: BCN.0,
            longitude: BCN.1,
        };
        // Sunrise/sunset as crossings of apparent elevation 0 (the table's criterion),
        // found by the crate's root search rather than by sampling.
        let target = ElevationTarget {
            angle: 0.0,
            height: 0.0,
            refraction: Some(RefractionCorrection::standard()),
        };
        let mut total = 0usize;
        for day in 0..365usize {
            let d0 = table.start() + Duration::days(day as i64);
            let d1 = d0 + Duration::days(1);
            let rise = spa
                .next_elevation_rise(&d0, &d1, loc, site.delta_t_s, target)
                .unwrap()
                .unwrap();
            let set = spa
                .next_elevation_set(&d0, &d1, loc, site.delta_t_s, target)
                .unwrap()
                .unwrap();
            let length_h = (set - rise).num_milliseconds() as f64 / 3.6e6;
            let day_steps = &table.steps()[day * steps_per_day..(day + 1) * steps_per_day];
            let count = day_steps.iter().filter(|s| s.above_horizon).count();
            let hours = count as f64 * table.step_hours();
            assert!(
                (hours - length_h).abs() <= table.step_hours() + 1e-9,
                "day {day}: {hours} h vs {length_h} h"
            );
            total += count;
        }
        let sh = sun_hours(&table, None, |_| false);
        assert_eq!(sh.steps, total);
        assert_eq!(sh.hours, sh.possible_hours);
        assert!((sh.monthly.iter().sum::<f64>() - sh.hours).abs() < 1e-9);
        // June days are longer than December days.
        assert!(sh.monthly[5] / 30.0 > sh.monthly[11] / 31.0 + 5.0);
    }

    #[test]
    fn barcelona_day_length_against_standard_sunrise() {
        // Cross-check with the conventional sunrise/sunset (upper limb, -0.833 deg): the
        // apparent-centre day is shorter by only a few minutes.
        let site = Site::new(BCN.0, BCN.1);
        let ev = SolarEvents::new();
        let loc = Location {
            latitude: BCN.0,
            longitude: BCN.1,
        };
        for (m, d) in [(3, 20), (6, 21), (12, 21)] {
            let date = NaiveDate::from_ymd_opt(2025, m, d).unwrap();
            let e = ev
                .for_date(date, &Utc, loc, site.delta_t_s, Horizon::SunriseSunset)
                .unwrap();
            let conventional = (e.sets[0] - e.rises[0]).num_seconds() as f64 / 3600.0;
            let start = Utc.from_utc_datetime(&date.and_hms_opt(0, 0, 0).unwrap());
            let t = SunTable::range(start, 1440, 1, &site).unwrap();
            let h = sun_hours(&t, None, |_| false).hours;
            assert!(
                h < conventional && conventional - h < 0.15,
                "{h} {conventional}"
            );
        }
    }

    /// Bottom centre of an infinitely long north-south canyon (walls x = +-W/2, height H).
    fn ns_canyon(d: DVec3) -> bool {
        let (w, h) = (10.0, 60.0);
        if d.x == 0.0 {
            return false;
        }
        let t = (w / 2.0) / d.x.abs();
        t * d.z < h
    }

    #[test]
    fn deep_canyon_sees_only_midday() {
        let site = Site::new(BCN.0, BCN.1)
            .with_time_zone("Europe/Madrid")
            .unwrap();
        let table = SunTable::year(2025, 5, &site).unwrap();
        let open = sun_hours(&table, None, |_| false);
        let sh = sun_hours(&table, None, ns_canyon);
        assert!(sh.hours > 0.0 && sh.hours < 0.1 * open.hours, "{sh:?}");
        assert!(sh.monthly[5] > 0.0 && sh.monthly[6] > 0.0);
        let ev = SolarEvents::new();
        let loc = Location {
            latitude: BCN.0,
            longitude: BCN.1,
        };
        let mut n = 0;
        for k in visible_steps(&table, None, ns_canyon) {
            let mid = table.step_mid(k).unwrap();
            let date = mid.date_naive();
            let e = ev
                .for_date(date, &Utc, loc, site.delta_t_s, Horizon::SunriseSunset)
                .unwrap();
            let noon = e.transits[0];
            let off = (mid - noon).num_seconds().abs();
            assert!(
                off <= 40 * 60,
                "step {k} at {mid}: {off} s from noon {noon}"
            );
            n += 1;
        }
        assert_eq!(n, sh.steps);
    }

    #[test]
    fn surface_orientation() {
        let site = Site::new(BCN.0, BCN.1);
        let table = SunTable::year(2025, 30, &site).unwrap();
        let south = sun_hours(&table, Some(DVec3::NEG_Y), |_| false);
        let north = sun_hours(&table, Some(DVec3::Y), |_| false);
        let east = sun_hours(&table, Some(DVec3::X), |_| false);
        let west = sun_hours(&table, Some(DVec3::NEG_X), |_| false);
        let open = sun_hours(&table, None, |_| false);
        // East + west facades together see every daytime step except exact noon ones.
        assert!((east.hours + west.hours - open.hours).abs() <= 366.0 * 0.5);
        assert!(south.hours > north.hours);
        // North wall: no sun in winter (Dec, Jan) at 41 N.
        assert_eq!(north.monthly[0] + north.monthly[11], 0.0);
        // Blocking everything leaves only the possible hours.
        let dark = sun_hours(&table, Some(DVec3::NEG_Y), |_| true);
        assert_eq!((dark.hours, dark.steps), (0.0, 0));
        assert_eq!(dark.possible_hours, south.possible_hours);
        // Facing down: nothing possible.
        let down = sun_hours(&table, Some(DVec3::NEG_Z), |_| false);
        assert_eq!(down.possible_hours, 0.0);
    }
}
