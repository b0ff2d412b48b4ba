//! Frames and CRSs end to end: a geographic PLATEAU model (EPSG:6697, latitude, longitude,
//! metres) traced in metres against an independent oracle (pyproj to JGD2011 / Japan Plane
//! Rectangular CS IX and a numpy ray caster, `tests/oracle/plateau_svf.py`); POIs given in
//! WGS 84 latitude/longitude equal to the same points in model coordinates (pyproj gives the
//! coordinates); a model in US survey feet equal to the same model in metres; mixed-LoD output
//! of a geographic model in its own CRS; the sun's site from a geographic CRS; skylod's EPSG
//! tables against pyproj's database (`tests/oracle/crs_tables.py`).
//!
//! Needs `../shared/data` and python3 with pyproj and numpy: missing, the test fails under
//! `CI=true` and prints `SKIP: ...` otherwise.

use crate::util::{fixture, manifest_dir, missing, os, python_has, run, shared_data, stderr};
use serde_json::Value;
use std::f64::consts::FRAC_1_SQRT_2;
use std::ffi::OsStr;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

fn plateau_2022() -> Option<PathBuf> {
    let f = shared_data()?.join("plateau/tokyo23ku-2022/53392633_bldg_6697_2_op.gml.gz");
    if f.is_file() {
        Some(f)
    } else {
        missing(&format!("{}", f.display()));
        None
    }
}

/// Street points of the Tokyo 2022 tile (latitude, longitude, height in m; 1.5 m above the
/// lowest ground of the tile), chosen in gaps between the buildings.
const STREET: [&str; 4] = [
    "35.53303834,139.79429521,4.7",
    "35.53312871,139.79501195,4.7",
    "35.53281320,139.79495696,4.7",
    "35.53321917,139.79605951,4.7",
];

/// `skylod svf --json` with extra arguments: (svf per POI, poi position per POI).
fn svf_json(args: &[&OsStr]) -> (Vec<f64>, Vec<[f64; 3]>, String) {
    let mut a = vec![os("svf")];
    a.extend_from_slice(args);
    a.push(os("--json"));
    let o = run(&a);
    assert_eq!(o.status.code(), Some(0), "svf {args:?}: {}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).expect("svf JSON");
    let pois = v["pois"].as_array().expect("pois");
    let svf = pois.iter().map(|p| p["svf"].as_f64().unwrap()).collect();
    let pos = pois
        .iter()
        .map(|p| {
            let a = p["poi"].as_array().unwrap();
            [0, 1, 2].map(|i| a[i].as_f64().unwrap())
        })
        .collect();
    (svf, pos, stderr(&o))
}

fn poi_args(points: &[&str]) -> Vec<String> {
    points
        .iter()
        .flat_map(|p| ["--poi".to_string(), p.to_string()])
        .collect()
}

fn python(script: &str, args: &[String], stdin: Option<&str>) -> String {
    let mut child = Command::new("python3")
        .arg(manifest_dir().join("tests/oracle").join(script))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn python3");
    if let Some(s) = stdin {
        child.stdin.take().unwrap().write_all(s.as_bytes()).unwrap();
    } else {
        drop(child.stdin.take());
    }
    let o = child.wait_with_output().unwrap();
    assert!(
        o.status.success(),
        "{script}: {}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout).unwrap()
}

/// pyproj `Transformer.from_crs(from, to)` (EPSG axis order unless `always_xy`) on points.
fn pyproj(from: &str, to: &str, always_xy: bool, pts: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let code = format!(
        "import sys,json\nfrom pyproj import Transformer\nt=Transformer.from_crs('{from}','{to}',always_xy={})\n\
         print(json.dumps([list(t.transform(a,b)) for a,b in json.load(sys.stdin)]))",
        if always_xy { "True" } else { "False" }
    );
    let mut child = Command::new("python3")
        .args(["-c", &code])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .expect("spawn python3");
    let input = serde_json::to_string(&pts.iter().map(|p| p.to_vec()).collect::<Vec<_>>()).unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(input.as_bytes())
        .unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success());
    let v: Vec<Vec<f64>> = serde_json::from_slice(&o.stdout).unwrap();
    v.into_iter().map(|p| [p[0], p[1]]).collect()
}

/// SVF at PLATEAU street points: skylod (local ENU frame) vs the oracle (pyproj to a metric
/// CRS + numpy ray casting). Tolerance: both sides are stratified Monte Carlo estimates; the
/// binomial standard deviation of the difference (an upper bound for stratified sampling) is
/// sqrt(p(1-p)(1/40000 + 1/22500)) <= 0.0042 for p near 0.7, so 0.012 is ~3 of them. The old
/// behaviour (degrees traced as metres) gave 0.99 at every point.
#[test]
fn plateau_svf_matches_oracle() {
    let Some(f) = plateau_2022() else { return };
    if !python_has("pyproj, numpy", "pip install pyproj numpy") {
        return;
    }
    let fs = f.display().to_string();
    let mut args: Vec<String> = vec![fs.clone(), "--rays".into(), "40000".into()];
    args.extend(poi_args(&STREET));
    let a: Vec<&OsStr> = args.iter().map(os).collect();
    let (svf, _, err) = svf_json(&a);
    assert!(
        err.contains("local east-north-up frame"),
        "frame announced: {err}"
    );
    let mut oargs = vec![fs.clone(), "150".into(), "1".into()];
    oargs.extend(STREET.iter().map(|s| s.to_string()));
    let out = python("plateau_svf.py", &oargs, None);
    let oracle: Vec<f64> = out
        .lines()
        .filter(|l| !l.starts_with("triangles"))
        .map(|l| l.split_whitespace().nth(1).unwrap().parse().unwrap())
        .collect();
    assert_eq!(oracle.len(), STREET.len(), "{out}");
    // Degrees as metres (the old behaviour), forced by declaring a metric CRS.
    let mut bad = args.clone();
    bad.extend(["--source-crs".into(), "EPSG:32654".into()]);
    let b: Vec<&OsStr> = bad.iter().map(os).collect();
    let (degrees, _, _) = svf_json(&b);
    for i in 0..STREET.len() {
        eprintln!(
            "PLATEAU {}: skylod {:.4}, oracle {:.4}, degrees-as-metres {:.4}",
            STREET[i], svf[i], oracle[i], degrees[i]
        );
        assert!(
            (svf[i] - oracle[i]).abs() < 0.012,
            "{}: skylod {} vs oracle {}",
            STREET[i],
            svf[i],
            oracle[i]
        );
    }
    // The fixture tells the frames apart: the degree-space SVF is far from the oracle.
    assert!(
        (degrees[0] - oracle[0]).abs() > 0.2,
        "{} vs {}",
        degrees[0],
        oracle[0]
    );
}

/// A POI given in WGS 84 (`--poi-crs EPSG:4326`, latitude first) is the same point as in
/// model coordinates: for PLATEAU (JGD2011; pyproj's 6668 -> 4326 is the null
/// transformation, like skylod's) and for a UTM model (pyproj gives the latitude/longitude).
#[test]
fn latlon_poi_equals_model_poi() {
    if !python_has("pyproj, numpy", "pip install pyproj numpy") {
        return;
    }
    // UTM (EPSG:25831): the facade POIs of the committed fixture (the third one sees the
    // other buildings: SVF 0.46).
    let g = fixture("synth-small.gml").display().to_string();
    let model = [
        [430009.950, 4581032.381, 16.6, -1.0, 0.0, 0.0],
        [
            430017.465,
            4581017.465,
            16.6,
            -FRAC_1_SQRT_2,
            -FRAC_1_SQRT_2,
            0.0,
        ],
        [430032.407, 4581009.950, 16.6, 0.0, -1.0, 0.0],
    ];
    let ll = pyproj(
        "EPSG:25831",
        "EPSG:4326",
        false,
        &model.map(|m| [m[0], m[1]]),
    );
    // Normals along the CRS's axes: 4326 is (north, east, up); the grid's east/north are
    // taken as true east/north here, skylod corrects the ~0.55 degree convergence.
    let as_model: Vec<String> = model
        .iter()
        .map(|m| format!("{},{},{},{},{},{}", m[0], m[1], m[2], m[3], m[4], m[5]))
        .collect();
    let as_ll: Vec<String> = model
        .iter()
        .zip(&ll)
        .map(|(m, l)| {
            format!(
                "{:.10},{:.10},{},{},{},{}",
                l[0], l[1], m[2], m[4], m[3], m[5]
            )
        })
        .collect();
    let run_pois = |pois: &[String], extra: &[&str]| {
        let mut v = vec![g.clone(), "--rays".into(), "20000".into()];
        v.extend(poi_args(
            &pois.iter().map(|s| s.as_str()).collect::<Vec<_>>(),
        ));
        v.extend(extra.iter().map(|s| s.to_string()));
        let a: Vec<&OsStr> = v.iter().map(os).collect();
        svf_json(&a)
    };
    let (s_model, p_model, _) = run_pois(&as_model, &[]);
    let (s_ll, p_ll, _) = run_pois(&as_ll, &["--poi-crs", "EPSG:4326"]);
    for i in 0..model.len() {
        let d =
            ((p_ll[i][0] - p_model[i][0]).powi(2) + (p_ll[i][1] - p_model[i][1]).powi(2)).sqrt();
        eprintln!(
            "UTM POI {i}: model ({:.3}, {:.3}) via lat/lon ({:.3}, {:.3}): {d:.4} m apart; svf {:.4} vs {:.4}",
            p_model[i][0], p_model[i][1], p_ll[i][0], p_ll[i][1], s_model[i], s_ll[i]
        );
        assert!(d < 0.02, "UTM round trip {d} m");
        assert_eq!(p_ll[i][2], p_model[i][2]);
        assert!(
            (s_ll[i] - s_model[i]).abs() < 0.01,
            "{} {}",
            s_ll[i],
            s_model[i]
        );
    }

    // PLATEAU: the model's JGD2011 (lat, lon) through pyproj to WGS 84, and back by skylod.
    let Some(f) = plateau_2022() else { return };
    let pts: Vec<[f64; 3]> = STREET
        .iter()
        .map(|s| {
            let v: Vec<f64> = s.split(',').map(|x| x.parse().unwrap()).collect();
            [v[0], v[1], v[2]]
        })
        .collect();
    let wgs = pyproj(
        "EPSG:6668",
        "EPSG:4326",
        false,
        &pts.iter().map(|p| [p[0], p[1]]).collect::<Vec<_>>(),
    );
    let fs = f.display().to_string();
    let as_wgs: Vec<String> = pts
        .iter()
        .zip(&wgs)
        .map(|(p, w)| format!("{:.12},{:.12},{}", w[0], w[1], p[2]))
        .collect();
    let mut a1 = vec![fs.clone(), "--rays".into(), "20000".into()];
    a1.extend(poi_args(&STREET));
    let mut a2 = vec![
        fs,
        "--rays".into(),
        "20000".into(),
        "--poi-crs".into(),
        "urn:ogc:def:crs:EPSG::4326".into(),
    ];
    a2.extend(poi_args(
        &as_wgs.iter().map(|s| s.as_str()).collect::<Vec<_>>(),
    ));
    let (s1, p1, _) = svf_json(&a1.iter().map(os).collect::<Vec<_>>());
    let (s2, p2, _) = svf_json(&a2.iter().map(os).collect::<Vec<_>>());
    for i in 0..pts.len() {
        // 1e-8 degree is ~1 mm.
        assert!(
            (p1[i][0] - p2[i][0]).abs() < 1e-8 && (p1[i][1] - p2[i][1]).abs() < 1e-8,
            "{:?} vs {:?}",
            p1[i],
            p2[i]
        );
        assert!((s1[i] - s2[i]).abs() < 1e-3, "{} vs {}", s1[i], s2[i]);
    }
}

/// Multiply the coordinates of every posList, pos, lowerCorner and upperCorner triple:
/// x, y by `h`, z by `v`; and replace the srsName.
fn scaled_gml(text: &str, h: f64, v: f64, srs: &str) -> String {
    let mut out = String::with_capacity(text.len() + text.len() / 4);
    let mut rest = text;
    let tags = [
        "<gml:posList",
        "<gml:pos",
        "<gml:lowerCorner",
        "<gml:upperCorner",
    ];
    while let Some((i, tag)) = tags
        .iter()
        .filter_map(|t| rest.find(t).map(|i| (i, *t)))
        .min_by_key(|x| x.0)
    {
        let gt = rest[i..].find('>').unwrap() + i + 1;
        let lt = rest[gt..].find('<').unwrap() + gt;
        out.push_str(&rest[..gt]);
        let nums: Vec<f64> = rest[gt..lt]
            .split_whitespace()
            .map(|x| x.parse().unwrap())
            .collect();
        assert_eq!(nums.len() % 3, 0, "{tag}: 3D coordinates expected");
        let s: Vec<String> = nums
            .iter()
            .enumerate()
            .map(|(k, x)| format!("{:.9}", if k % 3 == 2 { x * v } else { x * h }))
            .collect();
        out.push_str(&s.join(" "));
        rest = &rest[lt..];
    }
    out.push_str(rest);
    out.replace("srsName=\"EPSG:25831\"", &format!("srsName=\"{srs}\""))
}

fn scaled_pois(text: &str, h: f64, v: f64) -> String {
    let mut out = String::new();
    for (i, line) in text.lines().enumerate() {
        if i == 0 {
            out.push_str(line);
        } else {
            let f: Vec<&str> = line.split(',').collect();
            let x: f64 = f[1].parse().unwrap();
            let y: f64 = f[2].parse().unwrap();
            let z: f64 = f[3].parse().unwrap();
            out.push_str(&format!(
                "{},{:.9},{:.9},{:.9},{}",
                f[0],
                x * h,
                y * h,
                z * v,
                f[4..].join(",")
            ));
        }
        out.push('\n');
    }
    out
}

/// The committed fixture scaled to US survey feet gives the same SVF as in metres: heights in
/// feet too (EPSG:2263 alone, as New York's models), and heights in metres (compound with
/// NAVD88 height in metres, EPSG:5703), where tracing the feet as metres would be wrong.
#[test]
fn feet_model_same_svf() {
    let dir = tempfile::tempdir().unwrap();
    let g = fixture("synth-small.gml");
    let text = std::fs::read_to_string(&g).unwrap();
    let pois = std::fs::read_to_string(fixture("synth-small.pois.csv")).unwrap();
    let ft = 3937.0 / 1200.0; // feet per metre
    let write = |name: &str, s: &str| -> PathBuf {
        let p = dir.path().join(name);
        std::fs::write(&p, s).unwrap();
        p
    };
    let m_pois = fixture("synth-small.pois.csv");
    let svf_of = |model: &Path, pois: &Path, extra: &[&str]| {
        let mut a = vec![
            model.as_os_str(),
            os("--pois"),
            pois.as_os_str(),
            os("--rays"),
            os("4000"),
        ];
        a.extend(extra.iter().map(os));
        svf_json(&a)
    };
    let (metres, _, _) = svf_of(&g, &m_pois, &[]);
    assert_eq!(metres.len(), 3);
    for (name, v, srs) in [
        ("feet.gml", ft, "EPSG:2263"),
        (
            "feet-m.gml",
            1.0,
            "urn:ogc:def:crs,crs:EPSG::2263,crs:EPSG::5703",
        ),
    ] {
        let model = write(name, &scaled_gml(&text, ft, v, srs));
        let p = write(&format!("{name}.pois.csv"), &scaled_pois(&pois, ft, v));
        let (feet, pos, err) = svf_of(&model, &p, &[]);
        assert!(err.contains("feet to metres"), "{err}");
        eprintln!("{name} ({srs}): metres {metres:?}, feet {feet:?}");
        for (i, (a, b)) in metres.iter().zip(&feet).enumerate() {
            // A ray or four of 4,000 may flip on f32 rounding of other coordinates.
            assert!((a - b).abs() < 1e-3, "{name} POI {i}: metres {a}, feet {b}");
        }
        // Reports keep the input's coordinates (feet).
        assert!(pos[0][0] > 1.4e6, "{:?}", pos[0]);
        if v == 1.0 {
            // Heights in metres, plan in feet: traced as one unit, the geometry is stretched.
            let (wrong, _, _) = svf_of(&model, &p, &["--source-crs", "EPSG:32631"]);
            let worst = metres
                .iter()
                .zip(&wrong)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            eprintln!("{name} traced as one unit: {wrong:?}");
            assert!(worst > 0.02, "unit mix-up not visible: {worst}");
        }
    }
}

/// `lod` and `rough` on a geographic model write CityGML in the input's CRS and axis order
/// (latitude, longitude, metres), and the written LoD model gives the same SVF.
#[test]
fn plateau_lod_output_in_input_crs() {
    let Some(f) = plateau_2022() else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("lod.gml");
    let mut a: Vec<String> = vec![
        "lod".into(),
        f.display().to_string(),
        "-o".into(),
        out.display().to_string(),
        "--rays".into(),
        "4000".into(),
    ];
    a.extend(poi_args(&STREET));
    let o = run(&a.iter().map(os).collect::<Vec<_>>());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let rough = dir.path().join("rough.gml");
    let o = run(&[os("rough"), f.as_os_str(), os("-o"), rough.as_os_str()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let bbox = |p: &Path| -> Vec<f64> {
        let o = run(&[os("stats"), os("--json"), p.as_os_str()]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let v: Value = serde_json::from_slice(&o.stdout).unwrap();
        v["total"]["bbox"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let input = bbox(&f);
    for p in [&out, &rough] {
        let b = bbox(p);
        // Within the input's box (1e-5 degree ~ 1 m; heights 0.5 m): degrees, not ENU metres.
        for k in 0..3 {
            let tol = if k == 2 { 0.5 } else { 1e-5 };
            assert!(
                b[k] >= input[k] - tol,
                "{} {k}: {b:?} vs {input:?}",
                p.display()
            );
            assert!(
                b[k + 3] <= input[k + 3] + tol,
                "{} {k}: {b:?} vs {input:?}",
                p.display()
            );
        }
        let text = std::fs::read_to_string(p).unwrap();
        assert!(text.contains("http://www.opengis.net/def/crs/EPSG/0/6697"));
    }
    // The LoD model traced again (from the written file) at its POIs: the SVF of the full
    // model within the paper's accuracy.
    let mut full = vec![f.display().to_string(), "--rays".into(), "20000".into()];
    full.extend(poi_args(&STREET));
    let mut lod = vec![out.display().to_string(), "--rays".into(), "20000".into()];
    lod.extend(poi_args(&STREET));
    let (s_full, _, _) = svf_json(&full.iter().map(os).collect::<Vec<_>>());
    let (s_lod, _, _) = svf_json(&lod.iter().map(os).collect::<Vec<_>>());
    for (a, b) in s_full.iter().zip(&s_lod) {
        eprintln!("PLATEAU LoD output: full {a:.4}, lod {b:.4}");
        assert!((a - b).abs() < 0.02, "full {a} vs lod {b}");
    }
}

/// The sun's site from a geographic CRS: sun-hours without --lat/--lon on PLATEAU uses the
/// centre of the model (35.533 N, 139.795 E), and fisheye draws the sun paths for it.
#[test]
fn plateau_site_from_crs() {
    let Some(f) = plateau_2022() else { return };
    let o = run(&[
        os("sun-hours"),
        f.as_os_str(),
        os("--poi"),
        os(STREET[1]),
        os("--step"),
        os("60"),
        os("--json"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    let (lat, lon) = (v["lat"].as_f64().unwrap(), v["lon"].as_f64().unwrap());
    assert!(
        (lat - 35.5331).abs() < 1e-3 && (lon - 139.7951).abs() < 1e-3,
        "{lat} {lon}"
    );
    let h = v["pois"][0]["sun_hours"].as_f64().unwrap();
    assert!(h > 1000.0 && h < 4400.0, "{h}");
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("sky.svg");
    let o = run(&[
        os("fisheye"),
        f.as_os_str(),
        os("--poi"),
        os(STREET[1]),
        os("-o"),
        svg.as_os_str(),
        os("--rays"),
        os("300"),
        os("--colour-by"),
        os("kind"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(
        text.contains("12h") && text.contains("sun paths"),
        "sun paths drawn"
    );
}

/// A model naming no CRS is traced as metres, with a warning; `--source-crs` names it.
#[test]
fn no_crs_warns_and_source_crs_overrides() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(fixture("synth-small.gml")).unwrap();
    let p = dir.path().join("nocrs.gml");
    std::fs::write(&p, text.replace(" srsName=\"EPSG:25831\"", "")).unwrap();
    let poi = "430032.407,4581009.950,16.600,0,-1,0";
    let (a, _, err) = svf_json(&[p.as_os_str(), os("--poi"), os(poi)]);
    assert!(err.contains("names no CRS"), "{err}");
    let (b, _, err) = svf_json(&[
        p.as_os_str(),
        os("--poi"),
        os(poi),
        os("--source-crs"),
        os("EPSG:25831"),
    ]);
    assert!(!err.contains("warning"), "{err}");
    assert_eq!(a, b);
    // --poi-crs needs a model CRS to convert to.
    let o = run(&[
        os("svf"),
        p.as_os_str(),
        os("--poi"),
        os("41.38,2.16,16"),
        os("--poi-crs"),
        os("EPSG:4326"),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    // A flag that names no CRS is a usage error.
    let o = run(&[
        os("svf"),
        p.as_os_str(),
        os("--poi"),
        os(poi),
        os("--source-crs"),
        os("wgs84"),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

/// skylod's EPSG tables (feet units, geographic axis order and ellipsoid, projected metres)
/// against pyproj's EPSG database.
#[test]
fn crs_tables_match_pyproj() {
    if !python_has("pyproj, numpy", "pip install pyproj numpy") {
        return;
    }
    use skylod::model::crs::{foot_codes, US_SURVEY_FOOT};
    use skylod::model::crs::{GEOGRAPHIC, PROJECTED_METRES};
    let (us, intl): (Vec<_>, Vec<_>) = foot_codes().partition(|(_, u)| *u == US_SURVEY_FOOT);
    let claims = serde_json::json!({
        "feet_us": us.iter().map(|x| x.0).collect::<Vec<_>>(),
        "feet_intl": intl.iter().map(|x| x.0).collect::<Vec<_>>(),
        "geographic": GEOGRAPHIC
            .iter()
            .map(|(c, lat_first, e)| serde_json::json!([c, lat_first, e.a, e.inv_f]))
            .collect::<Vec<_>>(),
        "projected_m": PROJECTED_METRES
            .iter()
            .flat_map(|(a, b)| *a..=*b)
            .collect::<Vec<_>>(),
    });
    let out = python("crs_tables.py", &[], Some(&claims.to_string()));
    assert!(out.starts_with("ok "), "{out}");
}
