//! OBJ output proven with a real daylight tool: Radiance (`pyradiance`'s obj2rad, oconv,
//! rtrace) computes the SVF of skylod's OBJ under a uniform sky (tests/oracle/radiance_svf.py,
//! settings and their noise there), and it must match skylod's own full-model SVF
//! (`skylod svf`) within 1 % at every POI: for the LoD model's OBJ (`skylod lod -o x.obj`, the
//! claim of the export) and for the full model's OBJ (`skylod convert -o x.obj`, the exporter
//! alone), on the synthetic district (small and paper presets) and on real Ingolstadt LoD3
//! facades (all 53 tiles as one scene). Plus the file conventions of DESIGN.md, checked line by line.

use crate::util::*;
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Relative tolerance between Radiance and skylod.
const TOL: f64 = 0.01;

fn skylod(args: &[OsString]) -> String {
    let a: Vec<&std::ffi::OsStr> = args.iter().map(|s| s.as_os_str()).collect();
    let o = run(&a);
    assert!(
        o.status.success(),
        "skylod {:?}: {}",
        args,
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn os(v: &[&dyn AsRef<std::ffi::OsStr>]) -> Vec<OsString> {
    v.iter().map(|s| s.as_ref().to_os_string()).collect()
}

/// skylod's full-model SVF per POI id (100,000 rays).
fn skylod_svf(inputs: &[PathBuf], pois: &Path) -> BTreeMap<String, f64> {
    let mut args = os(&[&"svf"]);
    args.extend(inputs.iter().map(|p| p.clone().into_os_string()));
    args.extend(os(&[&"--pois", &pois, &"--rays", &"100000", &"--json"]));
    let v: Value = serde_json::from_str(&skylod(&args)).expect("svf JSON");
    v["pois"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            (
                p["id"].as_str().unwrap().to_string(),
                p["svf"].as_f64().unwrap(),
            )
        })
        .collect()
}

/// Radiance's SVF per POI id for a scene of OBJ files.
fn radiance_svf(objs: &[PathBuf], pois: &Path) -> BTreeMap<String, f64> {
    let out = Command::new("python3")
        .arg(manifest_dir().join("tests/oracle/radiance_svf.py"))
        .arg(pois)
        .args(objs)
        .output()
        .expect("cannot run python3");
    assert!(
        out.status.success(),
        "radiance_svf.py: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: BTreeMap<String, f64> = serde_json::from_slice(&out.stdout).expect("radiance JSON");
    v
}

/// Compare per POI; prints the table (BENCHMARKS.md figures come from here).
fn compare(what: &str, radiance: &BTreeMap<String, f64>, skylod: &BTreeMap<String, f64>) {
    assert!(!skylod.is_empty());
    assert_eq!(
        radiance.keys().collect::<Vec<_>>(),
        skylod.keys().collect::<Vec<_>>(),
        "{what}: POIs differ"
    );
    let mut bad = Vec::new();
    eprintln!("{what}: poi, Radiance SVF, skylod full-model SVF, relative difference");
    for (id, s) in skylod {
        let r = radiance[id];
        let rel = (r - s).abs() / s;
        eprintln!("  {id:<12} {r:.4} {s:.4} {:+.2}%", 100.0 * (r - s) / s);
        // Both must see some obstruction or sky: a 0 would make the relative check void.
        assert!(
            *s > 0.05,
            "{what}: {id}: skylod SVF {s} too small to compare"
        );
        if rel > TOL {
            bad.push(format!("{id}: Radiance {r:.4}, skylod {s:.4}"));
        }
    }
    assert!(bad.is_empty(), "{what}: over 1 %:\n{}", bad.join("\n"));
}

fn objs_in(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "obj"))
        .collect();
    v.sort();
    v
}

#[test]
fn synth_small_lod_and_full() {
    if !python_has("pyradiance", "pip install pyradiance") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let gml = fixture("synth-small.gml");
    let pois = fixture("synth-small.pois.csv");
    let lod = dir.path().join("lod.obj");
    skylod(&os(&[&"lod", &gml, &"--pois", &pois, &"-o", &lod]));
    let full = dir.path().join("full.obj");
    skylod(&os(&[&"convert", &gml, &"-o", &full]));
    let sky = skylod_svf(std::slice::from_ref(&gml), &pois);
    compare("synth-small LoD OBJ", &radiance_svf(&[lod], &pois), &sky);
    compare("synth-small full OBJ", &radiance_svf(&[full], &pois), &sky);
}

/// The paper-sized district (~300K polygons, street-canyon POIs): the LoD OBJ (0.5 % of the
/// polygons) against the full model.
#[test]
fn synth_paper_lod() {
    if !python_has("pyradiance", "pip install pyradiance") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let gml = dir.path().join("paper.gml");
    skylod(&os(&[&"synth", &"--preset", &"paper", &"-o", &gml]));
    let pois = dir.path().join("paper.pois.csv");
    let lod = dir.path().join("paper-lod.obj");
    skylod(&os(&[&"lod", &gml, &"--pois", &pois, &"-o", &lod]));
    let sky = skylod_svf(std::slice::from_ref(&gml), &pois);
    compare("paper LoD OBJ", &radiance_svf(&[lod], &pois), &sky);
}

/// Real LoD3 facades in Ingolstadt, all 53 tiles as one scene: `lod` writes one OBJ per tile
/// (`-o DIR --format obj`), each with its own origin; Radiance assembles them by their origins.
#[test]
fn ingolstadt_facades() {
    if !python_has("pyradiance", "pip install pyradiance") {
        return;
    }
    let Some(data) = shared_data() else { return };
    let tiles = citygml_files(&data.join("ingolstadt-lod3"));
    assert!(tiles.len() >= 50, "Ingolstadt tiles missing");
    let dir = tempfile::tempdir().unwrap();
    // The README's point, and points on large walls of five buildings with their outward
    // normals (Newell normal of the wall polygon).
    let pois = dir.path().join("ingolstadt.pois.csv");
    std::fs::write(
        &pois,
        "id,x,y,z,nx,ny,nz\n\
         readme,678095,5403890,418,0,-1,0\n\
         w4018257,678184.488,5403910.026,421.429,0.3969,-0.9178,0\n\
         w4018156,678146.706,5403898.825,421.289,0.2584,-0.9660,0\n\
         w4018149b,678086.159,5403875.438,421.434,0.9321,0.3623,0\n\
         w4018142,678150.193,5403776.433,419.363,-0.8357,-0.5492,0\n\
         w4018215,678111.129,5403764.510,420.585,-0.8520,-0.5236,0\n",
    )
    .unwrap();
    let lod_dir = dir.path().join("lod");
    let mut args = os(&[&"lod"]);
    args.extend(tiles.iter().map(|p| p.clone().into_os_string()));
    args.extend(os(&[
        &"--pois",
        &pois,
        &"-o",
        &lod_dir,
        &"--format",
        &"obj",
    ]));
    skylod(&args);
    let objs = objs_in(&lod_dir);
    assert_eq!(objs.len(), tiles.len(), "one OBJ per tile");
    let sky = skylod_svf(&tiles, &pois);
    compare("Ingolstadt LoD OBJ", &radiance_svf(&objs, &pois), &sky);
    // The whole street in one OBJ (`-o street.obj`): one origin for all tiles (issue 22).
    let street = dir.path().join("street.obj");
    let mut args = os(&[&"lod"]);
    args.extend(tiles.iter().map(|p| p.clone().into_os_string()));
    args.extend(os(&[&"--pois", &pois, &"-o", &street]));
    skylod(&args);
    compare(
        "Ingolstadt LoD OBJ, one file",
        &radiance_svf(std::slice::from_ref(&street), &pois),
        &sky,
    );
    // The exporter alone: every tile at full detail (holes, xlinks, real LoD3 geometry).
    let full_dir = dir.path().join("full");
    std::fs::create_dir(&full_dir).unwrap();
    for t in &tiles {
        let name =
            skylod::export::Format::Obj.output_name(&t.file_name().unwrap().to_string_lossy());
        skylod(&os(&[&"convert", t, &"-o", &full_dir.join(name)]));
    }
    compare(
        "Ingolstadt full OBJ",
        &radiance_svf(&objs_in(&full_dir), &pois),
        &sky,
    );
}

/// DESIGN.md's OBJ conventions on the full model's OBJ: origin line first, one `o` per asset
/// named by its gml:id, `usemtl <kind>_l2`, triangles only, vertices that give back the
/// model's box with the origin added; on the LoD OBJ, levels 1 and 2 only and as many
/// triangles as the traced LoD scene holds.
#[test]
fn obj_conventions() {
    let dir = tempfile::tempdir().unwrap();
    let gml = fixture("synth-small.gml");
    let pois = fixture("synth-small.pois.csv");
    let full = dir.path().join("full.obj");
    skylod(&os(&[&"convert", &gml, &"-o", &full]));
    let model = skylod::io::citygml::read_file(&gml).unwrap();

    let parse = |path: &Path| {
        let text = std::fs::read_to_string(path).unwrap();
        let mut lines = text.lines();
        let first: Vec<&str> = lines.next().unwrap().split(' ').collect();
        assert_eq!(&first[..2], ["#", "origin"], "first line");
        let origin: Vec<f64> = first[2..].iter().map(|v| v.parse().unwrap()).collect();
        let (mut names, mut mtls, mut faces) = (Vec::new(), BTreeSet::new(), 0usize);
        let mut bbox = skylod::model::Bbox::EMPTY;
        let mut nv = 0usize;
        for l in lines {
            let f: Vec<&str> = l.split(' ').collect();
            match f[0] {
                "o" => names.push(f[1].to_string()),
                "usemtl" => {
                    mtls.insert(f[1].to_string());
                }
                "v" => {
                    nv += 1;
                    let v: Vec<f64> = f[1..].iter().map(|x| x.parse().unwrap()).collect();
                    assert_eq!(v.len(), 3);
                    bbox.add(glam::DVec3::new(
                        v[0] + origin[0],
                        v[1] + origin[1],
                        v[2] + origin[2],
                    ));
                }
                "f" => {
                    assert_eq!(f.len(), 4, "not a triangle: {l}");
                    for k in &f[1..] {
                        let k: usize = k.parse().unwrap();
                        assert!(k >= 1 && k <= nv, "face index {k} of {nv} vertices");
                    }
                    faces += 1;
                }
                "#" => {}
                other => panic!("unexpected OBJ statement {other:?}"),
            }
        }
        (names, mtls, faces, bbox)
    };

    let (names, mtls, _, bbox) = parse(&full);
    let ids: Vec<String> = model
        .assets
        .iter()
        .map(|a| a.id.clone().unwrap().to_string())
        .collect();
    assert_eq!(names, ids, "one `o` per asset, named by its gml:id");
    let kinds: BTreeSet<String> = model
        .assets
        .iter()
        .map(|a| format!("{}_l2", a.kind))
        .collect();
    assert_eq!(mtls, kinds);
    let want = model.bbox();
    assert!(
        (bbox.min - want.min).abs().max_element() < 1e-4
            && (bbox.max - want.max).abs().max_element() < 1e-4,
        "{bbox:?} vs {want:?}"
    );

    // LoD OBJ: the traced LoD scene, triangle for triangle.
    let lod = dir.path().join("lod.obj");
    skylod(&os(&[&"lod", &gml, &"--pois", &pois, &"-o", &lod]));
    let (names, mtls, faces, _) = parse(&lod);
    let p: Vec<_> = skylod::lod::poi::read_pois_csv(&pois)
        .unwrap()
        .into_iter()
        .map(|l| l.poi)
        .collect();
    let r = skylod::lod::lod(&model, &p, &Default::default(), &skylod::Silent).unwrap();
    let scene = skylod::lod::mixed_scene(&model, &r.rough, &r.selection.levels);
    assert_eq!(faces, scene.len());
    let kept = r.selection.levels.iter().filter(|l| **l > 0).count();
    assert_eq!(names.len(), kept);
    assert!(mtls
        .iter()
        .all(|m| m.ends_with("_l1") || m.ends_with("_l2")));
}
