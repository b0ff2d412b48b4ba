//! Batch inputs as users give them: directories, glob patterns expanded by skylod, and `-`
//! (standard input, gzip recognised by content), on the shared Ingolstadt street.

mod common;

use common::*;
use serde_json::Value;
use std::ffi::OsStr;
use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, Output, Stdio};

fn stats(args: &[&OsStr]) -> Value {
    let mut a = vec![os("stats"), os("--json")];
    a.extend_from_slice(args);
    let o = run(&a);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

fn ingolstadt() -> Option<PathBuf> {
    let d = shared_data()?.join("ingolstadt-lod3");
    if d.is_dir() {
        Some(d)
    } else {
        missing(&d.display().to_string());
        None
    }
}

/// Run the binary with `input` on its standard input.
fn piped(args: &[&OsStr], input: &[u8]) -> Output {
    let mut child = Command::new(BIN)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let data = input.to_vec();
    let writer = std::thread::spawn(move || {
        let _ = stdin.write_all(&data);
    });
    let o = child.wait_with_output().unwrap();
    writer.join().unwrap();
    o
}

#[test]
fn directory_and_glob_give_the_files_they_hold() {
    let Some(dir) = ingolstadt() else {
        return;
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(".xml.gz"))
        .collect();
    files.sort();
    let listed = stats(&files.iter().map(|p| p.as_os_str()).collect::<Vec<_>>());
    let by_dir = stats(&[dir.as_os_str()]);
    let pattern = dir.join("*.xml.gz");
    let by_glob = stats(&[pattern.as_os_str()]);
    assert_eq!(by_dir["files"].as_array().unwrap().len(), files.len());
    assert_eq!(by_dir["total"], listed["total"]);
    assert_eq!(by_glob["total"], listed["total"]);
    // The files come in path order, whatever the directory order.
    let paths: Vec<&str> = by_dir["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["path"].as_str().unwrap())
        .collect();
    let mut sorted = paths.clone();
    sorted.sort();
    assert_eq!(paths, sorted);
    // A pattern that matches nothing is a usage error naming it.
    let none = dir.join("*.citygml");
    let o = run(&[os("stats"), none.as_os_str()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("no CityGML file"), "{}", stderr(&o));
}

#[test]
fn standard_input_in_standard_output_out_is_byte_identical_to_files() {
    let Some(dir) = ingolstadt() else {
        return;
    };
    let gz = dir.join("4018215.xml.gz");
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out.gml");
    let o = run(&[os("convert"), gz.as_os_str(), os("-o"), out.as_os_str()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let want = std::fs::read(&out).unwrap();
    // gzip on standard input is recognised by its magic bytes.
    let o = piped(
        &[os("convert"), os("-"), os("-o"), os("-")],
        &std::fs::read(&gz).unwrap(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        o.stdout == want,
        "stdin -> stdout differs from file -> file"
    );
    // Plain XML on standard input, into stats.
    let o = piped(&[os("stats"), os("--json"), os("-")], &want);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    let file = stats(&[out.as_os_str()]);
    assert_eq!(v["total"]["features"], file["total"]["features"]);
    assert_eq!(
        v["total"]["asset_polygons"],
        file["total"]["asset_polygons"]
    );
}

/// `rough` over a directory: the same bytes whatever `--jobs`; a broken file among them is
/// reported and the others are done (exit 1), and a closing line sums it up.
#[test]
fn rough_over_a_directory_any_jobs_and_a_broken_file() {
    let Some(dir) = ingolstadt() else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let tiles = tmp.path().join("tiles");
    std::fs::create_dir(&tiles).unwrap();
    let mut names: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(".xml.gz"))
        .collect();
    names.sort();
    for p in names.iter().take(8) {
        std::fs::copy(p, tiles.join(p.file_name().unwrap())).unwrap();
    }
    let run_jobs = |jobs: &str, out: &std::path::Path| {
        let o = run(&[
            os("rough"),
            tiles.as_os_str(),
            os("-o"),
            out.as_os_str(),
            os("--jobs"),
            os(jobs),
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let err = stderr(&o);
        assert!(err.contains("rough: 8 file(s) ok, 0 failed"), "{err}");
        let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(out)
            .unwrap()
            .map(|e| {
                let p = e.unwrap().path();
                (
                    p.file_name().unwrap().to_string_lossy().to_string(),
                    std::fs::read(&p).unwrap(),
                )
            })
            .collect();
        files.sort();
        files
    };
    let one = run_jobs("1", &tmp.path().join("one"));
    let two = run_jobs("2", &tmp.path().join("two"));
    assert_eq!(one.len(), 8);
    assert!(one == two, "--jobs 1 and --jobs 2 differ");

    // A broken tile among them.
    std::fs::write(tiles.join("broken.gml"), "<CityModel><unclosed>").unwrap();
    let out = tmp.path().join("three");
    let o = run(&[os("rough"), tiles.as_os_str(), os("-o"), out.as_os_str()]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("broken.gml"), "{err}");
    assert!(err.contains("rough: 8 file(s) ok, 1 failed"), "{err}");
    assert_eq!(
        std::fs::read_dir(&out).unwrap().count(),
        8,
        "the others are written, nothing for the broken one"
    );
    // stats: the same closing line.
    let o = run(&[os("stats"), tiles.as_os_str()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("stats: 8 file(s) ok, 1 failed"),
        "{}",
        stderr(&o)
    );
}
