//! `-o DIR/tileset.json`: 3D Tiles 1.1 from real files, checked by independent readers:
//! `tests/oracle/tileset_check.py` (the tileset's rules, every building in the leaves,
//! vertices on the globe against pyproj), Khronos' glTF Validator on every glb
//! (`tests/oracle/gltf_validate.cjs`), and CesiumJS in headless Chromium
//! (`tests/oracle/cesium_view.cjs`: loads, renders, picks). The npm packages come from the
//! folder `SKYLOD_NODE_MODULES` names (`.ci/run` installs them).

use crate::util::*;
use serde_json::Value;
use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The npm packages' folder (`gltf-validator`, `cesium`, `playwright-core`), when present.
fn node_modules() -> Option<PathBuf> {
    let dir = std::env::var_os("SKYLOD_NODE_MODULES").map(PathBuf::from);
    match dir.filter(|d| d.join("gltf-validator").is_dir()) {
        Some(d) => Some(d),
        None => {
            missing("npm packages gltf-validator, cesium, playwright-core (SKYLOD_NODE_MODULES)");
            None
        }
    }
}

/// Run a Node oracle of `tests/oracle/` with the npm packages; its JSON.
fn node_oracle(modules: &Path, script: &str, args: &[&OsStr]) -> Value {
    let o = Command::new("node")
        .arg(manifest_dir().join("tests/oracle").join(script))
        .args(args)
        .env("NODE_PATH", modules)
        .output()
        .expect("node");
    assert!(o.status.success(), "{script}: {}", stderr(&o));
    serde_json::from_slice(&o.stdout)
        .unwrap_or_else(|e| panic!("{script}: {e}: {}", String::from_utf8_lossy(&o.stdout)))
}

/// `tileset_check.py` of the tileset in `dir` (with `sources` in EPSG `epsg` for positions).
fn check(dir: &Path, sources: &[PathBuf], epsg: Option<u32>) -> Value {
    let mut c = Command::new("python3");
    c.arg(manifest_dir().join("tests/oracle/tileset_check.py"))
        .arg(dir);
    for s in sources {
        c.arg("--source").arg(s);
    }
    if let Some(e) = epsg {
        c.args(["--epsg", &e.to_string()]);
    }
    let o = c.output().expect("python3");
    assert!(o.status.success(), "tileset_check.py: {}", stderr(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

fn convert(inputs: &[PathBuf], out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args: Vec<&OsStr> = vec![os("convert")];
    args.extend(inputs.iter().map(|p| p.as_os_str()));
    args.extend([os("-o"), out.as_os_str()]);
    args.extend(extra.iter().map(os));
    run(&args)
}

fn strings(v: &Value, key: &str) -> Vec<String> {
    v[key]
        .as_array()
        .unwrap_or_else(|| panic!("{key}: {v}"))
        .iter()
        .map(|s| s.as_str().unwrap().to_string())
        .collect()
}

/// Every file of `../shared/data` with a CRS that the default build places on the globe, as
/// one tileset each (the Ingolstadt street as one, merged): valid by both readers, every
/// building in the leaves, vertices where pyproj puts them.
#[test]
fn shared_data_becomes_valid_tilesets() {
    let Some(data) = shared_data() else { return };
    if !python_has("numpy, pyproj", "pip install numpy pyproj") {
        return;
    }
    let modules = node_modules();
    let ingolstadt = citygml_files(&data.join("ingolstadt-lod3"));
    let one = |p: &str| vec![data.join(p)];
    let cases: Vec<(&str, Vec<PathBuf>, u32)> = vec![
        ("ingolstadt", ingolstadt, 32632),
        (
            "fzk2",
            one("kit-fzk-haus/citygml2/fzk_haus_lod3_v2.gml"),
            25832,
        ),
        (
            "fzk3",
            one("kit-fzk-haus/citygml3/FZK-Haus-LoD3-KIT-IAI-KHH-B36-V1__v3.gml"),
            25832,
        ),
        ("berlin", one("berlin/Berlin_Moabit_1Bldg_v2.gml"), 25833),
        ("rotterdam", one("rotterdam/Source.gml"), 28992),
        (
            "plateau",
            one("plateau/yokosuka/52397519_bldg_6697_op.gml"),
            6697,
        ),
    ];
    let tmp = tempfile::tempdir().unwrap();
    let mut glbs = 0;
    for (name, inputs, epsg) in &cases {
        let dir = tmp.path().join(name);
        let o = convert(inputs, &dir.join("tileset.json"), &[]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let r = check(&dir, inputs, Some(*epsg));
        assert_eq!(r["problems"], Value::Array(vec![]), "{name}");
        let err = r["position_error_m"].as_f64().unwrap();
        assert!(err < 0.01, "{name}: vertices {err} m from pyproj's");
        assert!(r["position_samples"].as_u64().unwrap() > 0, "{name}");
        // every building of the sources in the leaves (a merge's renamed id as `<id>__<k>`)
        let have = strings(&r, "buildings");
        for b in strings(&r, "source_buildings") {
            let renamed = format!("{b}__");
            assert!(
                have.iter().any(|h| *h == b || h.starts_with(&renamed)),
                "{name}: building {b} not in the leaves"
            );
        }
        eprintln!(
            "{name}: {} tiles, depth {}, {} objects in the leaves, error {:.2} m, positions within {:.1e} m",
            r["tiles"], r["depth"], r["leaf_rows"], r["max_error"].as_f64().unwrap(), err
        );
        if *name == "ingolstadt" {
            // a street: leaves below rough parents, whose error is measured, not zero
            assert!(r["depth"].as_u64().unwrap() >= 1, "{r}");
            assert!(r["max_error"].as_f64().unwrap() > 0.5, "{r}");
            let classes = strings(&r, "classes");
            for c in [
                "RoofSurface",
                "WallSurface",
                "Window",
                "BuildingInstallation",
            ] {
                assert!(classes.iter().any(|x| x == c), "{c} in {classes:?}");
            }
        }
        if let Some(m) = &modules {
            let v = node_oracle(m, "gltf_validate.cjs", &[dir.as_os_str()]);
            assert_eq!(v["errors"], 0, "{name}: {v}");
            assert_eq!(v["warnings"], 0, "{name}: {v}");
            glbs += v["files"].as_u64().unwrap();
        }
    }
    if modules.is_some() {
        assert!(glbs >= cases.len() as u64);
    }
}

/// `lod` writes its mixed model as a tileset: the leaves hold levels 2 and 1, level 0 is
/// absent, one row per object kept.
#[test]
fn lod_writes_the_mixed_model_as_a_tileset() {
    let Some(data) = shared_data() else { return };
    if !python_has("numpy, pyproj", "pip install numpy pyproj") {
        return;
    }
    let inputs = citygml_files(&data.join("ingolstadt-lod3"));
    let mut model = skylod::model::CityModel::default();
    for i in &inputs {
        model.merge(skylod::io::citygml::read_file(i).unwrap());
    }
    let pois = crate::lod::ingolstadt_pois(&model);
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("lod");
    let report = tmp.path().join("report.json");
    let mut args: Vec<&OsStr> = vec![os("lod")];
    args.extend(inputs.iter().map(|p| p.as_os_str()));
    for p in &pois {
        args.extend([os("--poi"), os(p)]);
    }
    let out = dir.join("tileset.json");
    args.extend([
        os("-o"),
        out.as_os_str(),
        os("--report"),
        report.as_os_str(),
    ]);
    let o = run(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = check(&dir, &inputs, Some(32632));
    assert_eq!(r["problems"], Value::Array(vec![]));
    assert!(r["position_error_m"].as_f64().unwrap() < 0.01);
    let rep: Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    let levels = &rep["totals"]["levels"];
    let (l1, l2) = (levels[1].as_u64().unwrap(), levels[2].as_u64().unwrap());
    let leaf = &r["leaf_levels"];
    assert_eq!(leaf["2"].as_u64(), Some(l2), "{leaf} vs {levels}");
    assert_eq!(leaf["1"].as_u64(), Some(l1), "{leaf} vs {levels}");
    assert_eq!(r["leaf_rows"].as_u64(), Some(l1 + l2));
    if let Some(m) = node_modules() {
        let v = node_oracle(&m, "gltf_validate.cjs", &[dir.as_os_str()]);
        assert_eq!(
            (v["errors"].as_u64(), v["warnings"].as_u64()),
            (Some(0), Some(0))
        );
    }
}

/// The refusals: a model without CRS names the flag that fixes it; an existing tileset is
/// kept without `--overwrite`, checked before any work; nothing staged is left behind.
#[test]
fn refusals_and_overwrite() {
    let Some(data) = shared_data() else { return };
    let tmp = tempfile::tempdir().unwrap();
    // the FZK house with its srsName taken out: a file that lost its CRS
    let fzk = vec![data.join("kit-fzk-haus/citygml2/fzk_haus_lod3_v2.gml")];
    let text = std::fs::read_to_string(&fzk[0]).unwrap();
    let stripped: String = text
        .split("srsName=\"")
        .enumerate()
        .map(|(k, part)| match k {
            0 => part,
            _ => part.split_once('"').map_or(part, |(_, rest)| rest),
        })
        .collect();
    assert!(!stripped.contains("srsName"));
    let no_crs = vec![tmp.path().join("fzk-no-crs.gml")];
    std::fs::write(&no_crs[0], stripped).unwrap();
    let dir = tmp.path().join("t");
    let out = dir.join("tileset.json");
    let o = convert(&no_crs, &out, &[]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("--source-crs"), "{}", stderr(&o));
    assert!(!out.exists());
    let o = convert(&no_crs, &out, &["--source-crs", "EPSG:25832"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let before = std::fs::read(&out).unwrap();
    let mtime = || std::fs::metadata(&out).unwrap().modified().unwrap();
    let written = mtime();
    let o = convert(&fzk, &out, &[]);
    assert_ne!(o.status.code(), Some(0));
    assert!(stderr(&o).contains("--overwrite"), "{}", stderr(&o));
    assert_eq!(mtime(), written);
    let o = convert(&fzk, &out, &["--overwrite", "--viewer"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // the CRS given is the one the file names: the same tileset
    assert_eq!(std::fs::read(&out).unwrap(), before);
    assert!(dir.join("index.html").is_file());
    let names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    let mut names = names;
    names.sort();
    assert_eq!(names, ["index.html", "tiles", "tileset.json"]);
}

/// CesiumJS in headless Chromium loads the viewer page of a real file's tileset, draws the
/// building and picks it at the screen's centre with its gml:id. The screenshot is kept in
/// `target/test-artifacts/`.
#[test]
fn cesium_loads_renders_and_picks() {
    let Some(data) = shared_data() else { return };
    let Some(modules) = node_modules() else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("fzk");
    let input = vec![data.join("kit-fzk-haus/citygml2/fzk_haus_lod3_v2.gml")];
    let o = convert(&input, &dir.join("tileset.json"), &["--viewer"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let artifacts = manifest_dir().join("target/test-artifacts");
    std::fs::create_dir_all(&artifacts).unwrap();
    let shot = artifacts.join("tiles-cesium-fzk.png");
    let v = node_oracle(
        &modules,
        "cesium_view.cjs",
        &[dir.as_os_str(), shot.as_os_str()],
    );
    assert_eq!(v["loaded"], true, "{v}");
    assert_eq!(v["error"], Value::Null, "{v}");
    assert_eq!(v["console_errors"], Value::Array(vec![]), "{v}");
    assert!(v["changed_pixels"].as_u64().unwrap() > 1000, "{v}");
    let ids = strings(&check(&dir, &[], None), "leaf_ids");
    let picked = v["picked_gml_id"].as_str().unwrap_or_default().to_string();
    assert!(ids.contains(&picked), "picked {picked:?}: {v}");
    assert!(shot.is_file());
}

/// A solar cadastre as a tileset (`irradiance --surfaces --output-attributes -o
/// DIR/tileset.json`): every surface of the table carries its mean as `irradiance`, the
/// tiles stay valid.
#[test]
fn cadastre_carries_irradiance() {
    let Some(data) = shared_data() else { return };
    if !python_has("numpy, pyproj", "pip install numpy pyproj") {
        return;
    }
    let Some(weather) = crate::irradiance::tmy3() else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let input = data.join("ingolstadt-lod3/4018106.xml.gz");
    let dir = tmp.path().join("cadastre");
    let table = tmp.path().join("surfaces.csv");
    let out = dir.join("tileset.json");
    let o = run(&[
        os("irradiance"),
        input.as_os_str(),
        os("--surfaces"),
        os("roof,wall"),
        os("--weather"),
        weather.as_os_str(),
        os("--lat"),
        os("36.1"),
        os("--lon"),
        os("-79.95"),
        os("--rays"),
        os("500"),
        os("--table"),
        table.as_os_str(),
        os("--output-attributes"),
        os("-o"),
        out.as_os_str(),
        os("--viewer"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.join("index.html").is_file());
    let r = check(&dir, &[input], Some(32632));
    assert_eq!(r["problems"], Value::Array(vec![]));
    let kwh = r["irradiance"].as_object().unwrap();
    let text = std::fs::read_to_string(&table).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let (id, mean, points) = (col("surface_id"), col("mean_kwh_m2"), col("points"));
    let mut checked = 0;
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        if f[points] == "0" || f[id].contains(':') {
            continue;
        }
        let want: f64 = f[mean].parse().unwrap();
        let got = kwh[f[id]]
            .as_f64()
            .unwrap_or_else(|| panic!("{} has none", f[id]));
        assert!(
            (got - want).abs() <= 1e-3 * want.max(1.0),
            "{}: {got} vs {want}",
            f[id]
        );
        checked += 1;
    }
    assert!(checked >= 10, "{checked} surfaces");
    if let Some(m) = node_modules() {
        let v = node_oracle(&m, "gltf_validate.cjs", &[dir.as_os_str()]);
        assert_eq!(
            (v["errors"].as_u64(), v["warnings"].as_u64()),
            (Some(0), Some(0))
        );
    }
}
