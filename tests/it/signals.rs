//! SIGTERM and SIGHUP stop a run like Ctrl-C: the current file or POI stops, no temporary
//! file is left, nothing partial is written, and the exit code says which signal (128 + its
//! number: 143, 129).

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};

/// A synthetic district big enough that `lod` on it runs well past its first log line.
fn district(dir: &Path) {
    let o = Command::new(env!("CARGO_BIN_EXE_skylod"))
        .args(["synth", "--blocks", "3x3", "-o"])
        .arg(dir.join("d.gml"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", crate::util::stderr(&o));
}

/// Start `skylod args…` in `dir`, send `signal` once it has said its first line, and return
/// its exit code, its standard error and what is left in `out_dir`.
fn stop(
    dir: &Path,
    args: &[&str],
    signal: &str,
    out_dir: &Path,
) -> (Option<i32>, String, Vec<String>) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_skylod"))
        .current_dir(dir)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut first = String::new();
    err.read_line(&mut first).unwrap();
    let killed = Command::new("kill")
        .args([&format!("-{signal}"), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(
        killed.success(),
        "kill -{signal}: the run had already ended: {first}"
    );
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut err, &mut rest).unwrap();
    let status = child.wait().unwrap();
    let mut left: Vec<String> = std::fs::read_dir(out_dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    (status.code(), first + &rest, left)
}

#[test]
fn sigterm_and_sighup_stop_lod_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    district(dir.path());
    std::fs::copy(dir.path().join("d.gml"), dir.path().join("e.gml")).unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    for (signal, code) in [("TERM", 143), ("HUP", 129)] {
        let runs: [&[&str]; 2] = [
            &["lod", "d.gml", "--pois", "d.pois.csv", "-o", "out/lod.gml"],
            // Two inputs merged: a staging directory and a merge that must not survive.
            &[
                "lod",
                "d.gml",
                "e.gml",
                "--pois",
                "d.pois.csv",
                "-o",
                "out/street.gml",
            ],
        ];
        for args in runs {
            let (got, err, left) = stop(dir.path(), args, signal, &out);
            assert_eq!(
                got,
                Some(code),
                "skylod {} after SIG{signal}: {err}",
                args.join(" ")
            );
            assert!(
                left.is_empty(),
                "left in the output directory after SIG{signal} of skylod {}: {left:?}\n{err}",
                args.join(" ")
            );
        }
    }
}
