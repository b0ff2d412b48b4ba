//! Faults: the global options in every combination (the worker pool is built once), errors
//! in standard input named `<stdin>`, a full disk on standard output, and the XML files of a
//! directory that are not CityGML.

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

/// JSON outputs name standard input `-`, never the spool file: `stats --json`'s file path
/// and the `inputs` of `svf --json`.
#[test]
fn json_names_standard_input_dash() {
    let gml = std::fs::read(crate::util::fixture("synth-small.gml")).unwrap();
    let o = with_stdin(&["stats", "-", "--json"], &gml);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["files"][0]["path"], "-", "{v}");
    let poi = "430032.4,4581009.95,16.6";
    let o = with_stdin(&["svf", "-", "--poi", poi, "--rays", "100", "--json"], &gml);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["inputs"], serde_json::json!(["-"]), "{v}");
    assert!(!String::from_utf8_lossy(&o.stdout).contains("skylod-stdin-"));
}

/// Standard output on a full disk (`/dev/full`): exit 2 (or 1 for the per-file `convert`),
/// the error names standard output and says "no space left on device", once.
#[test]
fn a_full_standard_output_says_no_space() {
    let full = std::path::Path::new("/dev/full");
    if !full.exists() {
        crate::util::missing("/dev/full");
        return;
    }
    let input = fixture("synth-small.gml");
    let pois = fixture("synth-small.pois.csv");
    let i = input.display().to_string();
    let p = pois.display().to_string();
    let runs: [(&[&str], i32); 4] = [
        (&["stats", "--json", &i], 2),
        (&["stats", &i], 2),
        (&["svf", &i, "--pois", &p, "--rays", "16", "--json"], 2),
        (&["convert", &i, "-o", "-"], 1),
    ];
    for (args, code) in runs {
        let o = Command::new(env!("CARGO_BIN_EXE_skylod"))
            .args(args)
            .stdout(std::fs::File::create(full).unwrap())
            .stderr(Stdio::piped())
            .output()
            .unwrap();
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(code), "{args:?}: {err}");
        assert!(
            err.contains("standard output: no space left on device"),
            "{args:?}: {err}"
        );
        assert_eq!(err.matches("o space left").count(), 1, "{args:?}: {err}");
        assert!(!err.contains("os error"), "{args:?}: {err}");
    }
}

/// A municipal download: tiles with a `metadata.xml` sidecar (and a gzipped one). A directory
/// or a pattern skips them with a warning naming each and exits 0; named, one is an error.
#[test]
fn a_walk_skips_xml_that_is_not_citygml() {
    let dir = tempfile::tempdir().unwrap();
    let tiles = dir.path().join("tiles");
    std::fs::create_dir(&tiles).unwrap();
    std::fs::copy(fixture("synth-small.gml"), tiles.join("a.gml")).unwrap();
    let meta = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<gmd:MD_Metadata \
        xmlns:gmd=\"http://www.isotc211.org/2005/gmd\"><gmd:fileIdentifier/></gmd:MD_Metadata>\n";
    std::fs::write(tiles.join("metadata.xml"), meta).unwrap();
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(meta.as_bytes()).unwrap();
    std::fs::write(tiles.join("more.xml.gz"), gz.finish().unwrap()).unwrap();
    for arg in [tiles.clone(), tiles.join("*")] {
        let o = run(&[os("stats"), os("--json"), arg.as_os_str()]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(0), "{err}");
        for name in ["metadata.xml", "more.xml.gz"] {
            assert!(
                err.lines().any(|l| l.starts_with("warning: ")
                    && l.contains(name)
                    && l.contains("not CityGML")),
                "{name}: {err}"
            );
        }
        let v = crate::util::json(&o);
        let files = v["files"].as_array().unwrap();
        assert_eq!(files.len(), 1, "{v}");
        assert!(files[0]["path"].as_str().unwrap().ends_with("a.gml"));
    }
    let o = run(&[os("stats"), tiles.join("metadata.xml").as_os_str()]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("not a CityGML document"), "{err}");
}

/// A full disk (a 16 KiB tmpfs; mounting needs privileges: fails under `CI=true` without
/// them, skips otherwise) for every output format of `convert` and for `rough`: exit 1, the
/// error names the output and says "no space left on device" once, nothing is left behind.
#[test]
fn a_full_disk_in_every_format_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let mnt = dir.path().join("small");
    std::fs::create_dir(&mnt).unwrap();
    let mounted = Command::new("mount")
        .args(["-t", "tmpfs", "-o", "size=16k", "tmpfs"])
        .arg(&mnt)
        .stderr(Stdio::piped())
        .output();
    match &mounted {
        Ok(o) if o.status.success() => {}
        Ok(o) => {
            crate::util::missing(&format!(
                "mount privileges for a 16 KiB tmpfs (full disk): {}",
                String::from_utf8_lossy(&o.stderr).trim()
            ));
            return;
        }
        Err(e) => {
            crate::util::missing(&format!("the mount command (full disk): {e}"));
            return;
        }
    }
    struct Unmount(std::path::PathBuf);
    impl Drop for Unmount {
        fn drop(&mut self) {
            let _ = Command::new("umount").arg(&self.0).status();
        }
    }
    let _guard = Unmount(mnt.clone());
    let input = fixture("synth-small.gml");
    for name in [
        "out.obj",
        "out.city.json",
        "out.city.jsonl",
        "out.gml.gz",
        "rough.gml",
    ] {
        let out = mnt.join(name);
        let cmd = if name == "rough.gml" {
            "rough"
        } else {
            "convert"
        };
        let o = run(&[os(cmd), input.as_os_str(), os("-o"), out.as_os_str()]);
        let err = stderr(&o);
        let code = 1;
        // A gzip output of the small fixture may fit in 16 KiB.
        if name.ends_with(".gz") && o.status.success() {
            std::fs::remove_file(&out).unwrap();
            continue;
        }
        assert_eq!(o.status.code(), Some(code), "{name}: {err}");
        assert!(
            err.contains(&format!("{}: no space left on device", out.display())),
            "{name}: {err}"
        );
        assert_eq!(
            err.matches(&out.display().to_string()).count(),
            1,
            "{name}: {err}"
        );
        assert_eq!(err.matches("o space left").count(), 1, "{name}: {err}");
        let left: Vec<_> = std::fs::read_dir(&mnt).unwrap().collect();
        assert!(left.is_empty(), "{name}: left behind: {left:?}");
    }
}
