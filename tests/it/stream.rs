//! Issue 22: reading a large file reports its bytes as it goes
//! ([`skylod::citygml::read_file_observed`]), with the same model as the plain read.
//!
//! The file (~70 MB) is made by the shared generator (`../shared/tools/bench_inputs.py`: the
//! Ingolstadt street repeated) in a temporary directory.

use crate::util;
use skylod::citygml::read::{read_file_with, ReadOptions};
use skylod::citygml::read_file_observed;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

/// Read `path` observed with `opts` on `threads` threads: the model must equal the plain
/// read's, the bytes must move more than once and add up to at most the file's size.
fn observed_matches(path: &Path, opts: &ReadOptions, threads: usize) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let len = std::fs::metadata(path).unwrap().len();
    let (calls, total) = (AtomicU64::new(0), AtomicU64::new(0));
    let (plain, seen) = pool.install(|| {
        let plain = read_file_with(path, opts).unwrap();
        let seen = read_file_observed(path, opts, &|n| {
            assert!(n > 0, "a report of 0 bytes");
            calls.fetch_add(1, Ordering::Relaxed);
            total.fetch_add(n, Ordering::Relaxed);
        })
        .unwrap();
        (plain, seen)
    });
    assert!(
        plain == seen,
        "the observed read differs from the plain read"
    );
    let (calls, total) = (calls.into_inner(), total.into_inner());
    assert!(
        calls >= 2,
        "bytes reported {calls} times while reading {len} bytes"
    );
    assert!(
        total > len / 2 && total <= len,
        "{total} bytes reported of {len}"
    );
}

#[test]
fn bytes_move_while_one_large_file_is_read() {
    let Some(data) = util::shared_data() else {
        return;
    };
    let tool = util::manifest_dir().join("../shared/tools/bench_inputs.py");
    if !tool.is_file() {
        util::missing(&format!("the generator {}", tool.display()));
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let big = dir.path().join("big.gml");
    let out = std::process::Command::new("python3")
        .arg(&tool)
        .arg(&data)
        .arg(&big)
        .arg("70")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", util::stderr(&out));
    // one core: a report every 32 MiB
    let serial = ReadOptions {
        split_min_bytes: u64::MAX,
        ..ReadOptions::default()
    };
    observed_matches(&big, &serial, 1);
    // two parts on two cores, each reporting its own way through
    let split = ReadOptions {
        split_min_bytes: 0,
        split_parts: 2,
        ..ReadOptions::default()
    };
    observed_matches(&big, &split, 2);
}
