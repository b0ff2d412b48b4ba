//! `subset` and `filter-lods` on real files, checked by an independent reader
//! (`tests/oracle/citygml_members.py`, Python's `xml.etree`), xmllint and the XSDs.

use crate::util::*;
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

fn oracle(path: &Path) -> Value {
    let o = std::process::Command::new("python3")
        .arg(manifest_dir().join("tests/oracle/citygml_members.py"))
        .arg(path)
        .output()
        .expect("python3");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).expect("oracle JSON")
}

fn ids(v: &Value) -> Vec<String> {
    v["members"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["id"].as_str().unwrap_or("").to_string())
        .collect()
}

fn data(rel: &str) -> Option<PathBuf> {
    let p = shared_data()?.join(rel);
    assert!(
        p.is_file(),
        "{} is missing from the shared data",
        p.display()
    );
    Some(p)
}

fn skylod_ok(args: &[&str]) -> String {
    let a: Vec<&std::ffi::OsStr> = args.iter().map(os).collect();
    let o = run(&a);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    stderr(&o)
}

/// Every local reference of `out` resolves, and its root envelope is the box of its members.
fn consistent(out: &Path, v: &Value) {
    assert_eq!(
        unresolved_refs(out).unwrap(),
        Vec::<String>::new(),
        "{}",
        out.display()
    );
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for m in v["members"].as_array().unwrap() {
        if let Some(b) = m["box"].as_array() {
            for i in 0..3 {
                lo[i] = lo[i].min(b[i].as_f64().unwrap());
                hi[i] = hi[i].max(b[i + 3].as_f64().unwrap());
            }
        }
    }
    if let Some(env) = v["envelope"].as_array() {
        let got: Vec<f64> = env
            .iter()
            .flat_map(|c| c.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()))
            .collect();
        let want: Vec<f64> = lo.iter().chain(&hi).copied().collect();
        assert_eq!(
            got,
            want,
            "{}: the root envelope is the box of what stays",
            out.display()
        );
    }
}

/// The PLATEAU Yokosuka tile (EPSG:6697, 13 buildings, global appearances) and what the
/// oracle reads of it.
fn yokosuka() -> Option<(PathBuf, Value)> {
    let src = data("plateau/yokosuka/52397519_bldg_6697_op.gml")?;
    if !python_has("json", "python3") {
        return None;
    }
    let all = oracle(&src);
    Some((src, all))
}

#[test]
fn subset_by_limit_id_type_and_invert_on_plateau() {
    let Some((src, all)) = yokosuka() else { return };
    let all_ids = ids(&all);
    let dir = tempfile::tempdir().unwrap();
    let out = |n: &str| dir.path().join(n);
    let s = |p: &PathBuf| p.to_str().unwrap().to_string();

    let line = skylod_ok(&[
        "subset",
        &s(&src),
        "--limit",
        "3",
        "-o",
        &s(&out("lim.gml")),
    ]);
    assert!(line.contains("3 of 13 city object(s) kept"), "{line}");
    let lim = oracle(&out("lim.gml"));
    assert_eq!(ids(&lim), all_ids[..3].to_vec());
    consistent(&out("lim.gml"), &lim);

    let pick = format!("{},{}", all_ids[4], all_ids[7]);
    skylod_ok(&["subset", &s(&src), "--id", &pick, "-o", &s(&out("id.gml"))]);
    skylod_ok(&[
        "subset",
        &s(&src),
        "--id",
        &pick,
        "--invert",
        "-o",
        &s(&out("inv.gml")),
    ]);
    let (a, b) = (ids(&oracle(&out("id.gml"))), ids(&oracle(&out("inv.gml"))));
    assert_eq!(a, vec![all_ids[4].clone(), all_ids[7].clone()]);
    let mut both: Vec<String> = a.iter().chain(&b).cloned().collect();
    both.sort();
    let mut want = all_ids.clone();
    want.sort();
    assert_eq!(both, want, "a subset and its inverse partition the members");
    consistent(&out("inv.gml"), &oracle(&out("inv.gml")));

    skylod_ok(&[
        "subset",
        &s(&src),
        "--type",
        "CityFurniture",
        "-o",
        &s(&out("none.gml")),
    ]);
    assert!(ids(&oracle(&out("none.gml"))).is_empty());
    skylod_ok(&[
        "subset",
        &s(&src),
        "--type",
        "Building",
        "-o",
        &s(&out("b.gml")),
    ]);
    let types: Vec<&str> = all["members"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["type"].as_str().unwrap())
        .collect();
    assert_eq!(
        ids(&oracle(&out("b.gml"))).len(),
        types.iter().filter(|t| **t == "Building").count()
    );
}

#[test]
fn subset_by_box_matches_an_independent_reader() {
    let Some((src, all)) = yokosuka() else { return };
    let members = all["members"].as_array().unwrap();
    let bx = |m: &Value| -> [f64; 4] {
        let b = m["box"].as_array().unwrap();
        let f = |i: usize| b[i].as_f64().unwrap();
        [f(0), f(1), f(3), f(4)]
    };
    // a box around the third member, grown by a third of its size
    let c = bx(&members[2]);
    let (gx, gy) = ((c[2] - c[0]) / 3.0, (c[3] - c[1]) / 3.0);
    let q = [c[0] - gx, c[1] - gy, c[2] + gx, c[3] + gy];
    let dir = tempfile::tempdir().unwrap();
    for mode in ["intersects", "within"] {
        let want: Vec<String> = members
            .iter()
            .filter(|m| {
                let b = bx(m);
                match mode {
                    "within" => b[0] >= q[0] && b[2] <= q[2] && b[1] >= q[1] && b[3] <= q[3],
                    _ => b[0] <= q[2] && b[2] >= q[0] && b[1] <= q[3] && b[3] >= q[1],
                }
            })
            .map(|m| m["id"].as_str().unwrap().to_string())
            .collect();
        assert!(!want.is_empty());
        let bbox = format!("{},{},{},{}", q[0], q[1], q[2], q[3]);
        // the box in the document's CRS, then the same numbers given in WGS 84 (lat, lon:
        // EPSG:6697 and 4326 differ by far less than the box's margin here)
        for crs in [None, Some("EPSG:4326")] {
            let out = dir
                .path()
                .join(format!("{mode}{}.gml", crs.map_or("", |_| "84")));
            let mut args = vec!["subset", src.to_str().unwrap(), "--bbox", &bbox];
            args.extend(["--bbox-mode", mode, "-o", out.to_str().unwrap()]);
            args.extend(crs.iter().flat_map(|c| ["--bbox-crs", *c]));
            skylod_ok(&args);
            let got = oracle(&out);
            assert_eq!(ids(&got), want, "{mode} in {crs:?}");
            consistent(&out, &got);
        }
    }
}

/// What citygml-tools' `filter-lods` keeps of a member that has `has`.
fn expected(has: &BTreeSet<u64>, listed: &[u64], mode: &str) -> BTreeSet<u64> {
    let l: Vec<u64> = has.iter().copied().filter(|n| listed.contains(n)).collect();
    match mode {
        "keep" => l.into_iter().collect(),
        "remove" => has
            .iter()
            .copied()
            .filter(|n| !listed.contains(n))
            .collect(),
        "minimum" => l.iter().min().into_iter().copied().collect(),
        _ => l.iter().max().into_iter().copied().collect(),
    }
}

#[test]
fn filter_lods_modes_match_citygml_tools_semantics() {
    let Some(data) = shared_data() else { return };
    if !python_has("json", "python3") {
        return;
    }
    let files = [
        (
            "ogc-citygml2-examples/appearance/Appearance-EPSG25832.gml",
            true,
        ),
        ("rotterdam/Source.gml", false),
        ("plateau/yokosuka/52397519_bldg_6697_op.gml", false),
        (
            "plateau/tokyo23ku-2022/53392633_bldg_6697_2_op.gml.gz",
            false,
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    let mut valid = Vec::new();
    let mut n = 0;
    for (rel, xsd_valid) in files {
        let src = data.join(rel);
        let before = oracle(&src);
        for (listed, mode) in [
            (&[2u64][..], "keep"),
            (&[1, 2], "remove"),
            (&[0, 1, 2], "minimum"),
            (&[1, 2], "maximum"),
        ] {
            n += 1;
            let out = dir.path().join(format!("{n}-{mode}.gml"));
            let l: Vec<String> = listed.iter().map(u64::to_string).collect();
            skylod_ok(&[
                "filter-lods",
                src.to_str().unwrap(),
                "--lod",
                &l.join(","),
                "--mode",
                mode,
                "-o",
                out.to_str().unwrap(),
            ]);
            let after = oracle(&out);
            let got: std::collections::HashMap<String, &Value> = after["members"]
                .as_array()
                .unwrap()
                .iter()
                .map(|m| (m["id"].as_str().unwrap_or("").to_string(), m))
                .collect();
            for m in before["members"].as_array().unwrap() {
                let id = m["id"].as_str().unwrap_or("");
                let has: BTreeSet<u64> = m["lods"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|x| x.as_u64().unwrap())
                    .collect();
                let want = expected(&has, listed, mode);
                match got.get(id) {
                    Some(g) => {
                        let lods: BTreeSet<u64> = g["lods"]
                            .as_array()
                            .unwrap()
                            .iter()
                            .map(|x| x.as_u64().unwrap())
                            .collect();
                        assert_eq!(lods, want, "{rel} {mode} {listed:?}: {id}");
                    }
                    None => assert!(
                        want.is_empty() && !has.is_empty(),
                        "{rel} {mode} {listed:?}: {id} (LoDs {has:?}) was dropped"
                    ),
                }
            }
            consistent(&out, &after);
            if xsd_valid {
                valid.push(out);
            }
        }
    }
    if have_xmllint() {
        for (p, r) in valid.iter().zip(xmllint_validate_many(&valid, "2.0")) {
            assert!(r.is_ok(), "{}: {}", p.display(), r.unwrap_err());
        }
    }
}

#[test]
fn a_batch_goes_on_after_a_bad_input_and_merges_into_one_file() {
    let Some(data) = shared_data() else { return };
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.gml");
    std::fs::write(
        &bad,
        b"<CityModel xmlns=\"http://www.opengis.net/citygml/2.0\"><cityObjectMember>",
    )
    .unwrap();
    let good = data.join("ingolstadt-lod3/4018106.xml.gz");
    let outdir = dir.path().join("out/");
    let a: Vec<&std::ffi::OsStr> = vec![
        os("filter-lods"),
        os(&bad),
        os(&good),
        os("--lod"),
        os("3"),
        os("-o"),
        os(&outdir),
    ];
    let o = run(&a);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("bad.gml:1:") && err.contains("1 file(s) ok, 1 failed"),
        "{err}"
    );
    // several inputs into one CityGML file: merged
    let merged = dir.path().join("street.gml");
    let b = data.join("ingolstadt-lod3/4018115.xml.gz");
    skylod_ok(&[
        "subset",
        good.to_str().unwrap(),
        b.to_str().unwrap(),
        "-o",
        merged.to_str().unwrap(),
    ]);
    assert_eq!(ids(&oracle(&merged)).len(), 2);
    assert_eq!(unresolved_refs(&merged).unwrap(), Vec::<String>::new());
}

#[test]
fn citygml3_outputs_stay_xsd_valid() {
    let Some(data) = shared_data() else { return };
    if !have_xmllint() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mut outs = Vec::new();
    for rel in [
        "ogc-citygml3-examples/Building/BuildingUnits_Storeys_xlink.gml",
        "ogc-citygml3-examples/Building/Building_CityGML3.0_LOD2_with_several_attributes.gml",
        "berlin/Berlin_Moabit_1Bldg_v3-draft2019.gml",
    ] {
        let src = data.join(rel);
        if xmllint_validate(&src, "3.0").is_err() {
            continue; // only valid inputs promise valid outputs
        }
        for (k, args) in [["subset", "--limit", "1"], ["filter-lods", "--lod", "2"]]
            .iter()
            .enumerate()
        {
            let out = dir.path().join(format!("{}-{k}.gml", outs.len()));
            skylod_ok(&[
                args[0],
                src.to_str().unwrap(),
                args[1],
                args[2],
                "-o",
                out.to_str().unwrap(),
            ]);
            assert_eq!(
                unresolved_refs(&out).unwrap(),
                Vec::<String>::new(),
                "{rel}"
            );
            outs.push(out);
        }
    }
    assert!(outs.len() >= 4, "at least two valid CityGML 3.0 inputs");
    for (p, r) in outs.iter().zip(xmllint_validate_many(&outs, "3.0")) {
        assert!(r.is_ok(), "{}: {}", p.display(), r.unwrap_err());
    }
}

/// `subset` and `filter-lods` with `--jobs 1` and `--jobs 2` over a directory of shared files:
/// the same files with the same bytes, and the same lines in the same order.
#[test]
fn jobs_give_the_same_bytes_and_lines() {
    let Some(data) = shared_data() else { return };
    let tiles = data.join("ingolstadt-lod3");
    let dir = tempfile::tempdir().unwrap();
    for (cmd, rule) in [
        ("subset", ["--type", "Building"]),
        ("filter-lods", ["--lod", "2"]),
    ] {
        let mut outs = Vec::new();
        for j in ["1", "2"] {
            let out = dir.path().join(format!("{cmd}-{j}"));
            let mut a = vec![cmd, tiles.to_str().unwrap(), "--jobs", j, "-o"];
            a.push(out.to_str().unwrap());
            a.extend(rule);
            let said = skylod_ok(&a);
            let lines: Vec<String> = said
                .lines()
                .filter(|l| l.contains(" -> "))
                .map(|l| l.replace(out.to_str().unwrap(), "OUT"))
                .collect();
            outs.push((out, lines));
        }
        let (a, b) = (&outs[0], &outs[1]);
        assert!(a.1.len() >= 50, "{cmd}: {} lines", a.1.len());
        assert_eq!(a.1, b.1, "{cmd}: lines differ");
        let files = |d: &Path| -> Vec<PathBuf> {
            let mut v: Vec<PathBuf> = std::fs::read_dir(d)
                .unwrap()
                .map(|e| e.unwrap().path().strip_prefix(d).unwrap().to_path_buf())
                .collect();
            v.sort();
            v
        };
        assert_eq!(files(&a.0), files(&b.0), "{cmd}");
        for f in files(&a.0) {
            let (x, y) = (
                std::fs::read(a.0.join(&f)).unwrap(),
                std::fs::read(b.0.join(&f)).unwrap(),
            );
            assert!(
                x == y,
                "{cmd}: {} differs between --jobs 1 and 2",
                f.display()
            );
        }
    }
}
