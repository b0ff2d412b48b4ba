//! Faults: the global options in every combination (the worker pool is built once), and
//! errors in standard input named `<stdin>`.

use crate::util::{fixture, os, run, stderr};
use std::io::Write;
use std::process::{Command, Stdio};

/// `--jobs`, `--scene-radius`, `--quiet` and `--shard` in every combination on the commands
/// that take them: each run exits 0 (`--scene-radius` with `--jobs` aborted with "The global
/// thread pool has already been initialized").
#[test]
fn global_options_in_every_combination() {
    let input = fixture("synth-small.gml");
    let pois = fixture("synth-small.pois.csv");
    let dir = tempfile::tempdir().unwrap();
    let mut failures = Vec::new();
    let mut runs = 0;
    for cmd in ["svf", "lod"] {
        for mask in 0u8..16 {
            let mut args: Vec<String> = vec![
                cmd.into(),
                input.display().to_string(),
                "--pois".into(),
                pois.display().to_string(),
            ];
            if cmd == "lod" {
                // A shard of `lod` writes its levels file, not a model.
                let ext = if mask & 8 != 0 { "jsonl" } else { "gml" };
                let out = dir.path().join(format!("{cmd}-{mask}.{ext}"));
                args.extend(["-o".into(), out.display().to_string(), "--overwrite".into()]);
            } else {
                args.extend(["--rays".into(), "64".into()]);
            }
            if mask & 1 != 0 {
                args.extend(["--jobs".into(), "2".into()]);
            }
            if mask & 2 != 0 {
                args.extend(["--scene-radius".into(), "200".into()]);
            }
            if mask & 4 != 0 {
                args.push("--quiet".into());
            }
            if mask & 8 != 0 {
                args.extend(["--shard".into(), "1/2".into()]);
            }
            let o = run(&args.iter().map(os).collect::<Vec<_>>());
            runs += 1;
            if !o.status.success() {
                failures.push(format!(
                    "skylod {}: {:?}: {}",
                    args.join(" "),
                    o.status.code(),
                    stderr(&o)
                ));
            }
        }
    }
    assert_eq!(runs, 32);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Run `skylod args…` with `input` on standard input.
fn with_stdin(args: &[&str], input: &[u8]) -> std::process::Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_skylod"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(input).unwrap();
    child.wait_with_output().unwrap()
}

/// A syntax error in standard input is at `<stdin>:1:…`, never at the deleted spool file.
#[test]
fn an_error_in_standard_input_names_it() {
    let o = with_stdin(&["stats", "-"], b"<bad");
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains("<stdin>:1:"), "{err}");
    assert!(!err.contains("skylod-stdin-"), "{err}");
    assert!(!err.contains("/tmp/"), "{err}");
}
