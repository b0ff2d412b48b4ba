//! The solar commands on the command line: `svf`, `sun-hours`, `fisheye` (exit codes,
//! JSON shape, outputs), on the committed fixture `fixtures/synth-small.gml` and its POIs.
//!
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

use crate::util::*;
use chrono::{DateTime, Datelike, Timelike, Utc};
use glam::DVec3;
use serde_json::Value;
use skylod::lod::poi::Poi;
use skylod::lod::poi::POI_OFFSET;
use skylod::solar::trace::{SceneBuilder, TraceScene};
use skylod::solar::{poi_sky_view, poi_sun_hours, visible_steps, Site, SkyBundles, SunTable};
use std::f64::consts::{FRAC_PI_2, PI};
use std::ffi::OsStr;
use std::path::PathBuf;
use std::process::Output;

fn gml() -> PathBuf {
    fixture("synth-small.gml")
}

fn pois_csv() -> PathBuf {
    fixture("synth-small.pois.csv")
}

/// Ids of the fixture's POI file, in order.
fn csv_ids() -> Vec<String> {
    let text = std::fs::read_to_string(pois_csv()).unwrap();
    text.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.split(',').next().unwrap().to_string())
        .collect()
}

const GROUND: &str = "430010,4581010,12";

fn run_s(args: &[&OsStr]) -> Output {
    run(args)
}

#[test]
fn svf_json_shape_and_order() {
    let (g, p) = (gml(), pois_csv());
    let o = run_s(&[
        os("svf"),
        os(&g),
        os("--poi"),
        os(GROUND),
        os("--pois"),
        os(&p),
        os("--rays"),
        os("2000"),
        os("--seed"),
        os("5"),
        os("--json"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    check_stdout_schema("svf.schema.json", &o);
    let v = json(&o);
    assert_eq!(v["rays"], 2000);
    assert_eq!(v["seed"], 5);
    assert_eq!(v["inputs"].as_array().unwrap().len(), 1);
    assert!(v["polygons"].as_u64().unwrap() > 100);
    for k in ["read", "bvh", "trace"] {
        assert!(v["timings_ms"][k].as_f64().unwrap() >= 0.0, "{k}");
    }
    let pois = v["pois"].as_array().unwrap();
    let mut ids = vec!["poi-1".to_string()];
    ids.extend(csv_ids());
    assert_eq!(pois.len(), ids.len());
    for (row, id) in pois.iter().zip(&ids) {
        assert_eq!(row["id"], id.as_str());
        assert_eq!(row["poi"].as_array().unwrap().len(), 3);
        for k in ["svf", "sky_exposure"] {
            let x = row[k].as_f64().unwrap();
            assert!((0.0..=1.0).contains(&x), "{k} {x}");
        }
        assert!(row["rays"].as_u64().unwrap() > 0);
    }
    // The ground point has no normal; the facade points have one and see at most half
    // the sky.
    assert!(pois[0]["normal"].is_null());
    assert!(pois[0]["svf"].as_f64().unwrap() > 0.5);
    for row in &pois[1..] {
        assert_eq!(row["normal"].as_array().unwrap().len(), 3);
        assert!(row["svf"].as_f64().unwrap() <= 0.5 + 1e-9);
    }

    // Same seed, the same POIs (same ids) in the other order: the same values per POI (a
    // POI's rays are seeded from its id, never from its place in the list).
    let text = std::fs::read_to_string(&p).unwrap();
    let mut lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
    let header = lines.remove(0);
    lines.reverse();
    let dir = tempfile::tempdir().unwrap();
    let reversed = dir.path().join("reversed.csv");
    std::fs::write(&reversed, format!("{header}\n{}\n", lines.join("\n"))).unwrap();
    let args: Vec<&OsStr> = vec![
        os("svf"),
        os(&g),
        os("--pois"),
        os(&reversed),
        os("--rays"),
        os("2000"),
        os("--seed"),
        os("5"),
        os("--json"),
    ];
    let o2 = run_s(&args);
    assert_eq!(o2.status.code(), Some(0), "{}", stderr(&o2));
    let v2 = json(&o2);
    let rev: Vec<&Value> = v2["pois"].as_array().unwrap().iter().rev().collect();
    for (a, b) in pois[1..].iter().zip(rev) {
        assert_eq!(a["id"], b["id"]);
        assert_eq!(a["svf"], b["svf"]);
        assert_eq!(a["sky_exposure"], b["sky_exposure"]);
    }
}

#[test]
fn svf_table_and_errors() {
    let (g, p) = (gml(), pois_csv());
    let o = run_s(&[
        os("svf"),
        os(&g),
        os("--pois"),
        os(&p),
        os("--rays"),
        os("500"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.lines().next().unwrap().contains("svf"));
    for id in csv_ids() {
        assert!(text.contains(&id), "{id} missing in\n{text}");
    }
    // An unreadable input next to a good one: results for the good one, exit 1.
    let o = run_s(&[
        os("svf"),
        os("/nonexistent/missing.gml"),
        os(&g),
        os("--pois"),
        os(&p),
        os("--rays"),
        os("500"),
        os("--json"),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("missing.gml"));
    let v = json(&o);
    assert_eq!(v["inputs"].as_array().unwrap().len(), 1);
    assert_eq!(v["pois"].as_array().unwrap().len(), csv_ids().len());
    // Only unreadable inputs: exit 1, nothing on stdout.
    let o = run_s(&[
        os("svf"),
        os("/nonexistent/missing.gml"),
        os("--poi"),
        os(GROUND),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(o.stdout.is_empty());
    // Usage errors: no POI, malformed POI, zero rays, missing POI file.
    for args in [
        vec![os("svf"), os(&g)],
        vec![os("svf"), os(&g), os("--poi"), os("1,2")],
        vec![
            os("svf"),
            os(&g),
            os("--poi"),
            os(GROUND),
            os("--rays"),
            os("0"),
        ],
        vec![os("svf"), os(&g), os("--pois"), os("/nonexistent/p.csv")],
    ] {
        let o = run_s(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("error"), "{}", stderr(&o));
    }
}

#[test]
fn sun_hours_json_and_errors() {
    let (g, p) = (gml(), pois_csv());
    let base = [os("sun-hours"), os(&g), os("--pois"), os(&p)];
    let mut args = base.to_vec();
    args.extend([
        os("--poi"),
        os(GROUND),
        os("--lat"),
        os("41.39"),
        os("--lon"),
        os("2.17"),
        os("--step"),
        os("60"),
        os("--timezone"),
        os("Europe/Madrid"),
        os("--json"),
    ]);
    let o = run_s(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    check_stdout_schema("sun-hours.schema.json", &o);
    let v = json(&o);
    assert_eq!(v["year"], 2025);
    assert_eq!(v["step_minutes"], 60);
    assert_eq!(v["steps"], 8760);
    let pois = v["pois"].as_array().unwrap();
    let mut ids = vec!["poi-1".to_string()];
    ids.extend(csv_ids());
    // --poi points come first, then the CSV.
    let got: Vec<&str> = pois.iter().map(|r| r["id"].as_str().unwrap()).collect();
    assert_eq!(got, ids);
    for row in pois {
        let h = row["sun_hours"].as_f64().unwrap();
        let possible = row["possible_hours"].as_f64().unwrap();
        let monthly: Vec<f64> = row["monthly"]
            .as_array()
            .unwrap()
            .iter()
            .map(|m| m.as_f64().unwrap())
            .collect();
        assert_eq!(monthly.len(), 12);
        assert!((monthly.iter().sum::<f64>() - h).abs() < 1e-6);
        assert!(h >= 0.0 && h <= possible + 1e-9 && possible <= 8760.0);
    }
    // The ground point between the buildings sees the sun for part of the day only.
    let ground = &pois[0];
    assert!(ground["sun_hours"].as_f64().unwrap() > 100.0);

    // Only one of --lat / --lon: usage error that names both.
    for extra in [
        vec![os("--lat"), os("41.39")],
        vec![os("--lon"), os("2.17")],
    ] {
        let mut a = base.to_vec();
        a.extend(extra);
        let o = run_s(&a);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains("--lat") && stderr(&o).contains("--lon"));
    }
    // Neither: the site comes from the model's CRS (EPSG:25831, Barcelona) and gives the
    // same hours as the explicit site within what a few hundred metres can change.
    let mut a = base.to_vec();
    a.extend([os("--step"), os("60"), os("--json")]);
    let o = run_s(&a);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let auto = json(&o);
    assert!(
        (auto["lat"].as_f64().unwrap() - 41.377).abs() < 0.01,
        "{}",
        auto["lat"]
    );
    assert!(
        (auto["lon"].as_f64().unwrap() - 2.162).abs() < 0.01,
        "{}",
        auto["lon"]
    );
    assert!(stderr(&o).contains("EPSG:25831"));
    // A model without a CRS skylod converts: usage error naming --lat/--lon.
    let dir = tempfile::tempdir().unwrap();
    let nocrs = dir.path().join("nocrs.gml");
    let boxes = skylod::model::synth::boxes_citygml(
        &[skylod::model::synth::BoxBuilding {
            id: "B".into(),
            min: [0.0, 0.0],
            max: [10.0, 10.0],
            height: 10.0,
            installations: vec![],
        }],
        [0.0, 0.0, 0.0],
    );
    std::fs::write(&nocrs, boxes).unwrap();
    let o = run_s(&[os("sun-hours"), os(&nocrs), os("--poi"), os("20,20,1")]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--lat") && stderr(&o).contains("--lon"));
    // Bad time zone, bad step, latitude out of range: usage errors.
    for extra in [
        [os("--timezone"), os("Mars/Olympus")],
        [os("--step"), os("0")],
        [os("--lat"), os("95")],
    ] {
        let mut a = base.to_vec();
        a.extend([os("--lat"), os("41.39"), os("--lon"), os("2.17")]);
        a.extend(extra);
        let o = run_s(&a);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {}", stderr(&o));
    }
    // Unreadable input: exit 1.
    let o = run_s(&[
        os("sun-hours"),
        os("/nonexistent/missing.gml"),
        os(&g),
        os("--poi"),
        os(GROUND),
        os("--lat"),
        os("-33.9"),
        os("--lon"),
        os("18.4"),
        os("--step"),
        os("120"),
        os("--json"),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(json(&o)["pois"].as_array().unwrap().len(), 1);
}

#[test]
fn fisheye_writes_svg() {
    let g = gml();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sky.svg");
    let facade = "430032.407,4581009.950,16.600,0,-1,0";
    let o = run_s(&[
        os("fisheye"),
        os(&g),
        os("--poi"),
        os(facade),
        os("-o"),
        os(&out),
        os("--rays"),
        os("800"),
        os("--lat"),
        os("41.39"),
        os("--lon"),
        os("2.17"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let svg = std::fs::read_to_string(&out).unwrap();
    assert!(svg.starts_with("<svg"), "{}", &svg[..100.min(svg.len())]);
    assert!(svg.trim_end().ends_with("</svg>"));
    // The svg crate puts text content on its own line.
    let svg = svg.replace('\n', "");
    for needle in [
        "id=\"cells\"",
        "id=\"sun-paths\"",
        "id=\"legend\"",
        ">N<",
        ">S<",
        "behind the surface",
        "sky ",
        "12h",
    ] {
        assert!(svg.contains(needle), "{needle} missing");
    }
    // Only the output in the directory (no temporary file left behind).
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);

    // Several POIs: one file per POI; stereographic; without --lat/--lon the sun paths are
    // drawn for the site of the model's CRS (EPSG:25831), as sun-hours does.
    let p = pois_csv();
    let o = run_s(&[
        os("fisheye"),
        os(&g),
        os("--pois"),
        os(&p),
        os("-o"),
        os(&out),
        os("--rays"),
        os("300"),
        os("--projection"),
        os("stereographic"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    for id in csv_ids() {
        let f = dir.path().join(format!("sky-{id}.svg"));
        let s = std::fs::read_to_string(&f).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        assert!(s.contains("stereographic") && s.contains("12h"));
    }
    assert!(
        stderr(&o).contains("site lat 41.3"),
        "site from the CRS: {}",
        stderr(&o)
    );

    // Unreadable input: exit 1 and no picture; --lat without --lon: exit 2.
    let out2 = dir.path().join("none.svg");
    let o = run_s(&[
        os("fisheye"),
        os("/nonexistent/missing.gml"),
        os("--poi"),
        os(GROUND),
        os("-o"),
        os(&out2),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(!out2.exists());
    let o = run_s(&[
        os("fisheye"),
        os(&g),
        os("--poi"),
        os(GROUND),
        os("-o"),
        os(&out2),
        os("--lat"),
        os("41.39"),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    // The output may not replace an input.
    let o = run_s(&[
        os("fisheye"),
        os(&g),
        os("--poi"),
        os(GROUND),
        os("-o"),
        os(&g),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(std::fs::read_to_string(&g).unwrap().contains("CityModel"));
}

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
fn canyon(w: f64, h: f64) -> TraceScene {
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
