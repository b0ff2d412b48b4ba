//! Several inputs merged into one OBJ, CityJSON or CityJSONSeq (issue 22): `convert tiles -o
//! m.obj` is the CityGML merge converted (`convert tiles -o m.gml`, then `convert m.gml -o
//! m.obj`), `rough tiles -o m.obj` the rough CityGML merge converted, and `lod tiles -o m.obj`
//! is `lod` of the CityGML merge, byte for byte but for the OBJ's comment line (it names the
//! inputs: "a.gml and 52 more", not the staged merge); colliding ids of later inputs renamed
//! `<id>__<k>` as the CityGML merge renames them; the CityJSON valid for `cjval`. Real data:
//! the 53 Ingolstadt tiles and the PLATEAU tiles.

use crate::util::*;
use std::ffi::{OsStr, OsString};
use std::path::{Path, PathBuf};

fn skylod(args: &[OsString]) {
    let a: Vec<&OsStr> = args.iter().map(OsString::as_os_str).collect();
    let o = run(&a);
    assert!(
        o.status.success(),
        "skylod {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

fn args(head: &[&str], inputs: &[PathBuf], tail: &[&dyn AsRef<OsStr>]) -> Vec<OsString> {
    let mut v: Vec<OsString> = head.iter().map(OsString::from).collect();
    v.extend(inputs.iter().map(|p| p.clone().into_os_string()));
    v.extend(tail.iter().map(|s| s.as_ref().to_os_string()));
    v
}

/// `a` and `b` are the same bytes; for OBJ, but for the second line (the comment naming the
/// source), which for `a` (the merge) names the first input and how many more.
fn same_output(a: &Path, b: &Path, first: &Path, n: usize) {
    let (x, y) = (std::fs::read(a).unwrap(), std::fs::read(b).unwrap());
    if a.extension().is_some_and(|e| e == "obj") {
        let (x, y) = (String::from_utf8(x).unwrap(), String::from_utf8(y).unwrap());
        let lines = |t: &str| -> Vec<String> { t.lines().map(str::to_string).collect() };
        let (mut lx, mut ly) = (lines(&x), lines(&y));
        assert_eq!(lx.len(), ly.len(), "{} vs {}", a.display(), b.display());
        let c = lx.remove(1);
        ly.remove(1);
        let name = format!("OBJ of {} and {} more;", first.display(), n - 1);
        assert!(c.contains(&name), "{c}: not {name}");
        assert!(
            lx == ly,
            "{} differs from {} beyond the comment line",
            a.display(),
            b.display()
        );
    } else {
        assert!(x == y, "{} differs from {}", a.display(), b.display());
    }
}

/// OBJ object names, in order.
fn obj_names(p: &Path) -> Vec<String> {
    std::fs::read_to_string(p)
        .unwrap()
        .lines()
        .filter_map(|l| l.strip_prefix("o ").map(str::to_string))
        .collect()
}

fn cjval_valid(file: &Path) {
    let mut bins = vec![PathBuf::from("cjval")];
    if let Ok(home) = std::env::var("HOME") {
        bins.push(Path::new(&home).join(".cargo/bin/cjval"));
    }
    let Some(bin) = bins.into_iter().find(|b| {
        std::process::Command::new(b)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
    }) else {
        missing("cjval (cargo install cjval --features build-binary)");
        return;
    };
    let seq = file.to_string_lossy().ends_with(".city.jsonl");
    let mut c = std::process::Command::new(bin);
    c.arg("--summary");
    if seq {
        c.stdin(std::fs::File::open(file).unwrap());
    } else {
        c.arg(file);
    }
    let o = c.output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    let ok = if seq {
        text.contains("❌ invalid:  0/")
    } else {
        text.contains("File is valid")
    };
    assert!(ok, "cjval on {}: {text}", file.display());
}

/// Every format: the merge converted equals the CityGML merge converted.
fn convert_merge_equals(inputs: &[PathBuf], dir: &Path) {
    let gml = dir.join("m.gml");
    skylod(&args(&["convert", "-q"], inputs, &[&"-o", &gml]));
    for ext in ["obj", "city.json", "city.jsonl"] {
        let merged = dir.join(format!("merged.{ext}"));
        let two_step = dir.join(format!("two-step.{ext}"));
        skylod(&args(&["convert", "-q"], inputs, &[&"-o", &merged]));
        skylod(&args(
            &["convert", "-q"],
            std::slice::from_ref(&gml),
            &[&"-o", &two_step],
        ));
        same_output(&merged, &two_step, &inputs[0], inputs.len());
        if ext != "obj" {
            cjval_valid(&merged);
        }
    }
    let names = obj_names(&dir.join("merged.obj"));
    let unique: std::collections::HashSet<&String> = names.iter().collect();
    assert_eq!(unique.len(), names.len(), "OBJ object names not unique");
}

#[test]
fn convert_ingolstadt_tiles_into_one_file() {
    let Some(data) = shared_data() else { return };
    let tiles = citygml_files(&data.join("ingolstadt-lod3"));
    assert!(tiles.len() >= 50, "Ingolstadt tiles missing");
    let dir = tempfile::tempdir().unwrap();
    convert_merge_equals(&tiles, dir.path());
    // One origin for the scene: every tile's geometry in the one file.
    let one = std::fs::read_to_string(dir.path().join("merged.obj")).unwrap();
    assert_eq!(
        one.lines().filter(|l| l.starts_with("# origin ")).count(),
        1
    );
}

#[test]
fn convert_plateau_tiles_into_one_file() {
    let Some(data) = shared_data() else { return };
    let p = data.join("plateau");
    // Tokyo 2020 and 2022 (same CRS, EPSG:6697); one gzip.
    let tiles = vec![
        p.join("tokyo23ku-2020/53392642_bldg_6697_op2.gml"),
        p.join("tokyo23ku-2022/53392633_bldg_6697_2_op.gml.gz"),
        p.join("yokosuka/52397519_bldg_6697_op.gml"),
    ];
    let dir = tempfile::tempdir().unwrap();
    convert_merge_equals(&tiles, dir.path());
}

/// One tile twice (and a third): the second copy's ids become `<id>__2`, as in the CityGML
/// merge, and every object name stays unique.
#[test]
fn colliding_ids_renamed_as_the_citygml_merge_does() {
    let Some(data) = shared_data() else { return };
    let tile = data.join("ingolstadt-lod3/4018106.xml.gz");
    let other = data.join("ingolstadt-lod3/4018115.xml.gz");
    let dir = tempfile::tempdir().unwrap();
    let copy = dir.path().join("copy.xml.gz");
    std::fs::copy(&tile, &copy).unwrap();
    let inputs = vec![tile.clone(), copy, other];
    convert_merge_equals(&inputs, dir.path());
    let names = obj_names(&dir.path().join("merged.obj"));
    let first = obj_names(&{
        let one = dir.path().join("one.obj");
        skylod(&args(&["convert", "-q"], &[tile], &[&"-o", &one]));
        one
    });
    for n in &first {
        assert!(names.contains(n), "{n} of the first input kept");
    }
    // The copy's objects: its ids renamed `<id>__2` (an object without an id is named by its
    // building's renamed id: `<building>__2_<k>`).
    let renamed = names.iter().filter(|n| n.contains("__2")).count();
    assert_eq!(renamed, first.len(), "every object of the copy renamed");
    let cj: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("merged.city.json")).unwrap())
            .unwrap();
    let objects = cj["CityObjects"].as_object().unwrap();
    assert!(
        objects.keys().any(|k| k.ends_with("__2")),
        "no renamed CityJSON id"
    );
}

/// `lod` of the tiles into one OBJ / CityJSON equals `lod` of their CityGML merge.
#[test]
fn lod_ingolstadt_tiles_into_one_file() {
    let Some(data) = shared_data() else { return };
    let tiles = citygml_files(&data.join("ingolstadt-lod3"));
    assert!(tiles.len() >= 50, "Ingolstadt tiles missing");
    let dir = tempfile::tempdir().unwrap();
    let gml = dir.path().join("m.gml");
    skylod(&args(&["convert", "-q"], &tiles, &[&"-o", &gml]));
    let poi: &[&dyn AsRef<OsStr>] = &[
        &"--poi",
        &"678095,5403890,418",
        &"--poi",
        &"678150,5403776,419",
    ];
    for ext in ["obj", "city.json"] {
        let merged = dir.path().join(format!("lod.{ext}"));
        let of_merge = dir.path().join(format!("lod-of-merge.{ext}"));
        let mut a = args(&["lod", "-q"], &tiles, poi);
        a.extend([OsString::from("-o"), merged.clone().into_os_string()]);
        skylod(&a);
        let mut a = args(&["lod", "-q"], std::slice::from_ref(&gml), poi);
        a.extend([OsString::from("-o"), of_merge.clone().into_os_string()]);
        skylod(&a);
        same_output(&merged, &of_merge, &tiles[0], tiles.len());
        if ext != "obj" {
            cjval_valid(&merged);
        }
    }
    assert!(!obj_names(&dir.path().join("lod.obj")).is_empty());
}

/// Inputs in different CRSs are refused before any work, as for a CityGML merge (`convert`
/// and `rough`).
#[test]
fn different_crss_refused() {
    for cmd in ["convert", "rough"] {
        different_crss_refused_by(cmd);
    }
}

fn different_crss_refused_by(cmd: &str) {
    let Some(data) = shared_data() else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.obj");
    let inputs = vec![
        data.join("kit-fzk-haus/citygml2/fzk_haus_lod2_v2.gml"),
        data.join("plateau/sapporo/64413325_bldg_6697_op.gml"),
    ];
    let a = args(&[cmd], &inputs, &[&"-o", &out]);
    let a: Vec<&OsStr> = a.iter().map(OsString::as_os_str).collect();
    let o = run(&a);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("different CRSs"), "{err}");
    assert!(!out.exists());
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "nothing left behind"
    );
}

/// `rough` of the tiles into one OBJ / CityJSON / CityJSONSeq equals `rough` of the tiles into
/// one CityGML merge, converted; and `rough` of the CityGML merge of the tiles, converted.
/// Ids unique, the CityJSON valid.
#[test]
fn rough_ingolstadt_tiles_into_one_file() {
    let Some(data) = shared_data() else { return };
    let tiles = citygml_files(&data.join("ingolstadt-lod3"));
    assert!(tiles.len() >= 50, "Ingolstadt tiles missing");
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (gml, rough_gml) = (d.join("m.gml"), d.join("rough.gml"));
    skylod(&args(&["rough", "-q"], &tiles, &[&"-o", &rough_gml]));
    skylod(&args(&["convert", "-q"], &tiles, &[&"-o", &gml]));
    let rough_of_merge = d.join("rough-of-merge.gml");
    skylod(&args(
        &["rough", "-q"],
        std::slice::from_ref(&gml),
        &[&"-o", &rough_of_merge],
    ));
    for ext in ["obj", "city.json", "city.jsonl"] {
        let merged = d.join(format!("rough.{ext}"));
        skylod(&args(&["rough", "-q"], &tiles, &[&"-o", &merged]));
        for source in [&rough_gml, &rough_of_merge] {
            let two_step = d.join(format!("two-step.{ext}"));
            let o: &[&dyn AsRef<OsStr>] = &[&"-o", &two_step, &"--overwrite"];
            skylod(&args(&["convert", "-q"], std::slice::from_ref(source), o));
            same_output(&merged, &two_step, &tiles[0], tiles.len());
        }
        if ext != "obj" {
            cjval_valid(&merged);
        }
    }
    let names = obj_names(&d.join("rough.obj"));
    assert!(!names.is_empty());
    let unique: std::collections::HashSet<&String> = names.iter().collect();
    assert_eq!(unique.len(), names.len(), "OBJ object names not unique");
    let one = std::fs::read_to_string(d.join("rough.obj")).unwrap();
    let origins = one.lines().filter(|l| l.starts_with("# origin ")).count();
    assert_eq!(origins, 1, "one origin");
}
