//! Horizon profiles: the skyline elevation seen from a point, per azimuth, in the convention
//! of PVGIS horizon files and pvlib (azimuth in degrees clockwise from north, elevation in
//! degrees above the horizontal). Model +Y is north, +X east, +Z up.
//!
//! The skyline elevation at an azimuth is the **highest obstructed elevation** there: under
//! an overhang (a balcony, a bridge, an arcade) the sky below it may be open, but the sun
//! behind the overhang is blocked, so the band counts. It is found per azimuth by
//!
//! 1. marching down from the zenith in steps of [`HorizonOptions::march_deg`] (0.25° by
//!    default) to the horizontal; the first blocked sample is the highest obstructed
//!    sample (nothing blocked: the skyline is at 0°);
//! 2. bisecting the open–blocked transition just above that sample until the bracket is
//!    narrower than [`HorizonOptions::tolerance_deg`] (0.01° by default) and reporting its
//!    middle.
//!
//! An obstruction whose angular height is smaller than the march step, lying entirely
//! above the first blocked sample (a thin mast above a roof line), can be missed; the
//! bisection then bounds the error by one march step. Elevations below the horizontal are
//! not searched: the profile is never negative.
//!
//! With a surface normal, directions behind the surface (`dot(n, d) < 0`) count as
//! obstructed: the surface's own plane is part of the horizon (a wall sees nothing of the
//! half-space behind it, a roof sloping south loses the low northern sky). That part is
//! exact ([`plane_elevation`]); the march only searches above it. Sun hours masked by such a
//! profile equal [`super::sun_hours()`] of the same point up to the resolution.
//!
//! # Example
//! ```rust
//! use glam::DVec3;
//! use skylod::solar::horizon::{horizon_profile, HorizonOptions};
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
#[derive(Debug, Clone, PartialEq)]
pub struct HorizonProfile {
    /// Azimuths, degrees clockwise from north, increasing from 0, below 360.
    pub azimuth: Vec<f64>,
    /// Skyline elevations in degrees above the horizontal, 0..=90.
    pub elevation: Vec<f64>,
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

/// The skyline elevation (degrees) at one azimuth: the highest elevation at which
/// `blocked(direction)` is true, found by the march-and-bisect of the module docs; 0 when
/// nothing from the horizontal to the zenith is blocked, 90 when the zenith is.
pub fn skyline_elevation(
    azimuth_deg: f64,
    opts: &HorizonOptions,
    blocked: impl Fn(DVec3) -> bool,
) -> f64 {
    skyline_above(azimuth_deg, 0.0, opts, blocked)
}

/// [`skyline_elevation`] searched only above `floor` degrees (returned when nothing above it
/// is blocked).
fn skyline_above(
    azimuth_deg: f64,
    floor: f64,
    opts: &HorizonOptions,
    blocked: impl Fn(DVec3) -> bool,
) -> f64 {
    if floor >= 90.0 {
        return 90.0;
    }
    let at = |e: f64| blocked(direction(azimuth_deg, e));
    let n = (90.0 / opts.march_deg).ceil().max(1.0) as usize;
    let sample = |k: usize| (k as f64 * opts.march_deg).min(90.0);
    // March down from the zenith (sample n = 90°) to the floor.
    let lowest = (floor / opts.march_deg).floor().max(0.0) as usize;
    let Some(k) = (lowest..=n).rev().find(|&k| at(sample(k))) else {
        return floor.max(0.0);
    };
    if k == n {
        return 90.0;
    }
    // Top transition inside (sample k: blocked, sample k + 1: open).
    let (mut lo, mut hi) = (sample(k), sample(k + 1));
    while hi - lo > opts.tolerance_deg {
        let mid = 0.5 * (lo + hi);
        if at(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (0.5 * (lo + hi)).max(floor)
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

/// The horizon profile of a point: [`skyline_elevation`] at every azimuth of `opts`.
/// `blocked(dir)` tells whether the ray from the point towards the unit direction `dir` is
/// obstructed; with a `normal`, directions behind the surface count as obstructed (module
/// docs): the profile is never below [`plane_elevation`]. A zero or non-finite normal is
/// ignored.
pub fn horizon_profile(
    opts: &HorizonOptions,
    normal: Option<DVec3>,
    blocked: impl Fn(DVec3) -> bool,
) -> Result<HorizonProfile, SolarError> {
    opts.validate()?;
    let n = normal.and_then(|n| n.try_normalize());
    let azimuth = opts.azimuths();
    let elevation = azimuth
        .iter()
        .map(|&a| {
            let floor = n.map_or(0.0, |n| plane_elevation(n, a));
            skyline_above(a, floor, opts, &blocked)
        })
        .collect();
    Ok(HorizonProfile { azimuth, elevation })
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
    fn overhang_counts_above_open_sky() {
        // A slab 8..9 m high spanning x in 4..12 (north of nothing, to the east): the sky
        // below it is open, the skyline is its top front edge atan(9 / 4).
        let slab = |d: DVec3| ray_box(d, [4.0, -50.0, 8.0], [12.0, 50.0, 9.0]);
        let e = skyline_elevation(90.0, &HorizonOptions::default(), slab);
        assert!((e - (9.0f64 / 4.0).atan().to_degrees()).abs() <= TOL, "{e}");
        // Below the band (under atan(8 / 12)) the sky is open.
        assert!(!slab(direction(
            90.0,
            (8.0f64 / 12.0).atan().to_degrees() - 1.0
        )));
        // The far side sees nothing.
        assert_eq!(
            skyline_elevation(270.0, &HorizonOptions::default(), slab),
            0.0
        );
    }

    #[test]
    fn open_roofed_and_wall() {
        let o = HorizonOptions::default().with_step(10.0);
        let open = horizon_profile(&o, None, |_| false).unwrap();
        assert_eq!(open.azimuth.len(), 36);
        assert!(open.elevation.iter().all(|&e| e == 0.0));
        let roofed = horizon_profile(&o, None, |_| true).unwrap();
        assert!(roofed.elevation.iter().all(|&e| e == 90.0));
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
        };
        assert_eq!(p.elevation_at(45.0), 15.0);
        assert_eq!(p.elevation_at(315.0), 25.0);
        assert_eq!(p.elevation_at(-45.0), 25.0);
        assert_eq!(p.elevation_at(360.0), 10.0);
        assert!(p.is_below(direction(180.0, 29.0)));
        assert!(!p.is_below(direction(180.0, 31.0)));
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
