//! Where a model's bytes come from: a model read from memory (`read_bytes`) or from standard
//! input (`-`) is written by every writer as the same model read from its file, byte for byte;
//! standard input is named `<stdin>` in messages and `-` in JSON outputs, never by a
//! temporary path (issues 22 and 27).

use crate::util::{citygml_files, os, shared_data, short, stderr, BIN};
use skylod::export::{Content, Format};
use skylod::io::citygml::{read_bytes, read_file};
use skylod::io::citygml::{write_document, write_document_to, WriteOptions};
use skylod::lod::rough::{rough_model, RoughOptions};
use skylod::lod::{write_mixed, write_mixed_to};
use skylod::model::{AssetKind, CityModel, Source};
use std::ffi::OsStr;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// Run the binary with `input` on its standard input.
fn piped(args: &[&OsStr], input: &[u8]) -> Output {
    let mut child = Command::new(BIN)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let data = input.to_vec();
    let writer = std::thread::spawn(move || {
        let _ = stdin.write_all(&data);
    });
    let o = child.wait_with_output().unwrap();
    writer.join().unwrap();
    o
}

/// Everything `model`'s file 0 gives through every writer, to memory: the document with its
/// envelopes recomputed, the mixed-LoD document at levels 0/1/2 by turns, OBJ, CityJSON and
/// CityJSONSeq at the same levels.
fn written(model: &CityModel) -> Vec<(&'static str, Vec<u8>)> {
    let rough = rough_model(model, &RoughOptions::default());
    let levels: Vec<u8> = (0..model.assets.len()).map(|i| (i % 3) as u8).collect();
    let opts = WriteOptions::default();
    let mut out = Vec::new();
    let mut doc = Vec::new();
    write_document_to(model, 0, Vec::new(), &mut doc, &opts).unwrap();
    out.push(("citygml", doc));
    let mut mixed = Vec::new();
    write_mixed_to(model, 0, &rough, &levels, &mut mixed, &opts).unwrap();
    out.push(("mixed", mixed));
    let content = Content::Levels {
        rough: &rough,
        levels: &levels,
    };
    for (name, format) in [
        ("obj", Format::Obj),
        ("cityjson", Format::CityJson),
        ("cityjsonseq", Format::CityJsonSeq),
    ] {
        let mut w = Vec::new();
        let chunks = skylod::export::Chunks::model(model, 0, content);
        let (s, _) = skylod::export::write_to(format, &chunks, &mut w).unwrap();
        assert_eq!(s.bytes, w.len() as u64, "{name}");
        out.push((name, w));
    }
    out
}

/// Real files of every kind in the shared data (plain and gzip, CityGML 1.0 to 3.0), up to
/// 8 MB each: read from memory they are written by every writer as read from their file.
#[test]
fn models_read_from_memory_are_written_as_from_their_file() {
    let Some(data) = shared_data() else {
        return;
    };
    let mut files: Vec<PathBuf> = citygml_files(&data)
        .into_iter()
        .filter(|p| std::fs::metadata(p).is_ok_and(|m| m.len() <= 8 << 20))
        .collect();
    // every dataset, a few files of each (the Ingolstadt street has 90 tiles)
    files.sort();
    let mut per_dir = std::collections::HashMap::<PathBuf, usize>::new();
    files.retain(|p| {
        let n = per_dir
            .entry(p.parent().unwrap().to_path_buf())
            .or_default();
        *n += 1;
        *n <= 3
    });
    let mut compared = 0;
    let mut gz = 0;
    let mut kinds = std::collections::BTreeSet::new();
    for p in &files {
        let Ok(from_file) = read_file(p) else {
            continue; // files that fail to read fail the same way from memory (below)
        };
        let bytes = std::fs::read(p).unwrap();
        let from_memory = read_bytes(&bytes, p).unwrap();
        assert!(
            matches!(&from_memory.files[0].source, Source::Memory(b) if **b == bytes[..]),
            "{}",
            short(p)
        );
        assert_eq!(from_file.files[0].source, Source::File(p.clone()));
        // the same model but for where its bytes are
        let mut same = from_memory.clone();
        same.files[0].source = from_file.files[0].source.clone();
        assert!(same == from_file, "{}: models differ", short(p));
        if from_file.assets.is_empty() {
            continue;
        }
        let a = written(&from_file);
        let b = written(&from_memory);
        for ((name, x), (_, y)) in a.iter().zip(&b) {
            assert!(!x.is_empty(), "{}: {name} empty", short(p));
            assert!(x == y, "{}: {name} differs from memory", short(p));
        }
        // the path-based writers too: a model from memory needs no file
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out/doc.gml");
        write_document(&from_memory, 0, Vec::new(), &out, &WriteOptions::default()).unwrap();
        assert!(std::fs::read(&out).unwrap() == a[0].1, "{}", short(p));
        let rough = rough_model(&from_memory, &RoughOptions::default());
        let levels: Vec<u8> = (0..from_memory.assets.len())
            .map(|i| (i % 3) as u8)
            .collect();
        let out = dir.path().join("mixed.gml");
        let opts = WriteOptions::default();
        write_mixed((&from_memory, 0), &rough, &levels, &out, &opts).unwrap();
        assert!(std::fs::read(&out).unwrap() == a[1].1, "{}", short(p));
        gz += usize::from(from_file.files[0].gzip);
        kinds.insert(from_file.files[0].version);
        compared += 1;
    }
    eprintln!("{compared} files written from memory as from their file ({gz} gzip, {kinds:?})");
    assert!(compared >= 10, "only {compared} files compared");
    assert!(gz >= 1 && kinds.len() >= 2, "{gz} gzip, {kinds:?}");
}

/// A file that cannot be read fails from memory with the same message, naming the name given.
#[test]
fn errors_from_memory_name_the_name_given() {
    let e = read_bytes(b"<CityModel", "given.gml")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("given.gml:1:"), "{e}");
    let e = read_bytes(b"<bad", "-").unwrap_err().to_string();
    assert!(e.starts_with("<stdin>:1:"), "{e}");
}

/// Facade POIs in front of the largest walls of the first buildings of `model` (0.2 m out).
fn facade_pois(model: &CityModel, n: usize) -> Vec<String> {
    let mut out = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for a in &model.assets {
        if a.kind != AssetKind::Wall || out.len() >= n {
            continue;
        }
        let Some(b) = a.building.map(|b| model.root_building(b)) else {
            continue;
        };
        let Some(p) = a
            .detail_polygons()
            .iter()
            .max_by(|x, y| x.area().total_cmp(&y.area()))
        else {
            continue;
        };
        let normal = p.newell_normal().normalize_or_zero();
        if seen.contains(&b) || normal.z.abs() > 0.2 || p.area() < 20.0 {
            continue;
        }
        let pts = p.exterior();
        let c = pts.iter().fold(glam::DVec3::ZERO, |s, q| s + *q) / pts.len() as f64;
        let q = c + normal * 0.2;
        seen.insert(b);
        out.push(format!(
            "{},{},{},{},{},{}",
            q.x, q.y, q.z, normal.x, normal.y, normal.z
        ));
    }
    out
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// `lod` with one Ingolstadt tile on standard input: the mixed-LoD document, OBJ, CityJSON
/// and the merge with another tile are byte-identical to those of the file; the report
/// names it `-`, the messages `<stdin>`, nothing names a temporary file.
#[test]
fn lod_from_standard_input_writes_what_the_file_writes() {
    let Some(data) = shared_data() else {
        return;
    };
    let dir = data.join("ingolstadt-lod3");
    let (a, b) = (dir.join("4018106.xml.gz"), dir.join("4018115.xml.gz"));
    if !a.is_file() || !b.is_file() {
        crate::util::missing(&format!("{} and {}", a.display(), b.display()));
        return;
    }
    let mut both = read_file(&a).unwrap();
    both.merge(read_file(&b).unwrap());
    let pois = facade_pois(&both, 3);
    assert!(!pois.is_empty());
    let piped_b = std::fs::read(&b).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let run = |inputs: &[&OsStr], out: &Path, report: &Path, stdin: bool| {
        let mut args: Vec<&OsStr> = vec![os("lod")];
        args.extend_from_slice(inputs);
        for p in &pois {
            args.extend([os("--poi"), os(p)]);
        }
        args.extend([os("--rays"), os("2000"), os("--no-bound")]);
        args.extend([
            os("-o"),
            out.as_os_str(),
            os("--report"),
            report.as_os_str(),
        ]);
        let o = if stdin {
            piped(&args, &piped_b)
        } else {
            crate::util::run(&args)
        };
        assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
        o
    };
    for ext in ["gml", "obj", "city.json"] {
        let (f, s) = (
            t.join(format!("file.{ext}")),
            t.join(format!("stdin.{ext}")),
        );
        let (rf, rs) = (
            t.join(format!("file.{ext}.json")),
            t.join(format!("stdin.{ext}.json")),
        );
        run(&[b.as_os_str()], &f, &rf, false);
        let o = run(&[os("-")], &s, &rs, true);
        let mut want = std::fs::read(&f).unwrap();
        if ext == "obj" {
            // the comment line names the source: the file, or standard input
            let (from, to) = (format!("OBJ of {};", b.display()), "OBJ of <stdin>;");
            let text = String::from_utf8(want).unwrap();
            assert!(text.contains(&from), "{text:.300}");
            want = text.replacen(&from, to, 1).into_bytes();
        }
        assert!(
            want == std::fs::read(&s).unwrap(),
            "{ext}: standard input differs from the file"
        );
        let (jf, js) = (json(&rf), json(&rs));
        assert_eq!(js["inputs"][0]["path"], "-", "{js}");
        assert_eq!(jf["inputs"][0]["path"], b.display().to_string());
        assert_eq!(jf["totals"], js["totals"]);
        let err = stderr(&o);
        if ext == "gml" {
            assert!(err.contains("<stdin> -> "), "{err}");
        }
        for text in [err, std::fs::read_to_string(&rs).unwrap()] {
            assert!(!text.contains("skylod-stdin"), "{text}");
            assert!(!text.contains(".skylod-"), "{text}");
        }
    }
    // The merge of a file and standard input, as of the two files.
    let (f, s) = (t.join("merged-file.gml"), t.join("merged-stdin.gml"));
    run(
        &[a.as_os_str(), b.as_os_str()],
        &f,
        &t.join("mf.json"),
        false,
    );
    run(&[a.as_os_str(), os("-")], &s, &t.join("ms.json"), true);
    assert!(
        std::fs::read(&f).unwrap() == std::fs::read(&s).unwrap(),
        "the merge with standard input differs from the merge of the files"
    );
    let js = json(&t.join("ms.json"));
    assert_eq!(js["inputs"][1]["path"], "-", "{js}");
    // -o DIR: standard input is written as DIR/stdin.gml.
    let out = t.join("tree");
    std::fs::create_dir(&out).unwrap();
    run(&[os("-")], &out, &t.join("tree.json"), true);
    assert!(
        std::fs::read(out.join("stdin.gml")).unwrap() == std::fs::read(t.join("file.gml")).unwrap()
    );
}

/// A warning about standard input names it `<stdin>` (here: a model without an envelope),
/// and a missing output folder is made.
#[test]
fn warnings_name_standard_input_and_missing_folders_are_made() {
    let gml = br#"<CityModel xmlns="http://www.opengis.net/citygml/2.0"
 xmlns:gml="http://www.opengis.net/gml" xmlns:bldg="http://www.opengis.net/citygml/building/2.0">
 <cityObjectMember><bldg:Building gml:id="b"><bldg:lod1Solid><gml:Solid><gml:exterior>
 <gml:CompositeSurface><gml:surfaceMember><gml:Polygon><gml:exterior><gml:LinearRing>
 <gml:posList srsDimension="3">0 0 0 2 0 0 2 1 3 0 0 0</gml:posList></gml:LinearRing></gml:exterior>
 </gml:Polygon></gml:surfaceMember></gml:CompositeSurface></gml:exterior></gml:Solid>
 </bldg:lod1Solid></bldg:Building></cityObjectMember></CityModel>"#;
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("new/folder/out.gml");
    let o = piped(&[os("convert"), os("-"), os("-o"), out.as_os_str()], gml);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.contains("<stdin> -> "), "{err}");
    assert!(err.contains("1 warning(s)"), "{err}");
    let o = piped(&[os("stats"), os("--verbose"), os("-")], gml);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    let want = "warning: <stdin>:1:1: CityModel has no gml:boundedBy envelope";
    assert!(err.contains(want), "{err}");
    assert!(
        !err.contains("skylod-stdin") && !err.contains(".tmp"),
        "{err}"
    );
    assert!(std::fs::read_to_string(&out)
        .unwrap()
        .contains("gml:id=\"b\""));
}
