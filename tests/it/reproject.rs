//! `skylod reproject` (feature `proj`): shared files reprojected and every coordinate checked
//! against pyproj (`tests/oracle/pyproj_reproject.py`, which parses the files itself), heights
//! kept, `srsName` and envelopes updated, XSD-valid output, and a round trip A -> B -> A.

use crate::util::*;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn reproject(input: &Path, out: &Path, target: &str, source: Option<&str>) {
    let mut args = vec![
        os("reproject"),
        os(input),
        os("-t"),
        os(target),
        os("-o"),
        os(out),
    ];
    if let Some(s) = source {
        args.extend([os("-s"), os(s)]);
    }
    let o = run(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// The oracle's report on `out` = `input` reprojected from `source` to `target`.
fn oracle(input: &Path, out: &Path, source: &str, target: &str) -> Value {
    let script = manifest_dir().join("tests/oracle/pyproj_reproject.py");
    let o = Command::new("python3")
        .arg(script)
        .args([os(input), os(out), os(source), os(target)])
        .output()
        .expect("python3");
    assert!(o.status.success(), "oracle: {}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v.get("error").is_none(), "{v}");
    v
}

fn f(v: &Value, k: &str) -> f64 {
    v[k].as_f64().unwrap_or_else(|| panic!("{k} in {v}"))
}

struct Case {
    file: &'static str,
    source: &'static str,
    target: &'static str,
    /// Largest accepted difference from pyproj per axis, in the target's units.
    tol: f64,
    /// The srsName the output must carry.
    srs: &'static str,
    /// The input is XSD-valid (PLATEAU's ADE is not in the shared schemas).
    xsd: Option<&'static str>,
}

const CASES: [Case; 5] = [
    // Ingolstadt LoD3 (WGS 84 / UTM 32N) to latitude/longitude: 1e-9 deg is 0.1 mm.
    Case {
        file: "ingolstadt-lod3/4018106.xml.gz",
        source: "EPSG:32632",
        target: "EPSG:4326",
        tol: 1e-9,
        srs: "urn:ogc:def:crs:EPSG::4326",
        xsd: Some("2.0"),
    },
    // KIT FZK-Haus (AdV ETRS89 / UTM 32N + DHHN92) to ETRS89 geographic: the compound keeps
    // its vertical CRS.
    Case {
        file: "kit-fzk-haus/citygml2/fzk_haus_lod3_v2.gml",
        source: "EPSG:25832",
        target: "EPSG:4258",
        tol: 1e-9,
        srs: "urn:ogc:def:crs,crs:EPSG::4258,crs:EPSG::5783",
        xsd: Some("2.0"),
    },
    // PLATEAU Sapporo (JGD2011 lat/lon + height, EPSG:6697) to JGD2011 / UTM 54N: 1 mm.
    Case {
        file: "plateau/sapporo/64413325_bldg_6697_op.gml",
        source: "EPSG:6697",
        target: "EPSG:6691",
        tol: 1e-3,
        srs: "urn:ogc:def:crs,crs:EPSG::6691,crs:EPSG::6695",
        xsd: None,
    },
    // The OGC example building (ETRS89 / UTM 32N + DHHN92, LoD3) to WGS 84.
    Case {
        file: "ogc-citygml2-examples/building/Building_LOD3-EPSG25832.gml",
        source: "EPSG:25832",
        target: "EPSG:4326",
        tol: 1e-9,
        srs: "urn:ogc:def:crs,crs:EPSG::4326,crs:EPSG::5783",
        xsd: Some("2.0"),
    },
    // CityGML 3.0 (GML 3.2) FZK-Haus into the neighbouring zone, UTM 33N.
    Case {
        file: "kit-fzk-haus/citygml3/FZK-Haus-LoD3-KIT-IAI-KHH-B36-V1__v3.gml",
        source: "EPSG:25832",
        target: "EPSG:25833",
        tol: 1e-3,
        srs: "urn:ogc:def:crs,crs:EPSG::25833,crs:EPSG::5783",
        xsd: Some("3.0"),
    },
];

#[test]
fn shared_files_match_pyproj() {
    let Some(data) = shared_data() else { return };
    if !python_has("pyproj", "pip install pyproj") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mut xsd: Vec<(PathBuf, PathBuf, String)> = Vec::new();
    let mut problems = Vec::new();
    for (k, c) in CASES.iter().enumerate() {
        let input = data.join(c.file);
        let out = dir.path().join(format!("out{k}.gml"));
        reproject(&input, &out, c.target, None);
        let v = oracle(&input, &out, c.source, c.target);
        let (d0, d1, dz) = (f(&v, "max_d0"), f(&v, "max_d1"), f(&v, "max_dz"));
        let env = f(&v, "envelope_error");
        eprintln!(
            "{} {} -> {}: {} points, max |d| {d0:.3e} / {d1:.3e}, heights {dz:.1e}, root envelope {env:.1e}",
            c.file, c.source, c.target, v["points"]
        );
        assert!(v["points"].as_u64().unwrap() > 100, "{v}");
        if d0 > c.tol || d1 > c.tol {
            problems.push(format!("{}: {d0} / {d1} over {}", c.file, c.tol));
        }
        if dz != 0.0 {
            problems.push(format!("{}: heights changed by {dz}", c.file));
        }
        if env > c.tol {
            problems.push(format!("{}: root envelope off by {env}", c.file));
        }
        let srs: Vec<&str> = v["srs_names"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s.as_str().unwrap())
            .collect();
        if srs != [c.srs] {
            problems.push(format!("{}: srsName {srs:?}, expected {}", c.file, c.srs));
        }
        if let Some(version) = c.xsd {
            xsd.push((input, out, version.to_string()));
        }
    }
    check_xsd(&xsd, &mut problems);
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn round_trip_within_a_millimetre() {
    let Some(data) = shared_data() else { return };
    if !python_has("pyproj", "pip install pyproj") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let input = data.join("ingolstadt-lod3/4018106.xml.gz");
    let there = dir.path().join("there.gml");
    let back = dir.path().join("back.gml.gz");
    reproject(&input, &there, "EPSG:4326", None);
    reproject(&there, &back, "EPSG:32632", None);
    // The identity, as pyproj sees it: every coordinate back within 1 mm.
    let v = oracle(&input, &back, "EPSG:32632", "EPSG:32632");
    let (d0, d1) = (f(&v, "max_d0"), f(&v, "max_d1"));
    eprintln!("round trip 32632 -> 4326 -> 32632: max |d| {d0:.2e} m / {d1:.2e} m");
    assert!(d0 < 1e-3 && d1 < 1e-3, "{v}");
    assert_eq!(f(&v, "max_dz"), 0.0);
    assert_eq!(v["srs_names"][0], "urn:ogc:def:crs:EPSG::32632");
}

#[test]
fn untouched_bytes_are_copied() {
    let Some(data) = shared_data() else { return };
    let dir = tempfile::tempdir().unwrap();
    let input = data.join("kit-fzk-haus/citygml2/fzk_haus_lod3_v2.gml");
    let out = dir.path().join("o.gml");
    reproject(&input, &out, "EPSG:4326", None);
    let a = std::fs::read_to_string(&input).unwrap();
    let b = std::fs::read_to_string(&out).unwrap();
    // Outside coordinate texts, srsName values and envelopes the documents are the same:
    // compare them with every such part blanked out.
    fn skeleton(s: &str) -> String {
        let mut s = s.to_string();
        while let (Some(i), Some(j)) = (s.find("<gml:Envelope"), s.find("</gml:Envelope>")) {
            s.replace_range(i..j + "</gml:Envelope>".len(), "<ENV/>");
        }
        let mut out = String::new();
        for (k, part) in s.split("srsName=\"").enumerate() {
            if k > 0 {
                out.push_str("srsName=\"");
                let q = part.find('"').unwrap();
                out.push_str(&part[q..]);
            } else {
                out.push_str(part);
            }
        }
        let mut blanked = String::new();
        let mut rest = out.as_str();
        while let Some(i) = rest.find('>') {
            let (head, tail) = rest.split_at(i + 1);
            blanked.push_str(head);
            let n = tail.find('<').unwrap_or(tail.len());
            let text = &tail[..n];
            let numeric = text.chars().any(|c| c.is_ascii_digit())
                && text
                    .chars()
                    .all(|c| c.is_ascii_digit() || " .-+eE\n\t\r".contains(c));
            if !numeric {
                blanked.push_str(text);
            }
            rest = &tail[n..];
        }
        blanked.push_str(rest);
        blanked
    }
    assert_eq!(skeleton(&a), skeleton(&b));
    assert_ne!(a, b);
    assert!(b.contains("<gml:Envelope srsName=\"urn:ogc:def:crs,crs:EPSG::4326,crs:EPSG::5783\""));
}

#[test]
fn usage_errors() {
    let dir = tempfile::tempdir().unwrap();
    let input = fixture("synth-small.gml");
    let out = dir.path().join("o.gml");
    for (args, code) in [
        (vec!["-t", "EPSG:999999"], 2),
        (vec!["-t", "nonsense"], 2),
        (vec!["-t", "EPSG:4326", "-s", "EPSG:0"], 2),
    ] {
        let mut a = vec![os("reproject"), os(&input), os("-o"), os(&out)];
        a.extend(args.iter().map(os));
        let o = run(&a);
        assert_eq!(o.status.code(), Some(code), "{args:?}: {}", stderr(&o));
        assert!(!out.exists());
    }
    // A document whose CRS is not given: exit 1, nothing written.
    let local = dir.path().join("local.gml");
    let text = std::fs::read_to_string(&input).unwrap();
    let srs = text.find("srsName=\"").expect("the fixture names its CRS");
    let end = text[srs + 9..].find('"').unwrap() + srs + 9;
    std::fs::write(
        &local,
        format!("{}srsName=\"#local-CRS-1{}", &text[..srs], &text[end..]),
    )
    .unwrap();
    let o = run(&[
        os("reproject"),
        os(&local),
        os("-t"),
        os("EPSG:4326"),
        os("-o"),
        os(&out),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("#local-CRS-1"), "{}", stderr(&o));
    assert!(!out.exists());
    // With -s it goes through.
    let o = run(&[
        os("reproject"),
        os(&local),
        os("-t"),
        os("EPSG:4326"),
        os("-s"),
        os("EPSG:25831"),
        os("-o"),
        os(&out),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stderr(&o).contains("warning"), "{}", stderr(&o));
}

/// The numbers of the first element named `tag` (any prefix) in `text`.
fn numbers_of(text: &str, tag: &str) -> Vec<f64> {
    let open = text.find(tag).expect(tag);
    let start = open + text[open..].find('>').unwrap() + 1;
    let end = start + text[start..].find('<').unwrap();
    text[start..end]
        .split_whitespace()
        .map(|t| t.parse().unwrap())
        .collect()
}

#[test]
fn implicit_geometry_follows_pyproj() {
    let Some(data) = shared_data() else { return };
    if !python_has("pyproj", "pip install pyproj") {
        return;
    }
    // Two implicit geometries (a template and an xlink to it) in DHDN / Gauss-Kruger + DHHN92,
    // written easting first.
    let input = data.join("ogc-citygml2-examples/spec-examples/GenericCityObjects.xml");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("g.gml");
    reproject(&input, &out, "EPSG:25832", None);
    let (a, b) = (
        std::fs::read_to_string(&input).unwrap(),
        std::fs::read_to_string(&out).unwrap(),
    );
    // The implicit geometry with a matrix, and its reference point (which follows it).
    let after = |t: &str| t[t.find("transformationMatrix").unwrap()..].to_string();
    let (a, b) = (after(&a), after(&b));
    let r = numbers_of(a.split("referencePoint").nth(1).unwrap(), "pos");
    let m = numbers_of(&a, "transformationMatrix");
    let r2 = numbers_of(b.split("referencePoint").nth(1).unwrap(), "pos");
    let m2 = numbers_of(&b, "transformationMatrix");
    // pyproj, easting first: the reference point r and the template origin r + d.
    let code = format!(
        "from pyproj import Transformer\n\
         t = Transformer.from_crs('EPSG:31466', 'EPSG:25832', always_xy=True)\n\
         print(*t.transform({x}, {y}), *t.transform({x} + {dx}, {y} + {dy}))",
        x = r[0],
        y = r[1],
        dx = m[3],
        dy = m[7]
    );
    let o = Command::new("python3")
        .args(["-c", &code])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Vec<f64> = String::from_utf8_lossy(&o.stdout)
        .split_whitespace()
        .map(|t| t.parse().unwrap())
        .collect();
    assert!(
        (r2[0] - v[0]).abs() < 1e-3 && (r2[1] - v[1]).abs() < 1e-3,
        "{r2:?} vs {v:?}"
    );
    assert_eq!(r2[2], r[2], "height kept");
    let (dx, dy) = (v[2] - v[0], v[3] - v[1]);
    assert!(
        (m2[3] - dx).abs() < 1e-3 && (m2[7] - dy).abs() < 1e-3,
        "{m2:?}: {dx} {dy}"
    );
    assert!(
        (m2[3] - m[3]).abs() > 1e-6,
        "the translation changed (grid convergence)"
    );
    // The linear part and the template stay.
    for i in [0, 1, 2, 4, 5, 6, 8, 9, 10, 11, 12, 13, 14, 15] {
        assert_eq!(m2[i], m[i], "matrix element {i}");
    }
    let whole = std::fs::read_to_string(&out).unwrap();
    assert!(whole.contains("urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783"));
    if have_xmllint() {
        xmllint_validate(&out, "2.0").unwrap();
    }
}

/// A CityJSON input (Ingolstadt converted by `convert`) is reprojected as CityJSON: every
/// vertex equal to pyproj's within the new transform's 1 mm, heights kept, the new
/// `referenceSystem`; a merge of two CityJSON inputs holds the union of their separate
/// outputs.
#[test]
fn cityjson_is_reprojected_as_cityjson() {
    let Some(data) = shared_data() else {
        return;
    };
    if !python_has("pyproj", "pip install pyproj") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (src, out) = (
        dir.path().join("in.city.json"),
        dir.path().join("out.city.json"),
    );
    let gml = data.join("ingolstadt-lod3/4018106.xml.gz");
    let o = run(&[os("convert"), os(&gml), os("-o"), os(&src)]);
    assert!(o.status.success(), "{}", stderr(&o));
    reproject(&src, &out, "EPSG:3857", Some("EPSG:32632"));
    let script = r#"
import json, sys
from pyproj import Transformer
a, b = (json.load(open(p)) for p in sys.argv[1:3])
real = lambda d: [[v[k] * d["transform"]["scale"][k] + d["transform"]["translate"][k] for k in range(3)] for v in d["vertices"]]
t = Transformer.from_crs("EPSG:32632", "EPSG:3857", always_xy=True)
worst = 0.0
for p, q in zip(real(a), real(b)):
    x, y = t.transform(p[0], p[1])
    worst = max(worst, abs(x - q[0]), abs(y - q[1]), abs(p[2] - q[2]))
print(json.dumps({"n": len(a["vertices"]), "m": len(b["vertices"]), "worst": worst, "crs": b["metadata"]["referenceSystem"]}))
"#;
    let o = Command::new("python3")
        .args([os("-c"), os(script), os(&src), os(&out)])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(f(&v, "n") > 500.0 && f(&v, "n") == f(&v, "m"), "{v}");
    assert!(f(&v, "worst") < 1e-3, "{v}");
    assert!(v["crs"].as_str().unwrap().ends_with("/EPSG/0/3857"), "{v}");
    let (src2, out2) = (
        dir.path().join("in2.city.json"),
        dir.path().join("out2.city.json"),
    );
    let gml2 = data.join("ingolstadt-lod3/4018115.xml.gz");
    let o = run(&[os("convert"), os(&gml2), os("-o"), os(&src2)]);
    assert!(o.status.success(), "{}", stderr(&o));
    reproject(&src2, &out2, "EPSG:3857", Some("EPSG:32632"));
    let merged = dir.path().join("both.city.json");
    let o = run(&[
        os("reproject"),
        os(&src),
        os(&src2),
        os("-t"),
        os("EPSG:3857"),
        os("-s"),
        os("EPSG:32632"),
        os("-o"),
        os(&merged),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("merged 2 file(s)"), "{}", stderr(&o));
    crate::cityjson_merge::check_union(&merged, &[out, out2], "reproject");
}
