//! `--poi-crs` and the sun's site through PROJ (feature `proj`), for CRSs the pure-Rust
//! conversions cannot do, checked against pyproj: POIs given in DHDN / Gauss-Kruger zone 3
//! (EPSG:31467) and in WGS 84 against a model in Gauss-Kruger zone 4 (EPSG:31468, the shared
//! CityGML 3.0 `Building_CityGML3.0_LOD2_with_several_attributes.gml`) land where pyproj puts them (1 mm); `sun-hours` without
//! `--lat`/`--lon` on a model in ED50 / UTM 31N (EPSG:23031, a temp copy of the committed
//! fixture relabelled) takes its site from pyproj's latitude/longitude of the model's centre.
//!
//! Needs `../shared/data` and python3 with pyproj: missing, the test fails under `CI=true`
//! and prints `SKIP: ...` otherwise.

use crate::util::{fixture, missing, os, python_has, run, shared_data, stderr};
use serde_json::Value;
use std::io::Write;
use std::process::{Command, Stdio};

/// Run python3 `code` with `input` on stdin, its stdout as JSON.
fn python_json(code: &str, input: &str) -> Value {
    let mut child = Command::new("python3")
        .args(["-c", code])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn python3");
    child
        .stdin
        .take()
        .unwrap()
        .write_all(input.as_bytes())
        .unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "python3: {}", stderr(&o));
    serde_json::from_slice(&o.stdout).expect("python JSON")
}

/// pyproj's (x, y) of `pts` from `from` to `to`, `always_xy` (easting/longitude first).
fn pyproj_xy(from: &str, to: &str, pts: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let code = format!(
        "import sys,json\nfrom pyproj import Transformer\n\
         t=Transformer.from_crs('{from}','{to}',always_xy=True)\n\
         print(json.dumps([list(t.transform(a,b)) for a,b in json.load(sys.stdin)]))"
    );
    let v = python_json(&code, &serde_json::to_string(pts).unwrap());
    v.as_array()
        .unwrap()
        .iter()
        .map(|p| [p[0].as_f64().unwrap(), p[1].as_f64().unwrap()])
        .collect()
}

/// `skylod svf --json` positions of the POIs `pois` (in `poi_crs`) in the model's CRS.
fn svf_positions(model: &str, poi_crs: &str, pois: &[String]) -> Vec<[f64; 3]> {
    let mut a = vec![
        os("svf"),
        os(model),
        os("--rays"),
        os("500"),
        os("--json"),
        os("--poi-crs"),
        os(poi_crs),
    ];
    for p in pois {
        a.extend([os("--poi"), os(p)]);
    }
    let o = run(&a);
    assert_eq!(o.status.code(), Some(0), "svf: {}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).expect("svf JSON");
    v["pois"]
        .as_array()
        .expect("pois")
        .iter()
        .map(|p| {
            let a = p["poi"].as_array().unwrap();
            [0, 1, 2].map(|i| a[i].as_f64().unwrap())
        })
        .collect()
}

/// POIs in Gauss-Kruger zone 3 (easting first, as projected CRSs are written) and in WGS 84
/// (latitude first) into a zone 4 model: pyproj's positions to 1 mm, heights kept.
#[test]
fn gauss_kruger_and_wgs84_pois_into_gauss_kruger_model() {
    let Some(data) = shared_data() else { return };
    let model = data.join(
        "ogc-citygml3-examples/Building/Building_CityGML3.0_LOD2_with_several_attributes.gml",
    );
    if !model.is_file() {
        missing(&model.display().to_string());
        return;
    }
    if !python_has("pyproj", "pip install pyproj") {
        return;
    }
    let m = model.display().to_string();
    // Points near the building (urn:adv:crs:DE_DHDN_3GK4 = EPSG:31468, around 4490663 E
    // 5322007 N).
    let near = [[4_490_640.0, 5_322_000.0], [4_490_700.25, 5_322_030.5]];
    let z = [556.5, 560.0];

    // Zone 3 (EPSG:31467): given as pyproj puts `near` there; expected as pyproj brings
    // the given point back to zone 4.
    let gk3 = pyproj_xy("EPSG:31468", "EPSG:31467", &near);
    let want = pyproj_xy("EPSG:31467", "EPSG:31468", &gk3);
    let given: Vec<String> = gk3
        .iter()
        .zip(z)
        .map(|(p, z)| format!("{:.4},{:.4},{z}", p[0], p[1]))
        .collect();
    let given_pts: Vec<[f64; 2]> = given
        .iter()
        .map(|s| {
            let v: Vec<f64> = s.split(',').map(|x| x.parse().unwrap()).collect();
            [v[0], v[1]]
        })
        .collect();
    let want_given = pyproj_xy("EPSG:31467", "EPSG:31468", &given_pts);
    let got = svf_positions(&m, "EPSG:31467", &given);
    for i in 0..near.len() {
        let d = (got[i][0] - want_given[i][0]).hypot(got[i][1] - want_given[i][1]);
        eprintln!(
            "GK3 POI {} -> skylod ({:.4}, {:.4}), pyproj ({:.4}, {:.4}): {:.2e} m apart",
            given[i], got[i][0], got[i][1], want_given[i][0], want_given[i][1], d
        );
        assert!(d < 1e-3, "{d} m from pyproj");
        assert_eq!(got[i][2], z[i], "height passed through");
        // The oracle round trip itself is consistent (a check on the oracle).
        assert!((want[i][0] - near[i][0]).hypot(want[i][1] - near[i][1]) < 1e-3);
    }

    // WGS 84 (latitude first as EPSG:4326 defines it): a datum shift from Bessel/DHDN.
    let ll = pyproj_xy("EPSG:31468", "EPSG:4326", &near);
    let given: Vec<String> = ll
        .iter()
        .zip(z)
        .map(|(p, z)| format!("{:.10},{:.10},{z}", p[1], p[0]))
        .collect();
    let given_pts: Vec<[f64; 2]> = given
        .iter()
        .map(|s| {
            let v: Vec<f64> = s.split(',').map(|x| x.parse().unwrap()).collect();
            [v[1], v[0]]
        })
        .collect();
    let want = pyproj_xy("EPSG:4326", "EPSG:31468", &given_pts);
    let got = svf_positions(&m, "EPSG:4326", &given);
    for i in 0..near.len() {
        let d = (got[i][0] - want[i][0]).hypot(got[i][1] - want[i][1]);
        eprintln!(
            "WGS 84 POI {} -> skylod ({:.4}, {:.4}), pyproj ({:.4}, {:.4}): {:.2e} m apart",
            given[i], got[i][0], got[i][1], want[i][0], want[i][1], d
        );
        assert!(d < 1e-3, "{d} m from pyproj");
        assert_eq!(got[i][2], z[i], "height passed through");
    }

    // A code PROJ does not know: a usage error naming the flag, not a guess.
    let o = run(&[
        os("svf"),
        os(&m),
        os("--poi-crs"),
        os("EPSG:999999"),
        os("--poi"),
        os("48.03,11.87,556"),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("--poi-crs EPSG:999999"),
        "{}",
        stderr(&o)
    );
}

/// The site of the sun from a model in ED50 / UTM 31N (International 1924 ellipsoid, which
/// the builtin conversion refuses): pyproj's latitude/longitude of the model's bounding-box
/// centre, and not the site of the same numbers read as ETRS89 / UTM 31N.
#[test]
fn sun_site_from_ed50_model() {
    if !python_has("pyproj", "pip install pyproj") {
        return;
    }
    let src = fixture("synth-small.gml");
    let text = std::fs::read_to_string(&src).unwrap();
    assert!(
        text.contains("srsName=\"EPSG:25831\""),
        "fixture CRS changed"
    );
    let dir = tempfile::tempdir().unwrap();
    let ed50 = dir.path().join("synth-ed50.gml");
    std::fs::write(
        &ed50,
        text.replace("srsName=\"EPSG:25831\"", "srsName=\"EPSG:23031\""),
    )
    .unwrap();
    // The bounding-box centre and its latitude/longitude, by pyproj, from the file itself.
    let code = "import sys,re,json\nfrom pyproj import Transformer\n\
        s=open(sys.stdin.read().strip()).read()\n\
        v=[float(x) for m in re.findall(r'<gml:posList[^>]*>([^<]*)<',s) for x in m.split()]\n\
        xs,ys=v[0::3],v[1::3]\n\
        cx,cy=(min(xs)+max(xs))/2,(min(ys)+max(ys))/2\n\
        lon,lat=Transformer.from_crs('EPSG:23031','EPSG:4326',always_xy=True).transform(cx,cy)\n\
        print(json.dumps([lat,lon,cx,cy]))";
    let want = python_json(code, &ed50.display().to_string());
    let (lat0, lon0) = (want[0].as_f64().unwrap(), want[1].as_f64().unwrap());
    let site = |file: &str| {
        let o = run(&[
            os("sun-hours"),
            os(file),
            os("--poi"),
            os("430009.950,4581032.381,16.6,-1,0,0"),
            os("--step"),
            os("60"),
            os("--json"),
        ]);
        assert_eq!(o.status.code(), Some(0), "sun-hours: {}", stderr(&o));
        let v: Value = serde_json::from_slice(&o.stdout).expect("sun-hours JSON");
        (
            v["lat"].as_f64().unwrap(),
            v["lon"].as_f64().unwrap(),
            stderr(&o),
        )
    };
    let (lat, lon, err) = site(&ed50.display().to_string());
    let (lat_e, lon_e, _) = site(&src.display().to_string());
    let m_per_deg = 111_320.0;
    let d = (lat - lat0).hypot((lon - lon0) * lat0.to_radians().cos()) * m_per_deg;
    let shift = (lat - lat_e).hypot((lon - lon_e) * lat0.to_radians().cos()) * m_per_deg;
    eprintln!(
        "ED50 site: skylod ({lat:.9}, {lon:.9}), pyproj ({lat0:.9}, {lon0:.9}) at centre \
         ({}, {}): {d:.2e} m apart; the same numbers as ETRS89: ({lat_e:.9}, {lon_e:.9}), \
         {shift:.1} m away",
        want[2], want[3]
    );
    assert!(err.contains("site lat"), "{err}");
    assert!(d < 1e-3, "{d} m from pyproj");
    // ED50 is ~100 m from ETRS89 in Spain: the CRS was read, not taken as UTM on GRS 1980.
    assert!(shift > 50.0, "{shift} m");
}
