//! The half of a [`SunTable`] that does not depend on the site, computed ahead on a core
//! nothing else wants.
//!
//! SPA's expensive part (the Earth's heliocentric longitude, latitude and radius from their
//! periodic terms, nutation, the obliquity of the ecliptic, the apparent sidereal time, the
//! sun's geocentric right ascension and declination) depends only on the instant and delta T;
//! the site (latitude, longitude, elevation, atmosphere) enters only in the cheap rest: hour
//! angle, topocentric parallax, refraction, azimuth and zenith angle. A [`SunEphemeris`]
//! computes the first half for every step of a year on a background thread, started before
//! the model (which gives the site) is read; [`SunTable::year_ahead`] then takes what is ready
//! and computes the rest as [`SunTable::year_with`] does. The table is the same to the bit
//! either way: `solar_positioning`'s `SolarPositions::at` is exactly `for_time` followed by
//! `PreparedPositions::at`, and both halves are those same calls.
//!
//! The work goes to rayon's pool a day of steps at a time, one day in flight, from a thread
//! that only waits: a worker takes such a day only when it finds no other work to steal, so
//! the days fill the pool's idle stretches (in `lod`, the one-core merge and assembly at the
//! end of the read) rather than slow what they run beside. A thread of its own would not do:
//! at the normal priority it shares the cores with the reading threads, and at Linux's
//! `SCHED_IDLE` it gets no core at all while other processes keep them busy; nor would one
//! job going through the days and running the pool's other work between them
//! (`rayon::yield_now`: it never sleeps, and the read's one-core tail slows beside it). It
//! stops at the next step once the table is built from it ([`SunEphemeris::stop`]) or the ephemeris is
//! dropped; nothing waits for it.
//!
//! Given a site near the one the table will have ([`SunEphemeris::year_near`], e.g. from the
//! first city objects of the model, found by the feeding thread before its first day), the steps at which
//! the sun is then far below the horizon ([`NIGHT_MARGIN_DEG`] below where the table skips
//! SPA) are left out: the table needs no SPA there, and for any such step it does need (a
//! site far from the one given) it computes SPA itself, as for a day not done. The table is
//! the same whatever the ephemeris holds.
//!
//! ```rust
//! use skylod::solar::{Site, SunEphemeris, SunTable};
//! use skylod::model::Silent;
//! let site = Site::new(41.39, 2.17);
//! let ahead = SunEphemeris::year(2025, 60, site.delta_t_s)?;
//! // ... the model is read here, and gives the site ...
//! let table = SunTable::year_ahead(2025, 60, &site, Some(&ahead), &Silent)?;
//! assert_eq!(table, SunTable::year(2025, 60, &site)?);
//! # Ok::<(), skylod::solar::SolarError>(())
//! ```
//!
//! [`SunTable`]: super::SunTable
//! [`SunTable::year_ahead`]: super::SunTable::year_ahead
//! [`SunTable::year_with`]: super::SunTable::year_with

use super::sun::{night_by_far, step_mid, year_span};
use super::{Site, SolarError};
use chrono::{DateTime, Utc};
use solar_positioning::{PreparedPositions, SolarPositions};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

/// SPA's site-independent half of every step of a year, computed on a background thread
/// (module docs).
#[derive(Debug)]
pub struct SunEphemeris {
    shared: Arc<Shared>,
}

#[derive(Debug)]
struct Shared {
    start: DateTime<Utc>,
    step_minutes: u32,
    steps: usize,
    delta_t_s: f64,
    per_day: usize,
    /// A day of steps (`per_day`, the table's tasks), set once the whole day is done; a step
    /// SPA refused is `None` (the table computes it again and gets the error where it did).
    days: Vec<OnceLock<Box<[Option<PreparedPositions>]>>>,
    stop: AtomicBool,
}

impl SunEphemeris {
    /// Starts computing the steps of the UTC calendar year `year` at `step_minutes` for
    /// `delta_t_s` (the site's delta T) on a background thread, as [`super::SunTable::year`]
    /// lays them out. If no thread can be started, nothing is computed ahead (the table is
    /// then built as without it). The days go to rayon's global pool, which this builds if it
    /// is not yet built: size it first (`ThreadPoolBuilder::build_global`) if it should not
    /// have one thread per core.
    ///
    /// # Errors
    /// As [`super::SunTable::year`] for the year and the step.
    pub fn year(year: i32, step_minutes: u32, delta_t_s: f64) -> Result<Self, SolarError> {
        SunEphemeris::year_near(year, step_minutes, delta_t_s, || None)
    }

    /// [`SunEphemeris::year`] for a table whose site is probably near the one `near` gives
    /// (called on the background thread before its first day; `None`: no idea): the steps at which the sun
    /// is then far below the horizon are not computed (module docs). The table built from it
    /// is the same as without it, for any site.
    ///
    /// # Errors
    /// As [`SunEphemeris::year`].
    pub fn year_near(
        year: i32,
        step_minutes: u32,
        delta_t_s: f64,
        near: impl FnOnce() -> Option<Site> + Send + 'static,
    ) -> Result<Self, SolarError> {
        let (start, steps) = year_span(year, step_minutes)?;
        let per_day = day_steps(step_minutes);
        let shared = Arc::new(Shared {
            start,
            step_minutes,
            steps,
            delta_t_s,
            per_day,
            days: (0..steps.div_ceil(per_day))
                .map(|_| OnceLock::new())
                .collect(),
            stop: AtomicBool::new(false),
        });
        // rayon's pool made by this thread, not the feeder (whose name its workers would take)
        rayon::current_num_threads();
        let feeder = Arc::clone(&shared);
        // Not started: the table computes every step itself.
        let _ = std::thread::Builder::new()
            .name("sun-ephemeris".into())
            .spawn(move || feeder.feed(near));
        Ok(SunEphemeris { shared })
    }

    /// Asks the thread to stop at its next step; the days done so far stay.
    pub fn stop(&self) {
        self.shared.stop.store(true, Ordering::Relaxed);
    }

    /// Steps computed so far (whole days).
    pub fn ready(&self) -> usize {
        let s = &self.shared;
        (s.days.iter().enumerate())
            .filter(|(_, d)| d.get().is_some())
            .map(|(d, _)| s.day_len(d))
            .sum()
    }

    /// The prepared steps of day `d` of a table of `steps` steps of `step_minutes` from
    /// `start` with `delta_t_s`, when this ephemeris is of that table and has the day done.
    pub(super) fn day(
        &self,
        (start, steps, step_minutes, delta_t_s): (DateTime<Utc>, usize, u32, f64),
        d: usize,
    ) -> Option<&[Option<PreparedPositions>]> {
        let s = &self.shared;
        let same = s.start == start
            && s.steps == steps
            && s.step_minutes == step_minutes
            && s.delta_t_s.to_bits() == delta_t_s.to_bits();
        if !same {
            return None;
        }
        s.days.get(d)?.get().map(|b| &b[..])
    }

    /// Steps of the day tasks of a table of `step_minutes` (shared with the table's build).
    pub(super) fn per_day(step_minutes: u32) -> usize {
        day_steps(step_minutes)
    }
}

impl Drop for SunEphemeris {
    fn drop(&mut self) {
        self.stop();
    }
}

impl Shared {
    fn day_len(&self, d: usize) -> usize {
        ((d + 1) * self.per_day).min(self.steps) - (d * self.per_day).min(self.steps)
    }

    /// Every day in order until asked to stop, one day at a time as a job of rayon's pool
    /// injected from this (non-worker) thread, which waits for it: a worker takes such a job
    /// only when it finds no other work (it steals first), and never two at once. The steps
    /// far into the night at the site `near` gives (asked first, on this thread) are left out.
    fn feed(self: Arc<Self>, near: impl FnOnce() -> Option<Site>) {
        let near = near();
        for d in 0..self.days.len() {
            if self.stop.load(Ordering::Relaxed) {
                return;
            }
            let (done, wait) = std::sync::mpsc::sync_channel(1);
            let me = Arc::clone(&self);
            rayon::spawn(move || {
                me.compute_day(d, &SolarPositions::new(), near.as_ref());
                let _ = done.send(());
            });
            if wait.recv().is_err() {
                return;
            }
        }
    }

    /// Day `d`, stored when whole (stops at the step it is asked to); a step far into the
    /// night at `near` is left as `None`.
    fn compute_day(&self, d: usize, spa: &SolarPositions, near: Option<&Site>) {
        let step_s = i64::from(self.step_minutes) * 60;
        let ks = d * self.per_day..((d + 1) * self.per_day).min(self.steps);
        let mut day = Vec::with_capacity(ks.len());
        for k in ks {
            if self.stop.load(Ordering::Relaxed) {
                return;
            }
            let mid = step_mid(self.start, step_s, k);
            let wanted =
                |t: &DateTime<Utc>| near.is_none_or(|s| !night_by_far(*t, s, NIGHT_MARGIN_DEG));
            day.push(
                mid.filter(wanted)
                    .and_then(|t| spa.for_time(&t, self.delta_t_s).ok()),
            );
        }
        if let Some(slot) = self.days.get(d) {
            let _ = slot.set(day.into_boxed_slice());
        }
    }
}

/// Degrees below the table's night threshold from which a step at the site an ephemeris is
/// given ([`SunEphemeris::year_near`]) is left out. The sun's zenith angle differs between two
/// sites by at most their angular distance: 5 degrees are 556 km, far more than between a
/// city's first objects and its centre.
pub const NIGHT_MARGIN_DEG: f64 = 5.0;

/// A day of steps of `step_minutes` (at least one).
fn day_steps(step_minutes: u32) -> usize {
    (1440 / step_minutes.max(1) as usize).max(1)
}

#[cfg(test)]
mod tests {
    use super::super::SunTable;
    use super::*;
    use crate::model::runtime::progress::Silent;

    /// Waits (bounded) until the thread has done every day.
    fn finished(e: &SunEphemeris) -> bool {
        let all = e.shared.steps;
        for _ in 0..2000 {
            if e.ready() == all {
                return true;
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        false
    }

    /// The bits of every direction of `t`.
    fn bits(t: &SunTable) -> Vec<[u64; 3]> {
        (t.steps().iter())
            .map(|s| s.direction.to_array().map(f64::to_bits))
            .collect()
    }

    /// Whole, partial or foreign ephemeris: the table is the one built without it, to the bit
    /// (SunTable's PartialEq compares f64 by value; the directions' bits are compared too).
    #[test]
    fn the_table_from_an_ephemeris_is_the_table_without() {
        let madrid = Site::new(41.39, 2.17)
            .with_time_zone("Europe/Madrid")
            .unwrap();
        let mut high = Site::new(-22.9, -68.2);
        (high.elevation_m, high.pressure_mbar, high.temperature_c) = (4000.0, 620.0, -5.0);
        for (year, step, site) in [(2025, 15, madrid), (2024, 60, high)] {
            let plain = SunTable::year(year, step, &site).unwrap();
            let whole = SunEphemeris::year(year, step, site.delta_t_s).unwrap();
            assert!(finished(&whole));
            let t = SunTable::year_ahead(year, step, &site, Some(&whole), &Silent).unwrap();
            assert_eq!((&t, bits(&t)), (&plain, bits(&plain)));
            // stopped at once: whatever it had done, the same table
            let part = SunEphemeris::year(year, step, site.delta_t_s).unwrap();
            part.stop();
            let t = SunTable::year_ahead(year, step, &site, Some(&part), &Silent).unwrap();
            assert_eq!((&t, bits(&t)), (&plain, bits(&plain)));
            // another year, another step, another delta T: not used, same table
            let mut other = site;
            other.delta_t_s += 1.0;
            for e in [
                SunEphemeris::year(year + 1, step, site.delta_t_s).unwrap(),
                SunEphemeris::year(year, step * 2, site.delta_t_s).unwrap(),
                SunEphemeris::year(year, step, other.delta_t_s).unwrap(),
            ] {
                assert!(finished(&e));
                let t = SunTable::year_ahead(year, step, &site, Some(&e), &Silent).unwrap();
                assert_eq!((&t, bits(&t)), (&plain, bits(&plain)));
            }
        }
    }

    /// An ephemeris given a site leaves out the steps deep in that site's night, and only
    /// those; the table from it is the table without, at that site and at sites far away.
    #[test]
    fn an_ephemeris_near_a_site_leaves_out_its_nights_only() {
        let year = 2025;
        let site = Site::new(48.14, 11.58);
        let e = SunEphemeris::year_near(year, 30, site.delta_t_s, move || Some(site)).unwrap();
        assert!(finished(&e));
        let (start, steps) = year_span(year, 30).unwrap();
        let (mut left_out, mut night) = (0, 0);
        for k in 0..steps {
            let t = step_mid(start, 30 * 60, k).unwrap();
            let deep = night_by_far(t, &site, NIGHT_MARGIN_DEG);
            let day = e.day((start, steps, 30, site.delta_t_s), k / 48).unwrap();
            assert_eq!(day[k % 48].is_none(), deep, "step {k}");
            left_out += usize::from(day[k % 48].is_none());
            night += usize::from(night_by_far(t, &site, 0.0));
        }
        // about a third of the year's steps, fewer than the table skips itself
        assert!(
            left_out > steps / 4 && left_out < night,
            "{left_out} {night} {steps}"
        );
        let plain = SunTable::year(year, 30, &site).unwrap();
        let t = SunTable::year_ahead(year, 30, &site, Some(&e), &Silent).unwrap();
        assert_eq!((&t, bits(&t)), (&plain, bits(&plain)));
        for far in [Site::new(-33.9, 151.2), Site::new(48.14, -100.0)] {
            let plain = SunTable::year(year, 30, &far).unwrap();
            let t = SunTable::year_ahead(year, 30, &far, Some(&e), &Silent).unwrap();
            assert_eq!((&t, bits(&t)), (&plain, bits(&plain)));
        }
    }

    /// A whole ephemeris has SPA's half of every step, and a foreign one answers no day.
    #[test]
    fn every_day_is_prepared_and_matched_to_its_table() {
        let e = SunEphemeris::year(2024, 30, 69.0).unwrap();
        assert!(finished(&e));
        assert_eq!(e.ready(), 366 * 48);
        let (start, steps) = year_span(2024, 30).unwrap();
        let day = e.day((start, steps, 30, 69.0), 365).unwrap();
        assert_eq!(day.len(), 48);
        assert!(day.iter().all(Option::is_some));
        assert!(e.day((start, steps, 30, 68.0), 0).is_none());
        assert!(e.day((start, steps, 15, 69.0), 0).is_none());
        assert!(e.day((start, steps, 30, 69.0), 366).is_none());
        assert!(SunEphemeris::year(2024, 0, 69.0).is_err());
    }
}
