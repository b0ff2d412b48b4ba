//! Cross-check of `sun_position` against pvlib's SPA implementation (an independent
//! implementation of the same NREL algorithm). The cases are chosen here and passed to
//! `tests/oracle/pvlib_sun.py` as JSON on stdin.
//!
//! Without pvlib (`python3 -c "import pvlib"` fails) the test fails when `CI=true` and is
//! skipped with a printed reason otherwise.

use chrono::{DateTime, TimeZone, Utc};
use serde_json::{json, Value};
use skylod::solar::{sun_position, Site};
use std::io::Write;
use std::process::{Command, Stdio};

/// (name, latitude, longitude, elevation m, pressure mbar, temperature C, delta T s)
const PLACES: [(&str, f64, f64, f64, f64, f64, f64); 12] = [
    ("Barcelona", 41.39, 2.17, 12.0, 1013.25, 15.0, 69.0),
    ("Denver", 39.742476, -105.1786, 1830.14, 820.0, 11.0, 67.0),
    ("Tromso", 69.65, 18.96, 10.0, 1005.0, 2.0, 69.2),
    ("Reykjavik", 64.15, -21.94, 20.0, 1000.0, 4.0, 64.5),
    ("Quito", -0.18, -78.47, 2850.0, 730.0, 14.0, 68.0),
    ("Singapore", 1.35, 103.82, 15.0, 1010.0, 28.0, 69.0),
    ("Sydney", -33.87, 151.21, 40.0, 1015.0, 18.0, 69.0),
    ("Cape Town", -33.92, 18.42, 25.0, 1016.0, 17.0, 58.0),
    ("Ushuaia", -54.80, -68.30, 30.0, 995.0, 6.0, 69.0),
    ("Drake Passage", -60.0, -60.0, 0.0, 990.0, 0.0, 69.0),
    ("Tokyo", 35.68, 139.69, 40.0, 1012.0, 16.0, 63.8),
    ("Anchorage", 61.22, -149.90, 30.0, 1008.0, 3.0, 69.0),
];

/// Times spread over all seasons and times of day (UTC), one pair per place.
fn times_for(i: usize) -> [DateTime<Utc>; 2] {
    let month = (i % 12) as u32 + 1;
    let month2 = ((i + 5) % 12) as u32 + 1;
    let year = 2000 + 2 * i as i32;
    [
        Utc.with_ymd_and_hms(
            year,
            month,
            1 + 2 * i as u32,
            (3 + 5 * i as u32) % 24,
            17,
            42,
        )
        .unwrap(),
        Utc.with_ymd_and_hms(
            year + 1,
            month2,
            28 - i as u32,
            (11 + 7 * i as u32) % 24,
            3,
            9,
        )
        .unwrap(),
    ]
}

#[test]
fn sun_position_matches_pvlib_spa() {
    if !crate::util::python_has("pvlib", "pip install pvlib") {
        return;
    }
    let mut cases = Vec::new();
    let mut sites = Vec::new();
    for (i, p) in PLACES.iter().enumerate() {
        let site = Site {
            latitude: p.1,
            longitude: p.2,
            elevation_m: p.3,
            pressure_mbar: p.4,
            temperature_c: p.5,
            delta_t_s: p.6,
            ..Site::new(p.1, p.2)
        };
        for t in times_for(i) {
            cases.push(json!({
                "time": t.to_rfc3339(),
                "latitude": site.latitude,
                "longitude": site.longitude,
                "elevation_m": site.elevation_m,
                "pressure_mbar": site.pressure_mbar,
                "temperature_c": site.temperature_c,
                "delta_t_s": site.delta_t_s,
            }));
            sites.push((p.0, t, site));
        }
    }
    assert!(cases.len() >= 20);
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/oracle/pvlib_sun.py");
    let mut child = Command::new("python3")
        .arg(script)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("spawn python3");
    let input = json!({ "cases": cases }).to_string();
    child
        .stdin
        .take()
        .expect("stdin")
        .write_all(input.as_bytes())
        .expect("write cases");
    let out = child.wait_with_output().expect("oracle output");
    assert!(out.status.success(), "oracle failed: {:?}", out.status);
    let results: Vec<Value> = serde_json::from_slice(&out.stdout).expect("oracle JSON");
    assert_eq!(results.len(), sites.len());

    let (mut day, mut night, mut south) = (0, 0, 0);
    for ((name, t, site), r) in sites.iter().zip(&results) {
        let ours = sun_position(*t, site).expect("sun position");
        let zen = r["apparent_zenith"].as_f64().expect("zenith");
        let az = r["azimuth"].as_f64().expect("azimuth");
        let dz = (ours.zenith_deg - zen).abs();
        let da = ((ours.azimuth_deg - az + 540.0) % 360.0 - 180.0).abs();
        assert!(
            dz < 1e-3 && da < 1e-3,
            "{name} {t}: ours ({}, {}) pvlib ({zen}, {az})",
            ours.zenith_deg,
            ours.azimuth_deg
        );
        if zen < 90.0 {
            day += 1;
        } else {
            night += 1;
        }
        if site.latitude < 0.0 {
            south += 1;
        }
    }
    // The case set must exercise daytime (refraction) and night, both hemispheres.
    assert!(
        day >= 8 && night >= 4 && south >= 8,
        "day {day} night {night}"
    );
}
