//! The solar commands on the command line: `svf`, `sun-hours`, `fisheye` (exit codes,
//! JSON shape, outputs), on the committed fixture `fixtures/synth-small.gml` and its POIs.

mod common;

use common::*;
use serde_json::Value;
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
    let boxes = skylod::synth::boxes::boxes_citygml(
        &[skylod::synth::boxes::BoxBuilding {
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
