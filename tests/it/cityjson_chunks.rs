//! A CityJSON document as an input of `stats` and `convert` read in chunks of whole
//! city-object trees, and CityJSONSeq in chunks of lines (issues 22 and 24): the same output
//! as the whole read (CityGML 2.0 and 3.0 too), members in any order, objects linked across
//! the document, errors with the file and line:column.
//!
//! Streamed runs use `--stream-chunk` small enough for several chunks; whole runs
//! `--stream-chunk 0`. A streamed read that declines says "read whole" on standard error (at
//! `--log-level info`): the streamed runs here must not.

use crate::util::*;
use std::path::Path;

/// `stats --json` and `convert -o` OBJ, CityJSON, CityJSONSeq and CityGML (2.0 and 3.0) of
/// `input`, streamed in chunks of `chunk` bytes and whole: the same bytes.
fn streamed_is_whole(input: &Path, chunk: &str, dir: &Path) {
    let name = input.file_name().unwrap().to_string_lossy().to_string();
    let stats = |c: &str| {
        let o = run(&[
            os("stats"),
            os("--json"),
            os("--log-level=info"),
            os("--stream-chunk"),
            os(c),
            os(input),
        ]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let err = stderr(&o);
        (o.stdout, err)
    };
    let (streamed, err) = stats(chunk);
    assert!(!err.contains("read whole"), "{name}: {err}");
    assert_eq!(streamed, stats("0").0, "{name}: stats");
    for (ext, version) in [
        ("obj", None),
        ("city.json", None),
        ("city.jsonl", None),
        ("gml", None),
        ("gml", Some("3.0")),
    ] {
        let mut outs = Vec::new();
        for c in [chunk, "0"] {
            let out = dir.join(format!("{name}.{c}.{}.{ext}", version.unwrap_or("")));
            let mut args = vec![
                os("convert"),
                os(input),
                os("-o"),
                os(&out),
                os("--stream-chunk"),
                os(c),
                os("--log-level=info"),
            ];
            if let Some(v) = version {
                args.extend([os("--citygml-version"), os(v)]);
            }
            let o = run(&args);
            assert!(o.status.success(), "{name} -> {ext}: {}", stderr(&o));
            assert!(!stderr(&o).contains("read whole"), "{}", stderr(&o));
            outs.push(std::fs::read(&out).unwrap());
        }
        assert!(outs[0] == outs[1], "{name} -> {ext}: streamed differs");
    }
}

/// The document of [`members_in_any_order`]: vertices before the city objects, `transform`
/// and `metadata` after them, a part before its building, an installation far from its
/// building, a building with attributes and semantic surfaces (with members of their own),
/// one without (a body), an object outside buildings. `far`: the installation is of the first
/// building (the whole document one chunk), else of the last.
fn any_order_document(buildings: usize, far: bool) -> String {
    let mut verts = Vec::new();
    let mut objects = Vec::new();
    let cube = |verts: &mut Vec<String>, x: usize| -> usize {
        let base = verts.len();
        for (dx, dy, z) in [
            (0, 0, 0),
            (900, 0, 0),
            (900, 900, 0),
            (0, 900, 0),
            (0, 0, 600),
            (900, 0, 600),
            (900, 900, 600),
            (0, 900, 600),
        ] {
            verts.push(format!("[{},{},{z}]", x * 1000 + dx, dy));
        }
        base
    };
    let solid = |b: usize| {
        format!(
            r#"[{{"type":"Solid","lod":"2.2","boundaries":[[[[{},{},{},{}]],[[{},{},{},{}]],[[{},{},{},{}]]]],
            "semantics":{{"surfaces":[{{"type":"GroundSurface"}},{{"type":"RoofSurface","slope":12,"id":"r{b}"}},{{"type":"WallSurface"}}],"values":[[0,1,2]]}}}}]"#,
            b,
            b + 3,
            b + 2,
            b + 1,
            b + 4,
            b + 5,
            b + 6,
            b + 7,
            b,
            b + 1,
            b + 5,
            b + 4
        )
    };
    for k in 0..buildings {
        let b = cube(&mut verts, k);
        let p = cube(&mut verts, k + 10_000);
        // the part first, its building after
        objects.push(format!(
            r#""p{k}":{{"type":"BuildingPart","parents":["b{k}"],"geometry":{}}}"#,
            solid(p)
        ));
        objects.push(format!(
            r#""b{k}":{{"type":"Building","children":["p{k}"],"attributes":{{"function":"{k}","yearOfConstruction":1990}},"geometry":{}}}"#,
            solid(b)
        ));
        let q = cube(&mut verts, k + 20_000);
        objects.push(format!(
            r#""body{k}":{{"type":"Building","geometry":[{{"type":"MultiSurface","lod":"1","boundaries":[[[{q},{},{},{}]]]}}]}}"#,
            q + 1,
            q + 2,
            q + 3
        ));
    }
    // an installation of the first (or last) building, at the end of the objects
    let i = cube(&mut verts, 30_000);
    let of = if far { 0 } else { buildings.saturating_sub(1) };
    objects.push(format!(
        r#""inst":{{"type":"BuildingInstallation","parents":["b{of}"],"geometry":[{{"type":"MultiSurface","lod":"2","boundaries":[[[{i},{},{}]]]}}]}}"#,
        i + 1,
        i + 2
    ));
    let t = cube(&mut verts, 40_000);
    objects.push(format!(
        r#""tree":{{"type":"SolitaryVegetationObject","attributes":{{"species":"oak"}},"geometry":[{{"type":"MultiSurface","lod":"1","boundaries":[[[{t},{},{}]]]}}]}}"#,
        t + 1,
        t + 2
    ));
    format!(
        r#"{{"type":"CityJSON","version":"2.0","vertices":[{}],"CityObjects":{{{}}},
        "transform":{{"scale":[0.001,0.001,0.001],"translate":[85000,446000,0]}},
        "metadata":{{"referenceSystem":"https://www.opengis.net/def/crs/EPSG/0/7415"}}}}"#,
        verts.join(","),
        objects.join(",")
    )
}

#[test]
fn members_in_any_order() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("any.city.json");
    std::fs::write(&input, any_order_document(30, true)).unwrap();
    // every part with its building, whatever the chunk: here about one object a chunk
    streamed_is_whole(&input, "200", dir.path());
    // and as CityJSONSeq, about one line a chunk
    let seq = dir.path().join("any.city.jsonl");
    let o = run(&[os("convert"), os(&input), os("-o"), os(&seq)]);
    assert!(o.status.success(), "{}", stderr(&o));
    streamed_is_whole(&seq, "200", dir.path());
    // the counts are the document's
    let o = run(&[
        os("stats"),
        os("--json"),
        os("--stream-chunk=200"),
        os(&input),
    ]);
    let s = &json(&o)["total"];
    assert_eq!(s["buildings"], 60, "{s}");
    assert_eq!(s["building_parts"], 30, "{s}");
    assert_eq!(s["installations"], 1, "{s}");
    assert_eq!(s["other_objects"], 1, "{s}");
}

#[test]
fn shared_data_converted_to_cityjson_streams_the_same() {
    let Some(data) = shared_data() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    for f in [
        "rotterdam/Source.gml",
        "berlin/Berlin_Moabit_1Bldg_v2.gml",
        "kit-fzk-haus/citygml3/FZK-Haus-LoD2-KIT-IAI-KHH-B36-V1__v3.gml",
        "plateau/tokyo23ku-2022/53392633_bldg_6697_2_op.gml.gz",
    ] {
        let src = data.join(f);
        let json = dir.path().join(format!(
            "{}.city.json",
            f.replace('/', "_").trim_end_matches(".gz")
        ));
        let o = run(&[os("convert"), os(&src), os("-o"), os(&json)]);
        assert!(o.status.success(), "{f}: {}", stderr(&o));
        let chunk = (std::fs::metadata(&json).unwrap().len() / 16).max(1);
        streamed_is_whole(&json, &chunk.to_string(), dir.path());
        let seq = json.with_extension("jsonl");
        let o = run(&[os("convert"), os(&json), os("-o"), os(&seq)]);
        assert!(o.status.success(), "{f}: {}", stderr(&o));
        let chunk = (std::fs::metadata(&seq).unwrap().len() / 16).max(1);
        streamed_is_whole(&seq, &chunk.to_string(), dir.path());
    }
}

/// `file:line:column` somewhere in `text`.
fn has_position(text: &str, file: &str) -> bool {
    text.match_indices(&format!("{file}:")).any(|(at, m)| {
        let rest = &text.as_bytes()[at + m.len()..];
        let line = rest.iter().take_while(|b| b.is_ascii_digit()).count();
        let column = rest
            .get(line + 1..)
            .map_or(0, |r| r.iter().take_while(|b| b.is_ascii_digit()).count());
        line > 0 && rest.get(line) == Some(&b':') && column > 0
    })
}

#[test]
fn errors_name_the_file_and_line_column() {
    let dir = tempfile::tempdir().unwrap();
    let doc = any_order_document(8, true);
    let truncated = dir.path().join("truncated.city.json");
    std::fs::write(&truncated, &doc[..doc.len() - 40]).unwrap();
    // a vertex index out of range in the second part
    let bad = dir.path().join("badindex.city.json");
    std::fs::write(&bad, doc.replacen("[[[[32,", "[[[[99999,", 1)).unwrap();
    assert_ne!(doc, std::fs::read_to_string(&bad).unwrap());
    // CityJSONSeq with a vertex index out of range on its third line (line 3 named)
    let good = dir.path().join("good.city.json");
    std::fs::write(&good, &doc).unwrap();
    let seq = dir.path().join("bad.city.jsonl");
    let o = run(&[os("convert"), os(&good), os("-o"), os(&seq)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&seq).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let at = lines[2].find("\"boundaries\":[").unwrap() + 14;
    let digits = lines[2][at..].find(|c: char| c.is_ascii_digit()).unwrap() + at;
    lines[2].insert_str(digits, "9999");
    std::fs::write(&seq, lines.join("\n") + "\n").unwrap();
    for (path, what) in [
        (&truncated, "EOF"),
        (&bad, "vertex index 99999 out of range"),
        (&seq, "vertex index 9999"),
    ] {
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        // the streamed read's reason for reading whole is said at `--log-level info`
        let o = run(&[
            os("stats"),
            os("--log-level=info"),
            os("--stream-chunk=200"),
            os(path),
        ]);
        assert!(!o.status.success(), "{name}");
        let err = stderr(&o);
        assert!(err.contains(what), "{name}: {err}");
        assert!(err.contains(": read whole ("), "{name}: {err}");
        assert!(has_position(&err, &name), "{name}: {err}");
        if path == &seq {
            assert!(err.contains(&format!("{name}:3:")), "{name}: {err}");
        }
    }
}

/// Opt-in (`cargo test --test it cityjson_chunks::a_large_document -- --ignored`): a
/// generated 39 MB `.city.json` (30,000 buildings with a part each, the vertices first, each
/// part before its building) through `stats` and `convert -o x.obj` in chunks of 4 MiB (the
/// default streams from 64 MiB on): the counts expected and a peak resident set under 160 MiB
/// (read whole: 503 MiB for `stats`). Measured: 57 MiB (`stats`), 74 MiB (`convert`).
#[test]
#[ignore = "writes and reads a 39 MB document (about a minute)"]
fn a_large_document_is_read_in_little_memory() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("big.city.json");
    std::fs::write(&input, any_order_document(30_000, false)).unwrap();
    let size = std::fs::metadata(&input).unwrap().len();
    assert!(size > 30_000_000, "{size}");
    let out = dir.path().join("big.obj");
    for args in [
        vec![
            os("stats"),
            os("--json"),
            os("--log-level=info"),
            os("--stream-chunk=4194304"),
            os(&input),
        ],
        vec![
            os("convert"),
            os(&input),
            os("-o"),
            os(&out),
            os("--log-level=info"),
            os("--stream-chunk=4194304"),
        ],
    ] {
        let r = crate::bad_input::run_timeout(&args, 600);
        assert_eq!(r.code, Some(0), "{args:?}: {}", r.stderr);
        assert!(!r.stderr.contains("read whole"), "{}", r.stderr);
        eprintln!("{args:?} on {size} bytes: peak RSS {} KiB", r.peak_rss_kib);
        assert!(
            r.peak_rss_kib < 160 * 1024,
            "{args:?}: peak RSS {} KiB",
            r.peak_rss_kib
        );
        if args[0] == "stats" {
            let s: serde_json::Value = serde_json::from_str(&r.stdout).unwrap();
            assert_eq!(s["total"]["buildings"], 60_000, "{s}");
            assert_eq!(s["total"]["building_parts"], 30_000, "{s}");
        }
    }
    assert!(std::fs::metadata(&out).unwrap().len() > size / 4);
}
