//! Several CityJSON / CityJSONSeq inputs merged into one file by `subset`, `filter-lods` and
//! `upgrade` (issue 24; `skylod::export::merge_cityjson`):
//!
//! * the merge of each command's outputs holds the union of the outputs it writes for each
//!   input alone: every city object with the same attributes and geometry, its vertices at the
//!   same real coordinates (within 1e-6 m: the inputs' scales agree), its materials, textures,
//!   texture coordinates and template resolved to the same values (indices offset), into a
//!   `.city.json` and a `.city.jsonl`; cjval finds the document valid, cjio reads the same
//!   city objects by type as in the separate outputs together;
//! * inputs: real CityJSON (cjio's test files: templates, materials, textures) and, with the
//!   shared data, our own CityJSON / CityJSONSeq of several Ingolstadt LoD3 files;
//! * colliding ids (one file twice): the second copy's objects renamed `<id>__2`, their
//!   `parents` / `children` following;
//! * inputs in different CRSs, CityJSON with CityGML, CityJSON into a `.gml`: refused, nothing
//!   written.

use crate::cityjson_edit::{cjio_edit, cjval, have, load};
use crate::util::*;
use serde_json::{json, Map, Value};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn ok(args: &[&std::ffi::OsStr]) -> String {
    let o = run(args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    stderr(&o)
}

/// The header and features of a CityJSON (one) or CityJSONSeq (several) file.
fn values(p: &Path) -> Vec<Value> {
    let text = std::fs::read_to_string(p).unwrap();
    serde_json::Deserializer::from_str(&text)
        .into_iter::<Value>()
        .map(Result::unwrap)
        .collect()
}

/// Every city object of a CityJSON / CityJSONSeq file, its geometry resolved: vertex indices
/// replaced by real coordinates, material and texture indices by what they name, a
/// template index by the template (its vertices resolved).
fn resolved(p: &Path) -> BTreeMap<String, Value> {
    let vs = values(p);
    let head = &vs[0];
    let t = &head["transform"];
    let f = |a: &Value, k: usize| a[k].as_f64().unwrap();
    let real = |v: &Value| {
        json!([
            f(v, 0) * f(&t["scale"], 0) + f(&t["translate"], 0),
            f(v, 1) * f(&t["scale"], 1) + f(&t["translate"], 1),
            f(v, 2) * f(&t["scale"], 2) + f(&t["translate"], 2)
        ])
    };
    let gt = &head["geometry-templates"];
    let mut out = BTreeMap::new();
    let parts: Vec<&Value> = if vs.len() == 1 {
        vec![head]
    } else {
        vs[1..].iter().collect()
    };
    for part in parts {
        let verts = part["vertices"].as_array().unwrap();
        let app = if part.get("appearance").is_some() {
            &part["appearance"]
        } else {
            &head["appearance"]
        };
        for (id, o) in part["CityObjects"].as_object().unwrap() {
            let mut o = o.clone();
            for g in o["geometry"].as_array_mut().into_iter().flatten() {
                if g["type"] == "GeometryInstance" {
                    let i = g["template"].as_u64().unwrap() as usize;
                    let mut tpl = gt["templates"][i].clone();
                    map(&mut tpl["boundaries"], &|k| {
                        gt["vertices-templates"][k as usize].clone()
                    });
                    g["template"] = tpl;
                }
                map(&mut g["boundaries"], &|k| real(&verts[k as usize]));
                if let Some(Value::Object(themes)) = g.get_mut("material") {
                    for th in themes.values_mut() {
                        for key in ["values", "value"] {
                            if let Some(v) = th.get_mut(key) {
                                map(v, &|k| app["materials"][k as usize].clone());
                            }
                        }
                    }
                }
                if let Some(Value::Object(themes)) = g.get_mut("texture") {
                    for th in themes.values_mut() {
                        texture(&mut th["values"], app);
                    }
                }
            }
            out.insert(id.clone(), o);
        }
    }
    out
}

fn map(v: &mut Value, f: &dyn Fn(u64) -> Value) {
    match v {
        Value::Array(a) => a.iter_mut().for_each(|x| map(x, f)),
        Value::Number(n) => *v = f(n.as_u64().unwrap()),
        _ => {}
    }
}

fn texture(v: &mut Value, app: &Value) {
    let Value::Array(a) = v else { return };
    if a.iter().any(Value::is_array) {
        a.iter_mut().for_each(|x| texture(x, app));
        return;
    }
    for (i, x) in a.iter_mut().enumerate() {
        if let Some(k) = x.as_u64() {
            *x = match i {
                0 => app["textures"][k as usize].clone(),
                _ => app["vertices-texture"][k as usize].clone(),
            };
        }
    }
}

/// JSON values equal, numbers within `tol`.
fn close(a: &Value, b: &Value, tol: f64) -> bool {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            (x.as_f64().unwrap() - y.as_f64().unwrap()).abs() <= tol
        }
        (Value::Array(x), Value::Array(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(p, q)| close(p, q, tol))
        }
        (Value::Object(x), Value::Object(y)) => {
            x.len() == y.len()
                && x.iter()
                    .all(|(k, v)| y.get(k).is_some_and(|w| close(v, w, tol)))
        }
        _ => a == b,
    }
}

/// Object `o` of input `k` (1-based) as the merge names its references (`renames`).
fn renamed(o: &Value, renames: &Map<String, Value>) -> Value {
    let mut o = o.clone();
    for key in ["parents", "children"] {
        if let Some(Value::Array(a)) = o.get_mut(key) {
            for r in a {
                if let Some(n) = renames.get(r.as_str().unwrap()) {
                    *r = n.clone();
                }
            }
        }
    }
    o
}

/// The merge `merged` holds the union of `separate` (in input order): the same objects, each
/// resolved to the same values; an id an earlier output used is named `<id>__<k>`.
pub(crate) fn check_union(merged: &Path, separate: &[PathBuf], what: &str) {
    let m = resolved(merged);
    let mut want = BTreeMap::new();
    for (k, s) in separate.iter().enumerate() {
        let r = resolved(s);
        let renames: Map<String, Value> = r
            .keys()
            .filter(|id| k > 0 && want.contains_key(*id))
            .map(|id| (id.clone(), Value::String(format!("{id}__{}", k + 1))))
            .collect();
        for (id, o) in &r {
            let name = renames
                .get(id)
                .map_or(id.clone(), |n| n.as_str().unwrap().to_string());
            assert!(
                want.insert(name, renamed(o, &renames)).is_none(),
                "{what}: {id}"
            );
        }
    }
    assert!(!want.is_empty(), "{what}: nothing to merge");
    assert_eq!(
        m.keys().collect::<Vec<_>>(),
        want.keys().collect::<Vec<_>>(),
        "{what}: the merged city objects"
    );
    // coordinates within the merged transform's rounding: half its step (exact where the
    // inputs' translates differ by whole steps)
    let vs = values(merged);
    let scale = vs[0]["transform"]["scale"].as_array().unwrap();
    let tol = scale
        .iter()
        .map(|s| s.as_f64().unwrap())
        .fold(0.0, f64::max)
        / 2.0
        + 1e-9;
    for (id, o) in &want {
        assert!(close(&m[id], o, tol), "{what}: {id}\n{}\n{}", m[id], o);
    }
    // one header; the extent that of the merged vertices
    assert_eq!(vs[0]["type"], "CityJSON", "{what}");
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for o in m.values() {
        for g in o["geometry"].as_array().into_iter().flatten() {
            let mut each = |v: &Value| {
                for k in 0..3 {
                    let c = v[k].as_f64().unwrap();
                    lo[k] = lo[k].min(c);
                    hi[k] = hi[k].max(c);
                }
            };
            walk_points(&g["boundaries"], &mut each);
        }
    }
    let e = &vs[0]["metadata"]["geographicalExtent"];
    for k in 0..3 {
        assert!(
            (e[k].as_f64().unwrap() - lo[k]).abs() < 1e-6,
            "{what}: {e} {lo:?}"
        );
        assert!(
            (e[k + 3].as_f64().unwrap() - hi[k]).abs() < 1e-6,
            "{what}: {e} {hi:?}"
        );
    }
}

/// Every point (array of three numbers) of resolved boundaries.
fn walk_points(v: &Value, f: &mut dyn FnMut(&Value)) {
    if let Value::Array(a) = v {
        if a.len() == 3 && a.iter().all(Value::is_number) {
            f(v);
        } else {
            a.iter().for_each(|x| walk_points(x, f));
        }
    }
}

/// cjio's city objects by type.
fn cjio_types(p: &Path) -> BTreeMap<String, u64> {
    let i = cjio_edit(&["info", p.to_str().unwrap()]);
    i["objects"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(k, v)| (k.clone(), v.as_u64().unwrap()))
        .collect()
}

/// Each edit on each input alone (`-o DIR/`) and on all into one `.city.json` and one
/// `.city.jsonl`: the merges are the union; the document cjval-valid, cjio's counts summed.
fn check_edits(inputs: &[PathBuf], dir: &Path, what: &str) {
    std::fs::create_dir_all(dir).unwrap();
    let cj = have("cjio", "cjio (pip install cjio)");
    let first = load(&inputs[0]);
    let (sc, tr) = (
        &first["transform"]["scale"],
        &first["transform"]["translate"],
    );
    // a box over the first input's lower half in x: some objects in, some out
    let xs: Vec<f64> = first["vertices"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v[0].as_f64().unwrap() * sc[0].as_f64().unwrap() + tr[0].as_f64().unwrap())
        .collect();
    let (x0, x1) = xs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    let bbox = format!("--bbox={},-1e9,{},1e9", x0 - 1.0, (x0 + x1) / 2.0);
    let edits: [(&str, Vec<&str>); 3] = [
        ("subset", vec![bbox.as_str()]),
        ("filter-lods", vec!["--lod", "2", "--mode", "remove"]),
        ("upgrade", vec![]),
    ];
    for (n, (cmd, extra)) in edits.iter().enumerate() {
        let sep: Vec<PathBuf> = inputs
            .iter()
            .enumerate()
            .map(|(k, i)| {
                let o = dir.join(format!("{n}-{k}.city.json"));
                let mut a = vec![os(*cmd), os(i)];
                a.extend(extra.iter().map(os));
                a.extend([os("-o"), os(&o)]);
                ok(&a);
                o
            })
            .collect();
        for end in ["city.json", "city.jsonl"] {
            let m = dir.join(format!("{n}-merged.{end}"));
            let mut a = vec![os(*cmd)];
            a.extend(inputs.iter().map(os));
            a.extend(extra.iter().map(os));
            a.extend([os("-o"), os(&m)]);
            let e = ok(&a);
            assert!(
                e.contains(&format!("merged {} file(s)", inputs.len())),
                "{e}"
            );
            let w = format!("{what} {cmd} -> {end}");
            check_union(&m, &sep, &w);
            if end == "city.json" {
                if let Some(v) = cjval(&m) {
                    assert!(v, "{w}: cjval says invalid");
                }
                if cj {
                    // (the separate outputs of a CityJSONSeq input are CityJSONSeq, which
                    // cjio's reader does not take: counted from their JSON)
                    let mut sum: BTreeMap<String, u64> = BTreeMap::new();
                    for o in sep.iter().flat_map(|s| resolved(s).into_values()) {
                        *sum.entry(o["type"].as_str().unwrap().into()).or_default() += 1;
                    }
                    assert_eq!(cjio_types(&m), sum, "{w}: cjio's city objects");
                }
            } else {
                let text = std::fs::read_to_string(&m).unwrap();
                for l in text.lines().skip(1) {
                    let f: Value = serde_json::from_str(l).unwrap();
                    assert_eq!(f["type"], "CityJSONFeature", "{w}");
                    assert!(
                        f["CityObjects"].get(f["id"].as_str().unwrap()).is_some(),
                        "{w}"
                    );
                }
            }
        }
    }
}

#[test]
fn merges_of_real_cityjson_are_the_union_of_the_separate_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let fx = manifest_dir().join("fixtures/cityjson");
    // templates, materials and textures (dummy), textures (rotterdam), several LoDs
    let inputs: Vec<PathBuf> = [
        "cjio-dummy.city.json",
        "cjio-rotterdam_subset.city.json",
        "cjio-multi_lod.city.json",
    ]
    .iter()
    .map(|n| fx.join(n))
    .collect();
    check_edits(&inputs, &dir.path().join("2.0"), "fixtures 2.0");
    // CityJSON 1.1 (materials): subset and filter-lods keep 1.1, upgrade merges their 2.0
    let old: Vec<PathBuf> = [
        "cjio-DH_01_subs-v1.1.city.json",
        "cjio-delft_1b-v1.1.city.json",
    ]
    .iter()
    .map(|n| fx.join(n))
    .collect();
    check_edits(&old, &dir.path().join("1.1"), "fixtures 1.1");
}

#[test]
fn merges_of_our_cityjson_and_cityjsonseq_are_the_union() {
    let Some(data) = shared_data() else { return };
    let dir = tempfile::tempdir().unwrap();
    let d = |n: &str| dir.path().join(n);
    let src = data.join("ingolstadt-lod3");
    let mut inputs = Vec::new();
    for (k, f) in ["4018106.xml.gz", "4018115.xml.gz", "4018128.xml.gz"]
        .iter()
        .enumerate()
    {
        // a document, a sequence, a document
        let end = if k == 1 { "city.jsonl" } else { "city.json" };
        let p = d(&format!("in{k}.{end}"));
        ok(&[os("convert"), os(&src.join(f)), os("-o"), os(&p)]);
        inputs.push(p);
    }
    check_edits(&inputs, &d("out"), "ingolstadt");
}

#[test]
fn colliding_ids_are_renamed_with_their_references() {
    let dir = tempfile::tempdir().unwrap();
    let d = |n: &str| dir.path().join(n);
    let fx = manifest_dir().join("fixtures/cityjson/cjval-japanese.city.json");
    // one file twice, the second a CityJSONSeq of it
    ok(&[os("convert"), os(&fx), os("-o"), os(&d("b.city.jsonl"))]);
    std::fs::copy(&fx, d("a.city.json")).unwrap();
    let m = d("m.city.json");
    let e = ok(&[
        os("upgrade"),
        os(&d("a.city.json")),
        os(&d("b.city.jsonl")),
        os("-o"),
        os(&m),
    ]);
    let a = load(&d("a.city.json"));
    let n = a["CityObjects"].as_object().unwrap().len();
    assert!(e.contains(&format!(", {n} id(s) renamed")), "{e}");
    let merged = load(&m);
    let objects = merged["CityObjects"].as_object().unwrap();
    assert_eq!(objects.len(), 2 * n);
    let mut refs = 0;
    for (id, o) in a["CityObjects"].as_object().unwrap() {
        let two = &objects[&format!("{id}__2")];
        assert_eq!(two["type"], o["type"]);
        for key in ["parents", "children"] {
            let (x, y) = (o[key].as_array(), two[key].as_array());
            assert_eq!(x.map(Vec::len), y.map(Vec::len), "{id} {key}");
            for (x, y) in x.into_iter().flatten().zip(y.into_iter().flatten()) {
                assert_eq!(y.as_str().unwrap(), format!("{}__2", x.as_str().unwrap()));
                refs += 1;
            }
        }
    }
    assert!(refs > 0, "the fixture has parts");
    check_union(&m, &[d("a.city.json"), d("b.city.jsonl")], "twice");
    if let Some(v) = cjval(&m) {
        assert!(v, "cjval says invalid");
    }
}

#[test]
fn mixed_crss_and_formats_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = |n: &str| dir.path().join(n);
    let fx = manifest_dir().join("fixtures/cityjson");
    let (nl, jp) = (
        fx.join("cjio-dummy.city.json"),
        fx.join("cjval-japanese.city.json"),
    );
    for cmd in ["subset", "upgrade"] {
        let o = run(&[os(cmd), os(&nl), os(&jp), os("-o"), os(&d("m.city.json"))]);
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains("different CRSs"), "{e}");
        assert!(
            e.contains("EPSG/0/7415") && e.contains("EPSG/0/6677"),
            "{e}"
        );
        assert!(!d("m.city.json").exists());
    }
    // CityJSON with CityGML, CityJSON into a CityGML name: refused before any work (exit 2)
    let gml = manifest_dir().join("fixtures/chimney-citygml2.gml");
    let cases = [
        (
            "subset",
            &gml,
            "m.city.json",
            "cannot be merged into one file",
        ),
        ("filter-lods", &jp, "m.gml", "name the target .city.json"),
    ];
    for (cmd, other, target, says) in cases {
        let t = d(target);
        let mut a = vec![os(cmd), os(&nl), os(other), os("-o"), os(&t)];
        if cmd == "filter-lods" {
            a.extend([os("--lod"), os("2")]);
        }
        let o = run(&a);
        assert_eq!(o.status.code(), Some(2), "{cmd}: {}", stderr(&o));
        assert!(stderr(&o).contains(says), "{cmd}: {}", stderr(&o));
    }
    assert!(!d("m.city.json").exists() && !d("m.gml").exists());
}
