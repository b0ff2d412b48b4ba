//! Horizon profiles: the skyline elevation seen from a point, per azimuth, in the convention
//! of PVGIS horizon files and pvlib (azimuth in degrees clockwise from north, elevation in
//! degrees above the horizontal). Model +Y is north, +X east, +Z up.
//!
//! The skyline elevation at an azimuth is the **lower edge of the visible sky** there: going
//! up from the horizontal, the first elevation at which the sky is open (what pvlib and
//! PVGIS expect: the sun below it is blocked). Under an overhang (an eave, a balcony, an
//! arcade) the sky above that visible band is blocked again; the profile reports where, as
//! the `overhang` of the azimuth (`None` when the band is open to the zenith). Sky above an
//! overhang (a second visible band) is not reported: the profile predicts it blocked. Both
//! are found per azimuth by
//!
//! 1. marching up from the floor (0°, or the surface's plane, below) in steps of
//!    [`HorizonOptions::march_deg`] (0.25° by default) to the first open sample, and on to
//!    the first blocked sample above it;
//! 2. bisecting each blocked–open transition until the bracket is narrower than
//!    [`HorizonOptions::tolerance_deg`] (0.01° by default) and reporting its middle.
//!
//! Nothing open up to the zenith: the skyline is 90° (no overhang). A visible gap or an
//! obstruction narrower than the march step can be missed. Elevations below the horizontal
//! are not searched: the profile is never negative.
//!
//! With a surface normal, directions behind the surface (`dot(n, d) < 0`) count as
//! obstructed: the surface's own plane is part of the horizon (a wall sees nothing of the
//! half-space behind it, a roof sloping south loses the low northern sky). That part is
//! exact ([`plane_elevation`]); the march only searches above it. Sun hours masked by such a
//! profile ([`HorizonProfile::is_blocked`]) equal [`super::sun_hours()`] of the same point up
//! to the resolution, except for sun in a second visible band above an overhang.
//!
//! # Example
//! ```rust
//! use glam::DVec3;
//! use skylod::solar::{HorizonOptions, horizon_profile};
//! // Floor centre of an infinitely long north-south canyon, walls x = ±5 m, 10 m high.
//! let blocked = |d: DVec3| d.x != 0.0 && 5.0 / d.x.abs() * d.z < 10.0;
//! let p = horizon_profile(&HorizonOptions::default(), None, blocked)?;
//! assert_eq!(p.azimuth.len(), 360);
//! let east = p.elevation_at(90.0);
//! assert!((east - 2f64.atan().to_degrees()).abs() < 0.01); // atan(2H/W) = 63.43°
//! assert!(p.elevation_at(0.0) < 0.01); // open along the canyon
//! # Ok::<(), skylod::solar::SolarError>(())
//! ```

use super::SolarError;
use glam::DVec3;

/// Sampling of [`horizon_profile`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HorizonOptions {
    /// Azimuth step in degrees (0.01..=90); azimuths are `k * step` below 360.
    pub step_deg: f64,
    /// Elevation march step in degrees (0.01..=10).
    pub march_deg: f64,
    /// Width in degrees below which the bisection of the top transition stops (> 0).
    pub tolerance_deg: f64,
}

impl Default for HorizonOptions {
    fn default() -> Self {
        HorizonOptions {
            step_deg: 1.0,
            march_deg: 0.25,
            tolerance_deg: 0.01,
        }
    }
}

impl HorizonOptions {
    /// These options with another azimuth step.
    pub fn with_step(self, step_deg: f64) -> Self {
        HorizonOptions { step_deg, ..self }
    }

    /// Check the ranges documented on the fields.
    pub fn validate(&self) -> Result<(), SolarError> {
        let ok = (0.01..=90.0).contains(&self.step_deg)
            && (0.01..=10.0).contains(&self.march_deg)
            && self.tolerance_deg.is_finite()
            && self.tolerance_deg > 0.0;
        if ok {
            Ok(())
        } else {
            Err(SolarError::Horizon(format!(
                "azimuth step {} (0.01..=90), march {} (0.01..=10), tolerance {} (> 0)",
                self.step_deg, self.march_deg, self.tolerance_deg
            )))
        }
    }

    /// The azimuths sampled: `k * step_deg` for every `k` with `k * step_deg < 360`.
    pub fn azimuths(&self) -> Vec<f64> {
        let n = (360.0 / self.step_deg - 1e-9).ceil().max(1.0) as usize;
        (0..n).map(|k| k as f64 * self.step_deg).collect()
    }
}

/// A horizon profile: `elevation[k]` is the skyline elevation at `azimuth[k]` (degrees).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct HorizonProfile {
    /// Azimuths, degrees clockwise from north, increasing from 0, below 360.
    pub azimuth: Vec<f64>,
    /// Skyline elevations in degrees above the horizontal, 0..=90: the lower edge of the
    /// first visible band of sky going up from the horizontal (90: no sky at this azimuth).
    pub elevation: Vec<f64>,
    /// Where sky above the skyline is blocked again (an eave, a balcony, an arcade): the
    /// elevation at which that blocking starts; `None` when the band is open to the zenith.
    pub overhang: Vec<Option<f64>>,
}

impl HorizonProfile {
    /// The skyline elevation at any azimuth: linear interpolation between the samples,
    /// wrapping around north (as pvlib and PVGIS interpolate horizon files).
    pub fn elevation_at(&self, azimuth_deg: f64) -> f64 {
        let n = self.azimuth.len().min(self.elevation.len());
        if n == 0 {
            return 0.0;
        }
        let a = azimuth_deg.rem_euclid(360.0);
        // Index of the last sample at or before `a` (samples increase from >= 0).
        let i = self.azimuth[..n].partition_point(|&x| x <= a);
        let (i0, i1) = if i == 0 { (n - 1, 0) } else { (i - 1, i % n) };
        let (a0, mut a1) = (self.azimuth[i0], self.azimuth[i1]);
        let mut x = a;
        if a1 <= a0 {
            a1 += 360.0;
        }
        if x < a0 {
            x += 360.0;
        }
        let (e0, e1) = (self.elevation[i0], self.elevation[i1]);
        if a1 - a0 <= 0.0 {
            return e0;
        }
        e0 + (e1 - e0) * (x - a0) / (a1 - a0)
    }

    /// True when the direction `d` (any length) lies below the skyline: its elevation is
    /// lower than [`Self::elevation_at`] its azimuth.
    pub fn is_below(&self, d: DVec3) -> bool {
        let (az, el) = azimuth_elevation(d);
        el < self.elevation_at(az)
    }

    /// The overhang at any azimuth: the value of the nearest sample (no interpolation: an
    /// overhang's edge is not continuous across azimuths the way a skyline is).
    pub fn overhang_at(&self, azimuth_deg: f64) -> Option<f64> {
        let n = self.azimuth.len().min(self.overhang.len());
        if n == 0 {
            return None;
        }
        let a = azimuth_deg.rem_euclid(360.0);
        let dist = |x: f64| {
            let d = (x - a).abs();
            d.min(360.0 - d)
        };
        let k = (0..n)
            .min_by(|&i, &j| dist(self.azimuth[i]).total_cmp(&dist(self.azimuth[j])))
            .unwrap_or(0);
        self.overhang[k]
    }

    /// True when the profile predicts the direction `d` blocked: below the skyline, or at
    /// or above the overhang of its azimuth. Only the first visible band counts as sky.
    pub fn is_blocked(&self, d: DVec3) -> bool {
        let (az, el) = azimuth_elevation(d);
        self.is_below(d) || self.overhang_at(az).is_some_and(|o| el >= o)
    }
}

/// Unit direction of `azimuth_deg` (clockwise from north = +Y, east = +X) and
/// `elevation_deg` (above the horizontal, +Z up).
pub fn direction(azimuth_deg: f64, elevation_deg: f64) -> DVec3 {
    let (sa, ca) = azimuth_deg.to_radians().sin_cos();
    let (se, ce) = elevation_deg.to_radians().sin_cos();
    DVec3::new(sa * ce, ca * ce, se)
}

/// Azimuth (0..360, clockwise from north) and elevation (degrees) of a direction.
pub fn azimuth_elevation(d: DVec3) -> (f64, f64) {
    let az = d.x.atan2(d.y).to_degrees().rem_euclid(360.0);
    let el = d.z.atan2(d.x.hypot(d.y)).to_degrees();
    (az, el)
}

/// The first visible band at one azimuth searched above `floor` degrees: its lower edge
/// (the skyline; 90 when nothing is open) and, when sky above it is blocked again, the
/// elevation where that blocking starts (the overhang; `None` when open to the zenith).
pub fn band_above(
    azimuth_deg: f64,
    floor: f64,
    opts: &HorizonOptions,
    blocked: impl Fn(DVec3) -> bool,
) -> (f64, Option<f64>) {
    let floor = floor.max(0.0);
    if floor >= 90.0 {
        return (90.0, None);
    }
    let at = |e: f64| blocked(direction(azimuth_deg, e));
    let n = (90.0 / opts.march_deg).ceil().max(1.0) as usize;
    let sample = |k: usize| (k as f64 * opts.march_deg).min(90.0);
    // Bisect a transition between `lo` (state `lo_blocked`) and `hi` (the other state).
    let bisect = |mut lo: f64, mut hi: f64, lo_blocked: bool| {
        while hi - lo > opts.tolerance_deg {
            let mid = 0.5 * (lo + hi);
            if at(mid) == lo_blocked {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    };
    // March up from the floor to the first open sample: the skyline.
    let first = (floor / opts.march_deg).ceil() as usize;
    let skyline = if !at(floor) {
        floor
    } else {
        let Some(k) = (first..=n).find(|&k| sample(k) > floor && !at(sample(k))) else {
            return (90.0, None);
        };
        let below = if k == 0 {
            floor
        } else {
            sample(k - 1).max(floor)
        };
        bisect(below, sample(k), true).max(floor)
    };
    // March on to the first blocked sample above the skyline: the overhang.
    let start = (skyline / opts.march_deg).floor() as usize + 1;
    let overhang = (start..=n)
        .find(|&k| sample(k) > skyline && at(sample(k)))
        .map(|k| {
            let open = sample(k - 1).max(skyline);
            bisect(open, sample(k), false)
        });
    (skyline, overhang)
}

/// The highest elevation (degrees, 0..=90) at `azimuth_deg` that lies behind the plane of a
/// surface with unit `normal` (`dot(normal, d) < 0`): 90 behind a vertical wall or under a
/// downward-facing surface, `atan(-(n_h . u) / n_z)` for an upward-facing one, 0 in front.
pub fn plane_elevation(normal: DVec3, azimuth_deg: f64) -> f64 {
    let (sa, ca) = azimuth_deg.to_radians().sin_cos();
    let a = normal.x * sa + normal.y * ca;
    let b = normal.z;
    const EPS: f64 = 1e-12;
    if b < -EPS {
        90.0
    } else if b <= EPS {
        if a < -EPS {
            90.0
        } else {
            0.0
        }
    } else {
        (-a).atan2(b).to_degrees().max(0.0)
    }
}

/// The horizon profile of a point: the skyline elevation (`band_above` from 0) at every azimuth of `opts`.
/// `blocked(dir)` tells whether the ray from the point towards the unit direction `dir` is
/// obstructed; with a `normal`, directions behind the surface count as obstructed (module
/// docs): the profile is never below `plane_elevation`. A zero or non-finite normal is
/// ignored.
pub fn horizon_profile(
    opts: &HorizonOptions,
    normal: Option<DVec3>,
    blocked: impl Fn(DVec3) -> bool,
) -> Result<HorizonProfile, SolarError> {
    opts.validate()?;
    let n = normal.and_then(|n| n.try_normalize());
    let azimuth = opts.azimuths();
    let (elevation, overhang) = azimuth
        .iter()
        .map(|&a| {
            let floor = n.map_or(0.0, |n| plane_elevation(n, a));
            band_above(a, floor, opts, &blocked)
        })
        .unzip();
    Ok(HorizonProfile {
        azimuth,
        elevation,
        overhang,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const TOL: f64 = 0.01;

    /// Floor centre (0, 0, 0) of a north-south canyon of walls x = ±w/2, height h, length l
    /// (y in -l/2..l/2), each wall the face of a building `depth` deep.
    fn canyon(w: f64, h: f64, l: f64, depth: f64) -> impl Fn(DVec3) -> bool {
        move |d: DVec3| {
            [-1.0, 1.0].iter().any(|&side: &f64| {
                // Building: x in side*(w/2 .. w/2+depth), y in -l/2..l/2, z in 0..h.
                let (x0, x1) = if side > 0.0 {
                    (w / 2.0, w / 2.0 + depth)
                } else {
                    (-w / 2.0 - depth, -w / 2.0)
                };
                ray_box(d, [x0, -l / 2.0, 0.0], [x1, l / 2.0, h])
            })
        }
    }

    /// Slab test of a ray from the origin against an axis-aligned box.
    fn ray_box(d: DVec3, lo: [f64; 3], hi: [f64; 3]) -> bool {
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for i in 0..3 {
            if d[i].abs() < 1e-15 {
                if 0.0 < lo[i] || 0.0 > hi[i] {
                    return false;
                }
                continue;
            }
            let (a, b) = (lo[i] / d[i], hi[i] / d[i]);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        t0 <= t1
    }

    #[test]
    fn direction_round_trip() {
        for (a, e) in [(0.0, 0.0), (90.0, 10.0), (180.0, 45.0), (271.5, 89.0)] {
            let d = direction(a, e);
            assert!((d.length() - 1.0).abs() < 1e-12);
            let (a2, e2) = azimuth_elevation(d);
            assert!((a2 - a).abs() < 1e-9 && (e2 - e).abs() < 1e-9, "{a} {e}");
        }
        assert!(direction(90.0, 0.0).abs_diff_eq(DVec3::X, 1e-12));
        assert!(direction(0.0, 0.0).abs_diff_eq(DVec3::Y, 1e-12));
    }

    #[test]
    fn canyon_matches_closed_form_at_every_azimuth() {
        let (w, h, l) = (10.0, 10.0, 400.0);
        let p = horizon_profile(&HorizonOptions::default(), None, canyon(w, h, l, 8.0)).unwrap();
        for (&a, &e) in p.azimuth.iter().zip(&p.elevation) {
            // Horizontal distance to the wall plane, if the hit lies along the wall.
            let s = a.to_radians().sin().abs();
            let c = a.to_radians().cos().abs();
            let expect = if s > 0.0 && (w / 2.0) / s * c <= l / 2.0 {
                (h * s / (w / 2.0)).atan().to_degrees()
            } else {
                // Past the wall's end: the end face of the building (y = ±l/2).
                let t = (l / 2.0) / c;
                let x = t * s;
                if x >= w / 2.0 && x <= w / 2.0 + 8.0 {
                    (h / t).atan().to_degrees()
                } else {
                    0.0
                }
            };
            assert!((e - expect).abs() <= TOL, "azimuth {a}: {e} vs {expect}");
        }
        assert!((p.elevation_at(90.0) - 2f64.atan().to_degrees()).abs() <= TOL);
        assert!((p.elevation_at(270.0) - 2f64.atan().to_degrees()).abs() <= TOL);
        assert!(p.elevation_at(0.0) < 1.5 && p.elevation_at(180.0) < 1.5);
    }

    #[test]
    fn overhang_is_reported_above_open_sky() {
        // A slab 8..9 m high spanning x in 4..12 to the east: the sky below it is open (the
        // skyline is 0), the slab's far lower edge atan(8 / 12) starts the overhang, above its
        // near top edge atan(9 / 4) a second band is open (not reported).
        let slab = |d: DVec3| ray_box(d, [4.0, -50.0, 8.0], [12.0, 50.0, 9.0]);
        let o = HorizonOptions::default();
        let (e, over) = band_above(90.0, 0.0, &o, slab);
        assert_eq!(e, 0.0);
        let expect = (8.0f64 / 12.0).atan().to_degrees();
        let over = over.unwrap();
        assert!((over - expect).abs() <= TOL, "{over} vs {expect}");
        // The far side sees nothing, up to the zenith.
        assert_eq!(band_above(270.0, 0.0, &o, slab), (0.0, None));
        // The profile predicts the slab blocked and the sky under it open.
        let p = horizon_profile(&o.with_step(90.0), None, slab).unwrap();
        assert!(p.is_blocked(direction(90.0, 40.0)));
        assert!(!p.is_blocked(direction(90.0, 20.0)));
        assert!(!p.is_blocked(direction(270.0, 80.0)));
    }

    #[test]
    fn eave_over_a_wall_foot() {
        // Under an eave: a wall 1 m west of the point (x = -1, 6 m high), an eave 3 m up
        // reaching 1.5 m east of the wall (x in -1..0.5). West: wall, no sky (90). East:
        // open from 0 up to the eave's edge atan(3 / 0.5) = 80.54°.
        let scene = |d: DVec3| {
            ray_box(d, [-2.0, -20.0, -1.0], [-1.0, 20.0, 6.0])
                || ray_box(d, [-1.0, -20.0, 3.0], [0.5, 20.0, 3.2])
        };
        let o = HorizonOptions::default();
        assert_eq!(band_above(270.0, 0.0, &o, scene), (90.0, None));
        let (e, over) = band_above(90.0, 0.0, &o, scene);
        assert_eq!(e, 0.0);
        let expect = (3.0f64 / 0.5).atan().to_degrees();
        assert!((over.unwrap() - expect).abs() <= TOL, "{over:?}");
        // A low wall to the east raises the skyline, the eave stays the overhang.
        let walled = |d: DVec3| scene(d) || ray_box(d, [5.0, -20.0, -1.0], [6.0, 20.0, 1.0]);
        let (e, over) = band_above(90.0, 0.0, &o, walled);
        assert!((e - (1.0f64 / 5.0).atan().to_degrees()).abs() <= TOL, "{e}");
        assert!((over.unwrap() - expect).abs() <= TOL);
    }

    #[test]
    fn open_roofed_and_wall() {
        let o = HorizonOptions::default().with_step(10.0);
        let open = horizon_profile(&o, None, |_| false).unwrap();
        assert_eq!(open.azimuth.len(), 36);
        assert!(open.elevation.iter().all(|&e| e == 0.0));
        assert!(open.overhang.iter().all(Option::is_none));
        let roofed = horizon_profile(&o, None, |_| true).unwrap();
        assert!(roofed.elevation.iter().all(|&e| e == 90.0));
        assert!(roofed.overhang.iter().all(Option::is_none));
        // A south-facing wall (normal -Y) sees nothing northwards: 90° there, 0° south.
        let wall = horizon_profile(&o, Some(DVec3::NEG_Y), |_| false).unwrap();
        assert_eq!(wall.elevation_at(0.0), 90.0);
        assert_eq!(wall.elevation_at(180.0), 0.0);
        assert_eq!(wall.elevation_at(90.0), 0.0);
        // A roof tilted 30° towards the south: its plane hides the low northern sky.
        let n = DVec3::new(0.0, -30f64.to_radians().sin(), 30f64.to_radians().cos());
        let roof = horizon_profile(&o, Some(n), |_| false).unwrap();
        assert!((roof.elevation_at(0.0) - 30.0).abs() <= 1e-9);
        assert_eq!(roof.elevation_at(180.0), 0.0);
        // Facing down: everything up to the zenith is behind.
        let down = horizon_profile(&o, Some(DVec3::NEG_Z), |_| false).unwrap();
        assert!(down.elevation.iter().all(|&e| e == 90.0));
        // An obstacle above the plane still counts.
        let high = horizon_profile(&o, Some(n), |d| d.z < 0.8).unwrap();
        assert!((high.elevation_at(0.0) - 0.8f64.asin().to_degrees()).abs() <= TOL);
    }

    #[test]
    fn interpolation_wraps_around_north() {
        let p = HorizonProfile {
            azimuth: vec![0.0, 90.0, 180.0, 270.0],
            elevation: vec![10.0, 20.0, 30.0, 40.0],
            overhang: vec![None, Some(60.0), None, None],
        };
        assert_eq!(p.elevation_at(45.0), 15.0);
        assert_eq!(p.elevation_at(315.0), 25.0);
        assert_eq!(p.elevation_at(-45.0), 25.0);
        assert_eq!(p.elevation_at(360.0), 10.0);
        assert!(p.is_below(direction(180.0, 29.0)));
        assert!(!p.is_below(direction(180.0, 31.0)));
        assert_eq!(p.overhang_at(80.0), Some(60.0));
        assert_eq!(p.overhang_at(140.0), None);
        assert!(p.is_blocked(direction(95.0, 61.0)));
        assert!(!p.is_blocked(direction(95.0, 59.0)));
        assert!(!p.is_blocked(direction(0.0, 61.0)));
    }

    #[test]
    fn options_are_checked() {
        for step in [0.0, -1.0, 91.0, f64::NAN] {
            let o = HorizonOptions::default().with_step(step);
            assert!(horizon_profile(&o, None, |_| false).is_err(), "{step}");
        }
        assert_eq!(
            HorizonOptions::default().with_step(7.0).azimuths().len(),
            52
        );
        assert_eq!(
            HorizonOptions::default().with_step(0.5).azimuths().len(),
            720
        );
    }
}
