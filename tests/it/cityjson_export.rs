//! CityJSON 2.0 and CityJSONSeq output against the CityJSON project's own tools: every shared
//! CityGML 1.0/2.0/3.0 file and every fixture is written as `.city.json` and `.city.jsonl`;
//! the official validator `cjval` must call both valid, and `cjio` must read both with object
//! and surface counts equal to `skylod stats`. `rough` and `lod` outputs are checked the same
//! way, with their `skylod_level`s against the levels the report gives.

use crate::util::*;
use serde_json::Value;
use skylod::export::report::Stats;
use skylod::export::{write, Chunks, Content, Format};
use skylod::io::citygml::read_file;
use skylod::model::{AssetKind, CityModel};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// `cjval` on PATH or in ~/.cargo/bin; `None` (skip rule) when missing.
fn cjval() -> Option<PathBuf> {
    let mut candidates = vec![PathBuf::from("cjval")];
    if let Some(home) = std::env::var_os("HOME") {
        candidates.push(Path::new(&home).join(".cargo/bin/cjval"));
    }
    for c in candidates {
        if Command::new(&c)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
        {
            return Some(c);
        }
    }
    missing("cjval (cargo install cjval --features build-binary)");
    None
}

/// cjval's verdict on a CityJSON file, or on a CityJSONSeq stream (every line must be valid).
/// `Err` holds the failed checks.
fn validate(cjval: &Path, file: &Path) -> Result<(), String> {
    let seq = file.to_string_lossy().ends_with(".city.jsonl");
    let out = if seq {
        Command::new(cjval)
            .arg("--report")
            .stdin(Stdio::from(std::fs::File::open(file).unwrap()))
            .output()
    } else {
        Command::new(cjval).arg("--report").arg(file).output()
    }
    .expect("cannot run cjval");
    let text = String::from_utf8_lossy(&out.stdout);
    // One (pretty-printed) report for a file, one report per line for a stream.
    let reports: Vec<Value> = match serde_json::from_str::<Value>(&text) {
        Ok(v) => vec![v],
        Err(_) => text
            .lines()
            .filter(|l| !l.trim().is_empty())
            .map(|l| {
                serde_json::from_str(l)
                    .map_err(|e| format!("cjval report does not parse ({e}): {l}"))
            })
            .collect::<Result<_, _>>()?,
    };
    for v in &reports {
        if v["valid"] != Value::Bool(true) {
            let mut failed = Vec::new();
            if let Some(checks) = v["checks"]["errors"].as_object() {
                for (k, c) in checks {
                    if c["valid"] != Value::Bool(true) {
                        failed.push(format!("{k}: {}", c["errors"]));
                    }
                }
            }
            return Err(format!("invalid: {}", failed.join("; ")));
        }
    }
    if reports.is_empty() {
        return Err(format!(
            "no cjval report (exit {:?}): {}",
            out.status.code(),
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(())
}

/// cjio's reading of files (tests/oracle/cjio_counts.py), keyed by path.
fn cjio_counts(files: &[PathBuf]) -> serde_json::Map<String, Value> {
    let script = manifest_dir().join("tests/oracle/cjio_counts.py");
    let mut all = serde_json::Map::new();
    for chunk in files.chunks(40) {
        let out = Command::new("python3")
            .arg(&script)
            .args(chunk)
            .output()
            .expect("cannot run python3");
        assert!(
            out.status.success(),
            "cjio failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: Value = serde_json::from_slice(&out.stdout).expect("cjio_counts JSON");
        if let Value::Object(m) = v {
            all.extend(m);
        }
    }
    all
}

fn n(v: &Value, k: &str) -> usize {
    v.get(k).and_then(Value::as_u64).unwrap_or(0) as usize
}

/// Object and semantic-surface counts that must equal `skylod stats`.
fn expected(s: &Stats) -> Vec<(&'static str, &'static str, usize)> {
    vec![
        ("objects", "Building", s.buildings),
        ("objects", "BuildingPart", s.building_parts),
        ("objects", "BuildingInstallation", s.installations),
        ("semantics", "RoofSurface", s.roof_surfaces),
        ("semantics", "WallSurface", s.wall_surfaces),
        ("semantics", "GroundSurface", s.ground_surfaces),
        ("semantics", "ClosureSurface", s.closure_surfaces),
        ("semantics", "OuterCeilingSurface", s.outer_ceiling_surfaces),
        ("semantics", "OuterFloorSurface", s.outer_floor_surfaces),
        ("semantics", "Window", s.windows),
        ("semantics", "Door", s.doors),
    ]
}

/// Surfaces and openings CityJSON cannot hold: no polygon of their own (e.g. a wall whose only
/// polygon is degenerate) and no opening with polygons below them. Counted out of the stats.
fn without_surfaces(model: &CityModel) -> Stats {
    let has = |a: &skylod::model::Asset| a.geometries.iter().any(|g| !g.polygons.is_empty());
    let mut empty = CityModel::default();
    for (i, a) in model.assets.iter().enumerate() {
        let kids = model.assets.iter().any(|x| x.parent == Some(i) && has(x));
        if !has(a) && !kids && a.kind != AssetKind::Installation {
            empty.assets.push(a.clone());
        }
    }
    Stats::of(&empty)
}

/// `skylod stats` of a model less the surfaces CityJSON cannot hold ([`without_surfaces`]).
fn cityjson_stats(model: &CityModel, input: &Path) -> Stats {
    let mut stats = Stats::of(model);
    let empty = without_surfaces(model);
    if empty.assets > 0 {
        eprintln!(
            "{}: {} surface(s) without polygons not expected in CityJSON",
            short(input),
            empty.assets
        );
        stats.roof_surfaces -= empty.roof_surfaces;
        stats.wall_surfaces -= empty.wall_surfaces;
        stats.ground_surfaces -= empty.ground_surfaces;
        stats.closure_surfaces -= empty.closure_surfaces;
        stats.outer_ceiling_surfaces -= empty.outer_ceiling_surfaces;
        stats.outer_floor_surfaces -= empty.outer_floor_surfaces;
        stats.windows -= empty.windows;
        stats.doors -= empty.doors;
    }
    stats
}

fn compare(name: &str, counts: &Value, s: &Stats, problems: &mut Vec<String>) {
    for (group, ty, want) in expected(s) {
        let got = n(&counts[group], ty);
        if got != want {
            problems.push(format!("{name}: {ty}: cjio reads {got}, stats says {want}"));
        }
    }
    let others: usize = counts["objects"]
        .as_object()
        .map(|m| {
            m.iter()
                .filter(|(k, _)| {
                    !matches!(
                        k.as_str(),
                        "Building" | "BuildingPart" | "BuildingInstallation"
                    )
                })
                .map(|(_, v)| v.as_u64().unwrap_or(0) as usize)
                .sum()
        })
        .unwrap_or(0);
    if others != s.other_objects {
        problems.push(format!(
            "{name}: other city objects: cjio reads {others}, stats says {}",
            s.other_objects
        ));
    }
}

#[test]
fn every_file_valid_and_counted() {
    let Some(cjval) = cjval() else { return };
    if !python_has("cjio", "pip install cjio") {
        return;
    }
    let inputs: Vec<PathBuf> = all_inputs()
        .into_iter()
        .filter(|p| !p.ends_with("val3dity/csol1b.gml")) // plain GML, not CityGML
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let mut problems = Vec::new();
    let mut written: Vec<(PathBuf, Stats, PathBuf)> = Vec::new();
    let mut versions = std::collections::BTreeSet::new();
    for (k, input) in inputs.iter().enumerate() {
        let Ok(model) = read_file(input) else {
            continue; // unreadable inputs are the bad-input tests' business
        };
        let stats = cityjson_stats(&model, input);
        versions.extend(stats.citygml_version.clone());
        for format in [Format::CityJson, Format::CityJsonSeq] {
            let out = dir.path().join(format!("{k}{}", format.extension()));
            let chunks = Chunks::model(&model, 0, Content::Full);
            match write(format, &chunks, &out, &Default::default()) {
                Ok(_) => written.push((input.clone(), stats.clone(), out)),
                Err(e) => problems.push(format!("{}: {format}: {e}", short(input))),
            }
        }
    }
    assert!(
        written.len() >= 2 * fixture_files().len(),
        "too few files written"
    );
    if shared_data().is_some() {
        for v in ["1.0", "2.0", "3.0"] {
            assert!(
                versions.contains(v),
                "no CityGML {v} input among {versions:?}"
            );
        }
    }
    // cjval on every output, on two threads.
    let verdicts: Vec<(usize, Result<(), String>)> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads())
            .map(|t| {
                let written = &written;
                let cjval = &cjval;
                s.spawn(move || {
                    written
                        .iter()
                        .enumerate()
                        .skip(t)
                        .step_by(threads())
                        .map(|(i, (_, _, out))| (i, validate(cjval, out)))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap())
            .collect()
    });
    let mut valid = 0;
    for (i, v) in verdicts {
        let (input, _, out) = &written[i];
        match v {
            Ok(()) => valid += 1,
            Err(e) => problems.push(format!(
                "{} -> {}: cjval: {e}",
                short(input),
                out.file_name().unwrap().to_string_lossy()
            )),
        }
    }
    let outs: Vec<PathBuf> = written.iter().map(|(_, _, o)| o.clone()).collect();
    let counts = cjio_counts(&outs);
    for (input, stats, out) in &written {
        let name = format!(
            "{} ({})",
            short(input),
            out.file_name().unwrap().to_string_lossy()
        );
        match counts.get(&out.display().to_string()) {
            Some(c) => compare(&name, c, stats, &mut problems),
            None => problems.push(format!("{name}: cjio gave no counts")),
        }
    }
    eprintln!(
        "{valid} of {} CityJSON/CityJSONSeq outputs valid for cjval, {} inputs",
        written.len(),
        written.len() / 2
    );
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The validator is not a rubber stamp: a LoD CityJSON does not know, a child without its
/// parent, and a vertex index out of range are each reported invalid.
#[test]
fn cjval_rejects_broken_output() {
    let Some(cjval) = cjval() else { return };
    let model = read_file(&fixture("synth-small.gml")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.city.json");
    write(
        Format::CityJson,
        &Chunks::model(&model, 0, Content::Full),
        &good,
        &Default::default(),
    )
    .unwrap();
    assert_eq!(validate(&cjval, &good), Ok(()));
    let doc: Value = serde_json::from_slice(&std::fs::read(&good).unwrap()).unwrap();
    let first_building = doc["CityObjects"]
        .as_object()
        .unwrap()
        .iter()
        .find(|(_, o)| o["type"] == "Building")
        .map(|(k, _)| k.clone())
        .unwrap();
    type Breakage<'a> = Box<dyn Fn(&mut Value) + 'a>;
    let breakages: [(&str, Breakage); 3] = [
        (
            "lod 4",
            Box::new(|d: &mut Value| {
                d["CityObjects"][&first_building]["geometry"][0]["lod"] = "4".into()
            }),
        ),
        (
            "orphan child",
            Box::new(|d: &mut Value| {
                d["CityObjects"][&first_building]["children"] = serde_json::json!(["nobody"])
            }),
        ),
        (
            "vertex index",
            Box::new(|d: &mut Value| {
                d["CityObjects"][&first_building]["geometry"][0]["boundaries"][0][0][0] =
                    10_000_000.into()
            }),
        ),
    ];
    for (what, f) in breakages {
        let mut d = doc.clone();
        f(&mut d);
        let bad = dir.path().join("bad.city.json");
        std::fs::write(&bad, serde_json::to_vec(&d).unwrap()).unwrap();
        assert!(validate(&cjval, &bad).is_err(), "cjval accepted {what}");
    }
}

fn cli(args: &[&str]) -> std::process::Output {
    let a: Vec<&std::ffi::OsStr> = args.iter().map(|s| s.as_ref()).collect();
    run(&a)
}

/// `lod` and `rough` through the command line: valid, every kept asset carries its level, and
/// the levels written are the report's.
#[test]
fn lod_and_rough_outputs_carry_levels() {
    let Some(cjval) = cjval() else { return };
    if !python_has("cjio", "pip install cjio") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = |n: &str| dir.path().join(n).display().to_string();
    let small = fixture("synth-small.gml").display().to_string();
    let pois = fixture("synth-small.pois.csv").display().to_string();
    let mut cases: Vec<(String, String, Option<[usize; 3]>)> = Vec::new();
    for ext in [".city.json", ".city.jsonl"] {
        let out = d(&format!("lod{ext}"));
        let report = d(&format!("lod{ext}.report.json"));
        let o = cli(&[
            "lod", &small, "--pois", &pois, "-o", &out, "--report", &report,
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let r: Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
        let l = &r["totals"]["levels"];
        let levels = [0, 1, 2].map(|k| l[k].as_u64().unwrap() as usize);
        cases.push((small.clone(), out, Some(levels)));
        let out = d(&format!("rough{ext}"));
        let o = cli(&["rough", &small, "-o", &out]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        cases.push((small.clone(), out, None));
    }
    // A real LoD3 building (CityGML 2.0) and a CityGML 3.0 file.
    if let Some(data) = shared_data() {
        let ing = data
            .join("ingolstadt-lod3/4018115.xml.gz")
            .display()
            .to_string();
        let out = d("ing.city.jsonl");
        let o = cli(&["rough", &ing, "-o", &out]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        cases.push((ing, out, None));
        let v3 = data
            .join("kit-fzk-haus/citygml3/FZK-Haus-LoD3-KIT-IAI-KHH-B36-V1__v3.gml")
            .display()
            .to_string();
        let out = d("fzk3.city.json");
        let o = cli(&["rough", &v3, "-o", &out]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        cases.push((v3, out, None));
    }
    let outs: Vec<PathBuf> = cases.iter().map(|(_, o, _)| PathBuf::from(o)).collect();
    let counts = cjio_counts(&outs);
    for (input, out, levels) in &cases {
        validate(&cjval, Path::new(out)).unwrap_or_else(|e| panic!("{out}: {e}"));
        let c = &counts[out.as_str()];
        let model = read_file(Path::new(input)).unwrap();
        let stats = cityjson_stats(&model, Path::new(input));
        let got = [
            n(&c["levels"], "0"),
            n(&c["levels"], "1"),
            n(&c["levels"], "2"),
        ];
        match levels {
            // Kept assets carry their level; level 0 is never written.
            Some(l) => assert_eq!(got, [0, l[1], l[2]], "{out}"),
            // rough: every asset at level 1, the counts of the input kept.
            None => {
                let with_polygons = model
                    .assets
                    .iter()
                    .filter(|a| a.geometries.iter().any(|g| !g.polygons.is_empty()))
                    .count();
                assert_eq!(got, [0, with_polygons, 0], "{out}");
                let mut problems = Vec::new();
                compare(out, c, &stats, &mut problems);
                assert!(problems.is_empty(), "{}", problems.join("\n"));
            }
        }
    }
}

/// A name that asks for no format is refused before any work (exit 2, nothing written), unless
/// `--format` names one; a directory output takes the format's ending.
#[test]
fn format_from_the_name() {
    let dir = tempfile::tempdir().unwrap();
    let small = fixture("synth-small.gml").display().to_string();
    let json = dir.path().join("x.json");
    let js = json.display().to_string();
    for cmd in ["convert", "rough"] {
        let o = cli(&[cmd, &small, "-o", &js]);
        assert_eq!(o.status.code(), Some(2), "{cmd}");
        assert!(
            String::from_utf8_lossy(&o.stderr).contains("unknown output format"),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(!json.exists());
    }
    let o = cli(&[
        "lod",
        &small,
        "--poi",
        "430032.407,4581009.950,16.6,0,-1,0",
        "-o",
        &js,
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(!json.exists());
    let o = cli(&["convert", &small, "-o", &js, "--format", "cityjson"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(v["type"], "CityJSON");
    let o = cli(&["convert", &small, "-o", &js, "--format", "json"]);
    assert_eq!(o.status.code(), Some(2));
    // Several inputs into a directory: names get the format's ending.
    let a = dir.path().join("a.gml");
    let b = dir.path().join("b.xml");
    std::fs::copy(fixture("synth-small.gml"), &a).unwrap();
    std::fs::copy(fixture("synth-small.gml"), &b).unwrap();
    let outdir = dir.path().join("out");
    let o = cli(&[
        "rough",
        &a.display().to_string(),
        &b.display().to_string(),
        "-o",
        &outdir.display().to_string(),
        "--format",
        "cityjsonseq",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(outdir.join("a.city.jsonl").is_file());
    assert!(outdir.join("b.city.jsonl").is_file());
}

/// `lod` on the whole Ingolstadt street (53 tiles, one scene) at six facade POIs, one
/// CityJSONSeq per tile: every file valid, and the levels written over all files (level 2
/// roofs and installations in full detail among them) are the report's.
#[test]
fn lod_ingolstadt_tiles_levels() {
    let Some(cjval) = cjval() else { return };
    if !python_has("cjio", "pip install cjio") {
        return;
    }
    let Some(data) = shared_data() else { return };
    let tiles = citygml_files(&data.join("ingolstadt-lod3"));
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("lod");
    let report = dir.path().join("report.json");
    let mut args: Vec<String> = vec!["lod".into()];
    args.extend(tiles.iter().map(|p| p.display().to_string()));
    for poi in [
        "678095,5403890,418,0,-1,0",
        "678184.488,5403910.026,421.429,0.3969,-0.9178,0",
        "678146.706,5403898.825,421.289,0.2584,-0.9660,0",
        "678086.159,5403875.438,421.434,0.9321,0.3623,0",
        "678150.193,5403776.433,419.363,-0.8357,-0.5492,0",
        "678111.129,5403764.510,420.585,-0.8520,-0.5236,0",
    ] {
        args.extend(["--poi".into(), poi.into()]);
    }
    args.extend([
        "-o".into(),
        out.display().to_string(),
        "--format".into(),
        "cityjsonseq".into(),
        "--report".into(),
        report.display().to_string(),
    ]);
    let a: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = cli(&a);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r: Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    let want = [0, 1, 2].map(|k| r["totals"]["levels"][k].as_u64().unwrap() as usize);
    assert!(want[2] > 0 && want[1] > 0, "levels {want:?}");
    let outs: Vec<PathBuf> = tiles
        .iter()
        .map(|t| {
            out.join(Format::CityJsonSeq.output_name(&t.file_name().unwrap().to_string_lossy()))
        })
        .collect();
    let mut problems = Vec::new();
    for o in &outs {
        if let Err(e) = validate(&cjval, o) {
            problems.push(format!("{}: {e}", o.display()));
        }
    }
    let counts = cjio_counts(&outs);
    let mut got = [0usize; 3];
    for c in counts.values() {
        for (k, g) in got.iter_mut().enumerate() {
            *g += n(&c["levels"], &k.to_string());
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    assert_eq!(got, [0, want[1], want[2]]);
}
