//! `convert x.city.json -o x.gml` (issue 24): CityJSON / CityJSONSeq → CityGML 2.0 and 3.0.
//!
//! * Every CityJSON fixture (cjio's and cjval's files) and the CityJSON / CityJSONSeq our own
//!   `convert` makes of every shared CityGML file → CityGML 2.0 and 3.0 that xmllint accepts
//!   against the official XSDs; the 2.0 counts (city objects by type, polygons by thematic
//!   surface, polygons, coordinate tuples, attributes) equal those an independent Python
//!   reader (`tests/oracle/citygml_from_cityjson.py`, `json` and `xml.etree`) finds in the
//!   CityJSON source.
//! * Round trip CityGML → CityJSON → CityGML: the same `skylod stats` (buildings, surfaces
//!   by kind, installations, openings, polygons, LoDs) as the CityJSON read directly, and as
//!   the original wherever the CityJSON step itself kept them; the same SVF at POIs.
//! * Batches: a merge of CityJSON inputs, `-` in and out; `upgrade --jobs 1` and `--jobs 2`
//!   write the same bytes.

use crate::util::*;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

fn ok(args: &[&std::ffi::OsStr]) -> String {
    let o = run(args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    stderr(&o)
}

/// Files under `dir` ending in `end`, sorted.
fn files(dir: &Path, end: &str) -> Vec<PathBuf> {
    let mut v = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.to_string_lossy().ends_with(end) {
                v.push(p);
            }
        }
    }
    v.sort();
    v
}

/// The CityGML written for `src` (under `from`) into `to`.
fn out_of(src: &Path, from: &Path, to: &Path) -> PathBuf {
    let rel = src
        .strip_prefix(from)
        .unwrap()
        .to_string_lossy()
        .into_owned();
    let stem = rel
        .strip_suffix(".city.jsonl")
        .or_else(|| rel.strip_suffix(".city.json"))
        .unwrap();
    to.join(format!("{stem}.gml"))
}

/// `skylod stats --json` per file, keyed by the path below `root` without its ending.
fn stats(root: &Path) -> BTreeMap<String, Value> {
    let o = run(&[os("stats"), os("--json"), os("-q"), root.as_os_str()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut m = BTreeMap::new();
    for f in json(&o)["files"].as_array().unwrap() {
        let p = PathBuf::from(f["path"].as_str().unwrap());
        let rel = p.strip_prefix(root).unwrap().to_string_lossy().into_owned();
        let key = [
            ".city.jsonl",
            ".city.json",
            ".citygml.gz",
            ".gml.gz",
            ".xml.gz",
            ".citygml",
            ".gml",
            ".xml",
        ]
        .iter()
        .find_map(|e| rel.strip_suffix(e))
        .unwrap_or(&rel)
        .to_string();
        m.insert(key, f.clone());
    }
    m
}

const KEYS: [&str; 15] = [
    "buildings",
    "building_parts",
    "roof_surfaces",
    "wall_surfaces",
    "ground_surfaces",
    "closure_surfaces",
    "outer_ceiling_surfaces",
    "outer_floor_surfaces",
    "installations",
    "windows",
    "doors",
    "bodies",
    "other_objects",
    "polygons",
    "lods",
];

fn differ(a: &Value, b: &Value) -> Vec<String> {
    KEYS.iter()
        .filter(|k| a[**k] != b[**k])
        .map(|k| format!("{k}: {} vs {}", a[*k], b[*k]))
        .collect()
}

#[test]
fn cityjson_to_citygml_valid_counted_and_round_tripped() {
    let Some(data) = shared_data() else { return };
    if !have_xmllint() || !python_has("json", "python3") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = |n: &str| dir.path().join(n);
    ok(&[
        os("convert"),
        data.as_os_str(),
        os("-o"),
        os(&d("cj/")),
        os("--format"),
        os("cityjson"),
    ]);
    ok(&[
        os("convert"),
        data.as_os_str(),
        os("-o"),
        os(&d("seq/")),
        os("--format"),
        os("cityjsonseq"),
    ]);
    let fixtures = manifest_dir().join("fixtures/cityjson");
    let sources = [
        (fixtures.clone(), ".city.json"),
        (d("cj"), ".city.json"),
        (d("seq"), ".city.jsonl"),
    ];
    let mut pairs: Vec<(PathBuf, PathBuf)> = Vec::new();
    let mut lint: Vec<(PathBuf, String)> = Vec::new();
    let mut lines = String::new();
    for (k, (src, end)) in sources.iter().enumerate() {
        for v in ["2.0", "3.0"] {
            let to = d(&format!("g{k}-{v}/"));
            let e = ok(&[
                os("convert"),
                src.as_os_str(),
                os("-o"),
                os(&to),
                os("--citygml-version"),
                os(v),
            ]);
            lines += &e;
            for s in files(src, end) {
                let out = out_of(&s, src, &to);
                assert!(out.is_file(), "{} not written", out.display());
                lint.push((out.clone(), v.to_string()));
                if v == "2.0" {
                    pairs.push((s, out));
                }
            }
        }
    }
    assert!(pairs.len() >= 2 * 120 + 6, "{} sources", pairs.len());
    // XSD-valid, every one
    let bad: Vec<String> = xmllint_validate_all(&lint, threads())
        .into_iter()
        .filter_map(|(p, r)| r.err().map(|e| format!("{}: {e}", p.display())))
        .collect();
    assert!(bad.is_empty(), "{} invalid:\n{}", bad.len(), bad.join("\n"));
    // counts of an independent reader, CityJSON source against CityGML output
    let mut args = vec![manifest_dir().join("tests/oracle/citygml_from_cityjson.py")];
    for (s, o) in &pairs {
        args.extend([s.clone(), o.clone()]);
    }
    let o = Command::new("python3")
        .args(&args)
        .output()
        .expect("python3");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let counts: Vec<Value> = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(counts.len(), pairs.len());
    let mut with_semantics = 0;
    for c in &counts {
        assert_eq!(c["cityjson"], c["citygml"], "{}", c["source"]);
        assert!(
            c["citygml"]["polygons"].as_u64().unwrap() > 0,
            "{}",
            c["source"]
        );
        with_semantics += usize::from(
            c["citygml"]["semantic"]
                .as_object()
                .is_some_and(|m| !m.is_empty()),
        );
    }
    assert!(with_semantics >= 100, "{with_semantics}");
    // round trip: stats of the CityGML = stats of the CityJSON it came from (what the summary
    // line does not say was left out), and = the original's where CityJSON kept them
    let (orig, cj, back) = (stats(&data), stats(&d("cj")), stats(&d("g1-2.0")));
    let (mut same, mut compared) = (0, 0);
    for (k, b) in &back {
        let c = &cj[k];
        let line = lines
            .lines()
            .find(|l| l.contains(&format!("/{k}.gml:")))
            .unwrap_or_else(|| panic!("no line for {k}"));
        if line.contains("left out or changed") {
            continue;
        }
        assert!(differ(c, b).is_empty(), "{k}: {:?}", differ(c, b));
        compared += 1;
        if differ(&orig[k], c).is_empty() {
            assert!(
                differ(&orig[k], b).is_empty(),
                "{k}: {:?}",
                differ(&orig[k], b)
            );
            same += 1;
        }
    }
    assert!(compared >= 120 && same >= 100, "{compared} {same}");
    // the same SVF at POIs beside walls and on roofs (millimetre rounding of CityJSON)
    for rel in [
        "kit-fzk-haus/citygml2/fzk_haus_lod2_v2.gml",
        "rotterdam/Source.gml",
    ] {
        let src = data.join(rel);
        assert!(src.is_file(), "{rel}");
        let key = rel.strip_suffix(".gml").unwrap();
        let pois = crate::cityjson_input::pois(&skylod::io::citygml::read_file(&src).unwrap());
        let a = crate::cityjson_input::svf(&src, &pois);
        let b = crate::cityjson_input::svf(&d(&format!("g1-2.0/{key}.gml")), &pois);
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() < 2e-3, "{rel}: {a:?} vs {b:?}");
        }
    }
}

#[test]
fn merges_stdin_stdout_and_upgrade_jobs() {
    let dir = tempfile::tempdir().unwrap();
    let d = |n: &str| dir.path().join(n);
    let fx = manifest_dir().join("fixtures/cityjson");
    let (a, b) = (
        fx.join("cjio-dummy.city.json"),
        fx.join("cjio-rotterdam_subset.city.json"),
    );
    // two CityJSON inputs merged into one CityGML document
    let e = ok(&[os("convert"), os(&a), os(&b), os("-o"), os(&d("m.gml"))]);
    assert!(e.contains("merged 2 file(s)"), "{e}");
    let m = skylod::io::citygml::read_file(&d("m.gml")).unwrap();
    assert_eq!(m.buildings.len(), 17);
    // - in, - out
    let mut c = Command::new(env!("CARGO_BIN_EXE_skylod"))
        .args(["convert", "-", "-o", "-", "--citygml-version", "3.0"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::io::Write::write_all(&mut c.stdin.take().unwrap(), &std::fs::read(&b).unwrap()).unwrap();
    let o = c.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("http://www.opengis.net/citygml/3.0") && text.contains("bldg:Building"));
    // a gzip output, a broken input fails alone (exit 1) with its file and line
    std::fs::write(d("bad.city.json"), b"{\"type\":\"CityJSON\",\"CityObjects\":{\"x\":{\"type\":\"Building\",\"geometry\":[{\"type\":\"MultiSurface\",\"lod\":\"2\",\"boundaries\":[[[0,1,9]]]}]}},\"vertices\":[[0,0,0],[1,0,0]]}").unwrap();
    let o = run(&[
        os("convert"),
        os(&d("bad.city.json")),
        os(&a),
        os("-o"),
        os(&d("o/")),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("bad.city.json") && stderr(&o).contains("[city object x]"),
        "{}",
        stderr(&o)
    );
    assert!(d("o/cjio-dummy.gml").is_file());
    ok(&[os("convert"), os(&a), os("-o"), os(&d("z.gml.gz"))]);
    assert_eq!(
        skylod::io::citygml::read_file(&d("z.gml.gz"))
            .unwrap()
            .buildings
            .len(),
        1
    );
    // upgrade --jobs: the same bytes whatever the number
    let Some(data) = shared_data() else { return };
    let src = data.join("ogc-citygml2-examples");
    let one = ok(&[
        os("upgrade"),
        src.as_os_str(),
        os("-o"),
        os(&d("u1/")),
        os("--jobs"),
        os("1"),
    ]);
    let two = ok(&[
        os("upgrade"),
        src.as_os_str(),
        os("-o"),
        os(&d("u2/")),
        os("-j"),
        os("2"),
    ]);
    let (f1, f2) = (files(&d("u1"), ".gml"), files(&d("u2"), ".gml"));
    assert!(f1.len() >= 10, "{}", f1.len());
    assert_eq!(f1.len(), f2.len());
    for (x, y) in f1.iter().zip(&f2) {
        assert_eq!(
            std::fs::read(x).unwrap(),
            std::fs::read(y).unwrap(),
            "{}",
            x.display()
        );
    }
    // the lines in input order whatever finished first
    let strip = |s: &str| {
        s.lines()
            .filter(|l| l.contains(" -> "))
            .map(|l| l.replace("/u1/", "/u/").replace("/u2/", "/u/"))
            .collect::<Vec<_>>()
    };
    assert_eq!(strip(&one), strip(&two));
}
