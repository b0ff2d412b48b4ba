//! `skylod reproject` in a build without the feature `proj`: a usage error naming the feature.

use crate::util::*;
use std::ffi::OsStr;

#[test]
fn without_the_feature_reproject_is_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.gml");
    let input = fixture("synth-small.gml");
    let o = run(&[
        OsStr::new("reproject"),
        input.as_os_str(),
        OsStr::new("-t"),
        OsStr::new("EPSG:4326"),
        OsStr::new("-o"),
        out.as_os_str(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--features proj"), "{err}");
    assert!(!out.exists());
}
