//! `skylod horizon`: profiles of box canyons against closed forms, the CSV/JSON outputs, and
//! sun hours from pvlib's sun positions masked by the profile (the pvlib/PVGIS workflow)
//! against skylod's own traced `sun-hours` (oracle `tests/oracle/pvlib_horizon.py`).

use crate::util::*;
use serde_json::{json, Value};
use skylod::model::synth::{boxes_citygml, BoxBuilding};
use std::ffi::OsStr;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

const ORIGIN: [f64; 3] = [430000.0, 4581000.0, 10.0];
/// Canyon length (north-south); long enough that its ends are below 6° from the centre.
const LENGTH: f64 = 400.0;
/// Depth (east-west) of each canyon building.
const DEPTH: f64 = 15.0;

fn json_out(o: &Output) -> Value {
    assert_eq!(o.status.code(), Some(0), "{}", stderr(o));
    serde_json::from_slice(&o.stdout)
        .unwrap_or_else(|e| panic!("stdout is not JSON ({e}): {}", stderr(o)))
}

/// Two box buildings `h` high forming a north-south canyon `w` wide centred on x = 0 (local).
fn canyon(w: f64, h: f64) -> Vec<BoxBuilding> {
    let half = LENGTH / 2.0;
    vec![
        BoxBuilding {
            id: "W".into(),
            min: [-w / 2.0 - DEPTH, -half],
            max: [-w / 2.0, half],
            height: h,
            installations: vec![],
        },
        BoxBuilding {
            id: "E".into(),
            min: [w / 2.0, -half],
            max: [w / 2.0 + DEPTH, half],
            height: h,
            installations: vec![],
        },
    ]
}

fn write_scene(dir: &Path, name: &str, b: &[BoxBuilding]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, boxes_citygml(b, ORIGIN)).unwrap();
    p
}

/// Model coordinates of a local point, as a `--poi` argument (with an optional normal).
fn poi_arg(local: [f64; 3], normal: Option<[f64; 3]>) -> String {
    let mut s = format!(
        "{},{},{}",
        ORIGIN[0] + local[0],
        ORIGIN[1] + local[1],
        ORIGIN[2] + local[2]
    );
    if let Some(n) = normal {
        s.push_str(&format!(",{},{},{}", n[0], n[1], n[2]));
    }
    s
}

/// Closed form: from a point at local height `z` below every roof, the skyline at azimuth
/// `az` is the highest of `atan((h - z) / t)` over the boxes the horizontal ray enters at
/// distance `t` (a vertical prism is entered through its side and climbs away from its top).
fn closed_form(b: &[BoxBuilding], p: [f64; 3], az: f64) -> f64 {
    let d = [az.to_radians().sin(), az.to_radians().cos()];
    let mut best = 0.0f64;
    for bb in b {
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        let mut miss = false;
        for i in 0..2 {
            if d[i].abs() < 1e-12 {
                if p[i] < bb.min[i] || p[i] > bb.max[i] {
                    miss = true;
                }
                continue;
            }
            let (a, c) = ((bb.min[i] - p[i]) / d[i], (bb.max[i] - p[i]) / d[i]);
            t0 = t0.max(a.min(c));
            t1 = t1.min(a.max(c));
        }
        if !miss && t0 <= t1 && t0 > 0.0 {
            best = best.max(((bb.height - p[2]) / t0).atan().to_degrees());
        }
    }
    best
}

fn horizon_json(args: &[&OsStr]) -> Value {
    let mut a = vec![os("horizon")];
    a.extend_from_slice(args);
    a.push(os("--json"));
    let o = run(&a);
    let v = json_out(&o);
    check_stdout_schema("horizon.schema.json", &o);
    v
}

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

#[test]
fn canyons_match_closed_forms() {
    let dir = tempfile::tempdir().unwrap();
    let mut worst = 0.0f64;
    // (W, H): the H = W canyon of the issue, a deep and a shallow one.
    for (w, h) in [(20.0, 20.0), (10.0, 20.0), (20.0, 10.0)] {
        let b = canyon(w, h);
        let gml = write_scene(dir.path(), &format!("canyon-{w}-{h}.gml"), &b);
        // Floor centre, and a point 3 m up, a quarter of the way across.
        let pts = [[0.0, 0.0, 0.0], [-w / 4.0, 30.0, 3.0]];
        let (p0, p1) = (poi_arg(pts[0], None), poi_arg(pts[1], None));
        let v = horizon_json(&[os(&gml), os("--poi"), os(&p0), os("--poi"), os(&p1)]);
        let rows = v["pois"].as_array().unwrap();
        assert_eq!(rows.len(), 2);
        for (row, p) in rows.iter().zip(pts) {
            let az = numbers(&row["azimuth"]);
            let el = numbers(&row["elevation"]);
            assert_eq!(az.len(), 360);
            assert_eq!(el.len(), 360);
            for (a, e) in az.iter().zip(&el) {
                let expect = closed_form(&b, p, *a);
                let err = (e - expect).abs();
                worst = worst.max(err);
                assert!(
                    err <= 0.05,
                    "W {w} H {h} poi {p:?} azimuth {a}: {e} vs closed form {expect}"
                );
            }
            if p == [0.0, 0.0, 0.0] {
                // Across the canyon from the floor centre: atan(2H / W); along it: open.
                let across = (2.0 * h / w).atan().to_degrees();
                assert!((el[90] - across).abs() <= 0.05, "{} vs {across}", el[90]);
                assert!((el[270] - across).abs() <= 0.05, "{} vs {across}", el[270]);
                assert!(el[0] <= 0.05 && el[180] <= 0.05, "{} {}", el[0], el[180]);
            }
        }
    }
    eprintln!(
        "horizon vs closed form: worst error {worst:.4} deg over 3 canyons x 2 POIs x 360 azimuths"
    );
}

#[test]
fn overhang_band_is_reported() {
    // A slab on posts (an installation box 8..9 m up) east of the point: the sky under it is
    // open (skyline 0 at azimuth 90), the slab's far lower edge atan(8 / 12) is the overhang.
    let dir = tempfile::tempdir().unwrap();
    let b = vec![BoxBuilding {
        id: "S".into(),
        min: [30.0, 30.0],
        max: [31.0, 31.0],
        height: 2.0,
        installations: vec![[4.0, -50.0, 8.0, 12.0, 50.0, 9.0]],
    }];
    let gml = write_scene(dir.path(), "slab.gml", &b);
    let p = poi_arg([0.0, 0.0, 0.0], None);
    let v = horizon_json(&[os(&gml), os("--poi"), os(&p), os("--step"), os("90")]);
    let el = numbers(&v["pois"][0]["elevation"]);
    assert_eq!(
        numbers(&v["pois"][0]["azimuth"]),
        vec![0.0, 90.0, 180.0, 270.0]
    );
    assert_eq!(el, vec![0.0; 4]);
    let over = &v["pois"][0]["overhang"];
    let expect = (8.0f64 / 12.0).atan().to_degrees();
    let east = over[1].as_f64().unwrap();
    assert!((east - expect).abs() <= 0.05, "{east} vs {expect}");
    assert!(
        over[0].is_null() && over[2].is_null() && over[3].is_null(),
        "{over}"
    );
}

/// A house (x in -10..0, 6 m high) with an eave 3..3.2 m up reaching 1.5 m east of its east
/// wall, along the whole wall.
fn eave_house() -> Vec<BoxBuilding> {
    vec![BoxBuilding {
        id: "H".into(),
        min: [-10.0, -10.0],
        max: [0.0, 10.0],
        height: 6.0,
        installations: vec![[0.0, -10.0, 3.0, 1.5, 10.0, 3.2]],
    }]
}

/// Run the pvlib oracle on `cfg` (see tests/oracle/pvlib_horizon.py).
fn pvlib_oracle(cfg: &Value) -> Vec<Value> {
    let script = manifest_dir().join("tests/oracle/pvlib_horizon.py");
    let mut child = Command::new("python3")
        .arg(&script)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("python3");
    child
        .stdin
        .take()
        .unwrap()
        .write_all(cfg.to_string().as_bytes())
        .unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "oracle: {}", stderr(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn under_an_eave_the_profile_is_the_lower_edge_and_matches_sun_hours() {
    let dir = tempfile::tempdir().unwrap();
    let gml = write_scene(dir.path(), "eave.gml", &eave_house());
    // Under the eave, 0.5 m above the ground and 1 m from the wall; and on the wall below
    // the eave, facing east.
    let pois = [
        poi_arg([1.0, 0.0, 0.5], None),
        poi_arg([0.0, 0.0, 1.0], Some([1.0, 0.0, 0.0])),
    ];
    let mut common = vec![os(&gml)];
    for p in &pois {
        common.extend([os("--poi"), os(p)]);
    }
    let prof = horizon_json(&common);
    let free = &prof["pois"][0];
    let el = numbers(&free["elevation"]);
    // East: open from the horizontal up to the eave's edge atan(2.5 / 0.5).
    assert_eq!(el[90], 0.0);
    let edge = (2.5f64 / 0.5).atan().to_degrees();
    let o90 = free["overhang"][90].as_f64().unwrap();
    assert!((o90 - edge).abs() <= 0.05, "{o90} vs {edge}");
    // South, along the wall: open below the eave's end, atan(2.5 / 10).
    let o180 = free["overhang"][180].as_f64().unwrap();
    let end = (2.5f64 / 10.0).atan().to_degrees();
    assert!((o180 - end).abs() <= 0.05, "{o180} vs {end}");
    // West: the wall, no sky.
    assert_eq!(el[270], 90.0);
    assert!(free["overhang"][270].is_null());
    // The point sees sky: its SVF is positive, and so not every azimuth is blocked.
    let mut svf_args = vec![os("svf")];
    svf_args.extend_from_slice(&common);
    svf_args.push(os("--json"));
    let svf = json_out(&run(&svf_args));
    let s = svf["pois"][0]["svf"].as_f64().unwrap();
    assert!(s > 0.05, "svf {s}");
    assert!(el.iter().any(|&e| e < 90.0));
    if !python_has("pvlib", "pip install pvlib") {
        return;
    }
    let mut sun_args = vec![os("sun-hours")];
    sun_args.extend_from_slice(&common);
    sun_args.extend([
        os("--lat"),
        os("41.39"),
        os("--lon"),
        os("2.17"),
        os("--step"),
        os("15"),
        os("--json"),
    ]);
    let sun = json_out(&run(&sun_args));
    let profiles: Vec<Value> = prof["pois"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            json!({"id": r["id"], "azimuth": r["azimuth"], "elevation": r["elevation"],
                   "normal": r["normal"], "overhang": r["overhang"]})
        })
        .collect();
    let cfg = json!({
        "latitude": 41.39, "longitude": 2.17, "elevation_m": 0.0, "pressure_mbar": 1013.25,
        "temperature_c": 15.0, "delta_t_s": 69.0, "year": sun["year"], "step_minutes": 15,
        "profiles": profiles,
    });
    let oracle = pvlib_oracle(&cfg);
    for (i, name) in ["under the eave", "wall under the eave"].iter().enumerate() {
        let traced = sun["pois"][i]["sun_hours"].as_f64().unwrap();
        let masked = oracle[i]["sun_hours"].as_f64().unwrap();
        eprintln!("{name}: skylod sun-hours {traced:.2} h, pvlib masked by the profile and overhang {masked:.2} h");
        // The overhang is taken from the nearest 1° azimuth sample: within 2 % + 1 h.
        assert!(
            (traced - masked).abs() <= 0.02 * traced + 1.0,
            "{name}: {traced} vs {masked}"
        );
        assert!(traced > 100.0, "{name}: {traced}");
    }
    // Ignoring the overhang (the old reading, or a pvlib user without it) overcounts.
    let mut without = cfg.clone();
    for p in without["profiles"].as_array_mut().unwrap() {
        p["overhang"] = Value::Null;
    }
    let plain = pvlib_oracle(&without);
    let traced = sun["pois"][0]["sun_hours"].as_f64().unwrap();
    assert!(plain[0]["sun_hours"].as_f64().unwrap() > traced + 50.0);
}

#[test]
fn csv_output_file_and_usage_errors() {
    let dir = tempfile::tempdir().unwrap();
    let gml = write_scene(dir.path(), "c.gml", &canyon(20.0, 20.0));
    let out = dir.path().join("horizon.csv");
    let p = poi_arg([0.0, 0.0, 0.0], None);
    let args = [
        os("horizon"),
        os(&gml),
        os("--poi"),
        os(&p),
        os("--step"),
        os("45"),
        os("-o"),
        os(&out),
    ];
    let o = run(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "id,azimuth,elevation");
    assert_eq!(lines.len(), 9);
    let east: Vec<&str> = lines[3].split(',').collect();
    assert_eq!(&east[..2], &["poi-1", "90"]);
    let e: f64 = east[2].parse().unwrap();
    assert!((e - 2f64.atan().to_degrees()).abs() <= 0.05, "{e}");
    // Existing output without --overwrite: usage error, file untouched.
    let o = run(&args);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&out).unwrap(), text);
    // Bad step, no POI.
    for bad in [
        vec![
            os("horizon"),
            os(&gml),
            os("--poi"),
            os(&p),
            os("--step"),
            os("0"),
        ],
        vec![
            os("horizon"),
            os(&gml),
            os("--poi"),
            os(&p),
            os("--step"),
            os("400"),
        ],
        vec![os("horizon"), os(&gml)],
    ] {
        let o = run(&bad);
        assert_eq!(o.status.code(), Some(2), "{:?}: {}", bad, stderr(&o));
    }
}

#[test]
fn pvlib_sun_hours_masked_by_the_profile_match_sun_hours() {
    if !python_has("pvlib", "pip install pvlib") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (20.0, 20.0);
    let b = canyon(w, h);
    let gml = write_scene(dir.path(), "canyon.gml", &b);
    let (lat, lon) = ("41.39", "2.17");
    // Open: on the east roof; canyon: the floor centre; facade: the west building's east
    // wall at 5 m, facing east (its own plane is part of its horizon).
    let pois = [
        poi_arg([w / 2.0 + DEPTH / 2.0, 0.0, h], Some([0.0, 0.0, 1.0])),
        poi_arg([0.0, 0.0, 0.0], None),
        poi_arg([-w / 2.0, 20.0, 5.0], Some([1.0, 0.0, 0.0])),
    ];
    let mut common_args = vec![os(&gml)];
    for p in &pois {
        common_args.push(os("--poi"));
        common_args.push(os(p));
    }
    let prof = horizon_json(&common_args);
    let mut sun_args = vec![os("sun-hours")];
    sun_args.extend_from_slice(&common_args);
    sun_args.extend([
        os("--lat"),
        os(lat),
        os("--lon"),
        os(lon),
        os("--step"),
        os("15"),
        os("--json"),
    ]);
    let sun = json_out(&run(&sun_args));
    let profiles: Vec<Value> = prof["pois"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            json!({"id": r["id"], "azimuth": r["azimuth"], "elevation": r["elevation"],
                   "normal": r["normal"]})
        })
        .collect();
    // Site::new's atmosphere, as `sun-hours` uses it.
    let cfg = json!({
        "latitude": 41.39, "longitude": 2.17, "elevation_m": 0.0, "pressure_mbar": 1013.25,
        "temperature_c": 15.0, "delta_t_s": 69.0, "year": sun["year"], "step_minutes": 15,
        "profiles": profiles,
    });
    let script = manifest_dir().join("tests/oracle/pvlib_horizon.py");
    let mut child = Command::new("python3")
        .arg(&script)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("python3");
    child
        .stdin
        .take()
        .unwrap()
        .write_all(cfg.to_string().as_bytes())
        .unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "oracle: {}", stderr(&o));
    let oracle: Vec<Value> = serde_json::from_slice(&o.stdout).unwrap();
    let names = ["open", "canyon", "facade"];
    for ((name, ours), theirs) in names
        .iter()
        .zip(sun["pois"].as_array().unwrap())
        .zip(&oracle)
    {
        let traced = ours["sun_hours"].as_f64().unwrap();
        let masked = theirs["sun_hours"].as_f64().unwrap();
        let open = theirs["open_hours"].as_f64().unwrap();
        eprintln!(
            "{name}: skylod sun-hours {traced:.2} h, pvlib masked by the profile {masked:.2} h \
             (open sky {open:.2} h; clear-sky beam {:.1} of {:.1} kWh/m2)",
            theirs["direct_kwh_m2"].as_f64().unwrap(),
            theirs["open_direct_kwh_m2"].as_f64().unwrap()
        );
        // Within 0.2 % + half an hour: the profile's azimuth interpolation and the 0.01°
        // bisection move the sun's crossing of the skyline by seconds per day. (Without
        // pvlib's angle of incidence the facade would differ by 7 h: interpolating across
        // the 0° -> 90° step of its own plane at azimuth 180 unmasks a sliver of sky.)
        assert!(
            (traced - masked).abs() <= 0.002 * traced + 0.5,
            "{name}: {traced} vs {masked}"
        );
    }
    // The canyon really shades: the masked hours are well below the open sky's.
    let canyon_h = oracle[1]["sun_hours"].as_f64().unwrap();
    assert!(canyon_h < 0.5 * oracle[1]["open_hours"].as_f64().unwrap());
    assert!(canyon_h > 100.0);
}

#[test]
fn ingolstadt_facade_profile() {
    let Some(data) = shared_data() else { return };
    let dir = data.join("ingolstadt-lod3");
    let files = citygml_files(&dir);
    assert!(!files.is_empty(), "no files in {}", dir.display());
    let mut args: Vec<&OsStr> = files.iter().map(os).collect();
    args.extend([os("--poi"), os("678095,5403890,418,0,-1,0")]);
    let v = horizon_json(&args);
    let el = numbers(&v["pois"][0]["elevation"]);
    assert_eq!(el.len(), 360);
    // A south-facing facade point: the north half-space is behind its wall.
    assert!(
        el[0] == 90.0 && el[45] == 90.0 && el[315] == 90.0,
        "{:?}",
        &el[..5]
    );
    assert!(el.iter().all(|e| (0.0..=90.0).contains(e)));
    let south: Vec<f64> = el[91..270].to_vec();
    let mean = south.iter().sum::<f64>() / south.len() as f64;
    eprintln!(
        "ingolstadt 678095,5403890,418 facing south: mean skyline over azimuths 91-269 {mean:.2} deg, max {:.2}",
        south.iter().cloned().fold(0.0, f64::max)
    );
    // A street facade in a city: something stands in front of it, and the sky is not shut.
    assert!(mean > 1.0 && mean < 80.0, "{mean}");
}
