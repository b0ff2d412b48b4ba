//! Exact checks of SVF, sky exposure and sun hours through the real ray caster
//! (DESIGN.md, "Solar analysis").
//!
//! Scenes are built from boxes with `SceneBuilder`; "infinitely long" walls are boxes
//! 10 km long (the missing sky beyond their ends is below 1e-3 of the hemisphere from
//! the points used). Coordinates are UTM-sized so the f32 shift of the scene is exercised.
//!
//! Closed forms (beta = elevation of the wall top seen from the point, perpendicular to
//! the walls):
//! * canyon floor centre, beta = atan(2H/W): SVF = cos(beta), sky exposure = 1 - 2 beta/pi
//!   (DESIGN.md);
//! * horizontal point at distance D from one wall, beta = atan(H/D): SVF = (1 + cos beta)/2
//!   (DESIGN.md), sky exposure = 1 - beta/pi (derived here: the blocked part of the
//!   hemisphere is a lune of dihedral angle beta with solid angle 2 beta, over 2 pi);
//! * unobstructed horizontal surface: 1 and 1; unobstructed vertical surface: 0.5 and 0.5;
//! * base of a canyon wall facing across, H = W: SVF = (1 - H/sqrt(H^2 + W^2))/2
//!   (DESIGN.md), sky exposure = (pi/2 - atan(H/W))/pi (derived here: the quarter sphere in
//!   front of the wall, pi, less the lune of dihedral atan(H/W) under the opposite wall's
//!   top, 2 atan(H/W), over 2 pi).
//!
//! Sun hours are checked against an independent low-precision solar position (NOAA's
//! "General Solar Position Calculations", Spencer's series, with SPA's refraction formula):
//! day length per day at Barcelona, and the timing of sun in a deep north-south canyon.

use chrono::{DateTime, Datelike, Timelike, Utc};
use glam::DVec3;
use skylod::poi::Poi;
use skylod::poi::POI_OFFSET;
use skylod::solar::{poi_sky_view, poi_sun_hours, visible_steps, Site, SkyBundles, SunTable};
use skylod::trace::{Scene, SceneBuilder};
use std::f64::consts::{FRAC_PI_2, PI};

const UTM: DVec3 = DVec3::new(430_000.0, 4_581_000.0, 12.0);
const TOL: f64 = 0.005;
const LONG: f64 = 5_000.0;

fn add_box(b: &mut SceneBuilder, lo: DVec3, hi: DVec3, tag: u32) {
    let c = |i: usize| {
        DVec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    };
    for q in [
        [0, 4, 6, 2],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 2, 3, 1],
        [4, 5, 7, 6],
    ] {
        let p = q.map(c);
        assert!(b.add_triangle(tag, [p[0], p[1], p[2]]));
        assert!(b.add_triangle(tag, [p[0], p[2], p[3]]));
    }
}

/// A wall 1 m thick whose face towards the origin is the plane x = `x` (relative to UTM),
/// from z = 0 to `h`, 10 km long in y. `side` = -1 for a wall west of the face.
fn wall(b: &mut SceneBuilder, x: f64, h: f64, side: f64, tag: u32) {
    let (x0, x1) = if side < 0.0 {
        (x - 1.0, x)
    } else {
        (x, x + 1.0)
    };
    add_box(
        b,
        UTM + DVec3::new(x0, -LONG, 0.0),
        UTM + DVec3::new(x1, LONG, h),
        tag,
    );
}

/// North-south canyon of width `w` and height `h` centred on UTM.
fn canyon(w: f64, h: f64) -> Scene {
    let mut b = SceneBuilder::new();
    wall(&mut b, -w / 2.0, h, -1.0, 0);
    wall(&mut b, w / 2.0, h, 1.0, 1);
    b.build()
}

fn poi(offset: DVec3, normal: Option<DVec3>) -> Poi {
    Poi {
        id: "p".into(),
        position: UTM + offset,
        normal,
    }
}

fn bundles() -> SkyBundles {
    SkyBundles::new(10_000, 2024).expect("bundles")
}

#[test]
fn canyon_floor_centre() {
    let b = bundles();
    let w = 12.0;
    for hw in [0.5, 1.0, 2.0] {
        let scene = canyon(w, hw * w);
        let v = poi_sky_view(&scene, &poi(DVec3::ZERO, None), &b);
        let beta = (2.0 * hw).atan();
        assert!((v.svf - beta.cos()).abs() < TOL, "H/W {hw}: {v:?}");
        let exp = 1.0 - 2.0 * beta / PI;
        assert!((v.sky_exposure - exp).abs() < TOL, "H/W {hw}: {v:?}");
        // An explicit upward normal is the same as none (offset apart).
        let up = poi_sky_view(&scene, &poi(DVec3::ZERO, Some(DVec3::Z)), &b);
        assert!((up.svf - v.svf).abs() < 1e-3 && (up.sky_exposure - v.sky_exposure).abs() < 1e-3);
    }
}

#[test]
fn point_at_distance_from_one_wall() {
    let b = bundles();
    for (h, d) in [(10.0, 10.0), (30.0, 10.0), (5.0, 20.0), (20.0, 7.0)] {
        let mut sb = SceneBuilder::new();
        wall(&mut sb, d, h, 1.0, 0);
        let scene = sb.build();
        let v = poi_sky_view(&scene, &poi(DVec3::new(0.0, 3.0, 0.0), None), &b);
        let beta = f64::atan(h / d);
        let svf = (1.0 + beta.cos()) / 2.0;
        assert!((v.svf - svf).abs() < TOL, "H {h} D {d}: {v:?} vs {svf}");
        let exp = 1.0 - beta / PI;
        assert!(
            (v.sky_exposure - exp).abs() < TOL,
            "H {h} D {d}: {v:?} vs {exp}"
        );
    }
}

#[test]
fn unobstructed_horizontal_and_vertical() {
    let b = bundles();
    // A lone 20 m cube: points on its roof (normal up) and on its four walls.
    let mut sb = SceneBuilder::new();
    add_box(
        &mut sb,
        UTM + DVec3::new(-10.0, -10.0, 0.0),
        UTM + DVec3::new(10.0, 10.0, 20.0),
        0,
    );
    let scene = sb.build();
    let roof = poi_sky_view(&scene, &poi(DVec3::new(1.0, 2.0, 20.0), Some(DVec3::Z)), &b);
    assert_eq!((roof.svf, roof.sky_exposure), (1.0, 1.0), "{roof:?}");
    for n in [DVec3::X, DVec3::NEG_X, DVec3::Y, DVec3::NEG_Y] {
        let p = poi(n * 10.0 + DVec3::new(0.0, 0.0, 5.0), Some(n));
        let v = poi_sky_view(&scene, &p, &b);
        assert!((v.svf - 0.5).abs() < TOL, "{n}: {v:?}");
        assert!((v.sky_exposure - 0.5).abs() < TOL, "{n}: {v:?}");
    }
}

#[test]
fn base_of_canyon_wall_facing_across() {
    let b = bundles();
    for w in [8.0, 15.0] {
        let h = w;
        let scene = canyon(w, h);
        // On the west wall's face, at its base, facing east.
        let p = poi(DVec3::new(-w / 2.0, 0.0, 0.0), Some(DVec3::X));
        let v = poi_sky_view(&scene, &p, &b);
        let svf = (1.0 - h / (h * h + w * w).sqrt()) / 2.0;
        assert!((v.svf - svf).abs() < TOL, "W {w}: {v:?} vs {svf}");
        let exp = (FRAC_PI_2 - (h / w).atan()) / PI;
        assert!((v.sky_exposure - exp).abs() < TOL, "W {w}: {v:?} vs {exp}");
    }
}

// ---------------------------------------------------------------------------------------
// Sun hours against an independent solar position.

const BCN: (f64, f64) = (41.39, 2.17);

/// Fractional-year angle (radians) of a UTC instant (NOAA).
fn gamma(t: DateTime<Utc>) -> f64 {
    let days = if t.date_naive().leap_year() {
        366.0
    } else {
        365.0
    };
    let hour = f64::from(t.hour()) + f64::from(t.minute()) / 60.0 + f64::from(t.second()) / 3600.0;
    2.0 * PI / days * (f64::from(t.ordinal()) - 1.0 + (hour - 12.0) / 24.0)
}

/// Equation of time in minutes and declination in radians (Spencer / NOAA).
fn eqtime_decl(g: f64) -> (f64, f64) {
    let eqtime = 229.18
        * (0.000075 + 0.001868 * g.cos()
            - 0.032077 * g.sin()
            - 0.014615 * (2.0 * g).cos()
            - 0.040849 * (2.0 * g).sin());
    let decl = 0.006918 - 0.399912 * g.cos() + 0.070257 * g.sin() - 0.006758 * (2.0 * g).cos()
        + 0.000907 * (2.0 * g).sin()
        - 0.002697 * (3.0 * g).cos()
        + 0.00148 * (3.0 * g).sin();
    (eqtime, decl)
}

/// Apparent elevation (degrees) at `t`, refraction as in SPA (1013.25 mbar, 15 C).
fn apparent_elevation(t: DateTime<Utc>, lat: f64, lon: f64) -> f64 {
    let (eqtime, decl) = eqtime_decl(gamma(t));
    let minutes = f64::from(t.hour()) * 60.0 + f64::from(t.minute()) + f64::from(t.second()) / 60.0;
    let tst = minutes + eqtime + 4.0 * lon;
    let ha = (tst / 4.0 - 180.0).to_radians();
    let phi = lat.to_radians();
    let cz = phi.sin() * decl.sin() + phi.cos() * decl.cos() * ha.cos();
    let e = 90.0 - cz.clamp(-1.0, 1.0).acos().to_degrees();
    let refr = if e >= -0.83337 {
        (1013.25 / 1010.0) * (283.0 / 288.0) * 1.02
            / (60.0 * (e + 10.3 / (e + 5.11)).to_radians().tan())
    } else {
        0.0
    };
    e + refr
}

/// UTC minute of the day of solar noon (NOAA).
fn solar_noon_minutes(t: DateTime<Utc>, lon: f64) -> f64 {
    let (eqtime, _) = eqtime_decl(gamma(t));
    720.0 - 4.0 * lon - eqtime
}

#[test]
fn open_ground_gets_the_day_length() {
    let site = Site::new(BCN.0, BCN.1);
    let table = SunTable::year(2025, 15, &site).expect("table");
    // A point on the roof of an isolated 10 m box.
    let mut sb = SceneBuilder::new();
    add_box(
        &mut sb,
        UTM + DVec3::new(-5.0, -5.0, 0.0),
        UTM + DVec3::new(5.0, 5.0, 10.0),
        0,
    );
    let scene = sb.build();
    let p = poi(DVec3::new(0.0, 0.0, 10.0), Some(DVec3::Z));
    let sh = poi_sun_hours(&scene, &p, &table);
    assert_eq!(sh.hours, sh.possible_hours);
    let per_day = 96;
    assert_eq!(table.len(), 365 * per_day);
    let mut counts = vec![0usize; 365];
    let origin = p.position + DVec3::Z * POI_OFFSET;
    for k in visible_steps(&table, p.normal, |d| {
        scene.occluded(origin, d, POI_OFFSET, f64::INFINITY)
    }) {
        counts[k / per_day] += 1;
    }
    assert_eq!(counts.iter().sum::<usize>(), sh.steps);
    let mut total_ref = 0.0;
    for (day, &count) in counts.iter().enumerate() {
        // Reference day length: minutes of the UTC day with the apparent sun above the
        // horizon (Barcelona's night is around 0 h UTC, so one UTC day holds one day).
        let d0 = table.start() + chrono::Duration::days(day as i64);
        let minutes = (0..1440)
            .filter(|m| {
                let t = d0 + chrono::Duration::seconds(60 * m + 30);
                apparent_elevation(t, BCN.0, BCN.1) > 0.0
            })
            .count();
        let ref_h = minutes as f64 / 60.0;
        total_ref += ref_h;
        let ours = count as f64 * table.step_hours();
        assert!(
            (ours - ref_h).abs() <= table.step_hours(),
            "day {day}: {ours} h vs {ref_h} h"
        );
    }
    assert!(
        (sh.hours - total_ref).abs() < 10.0,
        "{} vs {total_ref}",
        sh.hours
    );
}

#[test]
fn deep_north_south_canyon_sees_only_midday() {
    let site = Site::new(BCN.0, BCN.1);
    let table = SunTable::year(2025, 15, &site).expect("table");
    // W = 10 m, H = 60 m: the sun must be within atan(W / 2H) = 4.8 degrees of the
    // canyon's vertical plane, i.e. within ~20 min of solar noon in summer.
    let scene = canyon(10.0, 60.0);
    let p = poi(DVec3::ZERO, None);
    let sh = poi_sun_hours(&scene, &p, &table);
    let mut open = SceneBuilder::new();
    add_box(
        &mut open,
        UTM + DVec3::new(-5.0, -5.0, -20.0),
        UTM + DVec3::new(5.0, 5.0, -10.0),
        0,
    );
    let open = poi_sun_hours(&open.build(), &p, &table);
    assert!(sh.hours > 20.0, "{sh:?}");
    assert!(
        sh.hours < 0.1 * open.hours,
        "{} vs {}",
        sh.hours,
        open.hours
    );
    let mut n = 0;
    for k in visible_steps(&table, None, |d| {
        scene.occluded(p.position, d, POI_OFFSET, f64::INFINITY)
    }) {
        let mid = table.step_mid(k).expect("step");
        let m =
            f64::from(mid.hour()) * 60.0 + f64::from(mid.minute()) + f64::from(mid.second()) / 60.0;
        let off = (m - solar_noon_minutes(mid, BCN.1)).abs();
        assert!(
            off <= 30.0,
            "step {k} at {mid}: {off:.1} min from solar noon"
        );
        n += 1;
    }
    assert_eq!(n, sh.steps);
    // Every day with sun in the canyon has at most a few steps.
    assert!(sh.steps <= 365 * 3);
}
