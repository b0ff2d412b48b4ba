//! Batch work linear in the number of input files: every writing command run on 200 and on
//! 2,000 copies of a small real LoD2 tile (Berlin Moabit, 19 KB) does, per file, at most 1.5
//! times the work at 2,000 that it does at 200. The work is counted, not timed: the system
//! calls of the whole run and its path resolutions (`readlink`), as `strace -f -c` counts
//! them (an independent counter, installed by CI); the timings are printed. Every run holds
//! at most 256 descriptors (`ulimit -n 256`): no descriptor is held per input.

use crate::util::*;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// The tile, copied `n` times into `dir/tiles-n` (the same ids in each copy: merges rename).
fn tiles(dir: &Path, n: usize) -> Option<PathBuf> {
    let tile = shared_data()?.join("berlin/Berlin_Moabit_1Bldg_v2.gml");
    let bytes = std::fs::read(&tile).unwrap();
    let out = dir.join(format!("tiles-{n}"));
    std::fs::create_dir_all(&out).unwrap();
    for k in 0..n {
        std::fs::write(out.join(format!("t{k:05}.gml")), &bytes).unwrap();
    }
    Some(out)
}

/// The writing commands, each with its output below `out` (`TILES` stands for the folder).
fn commands(out: &Path) -> Vec<(&'static str, Vec<String>)> {
    let o = |name: &str| out.join(name).to_string_lossy().into_owned();
    let bbox = "388600,5818700,388800,5818900";
    let poi = "388678,5818805,40";
    let v = |args: &[&str]| args.iter().map(|a| a.to_string()).collect::<Vec<_>>();
    vec![
        (
            "convert -o DIR",
            v(&["convert", "TILES", "-o", &o("convert/")]),
        ),
        (
            "convert --shard",
            v(&["convert", "TILES", "--shard", "0/2", "-o", &o("shard/")]),
        ),
        (
            "subset -o DIR",
            v(&["subset", "TILES", "--bbox", bbox, "-o", &o("subset/")]),
        ),
        (
            "filter-lods -o DIR",
            v(&["filter-lods", "TILES", "--lod", "2", "-o", &o("lods/")]),
        ),
        (
            "upgrade -o DIR",
            v(&["upgrade", "TILES", "-o", &o("upgrade/")]),
        ),
        ("rough -o DIR", v(&["rough", "TILES", "-o", &o("rough/")])),
        (
            "lod -o DIR",
            v(&["lod", "TILES", "--poi", poi, "-o", &o("lod/")]),
        ),
        (
            "convert -o x.gml",
            v(&["convert", "TILES", "-o", &o("all.gml")]),
        ),
        (
            "convert -o x.city.json",
            v(&["convert", "TILES", "-o", &o("all.city.json")]),
        ),
        (
            "convert -o x.city.jsonl",
            v(&["convert", "TILES", "-o", &o("all.city.jsonl")]),
        ),
        (
            "convert -o x.obj",
            v(&["convert", "TILES", "-o", &o("all.obj")]),
        ),
        (
            "subset -o x.gml",
            v(&["subset", "TILES", "--bbox", bbox, "-o", &o("subset.gml")]),
        ),
    ]
}

/// The counts of one run: (system calls, `readlink` calls) as `strace -c` sums them, and
/// the run's time.
#[derive(Debug, Clone, Copy)]
struct Work {
    calls: u64,
    readlinks: u64,
    seconds: f64,
}

/// `skylod args` (with `TILES` replaced) under `ulimit -n 256`, counted by strace.
fn run(args: &[String], tiles: &Path, work: &Path) -> Work {
    let counts = work.join("strace.txt");
    let args: Vec<String> = args
        .iter()
        .map(|a| a.replace("TILES", &tiles.to_string_lossy()))
        .collect();
    let t = Instant::now();
    let o = Command::new("sh")
        .arg("-c")
        .arg("ulimit -n 256 && exec strace -f -c -o \"$0\" \"$@\"")
        .arg(&counts)
        .arg(BIN)
        .args(&args)
        .current_dir(work)
        .output()
        .unwrap();
    let seconds = t.elapsed().as_secs_f64();
    assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
    let text = std::fs::read_to_string(&counts).unwrap();
    // `% time  seconds  usecs/call  calls  [errors]  syscall`
    let calls_of = |name: &str| {
        (text.lines())
            .find(|l| l.split_whitespace().last() == Some(name))
            .and_then(|l| l.split_whitespace().nth(3)?.parse().ok())
            .unwrap_or(0)
    };
    Work {
        calls: calls_of("total"),
        readlinks: calls_of("readlink"),
        seconds,
    }
}

fn strace_present() -> bool {
    let found = Command::new("strace")
        .arg("-V")
        .output()
        .is_ok_and(|o| o.status.success());
    if !found {
        missing("strace");
    }
    found
}

#[test]
fn writing_commands_do_the_same_work_per_file_at_any_number_of_tiles() {
    if !strace_present() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (small, large) = (200, 2000);
    let (Some(a), Some(b)) = (tiles(dir.path(), small), tiles(dir.path(), large)) else {
        return;
    };
    let mut bad = Vec::new();
    let (at_small, at_large) = (
        commands(&dir.path().join("out-small")),
        commands(&dir.path().join("out-large")),
    );
    for (k, ((name, small_args), (_, large_args))) in at_small.iter().zip(&at_large).enumerate() {
        let work = |n: usize| {
            let w = dir.path().join(format!("work-{k}-{n}"));
            std::fs::create_dir_all(&w).unwrap();
            w
        };
        let s = run(small_args, &a, &work(small));
        let l = run(large_args, &b, &work(large));
        let per = |x: u64, n: usize| x as f64 / n as f64;
        let (cs, cl) = (per(s.calls, small), per(l.calls, large));
        let (rs, rl) = (per(s.readlinks, small), per(l.readlinks, large));
        eprintln!(
            "{name:24} calls/file {cs:7.1} -> {cl:7.1}, readlink/file {rs:5.1} -> {rl:5.1}, \
             ms/file (under strace) {:.2} -> {:.2}",
            1e3 * s.seconds / small as f64,
            1e3 * l.seconds / large as f64
        );
        if cl > 1.5 * cs || rl > 1.5 * rs.max(1.0) {
            bad.push(format!(
                "{name}: calls/file {cs:.1} -> {cl:.1}, readlink/file {rs:.1} -> {rl:.1}"
            ));
        }
    }
    assert!(
        bad.is_empty(),
        "work per file grows with the number of tiles: {bad:#?}"
    );
}
