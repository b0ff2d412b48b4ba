//! Issue 21: whole-building assets (LoD1/LoD2 solids without thematic surfaces) get a rough
//! form that never fills open ground (their own polygons generalised to their planes, holes
//! kept), so that a POI in a courtyard or in the inner corner of an L keeps its sky.
//!
//! Fixtures: `fixtures/rough/` (made by `fixtures/rough/make_rough_forms.py`). Before the
//! change the body became its oriented box: SVF full 0.605 vs LoD 0.000 in the courtyard,
//! 0.413 vs 0.000 in the inner corner. Each case checks `evaluate --json` (full vs LoD SVF)
//! on the `lod` input and on the written `rough` model (every asset at its rough form, the
//! form level 1 writes), compares the full SVF with numpy's ray caster
//! (`tests/oracle/street_svf.py`), and validates the written CityGML against the XSD.

use crate::util::{fixture, json, os, run, stderr};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// (full, LoD) SVF of each POI of `evaluate --json --no-sun`.
fn evaluate(gml: &Path, pois: &Path) -> Vec<(String, f64, f64)> {
    let o = run(&[
        os("evaluate"),
        gml.as_os_str(),
        os("--pois"),
        pois.as_os_str(),
        os("--json"),
        os("--no-sun"),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v = json(&o);
    v["pois"]
        .as_array()
        .expect("pois")
        .iter()
        .map(|p: &Value| {
            (
                p["id"].as_str().unwrap_or_default().to_string(),
                p["full"]["svf"].as_f64().expect("full svf"),
                p["lod"]["svf"].as_f64().expect("lod svf"),
            )
        })
        .collect()
}

/// `skylod CMD INPUT [--pois POIS] -o DIR/NAME`, checked; the output path.
fn write(cmd: &str, input: &Path, pois: Option<&Path>, dir: &Path, name: &str) -> PathBuf {
    let out = dir.join(name);
    let mut args = vec![os(cmd), input.as_os_str()];
    if let Some(p) = pois {
        args.extend([os("--pois"), p.as_os_str()]);
    }
    args.extend([os("-o"), out.as_os_str()]);
    let o = run(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // Before issue 21 the courtyard POI was blamed: "lies inside a closed solid".
    assert!(
        !stderr(&o).contains("inside a closed solid"),
        "{}",
        stderr(&o)
    );
    out
}

fn xsd_valid(paths: &[PathBuf]) {
    if !crate::util::have_xmllint() {
        return;
    }
    for (p, r) in paths
        .iter()
        .zip(crate::util::xmllint_validate_many(paths, "2.0"))
    {
        assert!(r.is_ok(), "{} not XSD-valid: {r:?}", p.display());
    }
}

/// The numpy oracle's full-model SVF (`tests/oracle/street_svf.py`, 48 x 48 cosine-weighted
/// rays, normal up) at one POI, or `None` (skip) without python3 + numpy.
fn oracle_svf(input: &Path, p: [f64; 3], dir: &Path) -> Option<f64> {
    if !crate::util::python_has("numpy", "pip install numpy") {
        return None;
    }
    let csv = dir.join("oracle.csv");
    let text = format!("id,x,y,z,nx,ny,nz\np,{},{},{},0,0,1\n", p[0], p[1], p[2]);
    std::fs::write(&csv, text).unwrap();
    let script = crate::util::manifest_dir().join("tests/oracle/street_svf.py");
    let o = std::process::Command::new("python3")
        .arg(&script)
        .args(["48", "11"])
        .arg(&csv)
        .arg(input)
        .arg("--")
        .arg(input)
        .output()
        .expect("python3");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    out.split_whitespace().nth(1).and_then(|v| v.parse().ok())
}

/// Full vs LoD SVF through `lod` and through the rough model, within `tol`; the full SVF.
fn check_case(input: &Path, pois: &Path, poi: [f64; 3], tol: f64) -> f64 {
    let dir = tempfile::tempdir().unwrap();
    let lod = write("lod", input, Some(pois), dir.path(), "lod.gml");
    let rough = write("rough", input, None, dir.path(), "rough.gml");
    xsd_valid(&[lod.clone(), rough.clone()]);
    let full = evaluate(input, pois);
    assert_eq!(full.len(), 1);
    let (id, svf_full, svf_lod) = full[0].clone();
    assert!(
        (svf_full - svf_lod).abs() <= tol,
        "{id}: full {svf_full} vs LoD {svf_lod}"
    );
    // The rough model alone (the body at its rough form) sees the same sky.
    let r = evaluate(&rough, pois);
    assert!(
        (svf_full - r[0].1).abs() <= tol,
        "{id}: full {svf_full} vs rough model {}",
        r[0].1
    );
    if let Some(o) = oracle_svf(input, poi, dir.path()) {
        assert!(
            (o - svf_full).abs() < 0.01,
            "{id}: full {svf_full} vs oracle {o}"
        );
    }
    svf_full
}

/// Cosine-weighted SVF at the centre of the floor of a square well (half width `a`, depth
/// `h` above the point): four corner-rectangle view factors (parallel planes).
fn square_well_svf(a: f64, h: f64) -> f64 {
    let x = a / h;
    let s = (1.0 + x * x).sqrt();
    4.0 * (2.0 * x / s * (x / s).atan()) / (2.0 * std::f64::consts::PI)
}

#[test]
fn courtyard_keeps_its_sky() {
    let svf = check_case(
        &fixture("rough/courtyard-lod1.gml"),
        &fixture("rough/courtyard-lod1.pois.csv"),
        [690_030.0, 5_336_030.0, 101.5],
        0.01,
    );
    // 30 x 30 m courtyard, walls 13.5 m above the POI: 0.6048.
    let analytic = square_well_svf(15.0, 13.5);
    assert!((analytic - 0.6048).abs() < 1e-3, "{analytic}");
    assert!(
        (svf - analytic).abs() < 0.01,
        "full {svf} vs analytic {analytic}"
    );
}

#[test]
fn inner_corner_of_an_l_keeps_its_sky() {
    let svf = check_case(
        &fixture("rough/l-shape-lod1.gml"),
        &fixture("rough/l-shape-lod1.pois.csv"),
        [690_015.0, 5_336_015.0, 101.5],
        0.01,
    );
    assert!(svf > 0.3 && svf < 0.5, "{svf}");
}

/// A LoD2 building without thematic surfaces (`lod2Solid` only) from the shared data, a POI
/// 5 m from its wall: LoD and rough SVF within 1 % of the full one.
#[test]
fn lod2_body_without_thematic_surfaces() {
    let Some(data) = crate::util::shared_data() else {
        return;
    };
    let input = data.join("libcitygml/b1_lod2_s.gml");
    let dir = tempfile::tempdir().unwrap();
    let pois = dir.path().join("pois.csv");
    std::fs::write(&pois, "id,x,y,z\nnear_house,-5,50,1.5\n").unwrap();
    let svf = check_case(&input, &pois, [-5.0, 50.0, 1.5], 0.01 * 0.54);
    assert!(svf > 0.4 && svf < 0.7, "{svf}");
}
