//! Progress and logging on standard error: bars under a pseudo-terminal (`script -qc`),
//! plain lines when stderr is a pipe (`--log-level`), nothing but errors with `--quiet`.

use crate::util::{fixture, os, run, stderr};
use std::path::Path;
use std::process::Command;

/// `skylod lod` on the committed synth fixture, writing into `dir`, with `extra` flags.
fn lod_args(dir: &Path, extra: &[&str]) -> Vec<String> {
    let mut a = vec![
        "lod".to_string(),
        fixture("synth-small.gml").display().to_string(),
        "--pois".into(),
        fixture("synth-small.pois.csv").display().to_string(),
        "--rays".into(),
        "2000".into(),
        "-o".into(),
        dir.join("out.gml").display().to_string(),
    ];
    a.extend(extra.iter().map(|s| s.to_string()));
    a
}

fn run_strs(a: &[String]) -> std::process::Output {
    let v: Vec<&std::ffi::OsStr> = a.iter().map(os).collect();
    run(&v)
}

/// Run the binary under a pseudo-terminal; what the terminal showed.
fn under_pty(args: &[String]) -> Option<(bool, String)> {
    let have = Command::new("script").arg("--version").output().is_ok();
    if !have {
        crate::util::missing("`script` (bsdutils) for a pseudo-terminal");
        return None;
    }
    let quote = |s: &str| format!("'{}'", s.replace('\'', r"'\''"));
    let mut cmd = quote(env!("CARGO_BIN_EXE_skylod"));
    for a in args {
        cmd.push(' ');
        cmd.push_str(&quote(a));
    }
    let o = Command::new("script")
        .args(["-qec", &cmd, "/dev/null"])
        .env("TERM", "xterm")
        .output()
        .expect("running script");
    Some((
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
    ))
}

#[test]
fn terminal_shows_bars() {
    let dir = tempfile::tempdir().unwrap();
    let Some((ok, shown)) = under_pty(&lod_args(dir.path(), &[])) else {
        return;
    };
    assert!(ok, "{shown}");
    for stage in ["reading inputs", "selecting levels", "writing outputs"] {
        assert!(
            shown.contains(stage),
            "no {stage:?} on the terminal:\n{shown}"
        );
    }
    assert!(
        shown.contains("POIs"),
        "no POI count on the terminal:\n{shown}"
    );
    // The summary stays after the bars are cleared.
    assert!(shown.contains("assets at level 0/1/2"), "{shown}");
}

#[test]
fn terminal_quiet_shows_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let Some((ok, shown)) = under_pty(&lod_args(dir.path(), &["--quiet"])) else {
        return;
    };
    assert!(ok, "{shown}");
    assert!(shown.trim().is_empty(), "--quiet showed:\n{shown}");
    assert!(dir.path().join("out.gml").exists());
}

#[test]
fn pipe_gets_plain_lines_by_level() {
    let dir = tempfile::tempdir().unwrap();
    // Default: warnings and the summary, no progress lines, no terminal control codes.
    let o = run_strs(&lod_args(dir.path(), &[]));
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("assets at level 0/1/2"), "{e}");
    assert!(!e.contains("reading inputs"), "{e}");
    assert!(!e.contains('\u{1b}'), "control codes on a pipe: {e:?}");
    // info: one line per stage and per file.
    let o = run_strs(&lod_args(
        dir.path(),
        &["--overwrite", "--log-level", "info"],
    ));
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    for want in [
        "reading inputs: 1 file(s)",
        "reading inputs 1/1: ",
        "selecting levels: 3 POI(s)",
        "selecting levels: done, 3 POI(s)",
        "building the scene: done in ",
        "writing outputs 1/1: ",
    ] {
        assert!(e.contains(want), "no {want:?} in:\n{e}");
    }
    assert!(!e.contains('\u{1b}'), "control codes on a pipe: {e:?}");
    // The global flag works before the subcommand too.
    let mut a = vec!["--log-level".to_string(), "error".into()];
    a.extend(lod_args(dir.path(), &["--overwrite"]));
    let o = run_strs(&a);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stderr(&o), "", "--log-level error");
}

#[test]
fn quiet_keeps_errors() {
    let dir = tempfile::tempdir().unwrap();
    let o = run_strs(&lod_args(dir.path(), &["-q"]));
    assert!(o.status.success());
    assert_eq!(stderr(&o), "", "--quiet");
    // The output exists now: without --overwrite the refusal is an error, said even with -q.
    let o = run_strs(&lod_args(dir.path(), &["-q"]));
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("error"), "{}", stderr(&o));
    // Every command has the global flags.
    let o = run(&[
        os("stats"),
        os("-q"),
        fixture("synth-small.gml").as_os_str(),
    ]);
    assert!(o.status.success());
    assert_eq!(stderr(&o), "", "stats -q");
}

/// Ctrl-C (SIGINT) stops `lod` at its next file or POI: exit 2 saying what was cancelled, and
/// nothing left in the output directory (no merged model, no staging directory, no temporary
/// file); or, should the run have ended before the signal, exit 0 with exactly the model.
#[test]
fn ctrl_c_leaves_nothing_partial() {
    let Some(data) = crate::util::shared_data() else {
        return;
    };
    let tiles = data.join("ingolstadt-lod3");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("street.gml");
    let child = Command::new(env!("CARGO_BIN_EXE_skylod"))
        .arg("lod")
        .arg(&tiles)
        .args(["--poi", "678090,5403790,415", "-o"])
        .arg(&out)
        .stderr(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(300));
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let o = child.wait_with_output().unwrap();
    let err = stderr(&o);
    let left: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    match o.status.code() {
        Some(2) => {
            assert!(err.contains("cancelled while"), "{err}");
            assert!(left.is_empty(), "left behind after Ctrl-C: {left:?}");
        }
        Some(0) => assert_eq!(left, vec!["street.gml".to_string()], "{err}"),
        c => panic!("exit {c:?} after Ctrl-C: {err}"),
    }
}
