//! CityJSON and CityJSONSeq as inputs (issue 24): read into the same model as CityGML.
//!
//! * Shared CityGML files written by our own `convert` as `.city.json` and `.city.jsonl`, and
//!   the `.city.json` turned into CityJSONSeq by `cjio … export jsonl`, read back: the same
//!   buildings, assets, polygons per kind and LoDs as the CityGML original, and the same SVF
//!   at POIs beside walls and on roofs (within the millimetre rounding of `transform`).
//! * Real CityJSON of the CityJSON project (`fixtures/cityjson/`, SOURCES.md): counts against
//!   an independent Python reading of the JSON (`tests/oracle/cityjson_assets.py`, which
//!   also loads the file with cjio); the CityJSON 1.1 files against `cjio upgrade` of them.
//! * Every command takes CityJSON (files, directories, `-`); `subset` and `filter-lods` refuse
//!   a CityGML name for its output with exit 1 and a message (edits: tests/it/cityjson_edit.rs); broken CityJSON fails with file, line:column or object id.
//! * `lod … -o y.city.json` from CityJSON keeps attributes and semantics; cjval-valid.

use crate::util::*;
use serde_json::Value;
use skylod::io::citygml::read_file;
use skylod::model::CityModel;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// Shared CityGML files for the round trip (projected and geographic CRSs, LoD0-3, openings,
/// installations, parts, gzip).
const SHARED: &[&str] = &[
    "rotterdam/Source.gml",
    "berlin/Berlin_Moabit_1Bldg_v2.gml",
    "tum/TUM-Main-Entrance.gml",
    "libcitygml/berlin_open_data_sample_data.citygml",
    "ingolstadt-lod3/4018154.xml.gz",
    "kit-fzk-haus/citygml2/fzk_haus_lod3_v2.gml",
    "kit-fzk-haus/citygml3/FZK-Haus-LoD2-KIT-IAI-KHH-B36-V1__v3.gml",
    "plateau/tokyo23ku-2022/53392633_bldg_6697_2_op.gml.gz",
];

fn fixture_dir() -> PathBuf {
    manifest_dir().join("fixtures/cityjson")
}

/// What must be equal between two models: buildings, parts, and per asset kind the assets
/// that CityJSON can hold (with polygons, or the wall of an opening that has some) and their
/// polygons; the LoDs.
fn counts(m: &CityModel) -> BTreeMap<String, usize> {
    let mut c = BTreeMap::new();
    c.insert(
        "buildings".into(),
        m.buildings.iter().filter(|b| !b.is_part).count(),
    );
    c.insert(
        "parts".into(),
        m.buildings.iter().filter(|b| b.is_part).count(),
    );
    let holds = |i: usize| {
        m.assets[i].polygon_count() > 0
            || m.assets
                .iter()
                .any(|a| a.parent == Some(i) && a.polygon_count() > 0)
    };
    for (i, a) in m.assets.iter().enumerate() {
        if holds(i) {
            *c.entry(format!("{}", a.kind)).or_default() += 1;
            *c.entry(format!("{}_polygons", a.kind)).or_default() += a.polygon_count();
            *c.entry("assets".into()).or_default() += 1;
        }
        for g in &a.geometries {
            c.insert(format!("lod{}", g.lod), 1);
        }
    }
    c.insert("polygons".into(), m.polygon_count());
    c.insert("traced".into(), m.traced_polygon_count());
    c
}

/// POIs with non-trivial skies: 5 cm out of up to three walls (their normal), 0.5 m above up
/// to two roofs; "x,y,z,nx,ny,nz".
pub(crate) fn pois(m: &CityModel) -> Vec<String> {
    use skylod::model::AssetKind;
    let mut out = Vec::new();
    let pick = |kind: AssetKind, n: usize| {
        let idx: Vec<usize> = (0..m.assets.len())
            .filter(|&i| m.assets[i].kind == kind && !m.assets[i].detail_polygons().is_empty())
            .collect();
        let step = (idx.len() / n.max(1)).max(1);
        idx.into_iter().step_by(step).take(n).collect::<Vec<_>>()
    };
    for i in pick(AssetKind::Wall, 3) {
        let p = &m.assets[i].detail_polygons()[0];
        let c = p.exterior().iter().copied().sum::<glam::DVec3>() / p.exterior().len() as f64;
        let n = p.newell_normal().normalize_or_zero();
        if n.length() > 0.5
            && !m.files[0]
                .srs_name
                .as_deref()
                .unwrap_or("")
                .contains("6697")
        {
            let q = c + n * 0.05;
            out.push(format!("{},{},{},{},{},{}", q.x, q.y, q.z, n.x, n.y, n.z));
        }
    }
    for i in pick(AssetKind::Roof, 2) {
        let p = &m.assets[i].detail_polygons()[0];
        let c = p.exterior().iter().copied().sum::<glam::DVec3>() / p.exterior().len() as f64;
        out.push(format!("{},{},{}", c.x, c.y, c.z + 0.5));
    }
    if out.is_empty() {
        let b = m.bbox();
        let c = b.center();
        out.push(format!("{},{},{}", c.x, b.min.y, b.min.z + 1.5));
    }
    out
}

/// SVF per POI from `skylod svf`.
pub(crate) fn svf(input: &Path, pois: &[String]) -> Vec<f64> {
    let mut args: Vec<&std::ffi::OsStr> = vec![os("svf"), os(input), os("--json")];
    for p in pois {
        args.push(os("--poi"));
        args.push(os(p));
    }
    let o = run(&args);
    assert!(
        o.status.success(),
        "svf {}: {}",
        input.display(),
        stderr(&o)
    );
    json(&o)["pois"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["svf"].as_f64().unwrap())
        .collect()
}

fn have_cjio() -> bool {
    let ok = Command::new("cjio")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        missing("cjio (pip install cjio)");
    }
    ok
}

fn cjio(args: &[&std::ffi::OsStr]) {
    let o = Command::new("cjio").args(args).output().expect("cjio");
    assert!(o.status.success(), "cjio {args:?}: {}", stderr(&o));
}

#[test]
fn own_cityjson_and_seq_read_back_as_the_citygml() {
    let Some(data) = shared_data() else { return };
    let cjio_ok = have_cjio();
    let dir = tempfile::tempdir().unwrap();
    let mut report = Vec::new();
    for (k, rel) in SHARED.iter().enumerate() {
        let gml = data.join(rel);
        let original = read_file(&gml).unwrap();
        let want = counts(&original);
        let json = dir.path().join(format!("{k}.city.json"));
        let seq = dir.path().join(format!("{k}.city.jsonl"));
        for out in [&json, &seq] {
            let o = run(&[os("convert"), os(&gml), os("-o"), os(out)]);
            assert!(o.status.success(), "{rel}: {}", stderr(&o));
        }
        let mut variants = vec![json.clone(), seq.clone()];
        // cjio writes `transform.scale` with six decimals ("%f"): the 1e-8° of a geographic
        // CRS becomes 0 and its CityJSONSeq collapses every vertex (cjio 0.10.1), not ours
        let geographic = original.files[0]
            .srs_name
            .as_deref()
            .is_some_and(|s| s.contains("6697"));
        if cjio_ok && !geographic {
            let by_cjio = dir.path().join(format!("{k}.cjio.city.jsonl"));
            cjio(&[os(&json), os("export"), os("jsonl"), os(&by_cjio)]);
            variants.push(by_cjio);
        }
        let poi = pois(&original);
        let base = svf(&gml, &poi);
        for v in &variants {
            let m = read_file(v).unwrap_or_else(|e| panic!("{rel} as {}: {e}", v.display()));
            assert!(m.files[0].cityjson.is_some());
            assert_eq!(counts(&m), want, "{rel} as {}", v.display());
            assert_eq!(
                m.files[0]
                    .srs_name
                    .as_deref()
                    .map(|s| skylod::model::crs::Crs::parse(s).epsg),
                original.files[0]
                    .srs_name
                    .as_deref()
                    .map(|s| skylod::model::crs::Crs::parse(s).epsg),
                "{rel}: CRS"
            );
            // the same geometry within the transform's rounding (1 mm, 1e-8°)
            let (a, b) = (original.bbox(), m.bbox());
            assert!(
                (a.min - b.min).abs().max_element() < 2e-3,
                "{rel}: {a:?} {b:?}"
            );
            assert!(
                (a.max - b.max).abs().max_element() < 2e-3,
                "{rel}: {a:?} {b:?}"
            );
            let got = svf(v, &poi);
            for (x, y) in base.iter().zip(&got) {
                assert!(
                    (x - y).abs() <= 2e-3,
                    "{rel} {}: SVF {x} vs {y}",
                    v.display()
                );
            }
            report.push(format!(
                "{rel} as {}: {} assets, {} polygons, SVF {:?} (CityGML {:?})",
                v.file_name().unwrap().to_string_lossy(),
                want.get("assets").unwrap_or(&0),
                want["polygons"],
                got,
                base
            ));
        }
    }
    println!("{}", report.join("\n"));
}

/// The Python oracle's counts of a CityJSON file against `skylod stats`.
fn oracle(files: &[PathBuf]) -> Option<serde_json::Map<String, Value>> {
    if !python_has("json", "python3") {
        return None;
    }
    let o = Command::new("python3")
        .arg(manifest_dir().join("tests/oracle/cityjson_assets.py"))
        .args(files)
        .output()
        .unwrap();
    assert!(o.status.success(), "oracle: {}", stderr(&o));
    Some(
        serde_json::from_slice::<Value>(&o.stdout)
            .unwrap()
            .as_object()
            .unwrap()
            .clone(),
    )
}

fn stats_total(file: &Path) -> Value {
    let o = run(&[os("stats"), os(file), os("--json")]);
    assert!(
        o.status.success(),
        "stats {}: {}",
        file.display(),
        stderr(&o)
    );
    json(&o)["total"].clone()
}

/// Compare `skylod stats` with the oracle's counts.
fn check_against_oracle(file: &Path, want: &Value) {
    let got = stats_total(file);
    let pairs = [
        ("buildings", "buildings"),
        ("building_parts", "building_parts"),
        ("assets", "assets"),
        ("polygons", "polygons"),
        ("roof", "roof_surfaces"),
        ("wall", "wall_surfaces"),
        ("ground", "ground_surfaces"),
        ("closure", "closure_surfaces"),
        ("window", "windows"),
        ("door", "doors"),
        ("installations", "installations"),
        ("bodies", "bodies"),
        ("others", "other_objects"),
    ];
    for (o, s) in pairs {
        assert_eq!(got[s], want[o], "{}: {s}", file.display());
    }
    assert_eq!(got["lods"], want["lods"], "{}: lods", file.display());
}

#[test]
fn real_cityjson_files_match_the_python_oracle() {
    let mut files: Vec<PathBuf> = std::fs::read_dir(fixture_dir())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(".city.json"))
        .collect();
    files.sort();
    assert!(files.len() >= 5, "{files:?}");
    let Some(want) = oracle(&files) else { return };
    for f in &files {
        check_against_oracle(f, &want[&f.to_string_lossy().to_string()]);
    }
}

#[test]
fn cityjson_1_1_reads_as_its_cjio_upgrade() {
    if !have_cjio() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    for name in [
        "cjio-DH_01_subs-v1.1.city.json",
        "cjio-delft_1b-v1.1.city.json",
    ] {
        let old = fixture_dir().join(name);
        let up = dir.path().join(name.replace("v1.1", "v2.0"));
        cjio(&[os(&old), os("upgrade"), os("save"), os(&up)]);
        let (a, b) = (read_file(&old).unwrap(), read_file(&up).unwrap());
        assert_eq!(a.files[0].cityjson.as_ref().unwrap().version, "1.1");
        assert_eq!(b.files[0].cityjson.as_ref().unwrap().version, "2.0");
        assert_eq!(counts(&a), counts(&b), "{name}");
        assert!(counts(&a)["polygons"] > 0);
        for (x, y) in a.assets.iter().zip(&b.assets) {
            assert_eq!(x.kind, y.kind);
            for (p, q) in x.geometries.iter().zip(&y.geometries) {
                for (u, v) in p.polygons.iter().zip(&q.polygons) {
                    for (s, t) in u.points().zip(v.points()) {
                        assert!((*s - *t).abs().max_element() < 2e-3, "{name}: {s} {t}");
                    }
                }
            }
        }
        let poi = pois(&a);
        assert_eq!(svf(&old, &poi), svf(&up, &poi), "{name}");
    }
}

#[test]
fn bad_cityjson_fails_with_a_location() {
    let bad = manifest_dir().join("fixtures/bad");
    let cases = [
        ("cityjson-syntax.city.json", "cityjson-syntax.city.json:4:"),
        ("cityjson-vertex-index.city.json", "[city object b1]"),
        ("cityjson-nan.city.json", "cityjson-nan.city.json:"),
        ("cityjson-no-lod.city.json", "without lod"),
        ("cityjson-not-cityjson.json", "not \"CityJSON\""),
        ("cityjson-template.city.json", "template"),
        ("cityjson-boundaries.city.json", "MultiSurface boundaries"),
        (
            "cityjson-seq-line.city.jsonl",
            "cityjson-seq-line.city.jsonl:3:",
        ),
        ("cjval-sem.city.json", "[city object id-3]"),
        ("cjval-cube_20.city.jsonl", ":5:"),
    ];
    for (name, want) in cases {
        let p = bad.join(name);
        assert!(p.is_file(), "{}", p.display());
        let o = run(&[os("stats"), os(&p)]);
        assert_eq!(o.status.code(), Some(1), "{name}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(
            e.contains("invalid CityJSON") && e.contains(want),
            "{name}: {e}"
        );
        assert!(skylod::io::citygml::read_file(&p).is_err(), "{name}");
    }
}

/// A small CityJSON scene: the Rotterdam subset of cjio's tests (16 buildings, semantics).
fn scene() -> PathBuf {
    fixture_dir().join("cjio-rotterdam_subset.city.json")
}

fn scene_poi(m: &CityModel) -> String {
    pois(m).remove(0)
}

#[test]
fn every_command_reads_cityjson() {
    let dir = tempfile::tempdir().unwrap();
    let input = scene();
    let m = read_file(&input).unwrap();
    let poi = scene_poi(&m);
    let out = |n: &str| dir.path().join(n);
    let ok = |args: &[&std::ffi::OsStr]| {
        let o = run(args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        o
    };
    ok(&[os("stats"), os(&input)]);
    for o in ["c.obj", "c.city.json", "c.city.jsonl"] {
        ok(&[os("convert"), os(&input), os("-o"), os(&out(o))]);
        assert!(out(o).is_file());
    }
    ok(&[os("rough"), os(&input), os("-o"), os(&out("r.obj"))]);
    ok(&[os("rough"), os(&input), os("-o"), os(&out("r.city.json"))]);
    let p = [os("--poi"), os(&poi)];
    ok(&[&[os("svf"), os(&input)][..], &p].concat());
    ok(&[&[os("horizon"), os(&input)][..], &p].concat());
    let site = [os("--lat"), os("51.92"), os("--lon"), os("4.48")];
    ok(&[&[os("evaluate"), os(&input)][..], &p, &site].concat());
    ok(&[&[os("sun-hours"), os(&input)][..], &p, &site].concat());
    ok(&[
        &[os("fisheye"), os(&input), os("-o"), os(&out("f.png"))][..],
        &p,
        &site,
    ]
    .concat());
    for o in ["l.obj", "l.city.json", "l.city.jsonl"] {
        ok(&[&[os("lod"), os(&input), os("-o"), os(&out(o))][..], &p].concat());
        assert!(out(o).is_file(), "{o}");
    }
    if let Some(tmy) = crate::irradiance::tmy3() {
        ok(&[
            &[os("irradiance"), os(&input), os("--weather"), os(&tmy)][..],
            &p,
            &site,
        ]
        .concat());
    }
    // a directory: .city.json, .city.jsonl and CityJSON .json by content; other JSON left out
    let tree = out("tree");
    std::fs::create_dir_all(tree.join("sub")).unwrap();
    std::fs::copy(&input, tree.join("a.city.json")).unwrap();
    std::fs::copy(out("c.city.jsonl"), tree.join("sub/b.city.jsonl")).unwrap();
    std::fs::copy(&input, tree.join("sub/c.json")).unwrap();
    std::fs::write(tree.join("package.json"), "{\"name\": \"x\"}").unwrap();
    let o = ok(&[os("stats"), os(&tree), os("--json")]);
    let v = json(&o);
    assert_eq!(v["files"].as_array().unwrap().len(), 3, "{v}");
    // (the export leaves out rings that rounding to millimetres makes degenerate)
    let seq = read_file(&out("c.city.jsonl")).unwrap().polygon_count();
    assert!(seq > 0 && seq <= m.polygon_count());
    assert_eq!(
        v["total"]["polygons"].as_u64().unwrap(),
        (2 * m.polygon_count() + seq) as u64
    );
    // standard input, plain and gzip
    for gz in [false, true] {
        let bytes = std::fs::read(&input).unwrap();
        let bytes = if gz {
            use std::io::Write;
            let mut e = flate2::write::GzEncoder::new(Vec::new(), Default::default());
            e.write_all(&bytes).unwrap();
            e.finish().unwrap()
        } else {
            bytes
        };
        let mut c = Command::new(env!("CARGO_BIN_EXE_skylod"))
            .args(["stats", "-", "--json"])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        {
            use std::io::Write;
            c.stdin.take().unwrap().write_all(&bytes).unwrap();
        }
        let o = c.wait_with_output().unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(
            json(&o)["total"]["polygons"].as_u64().unwrap(),
            m.polygon_count() as u64
        );
    }
}

#[test]
fn citygml_names_for_cityjson_edits_are_refused_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let input = scene();
    // (`convert`, `upgrade`, `rough` and `lod` write CityGML from CityJSON:
    // tests/it/cityjson_to_citygml.rs, tests/it/cityjson_edit.rs)
    let o: Vec<PathBuf> = ["s", "f"]
        .iter()
        .map(|n| dir.path().join(format!("{n}.gml")))
        .collect();
    let cases: Vec<Vec<&std::ffi::OsStr>> = vec![
        vec![
            os("subset"),
            os(&input),
            os("--id"),
            os("x"),
            os("-o"),
            os(&o[0]),
        ],
        vec![
            os("filter-lods"),
            os(&input),
            os("--lod"),
            os("2"),
            os("-o"),
            os(&o[1]),
        ],
    ];
    for args in cases {
        let o = run(&args);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(
            e.contains("a CityJSON input is written as CityJSON"),
            "{args:?}: {e}"
        );
        assert!(!e.contains("panicked"), "{args:?}: {e}");
    }
}

/// cjval's verdict (`--report`; skip rule when it is missing).
fn cjval_valid(file: &Path) -> Option<Result<(), String>> {
    let home = std::env::var_os("HOME").map(|h| Path::new(&h).join(".cargo/bin/cjval"));
    let cjval = [Some(PathBuf::from("cjval")), home]
        .into_iter()
        .flatten()
        .find(|c| {
            Command::new(c)
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success())
        });
    let Some(cjval) = cjval else {
        missing("cjval (cargo install cjval --features build-binary)");
        return None;
    };
    let o = Command::new(cjval)
        .arg("--report")
        .arg(file)
        .output()
        .unwrap();
    let report: Value = serde_json::from_slice(&o.stdout).unwrap_or(Value::Null);
    Some(if report["valid"] == Value::Bool(true) {
        Ok(())
    } else {
        Err(String::from_utf8_lossy(&o.stdout).to_string())
    })
}

#[test]
fn lod_from_cityjson_keeps_attributes_and_semantics() {
    let dir = tempfile::tempdir().unwrap();
    for name in [
        "cjval-japanese.city.json",
        "cjio-rotterdam_subset.city.json",
    ] {
        let input = fixture_dir().join(name);
        let m = read_file(&input).unwrap();
        let out = dir.path().join(name);
        let mut args = vec![os("lod"), os(&input), os("-o"), os(&out)];
        let pois = pois(&m);
        for p in &pois {
            args.push(os("--poi"));
            args.push(os(p));
        }
        let o = run(&args);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let src: Value = serde_json::from_slice(&std::fs::read(&input).unwrap()).unwrap();
        let got: Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
        let objects = got["CityObjects"].as_object().unwrap();
        assert!(!objects.is_empty(), "{name}");
        let mut copied = 0;
        let mut surfaces = 0;
        for (id, o) in objects {
            let Some(s) = src["CityObjects"].get(id) else {
                continue;
            };
            if let Some(a) = s["attributes"].as_object() {
                for (k, v) in a {
                    assert_eq!(&o["attributes"][k], v, "{name}: {id}.{k}");
                    copied += 1;
                }
            }
            for g in o["geometry"].as_array().into_iter().flatten() {
                for sf in g["semantics"]["surfaces"].as_array().into_iter().flatten() {
                    assert!(sf["type"].is_string());
                    assert!(sf.get("skylod_level").is_some(), "{name}: {sf}");
                    surfaces += 1;
                }
            }
        }
        assert!(copied > 0 && surfaces > 0, "{name}: {copied} {surfaces}");
        if let Some(v) = cjval_valid(&out) {
            v.unwrap_or_else(|e| panic!("{name}: cjval: {e}"));
        }
    }
}
