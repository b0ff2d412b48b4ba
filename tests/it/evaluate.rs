//! `skylod evaluate` on the command line: exit codes, the JSON shape, and figures against
//! scenes with known answers (`fixtures/scenes/`, the committed synth fixture).

use crate::util::*;
use serde_json::Value;

fn num(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("{v} is not a number"))
}

/// Local (0, 0, 1.5) of the scenes in `fixtures/scenes/` (shifted to EPSG:25831).
const SCENE_POI: &str = "430000,4581000,11.5";

#[test]
fn json_shape_and_consistent_figures() {
    let gml = fixture("scenes/skyline-roof.gml");
    let o = run(&[
        os("evaluate"),
        gml.as_os_str(),
        os("--poi"),
        os(SCENE_POI),
        os("--poi"),
        os("430000,4581000,200"),
        os("--json"),
        os("--step"),
        os("60"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    check_stdout_schema("evaluate.schema.json", &o);
    let v = json(&o);
    for key in [
        "inputs",
        "rays",
        "svf_rays",
        "seed",
        "sun",
        "pois",
        "timings_ms",
    ] {
        assert!(v.get(key).is_some(), "no {key}: {v}");
    }
    // The site comes from the CRS (EPSG:25831: Barcelona).
    assert!((num(&v["sun"]["lat"]) - 41.38).abs() < 0.05, "{}", v["sun"]);
    assert!((num(&v["sun"]["lon"]) - 2.16).abs() < 0.05, "{}", v["sun"]);
    let pois = v["pois"].as_array().unwrap();
    assert_eq!(pois.len(), 2);
    // Polygons of the full model: what `stats` counts.
    let s = run(&[os("stats"), os("--json"), gml.as_os_str()]);
    let sv = json(&s);
    let full_polys = sv["total"]["polygons"].as_u64().unwrap();
    for p in pois {
        for m in ["full", "lod", "boxes"] {
            for k in [
                "polygons",
                "svf",
                "sky_exposure",
                "sun_hours",
                "bvh_ms",
                "trace_ms",
            ] {
                assert!(p[m].get(k).is_some(), "{m}.{k} missing: {p}");
            }
            let svf = num(&p[m]["svf"]);
            assert!((0.0..=1.0).contains(&svf), "{m}: {svf}");
        }
        assert_eq!(p["full"]["polygons"].as_u64(), Some(full_polys));
        // The errors are what the figures say.
        let (f, l, b) = (
            num(&p["full"]["svf"]),
            num(&p["lod"]["svf"]),
            num(&p["boxes"]["svf"]),
        );
        assert!(
            (num(&p["lod_svf_error"]) - (l - f).abs() / f).abs() < 1e-9,
            "{p}"
        );
        assert!(
            (num(&p["boxes_svf_error"]) - (b - f).abs() / f).abs() < 1e-9,
            "{p}"
        );
        let (fs, ls) = (num(&p["full"]["sun_hours"]), num(&p["lod"]["sun_hours"]));
        assert!(
            (num(&p["lod_sun_error"]) - (ls - fs).abs() / fs).abs() < 1e-9,
            "{p}"
        );
        assert_eq!(p["flags"], serde_json::json!([]));
        let levels: u64 = p["levels"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_u64().unwrap())
            .sum();
        assert!(levels > 0);
    }
    // At street level the gable's ridge is the skyline: a level-2 asset, and the LoD model
    // is smaller than the full one with an SVF within 2 %.
    let street = &pois[0];
    assert!(street["levels"][2].as_u64().unwrap() >= 1, "{street}");
    assert!(street["lod"]["polygons"].as_u64() < street["full"]["polygons"].as_u64());
    assert!(num(&street["lod_svf_error"]) < 0.02, "{street}");
    assert!(num(&street["full"]["svf"]) < 0.99, "{street}");
    // The all-boxes model is the worse approximation (the paper's point).
    assert!(
        num(&street["boxes_svf_error"]) > num(&street["lod_svf_error"]),
        "{street}"
    );
    // 200 m up nothing is above the horizon: every model sees the whole sky.
    let high = &pois[1];
    for m in ["full", "lod", "boxes"] {
        assert!((num(&high[m]["svf"]) - 1.0).abs() < 1e-12, "{high}");
    }
    assert_eq!(high["levels"][1].as_u64(), Some(0));
    assert_eq!(high["levels"][2].as_u64(), Some(0));
}

#[test]
fn table_lists_three_models_per_poi() {
    let gml = fixture("scenes/skyline-roof.gml");
    let o = run(&[
        os("evaluate"),
        gml.as_os_str(),
        os("--poi"),
        os(SCENE_POI),
        os("--no-sun"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let rows: Vec<&str> = out.lines().filter(|l| l.starts_with("poi-1")).collect();
    assert_eq!(rows.len(), 3, "{out}");
    for (row, model) in rows.iter().zip(["full", "lod", "boxes"]) {
        assert_eq!(row.split_whitespace().nth(1), Some(model), "{out}");
    }
}

#[test]
fn exit_codes_and_errors() {
    let gml = fixture("scenes/skyline-roof.gml");
    let dir = tempfile::tempdir().unwrap();
    let missing_input = dir.path().join("missing.gml");
    // No POI, --lat without --lon, a bad threshold: usage errors (2), before any reading.
    for args in [
        vec![os("evaluate"), gml.as_os_str()],
        vec![
            os("evaluate"),
            gml.as_os_str(),
            os("--poi"),
            os(SCENE_POI),
            os("--lat"),
            os("41.4"),
        ],
        vec![
            os("evaluate"),
            gml.as_os_str(),
            os("--poi"),
            os(SCENE_POI),
            os("--threshold"),
            os("-2"),
        ],
        vec![os("evaluate"), gml.as_os_str(), os("--poi"), os("1,2")],
    ] {
        let o = run(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(o.stdout.is_empty());
    }
    // A model in a CRS skylod cannot place on the earth needs the site, or --no-sun.
    let local = dir.path().join("local.gml");
    let text = std::fs::read_to_string(&gml)
        .unwrap()
        .replace("EPSG:25831", "#local-CRS");
    std::fs::write(&local, text).unwrap();
    let o = run(&[
        os("evaluate"),
        local.as_os_str(),
        os("--poi"),
        os(SCENE_POI),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--lat"), "{}", stderr(&o));
    let o = run(&[
        os("evaluate"),
        local.as_os_str(),
        os("--poi"),
        os(SCENE_POI),
        os("--lat"),
        os("41.4"),
        os("--lon"),
        os("2.2"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // A missing input among readable ones: the others are evaluated, exit 1.
    let o = run(&[
        os("evaluate"),
        gml.as_os_str(),
        missing_input.as_os_str(),
        os("--poi"),
        os(SCENE_POI),
        os("--no-sun"),
        os("--json"),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("missing.gml"), "{}", stderr(&o));
    assert_eq!(json(&o)["pois"].as_array().map(Vec::len), Some(1));
    // Only missing inputs: nothing to evaluate, exit 1 and no output.
    let o = run(&[
        os("evaluate"),
        missing_input.as_os_str(),
        os("--poi"),
        os(SCENE_POI),
        os("--no-sun"),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(o.stdout.is_empty());
}
