//! The command line: exit codes, error messages, `stats --json`, `convert` safety.

use crate::util::*;
use serde_json::Value;
use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::Output;

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).to_string()
}

/// Sorted names of the files in a directory.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    v.sort();
    v
}

/// A copy of the 2.0 fixture cut in the middle of an element (truncated download).
fn truncated(dir: &Path) -> PathBuf {
    let text = std::fs::read(fixture("chimney-citygml2.gml")).unwrap();
    let p = dir.join("truncated.gml");
    std::fs::write(&p, &text[..text.len() / 2]).unwrap();
    p
}

/// A copy of the 2.0 fixture with a mismatched end tag; returns the path and its 1-based line.
fn mismatched(dir: &Path) -> (PathBuf, usize) {
    let text = std::fs::read_to_string(fixture("chimney-citygml2.gml")).unwrap();
    let at = text.find("</gml:posList>").unwrap();
    let line = text[..at].matches('\n').count() + 1;
    let broken = format!("{}</gml:posLst>{}", &text[..at], &text[at + 14..]);
    let p = dir.join("mismatched.gml");
    std::fs::write(&p, broken).unwrap();
    (p, line)
}

#[test]
fn usage_errors_exit_2() {
    let cases: Vec<Vec<&OsStr>> = vec![
        vec![],
        vec![os("stats")],
        vec![os("stats"), os("--no-such-flag"), fixture_os()],
        vec![os("no-such-command")],
        vec![os("convert"), fixture_os()],
    ];
    for args in cases {
        let o = run(&args);
        assert_eq!(o.status.code(), Some(2), "args {args:?}: {}", stderr(&o));
        assert!(!stderr(&o).is_empty(), "args {args:?}: no message");
    }
}

fn fixture_os() -> &'static OsStr {
    let p: &'static PathBuf = Box::leak(Box::new(fixture("chimney-citygml2.gml")));
    p.as_os_str()
}

#[test]
fn stats_ok_exits_0() {
    let o = run(&[os("stats"), fixture_os()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stdout(&o).contains("buildings"));
}

#[test]
fn missing_and_broken_inputs_exit_1_others_still_reported() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("does-not-exist.gml");
    let trunc = truncated(dir.path());
    let (mism, line) = mismatched(dir.path());
    let good1 = fixture("chimney-citygml1.gml");
    let good3 = fixture("chimney-citygml3.gml");
    let o = run(&[
        os("stats"),
        os("--json"),
        good1.as_os_str(),
        missing.as_os_str(),
        trunc.as_os_str(),
        mism.as_os_str(),
        good3.as_os_str(),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    // The good files are still reported.
    let v: Value = serde_json::from_slice(&o.stdout).expect("JSON on stdout");
    let paths: Vec<&str> = v["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["path"].as_str().unwrap())
        .collect();
    assert_eq!(
        paths,
        vec![good1.to_str().unwrap(), good3.to_str().unwrap()],
        "{v}"
    );
    assert_eq!(v["total"]["buildings"], 2);
    // One line per failed file, naming it.
    for bad in [&missing, &trunc, &mism] {
        let name = bad.display().to_string();
        let lines: Vec<&str> = err.lines().filter(|l| l.contains(&name)).collect();
        assert_eq!(lines.len(), 1, "{name}: expected one line in\n{err}");
    }
    assert_eq!(
        err.lines().filter(|l| l.starts_with("error: ")).count(),
        3,
        "exactly three error lines:\n{err}"
    );
    // The batch ends with one closing line.
    assert_eq!(err.lines().count(), 4, "{err}");
    assert!(
        err.lines()
            .last()
            .is_some_and(|l| l.starts_with("stats: 2 file(s) ok, 3 failed, 0 warning(s)")),
        "{err}"
    );
    // Malformed XML: line:column.
    let mline = err
        .lines()
        .find(|l| l.contains(&*mism.display().to_string()))
        .unwrap();
    assert!(
        mline.contains(&format!("{}:{line}:", mism.display())),
        "mismatched tag is on line {line}: {mline}"
    );
    let tline = err
        .lines()
        .find(|l| l.contains(&*trunc.display().to_string()))
        .unwrap();
    let after = &tline
        [tline.find(&*trunc.display().to_string()).unwrap() + trunc.display().to_string().len()..];
    let pos = after.split_whitespace().next().unwrap_or("");
    let mut it = pos.trim_start_matches(':').split(':');
    let l: Option<u64> = it.next().and_then(|s| s.parse().ok());
    let c: Option<u64> = it.next().and_then(|s| s.trim().parse().ok());
    assert!(
        l.is_some_and(|l| l > 1) && c.is_some(),
        "no line:column in {tline}"
    );
}

#[test]
fn single_missing_input_exits_1() {
    let o = run(&[os("stats"), os("/nonexistent/skylod/x.gml")]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("/nonexistent/skylod/x.gml"));
}

const KEYS: [&str; 19] = [
    "citygml_version",
    "srs_name",
    "buildings",
    "building_parts",
    "roof_surfaces",
    "wall_surfaces",
    "ground_surfaces",
    "closure_surfaces",
    "installations",
    "windows",
    "doors",
    "other_objects",
    "polygons",
    "traced_polygons",
    "polygon_elements",
    "lods",
    "implicit_geometries",
    "warnings",
    "bbox",
];

#[test]
fn stats_json_one_input() {
    let o = run(&[os("stats"), os("--json"), fixture_os()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let doc: Value = serde_json::from_slice(&o.stdout).expect("JSON");
    // One shape whatever the number of inputs: {"files":[...],"total":{...}}.
    assert_eq!(doc["files"].as_array().map(Vec::len), Some(1), "{doc}");
    let v = doc["files"][0].clone();
    assert_eq!(v["path"].as_str(), fixture_os().to_str());
    let mut total = doc["total"].clone();
    let mut file = v.clone();
    file.as_object_mut().unwrap().remove("path");
    total.as_object_mut().unwrap().remove("path");
    assert_eq!(file, total, "one file: the total is the file");
    let obj = v.as_object().expect("an object");
    assert_eq!(v["features"]["WallSurface"], 4);
    assert_eq!(v["features"]["CityModel"], 1);
    for k in KEYS {
        assert!(obj.contains_key(k), "missing key {k} in {v}");
    }
    assert_eq!(v["citygml_version"], "2.0");
    assert_eq!(v["buildings"], 1);
    assert_eq!(v["wall_surfaces"], 4);
    assert_eq!(v["installations"], 1);
    assert_eq!(v["windows"], 1);
    assert_eq!(v["doors"], 1);
    assert_eq!(v["polygons"], 14);
    assert_eq!(v["lods"], serde_json::json!([3]));
    assert_eq!(
        v["bbox"],
        serde_json::json!([690000.0, 5336000.0, 500.0, 690010.0, 5336008.0, 507.5])
    );
}

#[test]
fn stats_json_two_inputs_total_is_sum() {
    let a = fixture("chimney-citygml2.gml");
    let b = match shared_data() {
        Some(d) => d.join("ogc-citygml2-examples/building/Building_LOD3-EPSG25832.gml"),
        None => fixture("chimney-citygml3.gml"),
    };
    let o = run(&[os("stats"), os("--json"), a.as_os_str(), b.as_os_str()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    check_stdout_schema("stats.schema.json", &o);
    let v: Value = serde_json::from_slice(&o.stdout).expect("JSON");
    let files = v["files"].as_array().expect("files array");
    assert_eq!(files.len(), 2);
    assert_eq!(files[0]["path"], a.to_str().unwrap());
    assert_eq!(files[1]["path"], b.to_str().unwrap());
    let total = &v["total"];
    for k in KEYS {
        assert!(total.get(k).is_some(), "total lacks {k}");
        if files[0][k].is_u64() {
            let sum = files[0][k].as_u64().unwrap() + files[1][k].as_u64().unwrap();
            assert_eq!(total[k].as_u64(), Some(sum), "total {k}");
        }
    }
    // bbox of the total encloses both.
    let bb = |x: &Value| -> Vec<f64> {
        x["bbox"]
            .as_array()
            .unwrap()
            .iter()
            .map(|n| n.as_f64().unwrap())
            .collect()
    };
    let (t, f0, f1) = (bb(total), bb(&files[0]), bb(&files[1]));
    for i in 0..3 {
        assert_eq!(t[i], f0[i].min(f1[i]));
        assert_eq!(t[i + 3], f0[i + 3].max(f1[i + 3]));
    }
}

fn convert_args<'a>(input: &'a Path, out: &'a Path, overwrite: bool) -> Vec<&'a OsStr> {
    let mut v = vec![os("convert"), input.as_os_str(), os("-o"), out.as_os_str()];
    if overwrite {
        v.push(os("--overwrite"));
    }
    v
}

#[test]
fn convert_refuses_existing_output_without_overwrite() {
    let dir = tempfile::tempdir().unwrap();
    let input = fixture("chimney-citygml2.gml");
    let out = dir.path().join("out.gml");
    std::fs::write(&out, b"keep me").unwrap();
    let o = run(&convert_args(&input, &out, false));
    assert_ne!(o.status.code(), Some(0), "must refuse");
    assert!(stderr(&o).contains("out.gml"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&out).unwrap(), b"keep me");
    assert_eq!(listing(dir.path()), vec!["out.gml"]);
    let o = run(&convert_args(&input, &out, true));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_ne!(std::fs::read(&out).unwrap(), b"keep me");
    assert_eq!(listing(dir.path()), vec!["out.gml"]);
}

#[test]
fn convert_refuses_output_equal_to_input() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.gml");
    std::fs::copy(fixture("chimney-citygml2.gml"), &input).unwrap();
    let original = std::fs::read(&input).unwrap();
    let same_spellings = [
        input.clone(),
        dir.path().join(".").join("in.gml"),
        dir.path().join("sub").join("..").join("in.gml"),
    ];
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    for out in &same_spellings {
        let o = run(&convert_args(&input, out, true));
        assert_ne!(o.status.code(), Some(0), "{}: must refuse", out.display());
        assert_eq!(
            std::fs::read(&input).unwrap(),
            original,
            "{}",
            out.display()
        );
    }
    assert_eq!(listing(dir.path()), vec!["in.gml", "sub"]);
}

#[test]
fn convert_failure_leaves_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let trunc = truncated(dir.path());
    let out = dir.path().join("out.gml");
    let o = run(&convert_args(&trunc, &out, false));
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("truncated.gml"), "{}", stderr(&o));
    assert_eq!(listing(dir.path()), vec!["truncated.gml"]);
    // Output into a directory that does not exist: it is made, nothing else is left.
    let missing = dir.path().join("no-such-dir");
    let o = run(&convert_args(
        &fixture("chimney-citygml2.gml"),
        &missing.join("out.gml"),
        false,
    ));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(listing(&missing), vec!["out.gml"]);
    std::fs::remove_dir_all(&missing).unwrap();
    assert_eq!(listing(dir.path()), vec!["truncated.gml"]);
    // Output path is a directory: the output goes into it, under the input's name (as `cp`).
    std::fs::create_dir(dir.path().join("adir")).unwrap();
    let o = run(&convert_args(
        &fixture("chimney-citygml2.gml"),
        &dir.path().join("adir"),
        true,
    ));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(listing(dir.path()), vec!["adir", "truncated.gml"]);
    assert_eq!(
        listing(&dir.path().join("adir")),
        vec!["chimney-citygml2.gml"]
    );
}

#[test]
fn convert_never_modifies_the_input() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["chimney-citygml3.gml", "default-namespace.gml"] {
        let input = dir.path().join(name);
        std::fs::copy(fixture(name), &input).unwrap();
        let bytes = std::fs::read(&input).unwrap();
        let mtime = std::fs::metadata(&input).unwrap().modified().unwrap();
        let out = dir.path().join(format!("{name}.out.gml.gz"));
        let o = run(&convert_args(&input, &out, false));
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        assert_eq!(std::fs::read(&input).unwrap(), bytes, "{name}");
        assert_eq!(
            std::fs::metadata(&input).unwrap().modified().unwrap(),
            mtime,
            "{name}"
        );
    }
}

/// Completion scripts are valid for their shell (bash parses its own), and the manual page
/// names every command.
#[test]
fn completions_and_man_page() {
    let o = run(&[os("completions"), os("bash")]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let script = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(
        script.contains("skylod") && script.contains("--poi-margin"),
        "{script}"
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("skylod.bash");
    std::fs::write(&path, &script).unwrap();
    match std::process::Command::new("bash")
        .arg("-n")
        .arg(&path)
        .output()
    {
        Ok(b) => assert!(b.status.success(), "{}", String::from_utf8_lossy(&b.stderr)),
        Err(_) => crate::util::missing("bash"),
    }
    for shell in ["zsh", "fish"] {
        let o = run(&[os("completions"), os(shell)]);
        assert_eq!(o.status.code(), Some(0), "{shell}");
        assert!(!o.stdout.is_empty());
    }
    let o = run(&[os("completions"), os("tcsh-9")]);
    assert_eq!(o.status.code(), Some(2));
    let o = run(&[os("man")]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let page = String::from_utf8_lossy(&o.stdout);
    assert!(
        page.starts_with(".ie") || page.contains(".TH skylod"),
        "{page}"
    );
    for c in [
        "stats",
        "convert",
        "rough",
        "lod",
        "evaluate",
        "svf",
        "sun\\-hours",
        "fisheye",
    ] {
        assert!(page.contains(c), "man page lacks {c}");
    }
}
