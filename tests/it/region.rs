//! Region POIs on the command line: `--facade ID` and `--region WKT --height Z` with
//! `--spacing`, on `svf` and `lod` (the same arguments serve `sun-hours` and `evaluate`).

use serde_json::Value;
use skylod::io::citygml::read_file;
use skylod::lod::poi::facade_pois;
use std::ffi::OsStr;
use std::path::Path;

fn synth_small(dir: &Path) -> std::path::PathBuf {
    let gml = dir.join("small.gml");
    let o = crate::util::run(&[
        OsStr::new("synth"),
        OsStr::new("--preset"),
        OsStr::new("small"),
        OsStr::new("-o"),
        gml.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    gml
}

const REGION: &str =
    "POLYGON((430000 4581000, 430010 4581000, 430010 4581010, 430000 4581010, 430000 4581000))";

#[test]
fn facade_and_region_pois() {
    let dir = tempfile::tempdir().unwrap();
    let gml = synth_small(dir.path());
    let model = read_file(&gml).unwrap();
    let expected = facade_pois(&model, "B0_0_0_s0", 2.0, 0.05).unwrap();
    assert!(expected.len() > 10, "{} POIs", expected.len());

    let o = crate::util::run(&[
        OsStr::new("svf"),
        gml.as_os_str(),
        OsStr::new("--facade"),
        OsStr::new("B0_0_0_s0"),
        OsStr::new("--spacing"),
        OsStr::new("2"),
        OsStr::new("--json"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    let pois = v["pois"].as_array().unwrap();
    assert_eq!(pois.len(), expected.len());
    for (p, e) in pois.iter().zip(&expected) {
        assert_eq!(p["id"].as_str(), Some(e.id.as_str()));
        let svf = p["svf"].as_f64().unwrap();
        // a vertical wall sees at most half the sky
        assert!(p["normal"].is_array() && (0.0..=0.51).contains(&svf), "{p}");
    }

    // lod: a building's walls and a street grid in one model
    let out = dir.path().join("out.gml");
    let rep = dir.path().join("r.json");
    let o = crate::util::run(&[
        OsStr::new("lod"),
        gml.as_os_str(),
        OsStr::new("--facade"),
        OsStr::new("B0_0_0"),
        OsStr::new("--region"),
        OsStr::new(REGION),
        OsStr::new("--height"),
        OsStr::new("1.5"),
        OsStr::new("--spacing"),
        OsStr::new("2"),
        OsStr::new("-o"),
        out.as_os_str(),
        OsStr::new("--report"),
        rep.as_os_str(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    // party walls: no facade point may be left inside the neighbour
    assert!(!err.contains("inside a closed solid"), "{err}");
    crate::util::check_json_schema("report.schema.json", &rep);
    let r: Value = serde_json::from_str(&std::fs::read_to_string(&rep).unwrap()).unwrap();
    let walls = facade_pois(&model, "B0_0_0", 2.0, 0.05).unwrap().len();
    let n = r["pois"].as_array().unwrap().len();
    assert_eq!(n, walls + 25, "building walls + 5 x 5 street grid");
    assert!(walls > expected.len());

    // What the region model costs against single-POI models: every POI's own model is part
    // of the region model, and the largest one is what `lod` writes for that POI alone.
    let t = &r["totals"];
    let out_polys = t["polygons_out"].as_u64().unwrap();
    let own: Vec<u64> = r["pois"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["polygons_own"].as_u64().unwrap())
        .collect();
    let max = *own.iter().max().unwrap();
    assert_eq!(t["single_poi_polygons_max"].as_u64(), Some(max));
    assert!(
        own.iter().all(|&o| o <= out_polys),
        "{own:?} vs {out_polys}"
    );
    assert!(t["region_over_single_poi"].as_f64().unwrap() >= 1.0);
    assert!(err.contains("region: one model of"), "{err}");
    let k = own.iter().position(|&o| o == max).unwrap();
    let p = &r["pois"][k];
    let coords: Vec<String> = p["position"]
        .as_array()
        .unwrap()
        .iter()
        .chain(p["normal"].as_array().into_iter().flatten())
        .map(|c| format!("{}", c.as_f64().unwrap()))
        .collect();
    let one = dir.path().join("one.gml");
    let rep1 = dir.path().join("one.json");
    let o = crate::util::run(&[
        OsStr::new("lod"),
        gml.as_os_str(),
        OsStr::new("--poi"),
        OsStr::new(&coords.join(",")),
        OsStr::new("-o"),
        one.as_os_str(),
        OsStr::new("--report"),
        rep1.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r1: Value = serde_json::from_str(&std::fs::read_to_string(&rep1).unwrap()).unwrap();
    assert_eq!(
        r1["totals"]["polygons_out"].as_u64(),
        Some(max),
        "{}",
        r1["totals"]
    );
    assert_eq!(r1["pois"][0]["polygons_own"].as_u64(), Some(max));
}

#[test]
fn region_errors() {
    let dir = tempfile::tempdir().unwrap();
    let gml = synth_small(dir.path());
    for (args, code, says) in [
        (vec!["--facade", "no-such-id"], 2, "no-such-id"),
        (vec!["--region", REGION], 2, "--height"),
        (
            vec!["--region", "POLYGON((0 0, 1 0))", "--height", "1"],
            2,
            "WKT",
        ),
        (
            vec!["--facade", "B0_0_0_s0", "--spacing", "0"],
            2,
            "spacing",
        ),
    ] {
        let mut a: Vec<&OsStr> = vec![OsStr::new("svf"), gml.as_os_str()];
        a.extend(args.iter().map(OsStr::new));
        let o = crate::util::run(&a);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(code), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
    }
}

/// `horizon` takes the same region arguments: one profile per facade point.
#[test]
fn horizon_over_a_facade() {
    let dir = tempfile::tempdir().unwrap();
    let gml = synth_small(dir.path());
    let model = read_file(&gml).unwrap();
    let expected = facade_pois(&model, "B0_0_0_s0", 2.0, 0.05).unwrap();
    let o = crate::util::run(&[
        OsStr::new("horizon"),
        gml.as_os_str(),
        OsStr::new("--facade"),
        OsStr::new("B0_0_0_s0"),
        OsStr::new("--spacing"),
        OsStr::new("2"),
        OsStr::new("--step"),
        OsStr::new("10"),
        OsStr::new("--json"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    let pois = v["pois"].as_array().unwrap();
    assert_eq!(pois.len(), expected.len());
    for (p, e) in pois.iter().zip(&expected) {
        assert_eq!(p["id"].as_str(), Some(e.id.as_str()));
        assert_eq!(p["azimuth"].as_array().map(Vec::len), Some(36));
        // Behind its own wall a facade point sees no sky: 90 degrees there.
        let el: Vec<f64> = p["elevation"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert!(el.iter().any(|&x| (x - 90.0).abs() < 1e-6), "{el:?}");
    }
}
